"""A scene's lights in VTK, as usdview (Storm) lights a stage.

VTK's PBR and Storm share units (a Lambertian surface returns albedo/π of the light), so a
light's VTK intensity is its USD intensity × 2^exposure (colour and blackbody colour in
its colour), times its area (a distant light's solid angle) unless normalized. Positional
lights fall off with the square of the distance. A DomeLight is image-based lighting: its latitude-
longitude texture, or a constant image of its colour, since VTK's PBR has no ambient term;
a textured dome is also the background. A scene without lights gets usdview's default
camera light.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyvista

from ..core import vtk_classes as vtk
from .parts import SceneLight
from .textures import srgb_to_linear, stored_texels, unit_rgba

#: USD's latitude-longitude convention (longitude 0 on +z, +x a quarter turn on) from VTK's.
_LATLONG_ROTATION = ((0.0, 0.0, -1.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))
#: Image-based lighting lookup sizes: the defaults cost 3-4 s on llvmpipe for no visible gain.
_LUT_SIZE, _PREFILTER_SAMPLES = 128, 64


def add_scene_lights(plotter: pyvista.Plotter, lights: list[SceneLight], report) -> None:
    """Replace the plotter's lights by the scene's (a camera light when there are none)."""
    plotter.remove_all_lights()
    if not lights:
        plotter.add_light(pyvista.Light(light_type="headlight", intensity=1.0))
        return
    domes = [li for li in lights if li.kind == "dome"]
    for light in lights:
        if light.kind != "dome":
            plotter.add_light(_vtk_light(light))
    if not any(li.kind != "dome" for li in lights):
        # VTK's PBR path needs one light to run at all; this one adds nothing.
        plotter.add_light(pyvista.Light(light_type="headlight", intensity=0.0))
    if domes:
        if len(domes) > 1:
            report(domes[1].name, "only the first DomeLight is drawn")
        _add_dome(plotter, domes[0], report)


def _vtk_light(light: SceneLight) -> pyvista.Light:
    """A distant light as a directional scene light; the others as positional lights.

    VTK's light colours are at most 1: a brighter colour (a blackbody's can pass 1) gives its
    largest component to the intensity.
    """
    color, brightness = light_color(light.color)
    vtk_light = pyvista.Light(color=color, intensity=light.intensity * light.area * brightness,
                              light_type="scene light")
    if light.kind == "distant":
        vtk_light.positional = False
        vtk_light.position = tuple(-np.asarray(light.direction))
        vtk_light.focal_point = (0.0, 0.0, 0.0)
        return vtk_light
    vtk_light.positional = True
    vtk_light.position = light.position
    direction = np.asarray(light.direction if light.direction is not None else (0, 0, -1))
    vtk_light.focal_point = tuple(np.asarray(light.position) + direction)
    vtk_light.cone_angle = min(float(light.cone_angle), 90.0) \
        if light.cone_angle is not None else 180.0
    vtk_light.attenuation_values = (0.0, 0.0, 1.0)
    return vtk_light


def light_color(color) -> tuple[tuple[float, float, float], float]:
    """A colour split into VTK's (components in [0, 1]) and a brightness factor."""
    rgb = np.clip(np.asarray(color, dtype=np.float64), 0.0, None)
    top = float(rgb.max())
    if top <= 0.0:
        return (0.0, 0.0, 0.0), 0.0
    return tuple(float(c) for c in rgb / max(top, 1.0)), max(top, 1.0)


def _add_dome(plotter: pyvista.Plotter, light: SceneLight, report) -> None:
    """Image-based lighting from the dome's texture (and the background), or its colour."""
    scale = np.asarray(light.color, dtype=np.float64) * light.intensity
    image = None
    if light.texture is not None:
        try:
            image = _latlong(light.texture)
        except (OSError, ValueError) as exc:
            report(light.name, f"dome texture {light.texture!r} could not be read ({exc}); "
                   "a uniform dome of its colour is used")
    environment = np.full((32, 64, 3), 1.0) if image is None else \
        rotated_latlong(image, np.asarray(light.rotation))
    texture = _float_texture(environment * scale)
    renderer = plotter.renderer
    renderer.UseImageBasedLightingOn()
    renderer.SetEnvironmentTexture(texture, False)
    renderer.GetEnvMapLookupTable().SetLUTSize(_LUT_SIZE)
    renderer.GetEnvMapLookupTable().SetLUTSamples(_LUT_SIZE)
    renderer.GetEnvMapPrefiltered().SetPrefilterMaxSamples(_PREFILTER_SAMPLES)
    rotation = vtk.vtkMatrix3x3()
    for row in range(3):
        for column in range(3):
            rotation.SetElement(row, column, _LATLONG_ROTATION[row][column])
    renderer.SetEnvironmentRotationMatrix(rotation)
    if image is not None:
        sky = vtk.vtkSkybox()
        sky.SetTexture(texture)
        sky.SetProjectionToSphere()
        sky.GammaCorrectOn()
        renderer.AddActor(sky)


def rotated_latlong(image: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """A latitude-longitude image (rows bottom-up) as seen once its dome turns by ``rotation``.

    Each texel's world direction (USD's convention: u = 0.5 along +z, u = 0.25 along +x, the
    top row +y) is turned back into the dome's frame and looked up there (nearest texel),
    so VTK draws it with one fixed orientation for every dome.
    """
    if np.allclose(rotation, np.eye(3)):
        return image
    height, width = image.shape[:2]
    u = (np.arange(width) + 0.5) / width
    v = 1.0 - (np.arange(height) + 0.5) / height          # rows bottom-up: v from the top
    longitude = np.pi * (1.0 - 2.0 * u)[None, :]
    latitude = np.pi * (0.5 - v)[:, None]
    world = np.stack(np.broadcast_arrays(np.cos(latitude) * np.sin(longitude),
                                         np.sin(latitude),
                                         np.cos(latitude) * np.cos(longitude)), axis=-1)
    local = world @ rotation                                # rotationᵀ · direction, per texel
    source_u = (1.0 - np.arctan2(local[..., 0], local[..., 2]) / np.pi) / 2.0
    source_v = 0.5 - np.arcsin(np.clip(local[..., 1], -1.0, 1.0)) / np.pi
    column = np.clip((source_u * width).astype(int), 0, width - 1)
    row = np.clip(((1.0 - source_v) * height).astype(int), 0, height - 1)
    return image[row, column]


def _latlong(path: str) -> np.ndarray:
    """A latitude-longitude image as linear RGB floats, rows bottom-up (VTK's order)."""
    if Path(path).suffix.lower() == ".hdr":
        reader = vtk.vtkHDRReader()
        reader.SetFileName(path)
        reader.Update()
        data = reader.GetOutput()
        width, height, _ = data.GetDimensions()
        values = pyvista.convert_array(data.GetPointData().GetScalars())
        return np.asarray(values, dtype=np.float64).reshape(height, width, -1)[..., :3]
    if Path(path).suffix.lower() == ".exr":
        raise ValueError("OpenEXR images are not read (VTK has no EXR reader)")
    # decoded as the textures are: within their byte budget and the GL limit, a
    # decompression bomb a TextureError (a ValueError: the dome is reported, not drawn)
    texels, _eight_bit, _note = stored_texels(path)
    rgb = unit_rgba(texels)[..., :3]
    return (srgb_to_linear(rgb) if texels.dtype == np.uint8 else rgb)[::-1]   # 8-bit: sRGB


def _float_texture(rgb: np.ndarray) -> vtk.vtkTexture:
    """A float RGB texture (rows bottom-up), mipmapped, as image-based lighting needs."""
    height, width, _ = rgb.shape
    image = pyvista.ImageData(dimensions=(width, height, 1))
    image.point_data["rgb"] = np.ascontiguousarray(rgb, dtype=np.float32).reshape(-1, 3)
    texture = vtk.vtkTexture()
    texture.SetInputData(image)
    texture.SetColorModeToDirectScalars()
    texture.MipmapOn()
    texture.InterpolateOn()
    return texture
