"""The direct screen-space ray marcher (DSSRM): the shared marching GLSL on a box actor.

The box's back faces are drawn in the translucent pass, after every opaque prop, so the
opaque depth of the frame is complete: it is copied to a texture just before the box is
drawn and bounds each ray. This is the baseline the cube-map technique is measured against.
"""

from __future__ import annotations

import numpy as np
import pyvista
import vtk
from vtkmodules.vtkRenderingOpenGL2 import vtkTextureObject

from .gl_resources import ShaderBindings, Texture
from .shaders import Replacement, ShaderRecipe
from .volume import VolumeModel


class SceneDepth:
    """The renderer's opaque depth of this frame, copied into a texture at each draw.

    The copy needs a single-sampled framebuffer: :func:`build_direct_actor` turns the
    window's multisampling off (PyVista asks for 4 samples by default).
    """

    kind = "2d"
    nbytes = 0

    def __init__(self, renderer):
        self.renderer = renderer
        self.gl_object: vtkTextureObject | None = None
        self._size = None
        self._window = None

    def ensure(self, window) -> vtkTextureObject:
        """Copy the current depth buffer into the texture (context current, in the draw)."""
        width, height = self.renderer.GetSize()
        x0, y0 = self.renderer.GetOrigin()
        if self.gl_object is None or self._size != (width, height) or self._window is not window:
            self.release()
            self.gl_object = vtkTextureObject()
            self.gl_object.SetContext(window)
            self.gl_object.AllocateDepth(width, height, vtkTextureObject.Float32)
            self.gl_object.SetMinificationFilter(vtkTextureObject.Nearest)
            self.gl_object.SetMagnificationFilter(vtkTextureObject.Nearest)
            self._size, self._window = (width, height), window
        self.gl_object.CopyFromFrameBuffer(x0, y0, 0, 0, width, height)
        return self.gl_object

    def release(self) -> None:
        """Free the texture."""
        if self.gl_object is not None and self._window is not None:
            self.gl_object.ReleaseGraphicsResources(self._window)
        self.gl_object = self._window = None


def direct_recipe(defines: dict) -> ShaderRecipe:
    """The polydata-shader replacements of the direct marcher."""
    return ShaderRecipe(
        replacements=[
            Replacement("//VTK::Color::Dec",
                        ("ea_declarations", "ea_direct_declarations", "ea_march",
                         "ea_screen_ray"),
                        keep_tag="after"),
            Replacement("//VTK::Light::Impl", "ea_direct_fragment", keep_tag="before"),
        ],
        defines=defines,
    )


def _camera_matrices(renderer):
    camera = renderer.GetActiveCamera()
    width, height = renderer.GetSize()
    aspect = width / max(height, 1)
    view = _numpy(camera.GetModelViewTransformMatrix())
    projection = _numpy(camera.GetProjectionTransformMatrix(aspect, -1.0, 1.0))
    return view, projection


def _numpy(matrix) -> np.ndarray:
    return np.array([[matrix.GetElement(i, j) for j in range(4)] for i in range(4)])


def build_direct_actor(plotter, model: VolumeModel, step_scale: float, stop_opacity: float,
                       skip_empty: bool):
    """A box actor that marches ``model`` with the shared GLSL; returns the actor."""
    from .emission_absorption import VolumeBinding, bind_march, march_defines, world_from_texture

    renderer = plotter.renderer
    upper = np.array(model.dimensions, dtype=np.float64) - 1.0
    box = pyvista.Box(bounds=(0, upper[0], 0, upper[1], 0, upper[2])).triangulate()
    mapper = vtk.vtkOpenGLPolyDataMapper()
    mapper.SetInputData(box)
    actor = pyvista.Actor()
    actor.SetMapper(mapper)
    actor.GetProperty().FrontfaceCullingOn()
    actor.ForceTranslucentOn()
    matrix = vtk.vtkMatrix4x4()
    matrix.DeepCopy(model.world_from_index().ravel().tolist())
    actor.SetUserMatrix(matrix)

    bindings = ShaderBindings(mapper, renderer)
    skipping = bind_march(bindings, model, step_scale, stop_opacity, skip_empty)
    bindings.add_texture("cm_volume", Texture(model.values, kind="3d", interpolate=True))
    bindings.add_texture("cm_sceneDepth", SceneDepth(renderer))
    to_texture = np.linalg.inv(world_from_texture(model))

    def texture_from_view():
        view, _ = _camera_matrices(renderer)
        return to_texture @ np.linalg.inv(view)

    bindings.set_uniform("cm_textureFromView", texture_from_view)
    bindings.set_uniform("cm_inverseProjection",
                         lambda: np.linalg.inv(_camera_matrices(renderer)[1]))
    bindings.set_uniform("cm_projection", lambda: _camera_matrices(renderer)[1])
    bindings.set_uniform("cm_viewport",
                         lambda: (*renderer.GetOrigin(), *renderer.GetSize()))
    recipe = direct_recipe(march_defines(model, skipping))
    bindings.recipe = recipe
    recipe.apply(actor.GetShaderProperty())
    # Weighted order-independent translucency would reweight our single layer; plain
    # blending composites it exactly.
    renderer.SetUseOIT(False)
    # The opaque depth is copied each frame, which a multisampled framebuffer refuses.
    plotter.ren_win.SetMultiSamples(0)
    pyvista.set_new_attribute(actor, "cubemarch", VolumeBinding(
        model, bindings, recipe, step_scale, stop_opacity))
    return actor
