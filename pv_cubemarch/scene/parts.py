"""The parts of a scene: meshes with their materials, lights, and what was left out."""

from __future__ import annotations

from dataclasses import dataclass

import pyvista

from .materials import SurfaceMaterial


@dataclass
class SceneMesh:
    """An opaque or translucent surface in world coordinates with its material."""

    name: str
    mesh: pyvista.PolyData
    color: tuple[float, float, float] = (0.8, 0.8, 0.8)
    opacity: float = 1.0
    roughness: float = 0.5
    vertex_colors: str | None = None
    #: The surface material (textures and all), drawn with VTK's PBR; ``None``: the colour.
    material: SurfaceMaterial | None = None
    #: 'auto' (normals computed, sharp edges split), 'normals' (the mesh's "Normals"),
    #: 'smooth' (its smooth "Normals", computed) or 'flat'.
    shading: str = "auto"
    #: Both sides lit and drawn; a single-sided mesh's back faces are culled, as usdview does.
    double_sided: bool = True


@dataclass
class SceneLight:
    """A light as the file describes it; ``intensity`` is the file's, before normalisation."""

    name: str
    kind: str  # 'distant', 'sphere', 'rect', 'disk', 'cylinder' or 'dome'
    color: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 1.0
    position: tuple[float, float, float] | None = None
    direction: tuple[float, float, float] | None = None
    #: A distant light's angular diameter (degrees): read, not drawn (no soft shadows).
    angle: float | None = None
    #: A dome light's latitude-longitude image, drawn as image-based lighting.
    texture: str | None = None
    #: A dome light's orientation in the world (3x3 rotation; its +y is the image's pole).
    rotation: tuple = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    #: A shaped light's cone half-angle (degrees).
    cone_angle: float | None = None
    #: What the intensity is multiplied by: a positional light's emitting area, a distant
    #: light's solid angle (1 when ``normalize`` is on).
    area: float = 1.0


@dataclass
class SkippedPrim:
    """A prim that was not loaded, and why."""

    path: str
    reason: str
    #: Left out or drawn otherwise because something was wrong or unsupported (a
    #: SceneWarning was issued), not on purpose (invisible, inactive, guides).
    problem: bool = False
