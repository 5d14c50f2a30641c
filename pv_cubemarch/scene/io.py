"""One entry point for every scene format: USD through usd-core, meshes through trimesh.

A grid file (.vti, .vtk, .npy, .npz) is a scene of its one volume, voxel grid or surface.
"""

from __future__ import annotations

from pathlib import Path

from ..core.errors import SceneLoadError
from . import usd
from .grids import GRID_SUFFIXES, load_grid_scene
from .meshes import MESH_SUFFIXES, load_mesh_scene
from .model import Scene
from .usd import USD_SUFFIXES


def load_scene(path, progress_bar: bool | None = None, as_voxels: bool = False,
               isovalue: float | None = None, time: float | None = None,
               strict: bool = False, spline: str = "interpolating") -> Scene:
    """Load a scene from a USD stage, any mesh/scene file trimesh reads, or a grid file.

    Parameters
    ----------
    path : str or pathlib.Path
        A ``.usd``, ``.usda``, ``.usdc`` or ``.usdz`` stage, an OBJ, STL, PLY, OFF, GLB or
        glTF file, or a ``.vti``/``.vtk`` image or ``.npy``/``.npz`` array (one grid).
    progress_bar : bool, optional
        Show a progress bar while loading; by default only on a terminal.
    as_voxels : bool
        Load every volume (USD ``Volume`` prim or grid file) as a voxel grid of integer
        material labels, whatever its ``cubemarch:technique``. A USD ``Volume`` with
        ``cubemarch:technique = "voxels"`` is one anyway.
    isovalue : float, optional
        A grid file only: load its field as the implicit surface at this level (a
        :class:`~pv_cubemarch.models.surface.SplineField`, drawn by
        :func:`~pv_cubemarch.add_surface`). In a USD stage a ``Volume`` prim says so itself
        (``cubemarch:technique = "surface"`` and ``cubemarch:isovalue``).
    spline : str, default: 'interpolating'
        With ``isovalue``: how the samples become the surface's spline, as
        :func:`~pv_cubemarch.add_surface` takes it (``'approximating'`` never overshoots
        them). In a USD stage, ``cubemarch:spline`` on the prim.
    time : float, optional
        A USD stage only: the time code to read animated values at; by default the stage's
        start time when it is animated.
    strict : bool
        A USD stage only: raise at the first prim that cannot be read. By default such a
        prim is reported (a ``SceneWarning`` and an entry in ``scene.skipped``, with the
        prim path and the reason) and the rest of the stage is read.

    Returns
    -------
    Scene
        Meshes, volumes, voxel grids, cameras and lights in world coordinates, plus the
        prims skipped.

    Examples
    --------
    >>> import pv_cubemarch
    >>> scene = pv_cubemarch.load_scene("datasets/smoke_scene.usda")  # doctest: +SKIP
    >>> print(scene.summary())  # doctest: +SKIP
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if isovalue is not None and suffix not in GRID_SUFFIXES:
        raise SceneLoadError(
            f"isovalue applies to grid files ({', '.join(GRID_SUFFIXES)}), not {suffix!r}: in "
            "a USD stage set cubemarch:technique = \"surface\" and cubemarch:isovalue on the "
            "Volume prims to draw as surfaces.")
    if spline != "interpolating" and isovalue is None:
        raise SceneLoadError(f"spline={spline!r} says how a grid file's samples become a "
                             "surface: give isovalue= too (--isovalue on the command line; "
                             "in a USD stage, cubemarch:spline on the surface's Volume "
                             "prim).")
    if isovalue is not None and as_voxels:
        raise SceneLoadError("A grid file is loaded as voxels (as_voxels) or as a surface "
                             "(isovalue), not both: leave one out.")
    if time is not None and suffix not in USD_SUFFIXES:
        raise SceneLoadError(f"time applies to USD stages ({', '.join(USD_SUFFIXES)}), not "
                             f"{suffix!r} files, which hold no animation.")
    if suffix in USD_SUFFIXES:
        return usd.load_usd(path, progress_bar=progress_bar, as_voxels=as_voxels, time=time,
                            strict=strict)   # USD's modules are imported here, once read
    if suffix in MESH_SUFFIXES:
        return load_mesh_scene(path)
    if suffix in GRID_SUFFIXES:
        return load_grid_scene(path, as_voxels=as_voxels, isovalue=isovalue, spline=spline)
    raise SceneLoadError(
        f"Cannot load {str(path)!r}: unknown scene type {suffix!r}. Supported: "
        f"{', '.join(USD_SUFFIXES + MESH_SUFFIXES + GRID_SUFFIXES)}; a .zarr folder (an "
        "OME-Zarr pyramid or zarr array) is streamed by add_volume or pv-cubemarch render."
    )
