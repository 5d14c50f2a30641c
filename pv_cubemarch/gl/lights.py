"""The scene's lights as uniforms of our shaders (``common/blinn_phong.glsl``).

Up to :data:`MAX_LIGHTS` switched-on lights of the renderer, placed in view space once per
frame: column ``i`` of ``cm_lightVectors0/1`` is the direction toward a directional light
(w = 0) or a point light's position (w = 1), of ``cm_lightColors0/1`` its colour times
intensity; ``cm_normalFromIndex`` takes normals of the technique's index space to view
space (the inverse transpose).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..models.lights import VolumeLight
from .bindings import ShaderBindings
from .box import camera_matrices

#: Most scene lights a shader is lit by (two mat4 of light vectors and colours).
MAX_LIGHTS = 8


def scene_lights(renderer) -> list[VolumeLight]:
    """The renderer's switched-on lights as they shine now (headlights follow the camera)."""
    camera = renderer.GetActiveCamera()
    lights = [VolumeLight.from_pyvista(li, camera) for li in renderer.GetLights()
              if li.GetSwitch()]
    return lights[:MAX_LIGHTS]


def bind_scene_lights(bindings: ShaderBindings, renderer,
                      world_from_index: Callable[[], np.ndarray]) -> None:
    """Per-frame light uniforms: the scene's lights in view space, the normals' map.

    The lights are read and placed once per frame (keyed on the frame count of the
    bindings), however many uniforms take them.
    """
    cache: dict = {}

    def frame_lights() -> dict:
        if cache.get("frame") != bindings.frames_started:
            view = camera_matrices(renderer)[0]
            vectors, colors = np.zeros((4, 8)), np.zeros((4, 8))
            lights = scene_lights(renderer)
            for column, light in enumerate(lights):
                if light.kind == "point":
                    vectors[:, column] = view @ np.append(light.position, 1.0)
                    vectors[3, column] = 1.0
                else:
                    toward = -np.asarray(light.direction, dtype=np.float64)
                    vectors[:3, column] = view[:3, :3] @ (toward / np.linalg.norm(toward))
                colors[:3, column] = light.radiance
            cache.update(frame=bindings.frames_started, count=len(lights), vectors=vectors,
                         colors=colors)
        return cache

    bindings.set_uniform("cm_lightCount", lambda: frame_lights()["count"])
    for half in (0, 1):
        columns = slice(4 * half, 4 * half + 4)
        bindings.set_uniform(f"cm_lightVectors{half}",
                             lambda c=columns: frame_lights()["vectors"][:, c])
        bindings.set_uniform(f"cm_lightColors{half}",
                             lambda c=columns: frame_lights()["colors"][:, c])
    bindings.set_uniform("cm_normalFromIndex", lambda: camera_matrices(renderer)[0][:3, :3]
                         @ np.linalg.inv(world_from_index()[:3, :3]).T)
