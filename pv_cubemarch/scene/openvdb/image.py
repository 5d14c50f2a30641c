"""An OpenVDB grid as PyVista data placed by the grid's transform.

OpenVDB puts voxel ``ijk``'s value at the world point ``index_to_world @ (i, j, k, 1)``, so
a dense box of values is an ImageData whose points are the voxel centres (or, with
``cells``, whose cells are the voxels). A map with orthogonal axes is the ImageData's
spacing and direction matrix; a sheared one cannot be, and the ImageData stays in index
space with the 4x4 map in ``field_data["index_to_world"]`` (the volume readers compose it).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyvista

from .reader import list_grids, read_grid
from .records import VdbFormatError, VdbGrid

#: Where an ImageData that could not take the grid's map (a shear) keeps it.
INDEX_TO_WORLD = "index_to_world"


#: Value types a volume, voxel grid or surface can draw (one number per voxel).
SCALAR_TYPES = ("float", "double", "int32", "int64", "bool")


def choose_grid(path: str | Path, name: str | None = None, index: int | None = None
                ) -> tuple[str, int, list[str]]:
    """The grid to draw (``name``, else ``density``, else the first) and the other names.

    A grid of vectors is refused here, before any of its voxels is read.
    """
    infos = list_grids(path)
    if not infos:
        raise VdbFormatError(f"{str(path)!r} holds no grids.")
    names = [info.name for info in infos]
    if name is not None and name not in names:
        raise VdbFormatError(f"{str(path)!r} has no grid named {name!r}; it has "
                             f"{sorted(set(names))}.")
    chosen = name if name is not None else "density" if "density" in names else names[0]
    same = [info for info in infos if info.name == chosen]
    if index is not None and not 0 <= index < len(same):
        raise VdbFormatError(f"{str(path)!r} has {len(same)} grid(s) named {chosen!r}; "
                             f"fieldIndex {index} is not one of them.")
    others = [n for n in names if n != chosen]
    number = 0 if index is None else int(index)
    if same[number].value_type not in SCALAR_TYPES:
        raise VdbFormatError(
            f"grid {chosen!r} holds {same[number].value_type} vectors; a volume, voxel grid "
            f"or surface needs a scalar grid ({', '.join(SCALAR_TYPES)}): choose one with "
            f"fieldName / grid= (the file's grids: {sorted(set(names))})")
    return chosen, number, others


def vdb_image(path: str | Path, name: str | None = None, index: int | None = None,
              cells: bool = False, region=None, stride: int = 1,
              margin: int = 0, max_bytes: int | None = None) -> pyvista.ImageData:
    """One grid of a ``.vdb`` file as an ImageData (values in ``point_data[name]``).

    Parameters
    ----------
    path : str or pathlib.Path
        The ``.vdb`` file.
    name : str, optional
        The grid; by default ``density`` when the file has one, else the first.
    index : int, optional
        Which of several grids of that name (0 by default).
    cells : bool
        Put the values on cells (one per voxel) instead of points (voxel centres).
    region, stride
        A part of the grid (an inclusive index box) and a step, for grids too large to
        read whole (see :func:`~pv_cubemarch.scene.openvdb.read_grid`).
    margin : int
        Samples of what lies outside the active box (the background, mostly) to add on
        every side: a surface whose inside fills the active box closes there.
    max_bytes : int, optional
        The read's memory budget (see :func:`~pv_cubemarch.scene.openvdb.read_grid`).

    Returns
    -------
    pyvista.ImageData
        Placed in the grid's world space, or in index space with the map in
        ``field_data["index_to_world"]`` when the map shears.
    """
    chosen, number, _ = choose_grid(path, name, index)
    grid = read_grid(path, chosen, number, region=region, stride=stride, max_bytes=max_bytes)
    if margin and region is None:
        low = np.array(grid.origin_index) - margin * stride
        high = np.array(grid.origin_index) + (np.array(grid.values.shape[:3]) - 1 + margin) \
            * stride
        grid = read_grid(path, chosen, number, region=(tuple(low), tuple(high)), stride=stride,
                         max_bytes=max_bytes)
    return grid_image(grid, cells)


def grid_image(grid: VdbGrid, cells: bool = False) -> pyvista.ImageData:
    """A decoded grid as an ImageData (see :func:`vdb_image`)."""
    values = grid.values
    if values.ndim == 4:
        raise VdbFormatError(f"grid {grid.info.name!r} holds {grid.info.value_type} vectors; "
                             "a volume, voxel grid or surface needs a scalar grid (choose one "
                             "with fieldName).")
    if values.dtype == bool:
        values = values.astype(np.uint8)
    index_to_world = np.asarray(grid.info.index_to_world, dtype=np.float64)
    step = np.diag([grid.stride] * 3 + [1]).astype(np.float64)
    step[:3, 3] = grid.origin_index
    if cells:   # voxel ijk fills [i - 0.5, i + 0.5]: the box starts half a voxel earlier
        step[:3, 3] -= 0.5 * grid.stride
    matrix = index_to_world @ step          # sample (a, b, c) of the array -> world
    columns = matrix[:3, :3]
    spacing = np.linalg.norm(columns, axis=0)
    dims = tuple(int(n) + (1 if cells else 0) for n in values.shape)
    name = grid.info.name or "density"
    unit = columns / np.where(spacing > 0, spacing, 1.0)
    if np.allclose(unit.T @ unit, np.eye(3), atol=1e-9):
        image = pyvista.ImageData(dimensions=dims, spacing=tuple(spacing),
                                  origin=tuple(matrix[:3, 3]))
        image.direction_matrix = unit
    else:
        image = pyvista.ImageData(dimensions=dims)
        image.field_data[INDEX_TO_WORLD] = matrix.ravel()
    data = image.cell_data if cells else image.point_data
    data[name] = values.ravel(order="F")
    data.active_scalars_name = name
    return image


def read_vdb(path: str | Path, grid: str | None = None, index: int | None = None,
             region=None, stride: int = 1, max_bytes: int | None = None
             ) -> pyvista.ImageData | pyvista.StructuredGrid:
    """Read one grid of an OpenVDB file as PyVista data in its world space.

    This is what ``pyvista.read("x.vdb")`` returns; the values sit on the points (voxel
    centres), ready for :func:`pv_cubemarch.add_volume`.

    Parameters
    ----------
    path : str or pathlib.Path
        The ``.vdb`` file.
    grid : str, optional
        The grid's name; by default ``density`` when the file has one, else the first.
    index : int, optional
        Which of several grids of that name (0 by default).
    region : tuple, optional
        An inclusive index box ``((i0, j0, k0), (i1, j1, k1))`` to read instead of the
        grid's active bounding box: for grids too large for memory.
    stride : int
        Keep every ``stride``-th voxel along each axis: a coarser copy of a large grid.
    max_bytes : int, optional
        Refuse (with :class:`~pv_cubemarch.scene.openvdb.VdbFormatError`) a read that needs
        more memory than this; by default ``PV_CUBEMARCH_VDB_MAX_BYTES``, else 1 GiB.

    Returns
    -------
    pyvista.ImageData or pyvista.StructuredGrid
        An ImageData (spacing and direction from the grid's map), or a StructuredGrid
        when the map shears.

    Examples
    --------
    >>> import pv_cubemarch
    >>> smoke = pv_cubemarch.read_vdb("smoke.vdb", stride=2)  # doctest: +SKIP
    """
    image = vdb_image(path, grid, index, region=region, stride=stride, max_bytes=max_bytes)
    if INDEX_TO_WORLD not in image.field_data:
        return image
    matrix = np.asarray(image.field_data[INDEX_TO_WORLD]).reshape(4, 4)
    structured = image.cast_to_structured_grid()
    structured.points = structured.points @ matrix[:3, :3].T + matrix[:3, 3]
    return structured
