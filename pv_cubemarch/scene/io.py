"""One entry point for every scene format: USD through usd-core, meshes through trimesh."""

from __future__ import annotations

from pathlib import Path

from ..core.errors import SceneLoadError
from .meshes import MESH_SUFFIXES, load_mesh_scene
from .model import Scene
from .usd import USD_SUFFIXES, load_usd


def load_scene(path, progress_bar: bool | None = None) -> Scene:
    """Load a scene from a USD stage or any mesh/scene file trimesh reads.

    Parameters
    ----------
    path : str or pathlib.Path
        A ``.usd``, ``.usda``, ``.usdc`` or ``.usdz`` stage, or an OBJ, STL, PLY, OFF, GLB or
        glTF file.
    progress_bar : bool, optional
        Show a progress bar while loading; by default only on a terminal.

    Returns
    -------
    Scene
        Meshes, volumes, cameras and lights in world coordinates, plus the prims skipped.

    Examples
    --------
    >>> import pv_cubemarch
    >>> scene = pv_cubemarch.load_scene("datasets/smoke_scene.usda")  # doctest: +SKIP
    >>> print(scene.summary())  # doctest: +SKIP
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in USD_SUFFIXES:
        return load_usd(path, progress_bar=progress_bar)
    if suffix in MESH_SUFFIXES:
        return load_mesh_scene(path)
    raise SceneLoadError(
        f"Cannot load {str(path)!r}: unknown scene type {suffix!r}. Supported: "
        f"{', '.join(USD_SUFFIXES + MESH_SUFFIXES)}."
    )
