"""Lights as volumes see them: directional and point lights, from PyVista's or our own.

A sample's emitted colour is scaled by ``ambient + (1 - ambient) * sum_i colour_i * T_i``,
where ``T_i`` is the transmittance from the sample toward light ``i`` through the volume
itself: on the GPU from a light map (:mod:`pv_cubemarch.volume.light_map`), on the CPU by
:mod:`pv_cubemarch.reference.lighting`. Numpy only.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

#: One RGBA light map holds the transmittance toward at most this many lights.
MAX_LIGHTS = 4
#: Default share of the emission no light modulates.
DEFAULT_AMBIENT = 0.2
#: Default light-map points per axis.
DEFAULT_LIGHT_MAP_SIZE = 32


def light_placement(light, camera=None) -> tuple[np.ndarray, np.ndarray]:
    """A ``vtkLight``'s position and focal point in the world, now.

    Headlights and camera lights follow ``camera`` (a ``vtkCamera``), as VTK places them.
    """
    position = np.array(light.GetPosition(), dtype=np.float64)
    focal = np.array(light.GetFocalPoint(), dtype=np.float64)
    if camera is not None and light.LightTypeIsHeadlight():
        position = np.array(camera.GetPosition(), dtype=np.float64)
        focal = np.array(camera.GetFocalPoint(), dtype=np.float64)
    elif camera is not None and light.LightTypeIsCameraLight():
        matrix = camera.GetCameraLightTransformMatrix()
        position = np.array(matrix.MultiplyPoint((*position, 1.0))[:3])
        focal = np.array(matrix.MultiplyPoint((*focal, 1.0))[:3])
    return position, focal


@dataclass(frozen=True)
class VolumeLight:
    """A directional or point light as a volume sees it (world coordinates).

    ``direction`` is where a directional light's rays travel; ``position`` is a point
    light's place. ``color`` times ``intensity`` scales the transmitted light.
    """

    kind: str
    direction: tuple[float, float, float] = (0.0, 0.0, -1.0)
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    color: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 1.0

    def __post_init__(self):
        if self.kind not in ("directional", "point"):
            raise ValueError(f"A volume light is 'directional' or 'point', got {self.kind!r}.")
        if self.kind == "directional" and not np.linalg.norm(self.direction) > 0:
            raise ValueError("A directional light needs a non-zero direction.")

    @classmethod
    def from_pyvista(cls, light, camera=None) -> VolumeLight:
        """The light a ``pyvista.Light`` (or ``vtkLight``) casts now.

        Headlights and camera lights follow ``camera`` (a ``vtkCamera``), as VTK places them.
        """
        position, focal = light_placement(light, camera)
        color = tuple(float(c) for c in light.GetDiffuseColor())
        if light.GetPositional():
            return cls("point", position=tuple(position), color=color,
                       intensity=float(light.GetIntensity()))
        direction = focal - position
        if not np.linalg.norm(direction) > 0:
            direction = np.array([0.0, 0.0, -1.0])
        return cls("directional", direction=tuple(direction), color=color,
                   intensity=float(light.GetIntensity()))

    def toward_light(self, texture_from_world: np.ndarray) -> np.ndarray:
        """The light as the light-map pass reads it, in texture coordinates.

        ``(x, y, z, 0)``: the direction toward a directional light; ``(x, y, z, 1)``: a
        point light's position.
        """
        if self.kind == "point":
            return np.append(texture_from_world[:3, :3] @ self.position
                             + texture_from_world[:3, 3], 1.0)
        toward = -np.asarray(self.direction, dtype=np.float64)
        toward = texture_from_world[:3, :3] @ (toward / np.linalg.norm(toward))
        return np.append(toward, 0.0)

    @property
    def radiance(self) -> np.ndarray:
        """Colour times intensity."""
        return np.asarray(self.color, dtype=np.float64) * float(self.intensity)


LightSource = Callable[[], list[VolumeLight]]


def light_source(lights, renderer) -> LightSource | None:
    """Turn ``add_volume``'s ``lights`` argument into a callable giving this frame's lights.

    ``None`` or an empty list: no lighting (``None`` is returned). ``'scene'``: the
    renderer's switched-on lights, read at every frame. A ``pyvista.Light``, a
    :class:`VolumeLight` or a list of them: those lights (camera lights follow the camera).
    """
    if lights is None:
        return None
    if isinstance(lights, str):
        if lights != "scene":
            raise ValueError(f"lights must be None, 'scene', a light or a list of lights, "
                             f"got {lights!r}.")

        def scene_lights():
            camera = renderer.GetActiveCamera()
            return [VolumeLight.from_pyvista(li, camera) for li in renderer.GetLights()
                    if li.GetSwitch()]

        found = scene_lights()
        if not found:
            return None
        _check_count(len(found), "The plotter has")
        return scene_lights
    items = list(lights) if isinstance(lights, (list, tuple)) else [lights]
    if not items:
        return None
    _check_count(len(items), "lights holds")
    for item in items:
        if not isinstance(item, VolumeLight) and not hasattr(item, "GetTransformedPosition"):
            raise TypeError(f"lights must hold pyvista.Light or VolumeLight objects, got "
                            f"{type(item).__name__}.")
    return lambda: [item if isinstance(item, VolumeLight)
                    else VolumeLight.from_pyvista(item, renderer.GetActiveCamera())
                    for item in items]


def _check_count(count: int, what: str) -> None:
    if count > MAX_LIGHTS:
        raise ValueError(f"{what} {count} lights; a volume is lit by at most {MAX_LIGHTS}. "
                         "Pass lights=[...] with the ones that matter, or make the plotter "
                         "with pyvista.Plotter(lighting='three lights').")
