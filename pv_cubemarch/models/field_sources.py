"""Where spline fields come from (003): samples, ImageData, watertight meshes.

:func:`make_field` turns what a user passes into a
:class:`~pv_cubemarch.models.surface.SplineField`. A mesh's field is its signed distance,
positive inside: VTK's (``vtkImplicitPolyDataDistance``: to the nearest triangle, its sign
from the triangle's normal) at the cell centres of a grid of isotropic cells around the
mesh, then interpolated by the quadratic B-spline
(:func:`~pv_cubemarch.models.surface.interpolating_coefficients`).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pyvista
import vtk
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy

from ..core.errors import VolumeDataError
from ..core.progress import progress
from .surface import SplineField, interpolating_coefficients
from .voxels import image_samples

#: Distances evaluated per batch (one step of the progress bar).
BATCH = 65536
#: Cells of free space around the mesh on every side, so its surface is inside the domain.
MARGIN_CELLS = 2


def mesh_field(mesh: pyvista.DataSet, cells: int | Sequence[int] = 64, *,
               progress_bar: bool | None = None, name: str = "surface") -> SplineField:
    """The signed-distance field of a closed surface mesh on cubic cells around it.

    ``cells``: cells along the mesh's longest side (plus :data:`MARGIN_CELLS` on every
    side), or three counts. Raises ``VolumeDataError`` for a mesh with open edges (its
    inside is undefined: fit its points with normals instead), or with no faces.
    """
    surface = mesh.extract_surface() if not isinstance(mesh, pyvista.PolyData) else mesh
    surface = surface.triangulate().clean()
    if surface.n_cells == 0:
        raise VolumeDataError("The mesh has no faces: a signed distance needs a closed "
                              "surface.")
    open_edges = surface.n_open_edges
    if open_edges:
        raise VolumeDataError(f"The mesh is not watertight ({open_edges} open edges): its "
                              "inside is undefined, so it has no signed distance. Close "
                              "it (e.g. pyvista's fill_holes), or fit its points with "
                              "normals instead.")
    bounds = np.asarray(surface.bounds, dtype=np.float64).reshape(3, 2)
    extent = bounds[:, 1] - bounds[:, 0]
    if np.isscalar(cells) or np.ndim(cells) == 0:
        size = float(extent.max()) / max(int(cells), 1)
        counts = np.maximum(np.ceil(extent / max(size, 1e-300)).astype(int), 1)
    else:
        counts = np.asarray(cells, dtype=int)
        size = float((extent / counts).max())
    if not size > 0:
        raise VolumeDataError("The mesh is flat or a point: it encloses nothing.")
    counts = counts + 2 * MARGIN_CELLS
    start = (bounds[:, 0] + bounds[:, 1]) / 2 - counts * size / 2
    centres = np.stack(np.meshgrid(*[start[a] + (np.arange(counts[a]) + 0.5) * size
                                     for a in range(3)], indexing="ij"), -1).reshape(-1, 3)
    distance = vtk.vtkImplicitPolyDataDistance()
    distance.SetInput(surface)
    values = np.empty(len(centres))
    for begin in progress(range(0, len(centres), BATCH), desc="signed distance",
                          total=-(-len(centres) // BATCH), enabled=progress_bar):
        chunk = centres[begin:begin + BATCH]
        out = vtk.vtkDoubleArray()
        distance.FunctionValue(numpy_to_vtk(np.ascontiguousarray(chunk), deep=True), out)
        values[begin:begin + len(chunk)] = -vtk_to_numpy(out)   # VTK: negative inside
    grid_from_index = np.diag([size, size, size, 1.0])
    grid_from_index[:3, 3] = start
    samples = values.reshape(*counts)
    return SplineField(interpolating_coefficients(samples), grid_from_index, name=name)


def make_field(data, isovalue: float | None = None, scalars: str | None = None, *,
               cells: int | Sequence[int] = 64, transform=None, name: str = "surface",
               progress_bar: bool | None = None) -> SplineField:
    """The field whose zero set is the surface ``data`` describes, positive inside.

    ``data``: a :class:`SplineField` (as is); a 3D array of samples indexed x, y, z (one
    per unit cell, at its centre) or a ``pyvista.ImageData`` (cell data: one sample per
    cell; point data: a cell centred on each point), with ``isovalue``: the quadratic
    B-spline interpolating ``samples - isovalue`` at the cell centres
    (:func:`interpolating_coefficients`), so the inside is where the data exceed the
    isovalue; a closed surface mesh (``pyvista.PolyData`` or other non-image dataset, or
    a mesh file ``pyvista.read`` reads): its signed distance on ``cells`` cells along its
    longest side (:func:`mesh_field`). Raises ``VolumeDataError`` for NaN samples, a
    missing isovalue or an open mesh.
    """
    if isinstance(data, (str, Path)):
        data = pyvista.read(data)
    if isinstance(data, SplineField):
        field = data
    elif isinstance(data, pyvista.DataSet) and not isinstance(data, pyvista.ImageData):
        field = mesh_field(data, cells, progress_bar=progress_bar, name=name)
    else:
        field = _sampled_field(data, isovalue, scalars, name)
    if transform is not None:
        field.transform = np.asarray(transform, dtype=np.float64)
    return field


def _sampled_field(data, isovalue: float | None, scalars: str | None,
                   name: str) -> SplineField:
    """Samples (an array or an ImageData's) minus ``isovalue``, interpolated."""
    if isinstance(data, pyvista.ImageData):
        values, grid_from_index = image_samples(data, scalars)
    else:
        values, grid_from_index = np.asarray(data), np.eye(4)
    if values.ndim != 3 or values.size == 0:
        raise VolumeDataError(f"Samples must be a 3D array (x, y, z), got shape {values.shape}.")
    if values.dtype.kind not in "fiub":
        raise VolumeDataError(f"Samples must be numbers, got dtype {values.dtype}.")
    values = values.astype(np.float64)
    if not np.isfinite(values).all():
        raise VolumeDataError(f"The samples hold {int((~np.isfinite(values)).sum())} NaN or "
                              "infinite values; fill them (e.g. with a value outside the "
                              "surface) or crop the grid.")
    if isovalue is None:
        raise VolumeDataError(f"A sampled field needs isovalue= (its values span "
                              f"[{values.min():g}, {values.max():g}]).")
    if not values.min() <= float(isovalue) <= values.max():
        warnings.warn(f"isovalue={isovalue:g} is outside the data range [{values.min():g}, "
                      f"{values.max():g}]: the surface is empty.", stacklevel=4)
    return SplineField(interpolating_coefficients(values - float(isovalue)), grid_from_index,
                       name=name)
