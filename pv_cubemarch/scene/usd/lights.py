"""Cameras and UsdLux lights of a stage.

A light's colour is ``inputs:color`` times its blackbody colour when
``inputs:enableColorTemperature`` is on; its intensity is ``inputs:intensity`` times
2^``inputs:exposure``. A DomeLight keeps its texture file (image-based lighting where VTK
can draw it). A DistantLight's intensity is the radiance of a sun disk of ``inputs:angle``
(irradiance: times the disk's solid angle) unless ``inputs:normalize`` makes it the
irradiance itself; SphereLight, RectLight, DiskLight and
CylinderLight are positional lights at their origin, pointing down their -z axis with the
cone of ``shaping:cone:angle`` when shaped.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pxr import Gf, UsdGeom, UsdLux

from ...core.camera import Camera
from ..parts import SceneLight
from .context import PrimError, StageContext

LIGHT_KINDS = {"DistantLight": "distant", "SphereLight": "sphere", "DomeLight": "dome",
               "RectLight": "rect", "DiskLight": "disk", "CylinderLight": "cylinder",
               "DomeLight_1": "dome"}


def _area(kind: str, number) -> float:
    """The emitting area of a positional light, projected (what scales its power)."""
    if kind in ("sphere", "disk"):
        return float(np.pi * number("radius", 0.5) ** 2)
    if kind == "rect":
        return number("width", 1.0) * number("height", 1.0)
    return 2.0 * number("radius", 0.5) * number("length", 1.0)   # cylinder, side-on


def read_camera(ctx: StageContext, prim) -> Camera:
    """A UsdGeom.Camera at the stage time, placed in the world."""
    gf_camera = UsdGeom.Camera(prim).GetCamera(ctx.time)
    matrix = ctx.world_matrix(prim)
    position = matrix[:3, 3]
    forward = matrix[:3, :3] @ np.array([0.0, 0.0, -1.0])
    up = matrix[:3, :3] @ np.array([0.0, 1.0, 0.0])
    if not np.linalg.norm(forward) > 0 or not np.linalg.norm(up) > 0:
        raise PrimError("its transform is degenerate (no view direction)")
    forward /= np.linalg.norm(forward)
    distance = gf_camera.focusDistance if gf_camera.focusDistance > 0 else 1.0
    clip = gf_camera.clippingRange
    if not 0.0 < clip.min < clip.max:
        raise PrimError(f"its clippingRange ({clip.min:g}, {clip.max:g}) is not 0 < near < far")
    angle = float(gf_camera.GetFieldOfView(Gf.Camera.FOVVertical))
    if not 0.0 < angle < 180.0:
        raise PrimError(f"its vertical field of view is {angle:g} degrees (aperture or focal "
                        "length not positive)")
    camera = Camera(position=tuple(position), focal_point=tuple(position + forward * distance),
                    view_up=tuple(up / np.linalg.norm(up)), view_angle=angle,
                    clipping_range=(float(clip.min), float(clip.max)))
    if gf_camera.projection == Gf.Camera.Orthographic:
        camera.parallel_projection = True
        camera.parallel_scale = gf_camera.verticalAperture * Gf.Camera.APERTURE_UNIT / 2.0
    return camera


def read_light(ctx: StageContext, prim, type_name: str) -> SceneLight:
    """A UsdLux light as a SceneLight in world coordinates."""
    def number(name: str, default: float) -> float:
        value = ctx.get(prim, name, default)
        if isinstance(value, (bool, str)) or not np.isfinite(float(value)):
            raise PrimError(f"{name} is {value!r}, not a number")
        return float(value)

    intensity = number("inputs:intensity", 1.0) * 2.0 ** number("inputs:exposure", 0.0)
    color = np.asarray(ctx.get(prim, "inputs:color", (1.0, 1.0, 1.0)), dtype=np.float64)
    if color.shape != (3,) or not np.all(np.isfinite(color)):
        raise PrimError(f"inputs:color is {ctx.get(prim, 'inputs:color')!r}, not a colour")
    if ctx.get(prim, "inputs:enableColorTemperature", False):
        kelvin = number("inputs:colorTemperature", 6500.0)
        color = color * np.asarray(UsdLux.BlackbodyTemperatureAsRgb(kelvin), dtype=np.float64)
    matrix = ctx.world_matrix(prim)
    kind = LIGHT_KINDS[type_name]
    light = SceneLight(name=str(prim.GetPath()), kind=kind, color=tuple(color),
                       intensity=intensity)
    direction = matrix[:3, :3] @ np.array([0.0, 0.0, -1.0])
    if kind == "distant":
        if not np.linalg.norm(direction) > 0:
            raise PrimError("its transform is degenerate (no direction)")
        light.direction = tuple(direction / np.linalg.norm(direction))
        light.angle = number("inputs:angle", 0.53)
        if not ctx.get(prim, "inputs:normalize", False):
            # intensity is the sun disk's radiance: irradiance is it times the disk's solid
            # angle (6.7e-5 sr at the default 0.53 degrees), as Storm draws it
            light.area = 2.0 * np.pi * (1.0 - np.cos(np.radians(light.angle) / 2.0))
    elif kind == "dome":
        frame = matrix[:3, :3]
        u, _, vt = np.linalg.svd(frame)            # its rotation, scale left out
        light.rotation = tuple(map(tuple, u @ vt))
        texture = ctx.get(prim, "inputs:texture:file")
        if texture is not None and getattr(texture, "path", ""):
            if texture.resolvedPath and Path(texture.resolvedPath).is_file():
                light.texture = texture.resolvedPath
            else:
                ctx.report(light.name, f"dome texture {texture.path!r} not found; a uniform "
                           "ambient light of the dome's colour is used")
    else:
        light.position = tuple(matrix[:3, 3])
        if np.linalg.norm(direction) > 0:
            light.direction = tuple(direction / np.linalg.norm(direction))
        cone = ctx.get(prim, "inputs:shaping:cone:angle")
        if cone is not None:
            light.cone_angle = float(cone)
        if not ctx.get(prim, "inputs:normalize", False):
            light.area = _area(kind, lambda name, default: number(f"inputs:{name}", default))
    return light
