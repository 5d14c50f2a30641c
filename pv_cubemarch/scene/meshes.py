"""Read mesh and scene files trimesh understands (OBJ, STL, PLY, OFF, GLB/glTF) into a Scene."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyvista

from ..core.errors import SceneLoadError
from .model import Scene, SceneMesh

MESH_SUFFIXES = (".obj", ".stl", ".ply", ".off", ".glb", ".gltf")


def load_mesh_scene(path: str | Path) -> Scene:
    """Load every mesh of ``path`` with its scene-graph transform and base colour."""
    import trimesh  # here: trimesh costs every import of pv_cubemarch 0.1 s

    path = Path(path)
    if not path.is_file():
        raise SceneLoadError(f"Mesh file {str(path)!r} does not exist.")
    try:
        loaded = trimesh.load(str(path), force="scene")
    except Exception as exc:
        raise SceneLoadError(f"Mesh file {str(path)!r} could not be read: {exc}") from exc
    scene = Scene(source=str(path))
    for node in loaded.graph.nodes_geometry:
        matrix, geometry_name = loaded.graph[node]
        geometry = loaded.geometry[geometry_name]
        if not isinstance(geometry, trimesh.Trimesh) or len(geometry.faces) == 0:
            continue
        faces = np.column_stack([np.full(len(geometry.faces), 3), geometry.faces]).ravel()
        mesh = pyvista.PolyData(np.asarray(geometry.vertices, dtype=np.float64), faces=faces)
        if not np.allclose(matrix, np.eye(4)):
            mesh = mesh.transform(np.asarray(matrix, dtype=np.float64), inplace=False)
        item = SceneMesh(name=str(node), mesh=mesh)
        _apply_visual(geometry, item)
        scene.meshes.append(item)
    if not scene.meshes:
        raise SceneLoadError(f"Mesh file {str(path)!r} holds no triangle meshes.")
    return scene


def _apply_visual(geometry, item: SceneMesh) -> None:
    visual = geometry.visual
    kind = getattr(visual, "kind", None)
    if kind == "vertex":
        colors = np.asarray(visual.vertex_colors, dtype=np.float64)[:, :3] / 255.0
        if len(colors) == item.mesh.n_points and np.ptp(colors, axis=0).max() > 0:
            item.mesh.point_data["vertex_colors"] = colors
            item.vertex_colors = "vertex_colors"
        else:
            item.color = tuple(colors[0]) if len(colors) else item.color
    elif kind == "face":
        colors = np.asarray(visual.face_colors, dtype=np.float64)[:, :3] / 255.0
        item.color = tuple(colors.mean(axis=0))
    material = getattr(visual, "material", None)
    base = getattr(material, "baseColorFactor", None) if material is not None else None
    if base is None and material is not None:
        base = getattr(material, "main_color", None)
    if base is not None and kind in (None, "texture"):
        rgba = np.asarray(base, dtype=np.float64)
        rgba = rgba / 255.0 if rgba.max() > 1.0 else rgba
        item.color = tuple(rgba[:3])
        if rgba.size == 4:
            item.opacity = float(rgba[3])
