"""Reading authored attributes safely, and the ``cubemarch:*`` option tables of Volume prims."""

from __future__ import annotations

import re

from pxr import Usd

from ...core.errors import SceneLoadError


def attr(prim, name: str, time=None):
    """The value of attribute ``name`` at ``time`` (default time), or ``None`` if not authored."""
    attribute = prim.GetAttribute(name)
    if not attribute or not attribute.HasValue():
        return None
    return attribute.Get(Usd.TimeCode.Default() if time is None else time)


#: ``cubemarch:*`` attributes of a Volume prim and the ``add_volume`` options they set.
VOLUME_OPTIONS = (
    ("stepScale", "step_scale", float), ("technique", "technique", str),
    ("stopOpacity", "stop_opacity", float), ("skipEmpty", "skip_empty", bool),
    ("downsample", "downsample", int), ("faceSize", "face_size", int),
    ("maxSamples", "max_samples", int), ("upscale", "upscale", float),
    ("sampleFactor", "sample_factor", float),
    ("occlusionSharpness", "occlusion_sharpness", float), ("lights", "lights", str),
    ("lightMapSize", "light_map_size", int), ("ambient", "ambient", float),
    ("blending", "blending", str),
)

#: ``cubemarch:*`` attributes of a voxels Volume prim and the ``add_voxels`` options they set.
VOXEL_OPTIONS = (
    ("traversal", "traversal", str), ("stepScale", "step_scale", float),
    ("mipLevels", "mip_levels", int), ("distanceField", "distance_field", int),
    ("mode", "mode", str), ("shading", "shading", str),
    ("ambient", "ambient", float), ("specular", "specular", float),
    ("specularPower", "specular_power", float),
    ("ambientOcclusion", "ambient_occlusion", bool),
    ("occlusionStrength", "occlusion_strength", float), ("proxy", "proxy", str),
    ("lod", "lod", bool), ("lodBias", "lod_bias", float),
)

#: ``cubemarch:*`` attributes of a surface Volume prim and the ``add_surface`` options they
#: set (with ``cubemarch:isovalue``, required, and ``cubemarch:color``, a color3f).
SURFACE_OPTIONS = (
    ("surfaceTechnique", "technique", str), ("surfaceTraversal", "traversal", str),
    ("steps", "steps", int),
    ("refineSteps", "refine_steps", int), ("root", "root", str),
    ("activeTest", "active_test", str), ("activeSamples", "active_samples", int),
    ("shading", "shading", str), ("ambient", "ambient", float),
    ("specular", "specular", float), ("specularPower", "specular_power", float),
)

#: Volume attributes that a voxels Volume prim must not carry.
VOLUME_ONLY = tuple(key for key in ("opacity", "clim", "opacityUnitDistance", "interpolation",
                                    *(usd_key for usd_key, _, _ in VOLUME_OPTIONS))
                    if key != "technique" and key not in {k for k, _, _ in VOXEL_OPTIONS})


def options_error(name: str, authored_options: dict, kind: str,
                  error: ValueError) -> SceneLoadError:
    """A SceneLoadError naming the authored attributes the options' ``error`` is about."""
    named = [f"cubemarch:{key} = {value!r}" for key, (option, value) in authored_options.items()
             if re.search(rf"\b{option}\b", str(error))]
    return SceneLoadError(f"Volume {name}: {', '.join(named) or f'its {kind} options'}: "
                          f"{error}")


def authored(prim, name: str, table) -> dict:
    """The ``cubemarch:*`` options of ``table`` authored on ``prim``.

    ``{key: (option, value)}``, each converted to its kind (a SceneLoadError names a
    wrong one).
    """
    found = {}
    for key, option, kind in table:
        value = attr(prim, f"cubemarch:{key}")
        if value is not None:
            found[key] = (option, converted(name, key, value, kind))
    return found


def converted(name: str, key: str, value, kind):
    """An authored option value as ``kind``, or a SceneLoadError naming the attribute."""
    try:
        if kind is str:
            if not isinstance(value, str):
                raise TypeError
            return str(value)
        if kind is bool:
            if not isinstance(value, bool):
                raise TypeError
            return value
        if kind is int:
            if isinstance(value, (str, bool)) or float(value) != int(value):
                raise ValueError
            return int(value)
        if isinstance(value, (str, bool)):
            raise TypeError
        return kind(value)
    except (TypeError, ValueError, OverflowError):
        expected = {str: "a string or token", int: "a whole number", float: "a number",
                    bool: "a bool"}[kind]
        raise SceneLoadError(f"Volume {name}: cubemarch:{key} must be {expected}, got "
                             f"{value!r}.") from None
