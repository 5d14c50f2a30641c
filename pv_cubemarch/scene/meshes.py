"""Read mesh and scene files trimesh understands (OBJ, STL, PLY, OFF, GLB/glTF) into a Scene."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pyvista

from ..core.budgets import host_budget
from ..core.errors import SceneLoadError, SceneWarning
from ..gl.handle import MAX_WORLD_COORDINATE
from ..models.image_files import ARRAY_BYTES_ENV
from .model import Scene, SceneMesh
from .parts import SkippedPrim

MESH_SUFFIXES = (".obj", ".stl", ".ply", ".off", ".glb", ".gltf")
#: The most meshes a file's scene graph may place (glTF nodes each placing a copy of a
#: mesh: a 660 KB file of 6,000 nodes over one 20,000-triangle mesh asked for 5 GB).
MAX_PLACED_MESHES = 20_000
#: Bytes a placed copy takes per point and per triangle (the points and their transformed
#: copy in float64, normals, the triangles' connectivity), as counted before copying.
PLACED_BYTES_PER_POINT = 96
PLACED_BYTES_PER_TRIANGLE = 40


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
    placements = [(node, *loaded.graph[node]) for node in loaded.graph.nodes_geometry]
    placements = [(node, matrix, loaded.geometry[name]) for node, matrix, name in placements
                  if isinstance(loaded.geometry.get(name), trimesh.Trimesh)
                  and len(loaded.geometry[name].faces)]
    _check_placements(path, [geometry for _, _, geometry in placements])
    for node, matrix, geometry in placements:
        faces = np.column_stack([np.full(len(geometry.faces), 3), geometry.faces]).ravel()
        mesh = pyvista.PolyData(np.asarray(geometry.vertices, dtype=np.float64), faces=faces)
        if not np.allclose(matrix, np.eye(4)):
            mesh = mesh.transform(np.asarray(matrix, dtype=np.float64), inplace=False)
        reason = beyond_reach(mesh)
        if reason:   # said, and the rest drawn (it blanked the whole frame)
            scene.skipped.append(SkippedPrim(str(node), reason, problem=True))
            warnings.warn(f"{path.name}: mesh {node}: {reason}", SceneWarning, stacklevel=2)
            continue
        item = SceneMesh(name=str(node), mesh=mesh)
        _apply_visual(geometry, item)
        scene.meshes.append(item)
    if not scene.meshes:
        why = "; ".join(f"{k.path}: {k.reason}" for k in scene.skipped[:3])
        raise SceneLoadError(f"Mesh file {str(path)!r} holds no triangle meshes"
                             + (f" that can be drawn ({why})." if why else "."))
    return scene


def _check_placements(path: Path, geometries: list) -> None:
    """Refuse a scene graph placing more meshes, or copies, than may be made (before any)."""
    if len(geometries) > MAX_PLACED_MESHES:
        raise SceneLoadError(f"Mesh file {str(path)!r} places {len(geometries):,} meshes, more "
                             f"than the {MAX_PLACED_MESHES:,} a scene file may: merge them, "
                             "or save the copies as a USD PointInstancer.")
    nbytes = sum(len(g.vertices) * PLACED_BYTES_PER_POINT + len(g.faces)
                 * PLACED_BYTES_PER_TRIANGLE for g in geometries)
    budget = host_budget(ARRAY_BYTES_ENV, SceneLoadError)
    if budget is not None and nbytes > budget:
        raise SceneLoadError(f"Mesh file {str(path)!r}: its {len(geometries):,} placed meshes "
                             f"would take {nbytes:,} bytes, more than the {budget:,} they may "
                             f"({ARRAY_BYTES_ENV}, by default 80 % of the memory available).")


def beyond_reach(mesh: pyvista.PolyData) -> str:
    """Why ``mesh`` cannot be drawn where it is placed ('' if it can)."""
    points = np.asarray(mesh.points)
    if not np.isfinite(points).all():
        return "its points or transform make NaN or infinite coordinates"
    reach = float(np.abs(points).max()) if points.size else 0.0
    if reach > MAX_WORLD_COORDINATE:
        return (f"it reaches {reach:.3g} world units from the origin; past about "
                f"{MAX_WORLD_COORDINATE:g} VTK's clipping range and GL's float32 camera "
                "break down and the whole frame is drawn blank")
    return ""


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
