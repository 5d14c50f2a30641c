"""Scene meshes as PyVista actors: plain colours, or UsdPreviewSurface materials with VTK's PBR.

A material with textures, metallic or roughness is drawn physically based: the base
colour texture is sRGB (its alpha the opacity), occlusion / roughness / metallic are
packed into one ORM texture, normal maps need tangents (computed here), and
``opacityThreshold`` cuts out fragments below it (a one-line shader replacement).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pyvista

from ..core import vtk_classes as vtk
from ..gl.shaders import Replacement, ShaderRecipe
from .materials import PrimvarInput, SurfaceMaterial, TextureInput
from .parts import SceneMesh
from .textures import base_color_image, normal_image, orm_image, texture_note, texture_values

_WRAP = {"repeat": "REPEAT", "clamp": "CLAMP_TO_EDGE", "mirror": "MIRRORED_REPEAT",
         "black": "CLAMP_TO_BORDER"}


def add_scene_mesh(plotter: pyvista.Plotter, part: SceneMesh, report=None):
    """Add ``part`` to ``plotter`` as its material asks; return the actor.

    ``report(path, reason)`` is told what could not be drawn as authored.
    """
    report = report or (lambda path, reason: None)
    mesh = part.mesh
    material = part.material
    kwargs = dict(name=part.name, opacity=part.opacity,
                  smooth_shading=part.shading == "auto", split_sharp_edges=part.shading == "auto",
                  culling=None if part.double_sided else "back")
    if part.vertex_colors:
        kwargs.update(scalars=part.vertex_colors, rgb=True)
    else:
        kwargs["color"] = part.color
    if material is None:
        kwargs["specular"] = 0.3 * (1.0 - part.roughness)
        actor = plotter.add_mesh(mesh, **kwargs)
        _set_interpolation(actor, part, pbr=False)
        return actor
    mesh = mesh.copy(deep=False)
    textured = _texture_coordinates(mesh, material, part.name, report)
    material = _resolved(material, textured, mesh, part.name, report)
    textured = textured and bool(material.textures())
    constant = _constants(material, part)
    if not part.vertex_colors:
        kwargs["color"] = constant["color"]
    kwargs.update(opacity=constant["opacity"], pbr=True, metallic=constant["metallic"],
                  roughness=constant["roughness"])
    if material.normal is not None and textured:
        mesh = _with_tangents(mesh)
    emissive = material.emissive_color
    glows = not isinstance(emissive, TextureInput) and max(emissive) > 0
    if glows and mesh.active_texture_coordinates is None:
        mesh.active_texture_coordinates = np.zeros((mesh.n_points, 2), np.float32)
    actor = plotter.add_mesh(mesh, **kwargs)
    prop = actor.GetProperty()
    if textured:
        _bind_textures(prop, mesh, material)
    if glows:   # VTK's PBR emits only through a texture: a white texel times the colour
        prop.SetEmissiveTexture(_texture(np.full((1, 1, 3), 255, np.uint8), ("clamp", "clamp"),
                                         srgb=True))
        prop.SetEmissiveFactor(*emissive[:3])
    if material.opacity_threshold > 0:
        ShaderRecipe([Replacement("//VTK::Light::Impl", "alpha_cutout", keep_tag="before")],
                     defines={"CM_OPACITY_THRESHOLD": f"{material.opacity_threshold:.9g}"}
                     ).apply(actor.GetShaderProperty())
        actor.SetForceOpaque(True)
    _set_interpolation(actor, part, pbr=True)
    return actor


def _set_interpolation(actor, part: SceneMesh, pbr: bool) -> None:
    """PBR or Phong with the mesh's own normals; flat when it has none."""
    if pbr:
        actor.prop.interpolation = "pbr"
    elif part.shading in ("normals", "smooth"):
        actor.prop.interpolation = "phong"
    elif part.shading == "flat":
        actor.prop.interpolation = "flat"


#: UsdPreviewSurface's defaults, for inputs that cannot be drawn as authored.
_DEFAULTS = {"diffuse_color": (0.18, 0.18, 0.18), "emissive_color": (0.0, 0.0, 0.0),
             "opacity": 1.0, "metallic": 0.0, "roughness": 0.5, "occlusion": 1.0}


def _resolved(material: SurfaceMaterial, textured: bool, mesh: pyvista.PolyData, name: str,
              report) -> SurfaceMaterial:
    """The material with every input VTK cannot take as authored made a constant.

    A texture that cannot be read, or is not mapped (no texture coordinates), becomes its
    ``fallback`` or its mean (reported); a primvar read as metallic, roughness, opacity or
    occlusion becomes its mean on the mesh (reported), or its fallback, or the default.
    The diffuse colour's primvar stays (drawn as vertex colours).
    """
    out = replace(material)
    for field_name, default in _DEFAULTS.items():
        value = getattr(material, field_name)
        if isinstance(value, TextureInput):
            try:
                values = texture_values(value)
                mean = values.reshape(-1, values.shape[-1]).mean(0) if not textured else None
                note = texture_note(value)
                if note:
                    report(name, f"texture {value.file!r}: {note}")
            except (OSError, ValueError) as exc:   # a TextureError too (a bomb, no memory)
                report(name, f"texture {value.file!r} could not be read ({exc}); its "
                       "fallback or the default is used")
                setattr(out, field_name, _constant(value.fallback, default))
                continue
            if not textured:
                setattr(out, field_name, _constant(value.fallback, default)
                        if value.fallback is not None else _constant(tuple(mean), default))
        elif isinstance(value, PrimvarInput) and field_name != "diffuse_color":
            data = mesh.point_data.get(value.name, mesh.cell_data.get(value.name))
            if data is None and value.name in mesh.field_data:
                data = mesh.field_data[value.name]
            if data is not None:
                report(name, f"{field_name} from primvar {value.name!r} is drawn as its mean")
                setattr(out, field_name, _constant(tuple(np.asarray(data).mean(0).ravel()),
                                                   default))
            else:
                setattr(out, field_name, _constant(value.fallback, default))
    if material.normal is not None and not textured:
        out.normal = None
    return out


def _constant(value, default):
    """``value`` shaped like ``default`` (a float, or an RGB tuple), or ``default``."""
    if value is None:
        return default
    array = np.atleast_1d(np.asarray(value, dtype=np.float64))
    if isinstance(default, tuple):
        return tuple(float(v) for v in np.resize(array, 3)) if array.size in (1, 3, 4) \
            else default
    return float(array[0])


def _constants(material: SurfaceMaterial, part: SceneMesh) -> dict:
    """The uniform factors: 1 under a texture (VTK multiplies them), else the constant."""
    def number(value) -> float:
        return 1.0 if isinstance(value, TextureInput) else float(value)

    color = material.diffuse_color
    if isinstance(color, TextureInput):
        color = (1.0, 1.0, 1.0)
    elif isinstance(color, PrimvarInput):
        color = part.color
    return {"color": tuple(color[:3]), "opacity": number(material.opacity),
            "metallic": number(material.metallic), "roughness": number(material.roughness)}


def _texture_coordinates(mesh: pyvista.PolyData, material: SurfaceMaterial, name: str,
                         report) -> bool:
    """Make the material's ``st`` primvar the active texture coordinates (transformed)."""
    textures = material.textures()
    if not textures:
        return False
    first = textures[0]
    if any(t.st != first.st for t in textures):
        report(name, f"textures read different st primvars; all use {first.st!r}")
    if any(not _same_transform(t.st_transform, first.st_transform) for t in textures):
        report(name, "textures have different UsdTransform2d; all use the first one's")
    if any(t.wrap[0] != t.wrap[1] for t in textures):
        report(name, "a texture's wrapS and wrapT differ; VTK has one wrap mode (repeat is "
               "used when either repeats)")
    if first.st not in mesh.point_data or mesh.point_data[first.st].ndim != 2 \
            or mesh.point_data[first.st].shape[1] < 2:
        report(name, f"textures need the primvar {first.st!r} as 2D coordinates per point, "
               "which the mesh lacks; drawn untextured (each texture's fallback or mean)")
        return False
    st = np.asarray(mesh.point_data[first.st], dtype=np.float64)[:, :2]
    if first.st_transform is not None:
        st = st @ first.st_transform[:2, :2].T + first.st_transform[:2, 2]
    mesh.active_texture_coordinates = st.astype(np.float32)
    return True


def _same_transform(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return bool(np.allclose(a, b))


def _with_tangents(mesh: pyvista.PolyData) -> pyvista.PolyData:
    """Triangles with the point tangents a normal map needs (from normals and coordinates)."""
    triangles = mesh.triangulate()
    if "Normals" not in triangles.point_data:
        triangles = triangles.compute_normals(cell_normals=False, split_vertices=False)
    tangents = vtk.vtkPolyDataTangents()
    tangents.SetInputData(triangles)
    tangents.ComputePointTangentsOn()
    tangents.ComputeCellTangentsOff()
    tangents.Update()
    return pyvista.wrap(tangents.GetOutput())


def _one_wrap(wrap: tuple[str, str]) -> str:
    """VTK's one wrap mode for USD's two: repeat if either repeats (reported when they differ)."""
    return wrap[0] if wrap[0] == wrap[1] else "repeat" if "repeat" in wrap else wrap[0]


def _texture(image: np.ndarray, wrap: tuple[str, str], srgb: bool) -> pyvista.Texture:
    texture = pyvista.Texture(image)
    texture.wrap = pyvista.Texture.WrapType[_WRAP[_one_wrap(wrap)]]
    texture.mipmap = True
    texture.interpolate = True
    if srgb:
        texture.UseSRGBColorSpaceOn()
    return texture


def _bind_textures(prop, mesh: pyvista.PolyData, material: SurfaceMaterial) -> None:
    """Base colour, ORM, emissive and normal textures on a PBR property."""
    color, opacity = material.diffuse_color, material.opacity
    if isinstance(color, TextureInput) or isinstance(opacity, TextureInput):
        wrap = (color if isinstance(color, TextureInput) else opacity).wrap
        prop.SetBaseColorTexture(_texture(base_color_image(
            color if not isinstance(color, PrimvarInput) else (1.0, 1.0, 1.0),
            opacity if isinstance(opacity, TextureInput) else 1.0), wrap, srgb=True))
    orm = (material.occlusion, material.roughness, material.metallic)
    if any(isinstance(v, TextureInput) for v in orm):
        first = next(v for v in orm if isinstance(v, TextureInput))
        prop.SetORMTexture(_texture(orm_image(*orm), first.wrap, srgb=False))
        if not isinstance(material.roughness, TextureInput):
            prop.SetRoughness(1.0)
        if not isinstance(material.metallic, TextureInput):
            prop.SetMetallic(1.0)
    emissive = material.emissive_color
    if isinstance(emissive, TextureInput):
        prop.SetEmissiveTexture(_texture(base_color_image(emissive, 1.0), emissive.wrap,
                                         srgb=True))
        prop.SetEmissiveFactor(1.0, 1.0, 1.0)
    if material.normal is not None and "Tangents" in mesh.point_data:
        prop.SetNormalTexture(_texture(normal_image(material.normal), material.normal.wrap,
                                       srgb=False))
