"""A bound material's ``UsdPreviewSurface`` network, read into a :class:`SurfaceMaterial`.

Inputs are followed through connections, material interfaces (``inputs:`` on the Material
or a NodeGraph connected inward) and instance proxies to what produces their value: a
constant, a ``UsdUVTexture`` (its ``st`` from a ``UsdPrimvarReader_float2``, optionally
through a ``UsdTransform2d``), or a ``UsdPrimvarReader_*``. Anything else is reported.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pxr import Ar, UsdShade

from ..materials import PrimvarInput, SurfaceMaterial, TextureInput
from .context import PrimError, StageContext

#: UsdPreviewSurface inputs drawn, and the SurfaceMaterial field each sets.
DRAWN_INPUTS = {"diffuseColor": "diffuse_color", "emissiveColor": "emissive_color",
                "opacity": "opacity", "metallic": "metallic", "roughness": "roughness",
                "occlusion": "occlusion", "normal": "normal"}
#: Inputs not drawn (VTK's PBR has no equivalent we use), with the UsdPreviewSurface
#: defaults at which leaving them out changes nothing.
UNDRAWN_INPUTS = {"clearcoat": 0.0, "clearcoatRoughness": 0.01, "displacement": 0.0,
                  "specularColor": (0.0, 0.0, 0.0), "useSpecularWorkflow": 0, "ior": 1.5,
                  "specular": None}
_WRAPS = {"repeat": "repeat", "clamp": "clamp", "mirror": "mirror", "black": "black",
          "useMetadata": "repeat"}


def bound_material(prim):
    """The material bound to ``prim`` for previews (the all-purpose one otherwise)."""
    material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial(
        UsdShade.Tokens.preview)
    return material if material else None


def read_material(ctx: StageContext, material) -> SurfaceMaterial | None:
    """The material's ``UsdPreviewSurface``, or ``None`` (reported) when it has none."""
    path = str(material.GetPath())
    shader = None
    for context in ("glslfx", ""):
        source = material.ComputeSurfaceSource(context)[0]
        if source:
            shader = source
            break
    if shader is None:
        ctx.report(path, "material has no surface shader; drawn with displayColor")
        return None
    shader_id = shader.GetIdAttr().Get()
    if shader_id != "UsdPreviewSurface":
        ctx.report(path, f"surface shader {shader.GetPath()} is {shader_id!r}, not "
                         "UsdPreviewSurface; drawn with displayColor")
        return None
    result = SurfaceMaterial(name=path)
    for name, field_name in DRAWN_INPUTS.items():
        shader_input = shader.GetInput(name)
        if not shader_input:
            continue
        try:
            value = _input_value(ctx, shader_input, name)
        except PrimError as exc:
            ctx.report(f"{shader.GetPath()}.inputs:{name}", f"{exc}; its default is used")
            continue
        if field_name == "normal" and not isinstance(value, TextureInput):
            continue          # a constant normal is the surface's own (its default)
        if value is not None:
            setattr(result, field_name, value)
    threshold = shader.GetInput("opacityThreshold")
    if threshold:
        value = _input_value(ctx, threshold, "opacityThreshold")
        if isinstance(value, float):
            result.opacity_threshold = value
    result.ignored = [name for name, default in UNDRAWN_INPUTS.items()
                      if shader.GetInput(name) and _changes_look(ctx, shader, name, default)]
    if result.ignored:
        ctx.report(path, f"inputs {', '.join(result.ignored)} are read but not drawn (VTK's "
                   "PBR has no equivalent we use)")
    return result


def _changes_look(ctx: StageContext, shader, name: str, default) -> bool:
    """Whether an input we do not draw is authored away from its default (or connected)."""
    attribute = _producer(shader.GetInput(name))
    if attribute is None:
        return False
    if UsdShade.Output.IsOutput(attribute) or default is None:
        return True
    value = attribute.Get(ctx.time)
    try:
        return value is not None and not np.allclose(np.asarray(value, dtype=np.float64),
                                                     default)
    except (TypeError, ValueError):
        return True


def _producer(shader_input):
    """The attribute producing ``shader_input``'s value (through interfaces), or ``None``."""
    attributes = shader_input.GetValueProducingAttributes()
    return attributes[0] if attributes else None


def _input_value(ctx: StageContext, shader_input, name: str):
    """A constant (float or tuple), a TextureInput, a PrimvarInput or ``None``."""
    attribute = _producer(shader_input)
    if attribute is None:
        return None
    if not UsdShade.Output.IsOutput(attribute):
        return _constant(attribute.Get(ctx.time), name)
    output_name = UsdShade.Output(attribute).GetBaseName()
    source = UsdShade.Shader(attribute.GetPrim())
    source_id = source.GetIdAttr().Get() if source else None
    if source_id == "UsdUVTexture":
        return _texture(ctx, source, output_name)
    if source_id and str(source_id).startswith("UsdPrimvarReader_"):
        varname = _shader_value(ctx, source, "varname")
        if not varname:
            raise PrimError(f"{source.GetPath()} has no varname")
        return PrimvarInput(str(varname), _constant(_shader_value(ctx, source, "fallback"),
                                                    name))
    raise PrimError(f"connected to {attribute.GetPath()}, a {source_id or 'non-shader'} node "
                    "we do not evaluate")


def _constant(value, name: str):
    """A float, or a tuple of floats, or ``None``; a PrimError for other types."""
    if value is None:
        return None
    if isinstance(value, (bool, str)):
        raise PrimError(f"{name} is {value!r}, not a number or colour")
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise PrimError(f"{name} is {value!r}, not a number or colour") from None
    if not np.all(np.isfinite(array)):
        raise PrimError(f"{name} is {value!r}, not finite")
    return float(array) if array.ndim == 0 else tuple(float(v) for v in array.ravel())


def _shader_value(ctx: StageContext, shader, name: str):
    """A shader's input value through interfaces (not through node connections)."""
    shader_input = shader.GetInput(name)
    if not shader_input:
        return None
    attribute = _producer(shader_input)
    if attribute is None or UsdShade.Output.IsOutput(attribute):
        return None
    return attribute.Get(ctx.time)


def _texture(ctx: StageContext, shader, channels: str) -> TextureInput:
    """A UsdUVTexture node as a TextureInput reading ``channels``."""
    where = str(shader.GetPath())
    if channels not in ("rgb", "rgba", "r", "g", "b", "a"):
        raise PrimError(f"output {channels!r} of {where} is not rgb, rgba, r, g, b or a")
    asset = _shader_value(ctx, shader, "file")
    if asset is None or not getattr(asset, "path", ""):
        raise PrimError(f"{where} has no file")
    if "<UDIM>" in asset.path:
        raise PrimError(f"{where} is a UDIM texture set ({asset.path!r}), not read")
    resolved = asset.resolvedPath
    if not resolved:
        raise PrimError(f"texture {asset.path!r} of {where} was not found")
    texture = TextureInput(file=resolved, channels=channels)
    if Path(resolved).exists() and not Path(resolved).is_file():
        raise PrimError(f"texture {asset.path!r} of {where} is not a regular file (a device, "
                        "a pipe or a folder): not read")
    if not Path(resolved).is_file():   # inside a package (.usdz): read it through Ar
        packaged = Ar.GetResolver().OpenAsset(Ar.ResolvedPath(resolved))
        buffer = None if packaged is None else packaged.GetBuffer()
        if buffer is None:
            raise PrimError(f"texture {asset.path!r} of {where} could not be opened")
        texture.data = bytes(memoryview(buffer))
    for name, field_name in (("scale", "scale"), ("bias", "bias")):
        value = _constant(_shader_value(ctx, shader, name), name)
        if value is not None:
            setattr(texture, field_name, tuple(value) + (0.0,) * (4 - len(value)))
    wrap = tuple(str(_shader_value(ctx, shader, name) or "useMetadata")
                 for name in ("wrapS", "wrapT"))
    unknown = [w for w in wrap if w not in _WRAPS]
    if unknown:
        raise PrimError(f"{where} has unknown wrap mode {unknown[0]!r}")
    texture.wrap = (_WRAPS[wrap[0]], _WRAPS[wrap[1]])
    space = _shader_value(ctx, shader, "sourceColorSpace")
    texture.color_space = str(space) if space in ("sRGB", "raw", "auto") else "auto"
    fallback = _constant(_shader_value(ctx, shader, "fallback"), "fallback")
    texture.fallback = None if fallback is None else tuple(np.atleast_1d(fallback))
    st_input = shader.GetInput("st")
    attribute = _producer(st_input) if st_input else None
    if attribute is not None and UsdShade.Output.IsOutput(attribute):
        texture.st, texture.st_transform = _st_source(ctx, UsdShade.Shader(attribute.GetPrim()))
    return texture


def _st_source(ctx: StageContext, shader) -> tuple[str, np.ndarray | None]:
    """The primvar name and 2D transform of a texture's ``st`` network."""
    shader_id = shader.GetIdAttr().Get() if shader else None
    if shader_id == "UsdTransform2d":
        st_input = shader.GetInput("in")
        attribute = _producer(st_input) if st_input else None
        name = "st"
        if attribute is not None and UsdShade.Output.IsOutput(attribute):
            name, inner = _st_source(ctx, UsdShade.Shader(attribute.GetPrim()))
        else:
            inner = None
        matrix = transform_2d(*(_constant(_shader_value(ctx, shader, n), n)
                                for n in ("scale", "rotation", "translation")))
        return name, matrix if inner is None else matrix @ inner
    if shader_id and str(shader_id).startswith("UsdPrimvarReader_"):
        varname = _shader_value(ctx, shader, "varname")
        return (str(varname) if varname else "st"), None
    raise PrimError(f"st comes from {shader.GetPath()}, a {shader_id} node we do not evaluate")


def transform_2d(scale=None, rotation=None, translation=None) -> np.ndarray:
    """UsdTransform2d's matrix on (s, t, 1): scale, then rotate (degrees), then translate."""
    sx, sy = scale if scale is not None else (1.0, 1.0)
    angle = np.radians(rotation if rotation is not None else 0.0)
    tx, ty = translation if translation is not None else (0.0, 0.0)
    cos, sin = np.cos(angle), np.sin(angle)
    return np.array([[cos * sx, -sin * sy, tx], [sin * sx, cos * sy, ty], [0.0, 0.0, 1.0]])
