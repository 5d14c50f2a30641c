"""The scene's lights as uniforms of our shaders (``common/blinn_phong.glsl``).

Up to :data:`MAX_LIGHTS` switched-on lights of the renderer, placed in view space once per
frame: column ``i`` of ``cm_lightVectors0/1`` is the direction toward a directional light
(w = 0) or a point light's position (w = 1), of ``cm_lightColors0/1`` its colour times
intensity; ``cm_normalFromIndex`` takes normals of the technique's index space to view
space (the inverse transpose).
"""

from __future__ import annotations

import weakref
from collections.abc import Callable

import numpy as np

from ..core import vtk_classes as vtk
from ..core.frame_errors import observe
from ..models.lights import VolumeLight
from .bindings import ShaderBindings
from .box import camera_matrices, kept_inverse
from .frame_inputs import frame_inputs

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

    The lights are read and placed once per frame of the renderer, however many uniforms
    and bindings take them (:meth:`~.frame_inputs.FrameInputs.per_frame`).
    """
    def frame_lights() -> dict:
        return frame_inputs(renderer).per_frame("scene lights", lambda: placed_lights(renderer))

    bindings.set_uniform("cm_lightCount", lambda: frame_lights()["count"])
    for half in (0, 1):
        for name, key in (("Vectors", f"vectors{half}"), ("Colors", f"colors{half}")):
            bindings.set_uniform(f"cm_light{name}{half}", lambda key=key: frame_lights()[key])
    linear_inverse = kept_inverse()
    bindings.set_uniform("cm_normalFromIndex", lambda: frame_lights()["view"][:3, :3]
                         @ linear_inverse(np.asarray(world_from_index())[:3, :3]).T)


def placed_lights(renderer) -> dict:
    """The scene's lights now, in view space, as the light uniforms take them."""
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
    placed = {"count": len(lights), "vectors": vectors, "colors": colors, "view": view}
    for half in (0, 1):   # the halves the uniforms take, made once: read-only, shared
        for name in ("vectors", "colors"):
            part = np.ascontiguousarray(placed[name][:, 4 * half:4 * half + 4])
            part.flags.writeable = False
            placed[f"{name}{half}"] = part
    return placed


#: Set on a light :func:`steady_headlights` turned from a headlight into a camera light.
WAS_HEADLIGHT = "_cubemarch_was_headlight"   # private: PyVista allows it on its Light


def steady_headlights(renderer) -> None:
    """Turn the renderer's headlights into the same lights fixed to the camera.

    VTK moves a headlight to the camera at every frame the camera moved, which modifies
    the light; VTK's GPU volume mapper rebuilds its shader whenever a light was modified
    (shading on or off), and skips on that frame the ``UpdateShaderEvent`` our bindings
    are set in, so the frame had to be drawn twice. A camera light at (0, 0, 1) looking at
    the origin (camera coordinates) shines from the eye along the view, as a headlight
    does, and follows the camera through a matrix VTK updates in place: the light itself
    is never modified. The light keeps a mark (:func:`is_headlight`).

    A lone headlight is left as it is: VTK lights meshes by it in a path of its own (a
    camera light there draws a lit sphere up to 50 levels apart at intensity 1, 30 at
    0.5), so that scene keeps its second draw after a camera move.
    """
    switched_on = [light for light in renderer.GetLights() if light.GetSwitch()]
    if len(switched_on) == 1 and switched_on[0].LightTypeIsHeadlight():
        return
    for light in renderer.GetLights():
        if light.LightTypeIsHeadlight():
            light.SetLightTypeToCameraLight()
            light.SetPosition(0.0, 0.0, 1.0)
            light.SetFocalPoint(0.0, 0.0, 0.0)
            setattr(light, WAS_HEADLIGHT, True)


# Renderers whose headlights are held steady: id -> [holders, StartEvent observer tag,
# a weak reference to the renderer (an id may be reused once it is gone)].
_held: dict[int, list] = {}


def hold_headlights_steady(renderer) -> Callable[[], None]:
    """Steady ``renderer``'s headlights at every frame until the returned call lets go.

    Each ``'vtk'`` volume holds them; when the last lets go (its volume removed), the
    lights still as :func:`steady_headlights` left them are headlights again, so meshes
    drawn afterwards are lit as before the volume came.
    """
    entry = _held.get(id(renderer))
    if entry is None or entry[2]() is not renderer:   # none, or a gone renderer's id
        tag = observe(renderer, vtk.vtkCommand.StartEvent,
                      lambda *_: steady_headlights(renderer))
        entry = _held[id(renderer)] = [0, tag, weakref.ref(renderer)]
    entry[0] += 1
    let_go_once = [False]

    def let_go() -> None:
        if let_go_once[0]:
            return
        let_go_once[0] = True
        entry[0] -= 1
        if entry[0] == 0:
            renderer.RemoveObserver(entry[1])
            if _held.get(id(renderer)) is entry:
                del _held[id(renderer)]
            restore_headlights(renderer)
    return let_go


def restore_headlights(renderer) -> None:
    """Make the lights :func:`steady_headlights` turned, and nobody moved since, headlights."""
    for light in renderer.GetLights():
        if getattr(light, WAS_HEADLIGHT, False) and not light.LightTypeIsHeadlight() \
                and is_headlight(light):
            light.SetLightTypeToHeadlight()
            delattr(light, WAS_HEADLIGHT)


def is_headlight(light) -> bool:
    """A headlight, or one :func:`steady_headlights` fixed to the camera (the same light)."""
    return bool(light.LightTypeIsHeadlight()) or (
        bool(getattr(light, WAS_HEADLIGHT, False)) and bool(light.LightTypeIsCameraLight())
        and tuple(light.GetPosition()) == (0.0, 0.0, 1.0)
        and tuple(light.GetFocalPoint()) == (0.0, 0.0, 0.0))
