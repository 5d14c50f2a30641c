"""Show a GPU texture on screen: for looking at intermediate passes, and for testing uploads."""

from __future__ import annotations

import numpy as np
import pyvista

from ..core import vtk_classes as vtk
from .bindings import ShaderBindings
from .handle import DrawnBinding
from .shaders import Replacement, ShaderRecipe
from .textures import Texture

_DEFINES = {"2d": "CM_VIEW_2D", "3d": "CM_VIEW_3D", "buffer": "CM_VIEW_BUFFER"}


def add_texture_view(plotter: pyvista.Plotter, texture: Texture, *, slice_position: float = 0.5,
                     scale=1.0, bias=0.0) -> vtk.vtkActor:
    """Cover the current view with ``texture`` (u, v = window position); return the actor.

    ``texel * scale + bias`` is written (RGB). For a 3D texture, ``slice_position`` is the
    texture z of the slice shown; a buffer is shown as grey levels along x. Set the camera
    before calling: the quad is placed across the view at the focal point.
    """
    camera = plotter.camera
    focal = np.asarray(camera.focal_point, dtype=float)
    normal = focal - np.asarray(camera.position, dtype=float)
    distance = float(np.linalg.norm(normal))
    height = 4.0 * distance * np.tan(np.radians(camera.view_angle) / 2.0) + 4.0
    plane = pyvista.Plane(center=focal, direction=normal, i_size=4 * height, j_size=4 * height)
    mapper = vtk.vtkOpenGLPolyDataMapper()
    mapper.SetInputData(plane)
    actor = vtk.vtkActor()
    actor.SetMapper(mapper)
    recipe = ShaderRecipe(
        replacements=[Replacement("//VTK::Color::Dec", "debug_view_declarations", keep_tag="after"),
                      Replacement("//VTK::Light::Impl", "debug_view_color", keep_tag="before")],
        defines={_DEFINES[texture.kind]: True})
    recipe.apply(actor.GetShaderProperty())
    bindings = ShaderBindings(mapper, plotter.renderer, recipe)
    bindings.add_texture("cm_viewTexture", texture, owned=True)
    bindings.set_uniform("cm_viewport", lambda: tuple(float(v) for v in plotter.window_size))
    bindings.set_uniform("cm_viewScale", np.broadcast_to(np.asarray(scale, float), (4,)))
    bindings.set_uniform("cm_viewBias", np.broadcast_to(np.asarray(bias, float), (4,)))
    if texture.kind == "3d":
        bindings.set_uniform("cm_slice", float(slice_position))
    if texture.kind == "buffer":
        bindings.set_uniform("cm_bufferLength", int(texture.array.size))
    plotter.add_actor(actor, reset_camera=False)
    tracked = _Tracked("texture view", bindings, recipe)
    tracked.actor = actor
    tracked.main_renderer = plotter.renderer
    plotter.cubemarch.track(tracked)
    return actor


class _Tracked(DrawnBinding):
    """Minimal tracked item: a texture view's actor, bindings and recipe, and release()."""

    technique = "texture view"
    name = "texture view"

    def __init__(self, name: str, bindings: ShaderBindings, recipe: ShaderRecipe):
        super().__init__(None, bindings, recipe)
        self.name = name

    @property
    def nbytes(self) -> int:
        return self.bindings.nbytes

    def release(self) -> None:
        self.bindings.release()
