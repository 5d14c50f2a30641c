"""Grid files (.vti, .vtk, .nrrd, .mha, .npy, .npz, .vdb): USD volume fields' data, or scenes.

A ``.npy``/``.npz`` array is indexed x, y, z. Read as a volume, its values sit on the
points of an ImageData (``origin`` is the first point); read as material labels
(``cells=True``), each value fills a voxel and ``origin`` is the grid box's corner, as
:func:`pv_cubemarch.add_voxels` places a numpy array.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyvista

from ..core.errors import SceneLoadError, VolumeDataError
from ..models.array_files import read_array_file
from ..models.channels import make_data_model
from ..models.field_sources import make_field
from ..models.image_files import IMAGE_SUFFIXES, read_image_file
from ..models.voxels import make_voxels
from .model import Scene
from .openvdb import VdbFormatError
from .openvdb.image import INDEX_TO_WORLD, vdb_image

#: The grid files a USD field may name, and that ``load_scene`` reads as a scene of one grid.
GRID_SUFFIXES = (*IMAGE_SUFFIXES, ".npy", ".npz", ".vdb")


def placement(grid, world: np.ndarray | None = None) -> np.ndarray | None:
    """The transform to draw ``grid`` with (``None``: as it is placed).

    ``world`` (a prim's placement) after the map a sheared OpenVDB grid keeps in its field
    data.
    """
    if INDEX_TO_WORLD not in grid.field_data:
        return world
    matrix = np.asarray(grid.field_data[INDEX_TO_WORLD], dtype=np.float64).reshape(4, 4)
    return matrix if world is None else world @ matrix


def read_grid(path: str | Path, where: str, shown: str | None = None,
              field_name: str | None = None, origin=None, spacing=None,
              cells: bool = False, field_index: int | None = None,
              margin: int = 0) -> pyvista.ImageData:
    """Read the grid in ``path``; errors start with ``where`` and name the file as ``shown``.

    Parameters
    ----------
    path : str or pathlib.Path
        An existing ``.vti``/``.vtk`` image, ``.npy``/``.npz`` array or ``.vdb`` OpenVDB
        file.
    where : str
        What the file belongs to, for error messages (e.g. ``"field prim /Vol/density"``).
    shown : str, optional
        The file as the user wrote it (a USD asset path); ``path`` by default.
    field_name : str, optional
        The array to use: made the active scalars of an image, the key of an ``.npz``, the
        grid of a ``.vdb`` (by default its ``density`` grid, else its first).
    origin, spacing : sequence of float, optional
        Placement of a numpy array (``(0, 0, 0)`` and ``(1, 1, 1)`` by default).
    cells : bool
        Put a numpy array's values on cells (one voxel each, ``origin`` the box's corner)
        instead of points.
    field_index : int, optional
        Which of several ``.vdb`` grids named ``field_name`` (USD's ``fieldIndex``).
    margin : int
        A ``.vdb`` grid only: voxels beyond its active box to read on every side (one, for
        a surface: its inside may fill the active box).

    Returns
    -------
    pyvista.ImageData
        The grid (a ``.vtk`` file may hold another dataset type; the caller checks it).
    """
    shown = str(path) if shown is None else shown
    suffix = Path(path).suffix.lower()
    if suffix == ".vdb":
        try:
            return vdb_image(path, str(field_name) if field_name else None, field_index,
                             cells=cells, margin=margin)
        except VdbFormatError as exc:
            raise SceneLoadError(f"{where}: OpenVDB file {shown!r}: {exc}") from exc
    if suffix in IMAGE_SUFFIXES:
        grid = read_image_file(path, where, shown)
        if field_name:
            if field_name not in grid.array_names:   # not another array, in silence
                raise SceneLoadError(f"{where}: {shown!r} has no array named {field_name!r} "
                                     f"(its arrays: {', '.join(grid.array_names) or 'none'}).")
            grid.set_active_scalars(str(field_name))
        return grid
    if suffix in (".npy", ".npz"):
        loaded = read_array_file(path, suffix, field_name, where, shown)
        if loaded.ndim != 3:
            raise VolumeDataError(f"{where}: {shown!r} holds an array of shape "
                                  f"{loaded.shape}; a volume needs 3 axes (x, y, z).")
        if loaded.dtype.kind not in "biuf":
            raise VolumeDataError(f"{where}: {shown!r} has dtype {loaded.dtype}; volumes "
                                  "need real numbers.")
        if loaded.dtype == np.float16:   # VTK has no half floats; float32 holds them exactly
            loaded = loaded.astype(np.float32)
        dimensions = tuple(int(n) + 1 for n in loaded.shape) if cells else loaded.shape
        grid = pyvista.ImageData(dimensions=dimensions,
                                 origin=tuple(origin) if origin is not None else (0, 0, 0),
                                 spacing=tuple(spacing) if spacing is not None else (1, 1, 1))
        data = grid.cell_data if cells else grid.point_data
        data[str(field_name or ("labels" if cells else "density"))] = loaded.ravel(order="F")
        return grid
    raise SceneLoadError(f"{where}: unsupported volume file type {suffix!r} ({shown!r}); "
                         "use .vti, .vtk, .npy or .npz.")




def load_grid_scene(path: str | Path, as_voxels: bool = False,
                    isovalue: float | None = None, spline: str = "interpolating") -> Scene:
    """A scene of the one grid in a ``.vti``/``.vtk``/``.npy``/``.npz`` file.

    Parameters
    ----------
    path : str or pathlib.Path
        The grid file.
    as_voxels : bool
        Read it as integer material labels (a voxel grid with the default palette) instead
        of a volume (``magma``, linear opacity).
    isovalue : float, optional
        Read it as samples (one per cell, or the point data at the points) whose surface
        at this level is drawn (a spline field), instead of a volume.
    spline : str, default: 'interpolating'
        How those samples become the spline, as :func:`~pv_cubemarch.add_surface` takes it.

    Returns
    -------
    Scene
        One volume (an array of 2 to 4 components: a channel volume; 4 uint8: RGBA),
        voxel grid or surface named after the file, no camera (the default view).
    """
    path = Path(path)
    if not path.is_file():
        raise SceneLoadError(f"Grid file {str(path)!r} does not exist.")
    where = f"grid file {str(path)!r}"
    grid = read_grid(path, where, cells=as_voxels, margin=1 if isovalue is not None else 0)
    scene = Scene(source=str(path))
    try:
        if as_voxels:
            if not isinstance(grid, pyvista.ImageData):
                raise VolumeDataError(f"it holds a {type(grid).__name__}; material labels "
                                      "come on an ImageData (cell or point data).")
            scene.voxels.append(make_voxels(grid, transform=placement(grid), name=path.name))
        elif isovalue is not None:
            scene.surfaces.append(make_field(grid, float(isovalue), transform=placement(grid),
                                             name=path.name, spline=spline))
        else:
            scene.volumes.append(make_data_model(grid, None, None, None, {},
                                                 transform=placement(grid), name=path.name))
    except VolumeDataError as exc:
        raise VolumeDataError(f"{where}: {exc}") from exc
    return scene
