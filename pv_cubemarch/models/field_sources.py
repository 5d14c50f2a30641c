"""Where spline fields come from: samples, ImageData, watertight meshes.

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
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pyvista
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy

from ..core import vtk_classes as vtk
from ..core.errors import VolumeDataError, VolumeDataWarning
from ..core.progress import progress
from ..core.user_warnings import warn_user
from .array_files import ARRAY_SUFFIXES, read_array_file
from .image_files import read_data_file
from .surface import (
    SPLINES,
    SplineField,
    bernstein_basis,
    point_hull,
    spline_coefficients,
)
from .volume import checked_transform, uniform_grid
from .voxel_levels import grown_by_one
from .voxels import image_samples, samples_at_points

if TYPE_CHECKING:   # scipy is imported where it is used
    import scipy.sparse

#: Distances evaluated per batch (one step of the progress bar).
BATCH = 65536
#: Cells of free space around the mesh on every side, so its surface is inside the domain.
MARGIN_CELLS = 2


def mesh_field(mesh: pyvista.DataSet, cells: int | Sequence[int] = 64, *,
               progress_bar: bool | None = None, name: str = "surface",
               spline: str = "interpolating", parts: list | None = None) -> SplineField:
    """The signed-distance field of a closed surface mesh on cubic cells around it.

    ``cells``: cells along the mesh's longest side (plus :data:`MARGIN_CELLS` on every
    side), or three counts. Raises ``VolumeDataError`` for a mesh with open edges (its
    inside is undefined: fit its points with normals instead), or with no faces.
    ``parts``: closed meshes that overlap, whose union ``mesh`` is: the field is the
    largest of theirs (inside any is inside), where ``mesh``'s own would change sign
    inside one near another's faces.
    """
    surface = outer_surface(mesh).triangulate().clean()
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
        if counts.shape != (3,) or counts.min() < 1:
            raise VolumeDataError(f"cells is one count or three counts of at least 1, got "
                                  f"{cells!r}.")
        size = float((extent / counts).max())
    if not size > 0:
        raise VolumeDataError("The mesh is flat or a point: it encloses nothing.")
    counts = counts + 2 * MARGIN_CELLS
    start = (bounds[:, 0] + bounds[:, 1]) / 2 - counts * size / 2
    centres = np.stack(np.meshgrid(*[start[a] + (np.arange(counts[a]) + 0.5) * size
                                     for a in range(3)], indexing="ij"), -1).reshape(-1, 3)
    surfaces = [surface] if parts is None else [outer_surface(p).triangulate().clean()
                                                for p in parts]
    batches = -(-len(centres) // BATCH)
    steps = iter(progress(range(batches * len(surfaces)), desc="signed distance",
                          total=batches * len(surfaces), enabled=progress_bar))
    values = np.full(len(centres), -np.inf)
    for part in surfaces:
        part_values = _signed_distance(part, centres, steps)
        if part_values[0] > 0:   # the domain's corner lies outside: the faces point inward
            warnings.warn("The mesh's faces are wound inward (its outside came out "
                          "positive): the field is flipped so that it is positive inside.",
                          stacklevel=3)
            part_values = -part_values
        values = np.maximum(values, part_values)
    for _ in steps:   # the bar to its end
        pass
    grid_from_index = np.diag([size, size, size, 1.0])
    grid_from_index[:3, 3] = start
    samples = values.reshape(*counts)
    return SplineField(spline_coefficients(samples, spline), grid_from_index, name=name)


def _signed_distance(surface: pyvista.PolyData, centres: np.ndarray, steps) -> np.ndarray:
    """``surface``'s signed distance at ``centres``, positive inside (a bar step a batch)."""
    distance = vtk.vtkImplicitPolyDataDistance()
    distance.SetInput(surface)
    values = np.empty(len(centres))
    for begin in range(0, len(centres), BATCH):
        next(steps, None)
        chunk = centres[begin:begin + BATCH]
        out = vtk.vtkDoubleArray()
        distance.FunctionValue(numpy_to_vtk(np.ascontiguousarray(chunk), deep=True), out)
        values[begin:begin + len(chunk)] = -vtk_to_numpy(out)   # VTK: negative inside
    return values


def make_field(data, isovalue: float | None = None, scalars: str | None = None, *,
               cells: int | Sequence[int] = 64, transform=None, name: str = "surface",
               progress_bar: bool | None = None,
               spline: str = "interpolating") -> SplineField:
    """The field whose zero set is the surface ``data`` describes, positive inside.

    ``data``: a :class:`SplineField` (a copy; ``isovalue``, if given, is subtracted: the
    field's level drawn); a 3D array of samples indexed x, y, z (one
    per unit cell, at its centre) or a ``pyvista.ImageData`` (cell data: one sample per
    cell; point data: a cell centred on each point), with ``isovalue``: the quadratic
    B-spline interpolating ``samples - isovalue`` at the cell centres
    (:func:`interpolating_coefficients`), so the inside is where the data exceed the
    isovalue; a closed surface mesh (``pyvista.PolyData`` or other non-image dataset, or
    a mesh file ``pyvista.read`` reads): its signed distance on ``cells`` cells along its
    longest side (:func:`mesh_field`); a point cloud with outward normals (a PolyData
    without faces and with ``point_data['Normals']``, or a ``(points, normals)`` pair):
    the least-squares fit of :func:`point_cloud_field` on ``cells`` cells. Raises
    ``VolumeDataError`` for NaN samples, a missing isovalue, an open mesh or a cloud
    without normals.

    ``spline`` (samples and meshes): ``'interpolating'`` (the field passes through every
    sample) or ``'approximating'`` (the samples are its coefficients: smoother, never
    crossing a level where no neighbouring sample does, but not through the samples:
    see :func:`~pv_cubemarch.models.surface.spline_coefficients`).
    """
    if spline not in SPLINES:
        raise VolumeDataError(f"spline must be one of {SPLINES}: 'interpolating' passes "
                              "through the samples, 'approximating' never overshoots them; "
                              f"got {spline!r}.")
    if isinstance(data, vtk.vtkDataObject) and not isinstance(data, pyvista.DataObject):
        data = pyvista.wrap(data)   # a VTK object, as PyVista's filters take one
    data, scalars = with_scalars_array(data, scalars)
    if isinstance(data, (str, Path)) and Path(data).suffix.lower() in ARRAY_SUFFIXES:
        data = read_array_file(Path(data), Path(data).suffix.lower(), None, "make_field",
                               str(data), error=VolumeDataError)   # samples, x, y, z
    elif isinstance(data, (str, Path)):   # an image file's header checked first
        data = read_data_file(data, "make_field", error=VolumeDataError)
    if isinstance(data, pyvista.RectilinearGrid):   # samples, if uniform (else refused)
        data = uniform_grid(data)
    _check_data(data, isovalue, scalars)
    _check_cells(cells)
    if isovalue is not None and not (isinstance(isovalue, (int, float, np.number))
                                     and np.isfinite(isovalue)):
        raise VolumeDataError(f"isovalue must be a finite number, got {isovalue!r}.")
    fitted = isinstance(data, SplineField) or (isinstance(data, tuple) and len(data) == 2) \
        or (isinstance(data, pyvista.PolyData) and data.n_faces == 0)
    if fitted and spline != "interpolating":
        raise VolumeDataError(f"spline={spline!r} says how samples or a mesh's distances "
                              "become coefficients; a spline field or a point cloud's fit "
                              "has its own: leave spline out.")
    if isinstance(data, SplineField):   # a copy: the caller's field stays as it was
        field = replace(data, coefficients=data.coefficients - float(isovalue or 0.0))
    elif isinstance(data, tuple) and len(data) == 2:   # (points, normals)
        field = point_cloud_field(*data, cells, progress_bar=progress_bar, name=name)
    elif isinstance(data, pyvista.PolyData) and data.n_faces == 0:
        if "Normals" not in data.point_data:
            raise VolumeDataError("A point cloud needs normals (point_data['Normals'], "
                                  "pointing out of the surface) to be fitted; estimate them "
                                  "first, or pass a closed mesh.")
        field = point_cloud_field(data.points, data.point_data["Normals"], cells,
                                  progress_bar=progress_bar, name=name)
    elif isinstance(data, pyvista.MultiBlock):   # a glTF or OBJ scene's meshes, as one
        meshes = meshes_of(data)
        field = mesh_field(pyvista.merge([outer_surface(m) for m in meshes],
                                         merge_points=False),
                           cells, progress_bar=progress_bar, name=name, spline=spline,
                           parts=meshes if _boxes_overlap(meshes) else None)
    elif isinstance(data, pyvista.DataSet) and not isinstance(data, pyvista.ImageData):
        field = mesh_field(data, cells, progress_bar=progress_bar, name=name, spline=spline)
    else:
        field = _sampled_field(data, isovalue, scalars, name, spline)
    if transform is not None:
        field.transform = checked_transform(transform)
    return field


def _check_data(data, isovalue, scalars) -> None:
    """Refuse what ``make_field`` cannot draw, or would draw otherwise than asked."""
    meshes = isinstance(data, pyvista.MultiBlock) or (
        isinstance(data, pyvista.DataSet) and not isinstance(data, pyvista.ImageData))
    if meshes and (isovalue is not None or scalars is not None):
        what = "isovalue=" if isovalue is not None else "scalars="
        if isinstance(data, pyvista.PolyData) and data.n_faces == 0:
            raise VolumeDataError(f"{what} picks a level of samples on a regular grid; a "
                                  "point cloud is fitted by its points and normals, whose "
                                  f"surface is the fit's zero: leave {what} out.")
        raise VolumeDataError(
            f"{what} picks a level of samples on a regular grid (an ImageData, a uniform "
            f"RectilinearGrid or a 3D array); a {type(data).__name__} is drawn as the closed "
            "surface of its cells or faces, from its signed distance, and its data are not "
            "read. To draw a level of its data, resample it onto an ImageData first "
            "(pyvista.ImageData(...).sample(grid)); to draw its surface, leave "
            f"{what} out.")
    if isinstance(data, pyvista.DataObject) and not isinstance(
            data, (pyvista.DataSet, pyvista.MultiBlock)):
        raise VolumeDataError(f"A {type(data).__name__} holds no grid or mesh to draw a "
                              "surface of: give samples (an ImageData or a 3D array), a "
                              "closed mesh, or a point cloud with normals.")


def meshes_of(blocks: pyvista.MultiBlock) -> list:
    """A MultiBlock's meshes with cells (nested blocks too); images are refused.

    A glTF, OBJ or 3DS file reads as a MultiBlock of its meshes: their union is drawn.
    """
    meshes = [block for block in blocks.recursive_iterator(skip_none=True)
              if isinstance(block, pyvista.DataSet) and block.n_cells]
    images = [block for block in meshes if isinstance(block, pyvista.ImageData)]
    if images:
        raise VolumeDataError(f"The MultiBlock holds {len(images)} image(s): add_surface "
                              "draws one grid of samples; add each block on its own.")
    if not meshes:
        raise VolumeDataError("The MultiBlock holds no mesh with cells to draw.")
    return meshes


def _boxes_overlap(meshes: list) -> bool:
    """Whether any two of ``meshes``' bounding boxes overlap (their union is not theirs)."""
    boxes = np.asarray([m.bounds for m in meshes], np.float64).reshape(-1, 3, 2)
    return any(np.all((boxes[i, :, 0] <= boxes[j, :, 1]) & (boxes[j, :, 0] <= boxes[i, :, 1]))
               for i in range(len(boxes)) for j in range(i))


def outer_surface(mesh: pyvista.DataSet) -> pyvista.PolyData:
    """``mesh`` itself if a PolyData, else its outer faces (VTK's dataset surface filter)."""
    if isinstance(mesh, pyvista.PolyData):
        return mesh
    faces = vtk.vtkDataSetSurfaceFilter()
    faces.SetInputData(mesh)
    faces.Update()
    return pyvista.wrap(faces.GetOutput())


def with_scalars_array(data, scalars):
    """``(data, scalars)``, an array of ``scalars`` put on a shallow copy of the grid.

    As PyVista's ``contour(scalars=array)``: one value per point (point data) or per cell
    (cell data), named ``'Data'``; a name or None passes through.
    """
    if scalars is None or isinstance(scalars, str):
        return data, scalars
    if not isinstance(data, pyvista.DataSet):
        raise VolumeDataError("scalars= as an array needs a grid to sit on; pass the array "
                              "itself in the grid's place.")
    values = np.asarray(scalars).reshape(-1)
    grid = data.copy(deep=False)
    if values.size == grid.n_points:
        grid.point_data["Data"] = values
    elif values.size == grid.n_cells:
        grid.cell_data["Data"] = values
    else:
        raise VolumeDataError(f"scalars has {values.size:,} values; the grid has "
                              f"{grid.n_points:,} points and {grid.n_cells:,} cells.")
    return grid, "Data"


def _check_cells(cells) -> None:
    """``cells``: a whole number >= 1, or three of them (a clear error otherwise)."""
    counts = np.atleast_1d(np.asarray(cells, dtype=object))
    whole = all(isinstance(c, (int, np.integer)) and not isinstance(c, bool) and c >= 1
                for c in counts)
    if counts.ndim != 1 or len(counts) not in (1, 3) or not whole:
        raise VolumeDataError(f"cells must be a whole number >= 1 (cells along the longest "
                              f"side) or three of them, got {cells!r}.")


def _sampled_field(data, isovalue: float | None, scalars: str | None,
                   name: str, spline: str = "interpolating") -> SplineField:
    """Samples (an array or an ImageData's) minus ``isovalue``, by ``spline``."""
    domain = None
    if isinstance(data, pyvista.ImageData):
        values, grid_from_index = image_samples(data, scalars)
        if samples_at_points(data, scalars):   # drawn up to the points, as contour draws
            domain = point_hull(values.shape)
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
    coefficients = spline_coefficients(values - float(isovalue), spline)
    if float(isovalue) == values.min():
        # VTK's contour counts a point at the level as inside: none lies below this one
        warnings.warn(f"isovalue={isovalue:g} is the data's smallest value: no sample lies "
                      "below it, so PyVista's contour draws nothing there, and neither does "
                      "add_surface (the interpolating spline dips below it only where it "
                      "rings).", stacklevel=4)
        coefficients = np.ones_like(coefficients)   # no point below 0: the surface is empty
    elif not values.min() <= float(isovalue) <= values.max():
        # the spline lies within its coefficients' range; between samples that step
        # sharply it overshoots them, and may cross a level no sample reaches
        crosses = coefficients.min() <= 0.0 <= coefficients.max()
        warnings.warn(f"isovalue={isovalue:g} is outside the data range [{values.min():g}, "
                      f"{values.max():g}]: " + (
                          "PyVista's contour draws nothing there, but the interpolating "
                          "spline overshoots the samples where they step sharply and may "
                          "cross it: where it does, that surface is drawn (give an isovalue "
                          "inside the range, or smoother samples)." if crosses else
                          "the surface is empty."), stacklevel=4)
    flat = [("x", "y", "z")[a] for a in range(3) if values.shape[a] == 1]
    if domain is not None and flat:   # a sheet, a line or a point: no surface of area
        along = " and ".join(flat)
        what = ("a curve, which PyVista's contour draws as lines", "isolated points",
                "a point at most")[len(flat) - 1]
        warn_user(f"The grid is flat (one point along {along}): its isosurface is {what}; "
                  "a surface, it has no area and add_surface draws nothing of it. Draw it "
                  "with pl.add_mesh(grid.contour([isovalue])), or give the grid two points or "
                  f"more along {along}.", VolumeDataWarning)
    field = SplineField(coefficients, grid_from_index, name=name, domain=domain)
    if values.min() < float(isovalue) < values.max() and spline == "interpolating":
        _say_overshoot(field, values - float(isovalue), isovalue)   # the other cannot
    return field


def _say_overshoot(field: SplineField, values: np.ndarray, isovalue) -> None:
    """Warn where the spline crosses the level in cells none of whose samples do.

    The interpolating spline overshoots samples that step sharply: near a plateau at a
    value close to the level it crosses it where no sample does, and draws a sheet that
    PyVista's contour (linear between samples) does not (CT air at -1000 and tissue at 40
    HU, a level of 100: 4,226 pixels drawn where contour draws 1,399).
    """
    # no sample among its 27 neighbours at or above 0, or none at or below
    one_sided = np.argwhere(~grown_by_one(values >= 0.0) | ~grown_by_one(values <= 0.0))
    if not len(one_sided):
        return
    beta = field.cell_bernstein(one_sided)
    maybe = (beta.min(axis=(1, 2, 3)) < 0.0) & (beta.max(axis=(1, 2, 3)) > 0.0)
    basis = bernstein_basis(np.linspace(0.0, 1.0, 5))   # the field at 5^3 points of each
    at = np.einsum("nabc,ia,jb,kc->nijk", beta[maybe], basis, basis, basis, optimize=True)
    crossed = int(((at.min(axis=(1, 2, 3)) < 0.0) & (at.max(axis=(1, 2, 3)) > 0.0)).sum())
    if crossed:
        warn_user(f"isovalue={isovalue:g}: the interpolating spline crosses it in {crossed:,} "
                  "cells none of whose neighbouring samples does (it overshoots samples that "
                  "step sharply, near a plateau close to the level): a surface is drawn "
                  "there that PyVista's contour does not draw. spline='approximating' "
                  "never overshoots; an isovalue further from the data's plateaus, or "
                  "smoother samples, has none.", VolumeDataWarning)


def point_cloud_field(points, normals, cells: int = 32, *, offset: float = 0.5,
                      smoothness: float = 0.1, tolerance: float = 1e-6,
                      max_iterations: int = 2000, progress_bar: bool | None = None,
                      name: str = "surface") -> SplineField:
    """A field fitted to oriented points: 0 on them, positive inside (behind the normals).

    Least squares on the coefficients (scipy.sparse): each point asks ``f = 0`` there and
    ``f = -+h`` at ``offset`` cells (``h`` world units) along its outward normal either side;
    ``smoothness`` weighs the coefficients' second differences along each axis, which fill
    the space far from the points. Solved by conjugate gradients on the normal equations
    (Jacobi preconditioner), started from each coefficient's signed distance to its nearest
    point along that point's normal, with a progress bar over the iterations. ``cells``:
    cells along the points' longest side (two more on every side).
    """
    if not np.isscalar(cells) and np.ndim(cells) != 0:
        raise VolumeDataError(f"A point cloud's cells is one count (along its longest side), "
                              f"got {cells!r}.")
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    if len(points) < 10:
        raise VolumeDataError(f"A fit needs at least 10 points with normals, got "
                              f"{len(points)}.")
    if normals.shape != points.shape:
        raise VolumeDataError(f"One normal per point: {len(points)} points and "
                              f"{len(normals)} normals.")
    if not (np.isfinite(points).all() and np.isfinite(normals).all()):
        raise VolumeDataError("The points or normals hold NaN or infinite values.")
    lengths = np.linalg.norm(normals, axis=1)
    if (lengths == 0).any():
        raise VolumeDataError(f"{int((lengths == 0).sum())} normals are zero: every point "
                              "needs a direction out of the surface.")
    normals = normals / lengths[:, None]
    low, high = points.min(axis=0), points.max(axis=0)
    size = float((high - low).max()) / max(int(cells), 1)
    if not size > 0:
        raise VolumeDataError("The points all coincide: they span no surface.")
    counts = np.maximum(np.ceil((high - low) / size).astype(int), 1) + 2 * MARGIN_CELLS
    start = (low + high) / 2 - counts * size / 2
    shape = tuple(int(n) + 2 for n in counts)
    h = float(offset) * size
    samples = np.concatenate([points, points - h * normals, points + h * normals])
    targets = np.concatenate([np.zeros(len(points)), np.full(len(points), h),
                              np.full(len(points), -h)])
    data = _basis_rows((samples - start) / size, counts, shape)
    smooth = _second_differences(shape) * (float(smoothness) * np.sqrt(len(samples)
                                                                       / np.prod(shape)))
    from scipy import sparse  # here: scipy's sparse and spatial cost every import 0.2 s
    from scipy.sparse import linalg as sparse_linalg

    system = (data.T @ data + smooth.T @ smooth).tocsr()
    rhs = data.T @ targets
    guess = _nearest_signed_distance(points, normals, start, size, shape)
    preconditioner = sparse.diags(1.0 / np.maximum(system.diagonal(), 1e-300))
    bar = progress(total=int(max_iterations), desc="fitting points", enabled=progress_bar)
    try:
        solution, info = sparse_linalg.cg(system, rhs, x0=guess, rtol=tolerance,
                                          maxiter=int(max_iterations), M=preconditioner,
                                          callback=lambda _: bar.update(1))
    finally:
        bar.close()
    if info > 0:
        warnings.warn(f"The point fit stopped after {max_iterations} iterations before its "
                      f"tolerance {tolerance:g}: the surface may be rough; raise "
                      "max_iterations or smoothness.", stacklevel=2)
    grid_from_index = np.diag([size, size, size, 1.0])
    grid_from_index[:3, 3] = start
    coefficients = solution.reshape(shape)
    if coefficients[0, 0, 0] > 0:   # the domain's corner lies outside: normals point in
        warnings.warn("The normals point into the surface (its outside came out positive): "
                      "the field is flipped so that it is positive inside.", stacklevel=3)
        coefficients = -coefficients
    return SplineField(coefficients, grid_from_index, name=name)


def _basis_rows(x: np.ndarray, counts, shape) -> scipy.sparse.csr_matrix:
    """Per cell-space point, its 27 B-spline basis weights on the coefficients."""
    from scipy import sparse

    cell = np.clip(np.floor(x).astype(np.int64), 0, np.asarray(counts) - 1)
    u = x - cell
    weights = [np.stack([(1 - v) ** 2 / 2, 0.5 + v - v * v, v * v / 2], axis=-1)
               for v in u.T]
    rows, columns, values = [], [], []
    index = np.arange(len(x))
    for a in range(3):
        for b in range(3):
            for c in range(3):
                rows.append(index)
                columns.append(np.ravel_multi_index((cell[:, 0] + a, cell[:, 1] + b,
                                                     cell[:, 2] + c), shape))
                values.append(weights[0][:, a] * weights[1][:, b] * weights[2][:, c])
    return sparse.csr_matrix((np.concatenate(values), (np.concatenate(rows),
                                                       np.concatenate(columns))),
                             shape=(len(x), int(np.prod(shape))))


def _second_differences(shape) -> scipy.sparse.csr_matrix:
    """Rows ``c[i-1] - 2 c[i] + c[i+1]`` along each axis of a coefficient grid."""
    from scipy import sparse

    blocks = []
    for axis in range(3):
        n = shape[axis]
        if n < 3:
            continue
        second = sparse.diags([1.0, -2.0, 1.0], [0, 1, 2], shape=(n - 2, n))
        parts = [sparse.identity(m) for m in shape]
        parts[axis] = second
        blocks.append(sparse.kron(sparse.kron(parts[0], parts[1]), parts[2]))
    return sparse.vstack(blocks).tocsr()


def _nearest_signed_distance(points, normals, start, size, shape) -> np.ndarray:
    """Each coefficient's centre's distance along its nearest point's normal, negated."""
    from scipy.spatial import cKDTree

    axes = [start[a] + (np.arange(shape[a]) - 0.5) * size for a in range(3)]
    centres = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    _, nearest = cKDTree(points).query(centres)
    return -np.einsum("ij,ij->i", centres - points[nearest], normals[nearest])


def color_values(data, surface: SplineField, spline: str = "interpolating") -> np.ndarray:
    """Coefficients of a second field on ``surface``'s cells, from one sample per cell.

    ``data``: an array (or an ImageData's first array) of the surface's cell counts, made a
    spline as the surface's own samples are (``spline``: :func:`spline_coefficients`).
    """
    values = image_samples(data, None)[0] if isinstance(data, pyvista.ImageData) else \
        np.asarray(data)
    shape = tuple(surface.dimensions)
    if values.ndim == 1 and values.size == np.prod(shape):   # VTK's order, x fastest
        values = values.reshape(shape, order="F")
    if values.shape != shape:
        raise VolumeDataError(
            f"color_by values must have one sample per cell of the surface: an array of "
            f"shape {shape} indexed [i, j, k], or {int(np.prod(shape))} values in VTK's "
            f"point order (x fastest, as grid.point_data holds them), or an array's name; "
            f"got {values.shape}.")
    values = values.astype(np.float64)
    if not np.isfinite(values).all():
        raise VolumeDataError("color_by values hold NaN or infinite values.")
    return spline_coefficients(values, spline)
