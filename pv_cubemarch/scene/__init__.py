"""Scene import: the ``Scene`` model, USD stages (usd-core), meshes (trimesh), ``load_scene``."""

from .io import load_scene
from .model import Scene, SceneLight, SceneMesh, SkippedPrim

__all__ = ["Scene", "SceneLight", "SceneMesh", "SkippedPrim", "load_scene"]
