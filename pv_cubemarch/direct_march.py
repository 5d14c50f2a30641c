"""The direct screen-space ray marcher (DSSRM): the shared marching GLSL on a box actor.

The box's back faces are drawn in the translucent pass, after every opaque prop, so the
opaque depth of the frame is complete when the box is drawn and bounds each ray: read in
place from a multisampled framebuffer, or copied to a texture from a single-sampled one.
With ``downsample`` > 1 a low-resolution pass marches in an overlay renderer drawn after
the scene, and the box upsamples its result. This is the baseline the cube-map technique
is measured against.
"""

from __future__ import annotations

import numpy as np
import pyvista
import vtk
from vtkmodules.vtkRenderingOpenGL2 import vtkTextureObject

from .gl_resources import ShaderBindings, Texture
from .shaders import Replacement, ShaderRecipe
from .volume import VolumeModel

_GL_READ_FRAMEBUFFER = 0x8CA8


class SceneDepth:
    """The renderer's depth (or colour) of this frame, copied into a texture at each draw.

    The copy needs a single-sampled framebuffer (a multisampled one gives zeros), which the
    reduced-resolution path asks for; the full-resolution path reads a multisampled depth in
    place instead (:class:`FramebufferDepth`).
    """

    kind = "2d"
    nbytes = 0

    def __init__(self, renderer, color: bool = False):
        self.renderer = renderer
        self.color = color
        self.gl_object: vtkTextureObject | None = None
        self._size = None
        self._window = None

    def ensure(self, window) -> vtkTextureObject:
        """Copy the current depth (or colour) buffer into the texture (in the draw)."""
        width, height = self.renderer.GetSize()
        x0, y0 = self.renderer.GetOrigin()
        if self.gl_object is None or self._size != (width, height) or self._window is not window:
            self.release()
            self.gl_object = vtkTextureObject()
            self.gl_object.SetContext(window)
            if self.color:
                self.gl_object.Allocate2D(width, height, 4, vtk.VTK_UNSIGNED_CHAR)
            else:
                self.gl_object.AllocateDepth(width, height, vtkTextureObject.Float32)
            self.gl_object.SetMinificationFilter(vtkTextureObject.Nearest)
            self.gl_object.SetMagnificationFilter(vtkTextureObject.Nearest)
            self._size, self._window = (width, height), window
        # Read from the framebuffer VTK draws this frame into (another may be bound for
        # reading between renderers).
        state = window.GetState()
        state.PushReadFramebufferBinding()
        try:
            window.GetRenderFramebuffer().Bind(_GL_READ_FRAMEBUFFER)
            self.gl_object.CopyFromFrameBuffer(x0, y0, 0, 0, width, height)
        finally:
            state.PopReadFramebufferBinding()
        return self.gl_object

    def shared(self) -> _CopiedDepth:
        """The same texture for another binding in the frame, without copying again."""
        return _CopiedDepth(self)

    def release(self) -> None:
        """Free the texture."""
        if self.gl_object is not None and self._window is not None:
            self.gl_object.ReleaseGraphicsResources(self._window)
        self.gl_object = self._window = None


class FramebufferDepth:
    """The depth attachment VTK draws into, bound as is (a multisampled texture).

    Read with ``texelFetch`` while the box is drawn in the translucent pass, which writes
    no depth, so nothing reads what it writes; no copy is made and multisampling stays on.
    """

    kind = "2d"
    nbytes = 0

    def ensure(self, window) -> vtkTextureObject:
        """The current render framebuffer's depth texture."""
        return window.GetRenderFramebuffer().GetDepthAttachmentAsTextureObject()

    def release(self) -> None:
        """Nothing: VTK owns it."""


class _CopiedDepth:
    """A second binding of a :class:`SceneDepth` already copied in this frame."""

    kind = "2d"
    nbytes = 0

    def __init__(self, depth: SceneDepth):
        self.depth = depth

    def ensure(self, window) -> vtkTextureObject:
        return self.depth.gl_object if self.depth.gl_object is not None else \
            self.depth.ensure(window)

    def release(self) -> None:
        """Nothing: the :class:`SceneDepth` owns the texture."""


def direct_recipe(defines: dict, lit: bool = False,
                  sampling: str = "volume_sample") -> ShaderRecipe:
    """The polydata-shader replacements of the direct marcher."""
    return ShaderRecipe(
        replacements=[
            Replacement("//VTK::Color::Dec",
                        ("ea_declarations", sampling, "ea_direct_declarations",
                         "ea_march", *(("light_sample",) if lit else ()), "ea_screen_ray"),
                        keep_tag="after"),
            Replacement("//VTK::Light::Impl", "ea_direct_fragment", keep_tag="before"),
            Replacement("//VTK::PositionVC::Impl", "ea_box_vertex", stage="vertex",
                        keep_tag="before"),
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


def _box_actor(model: VolumeModel) -> pyvista.Actor:
    """The volume's box in its world placement, back faces only, drawn as translucent."""
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
    return actor


def _bind_camera(target, renderer, model: VolumeModel) -> None:
    """Per-frame camera uniforms of the screen-ray code, for a binding or a pass."""
    from .emission_absorption import world_from_texture

    target.set_uniform("cm_textureFromView", lambda: np.linalg.inv(
        _camera_matrices(renderer)[0] @ world_from_texture(model)))
    target.set_uniform("cm_inverseProjection",
                       lambda: np.linalg.inv(_camera_matrices(renderer)[1]))
    target.set_uniform("cm_projection", lambda: _camera_matrices(renderer)[1])
    target.set_uniform("cm_viewport", lambda: (*renderer.GetOrigin(), *renderer.GetSize()))


def build_direct_actor(plotter, model: VolumeModel, step_scale: float, stop_opacity: float,
                       skip_empty: bool, downsample: int = 1, light_map=None,
                       volume_texture: Texture | None = None):
    """A box actor that marches ``model`` with the shared GLSL; returns the actor.

    With ``downsample`` > 1 the rays are marched by a full-screen pass at 1/downsample of
    the viewport, and the box only upsamples the result with a depth-aware filter.
    """
    from .emission_absorption import VolumeBinding, bind_sampling, march_defines
    from .multi_volume import VolumeGroup

    renderer = plotter.renderer
    actor = _box_actor(model)
    if volume_texture is None and not isinstance(model, VolumeGroup):
        volume_texture = Texture(model.values, kind="3d", interpolate=True)
    # Weighted order-independent translucency would reweight our single layer.
    renderer.SetUseOIT(False)
    extra = []
    if downsample == 1:
        bindings = ShaderBindings(actor.GetMapper(), renderer)
        sampling, defines = bind_sampling(bindings, model, volume_texture, step_scale,
                                          stop_opacity, skip_empty)
        multisampled = plotter.ren_win.GetMultiSamples() > 1
        bindings.add_texture("cm_sceneDepth",
                             FramebufferDepth() if multisampled else SceneDepth(renderer))
        if multisampled:
            window = plotter.ren_win
            bindings.set_uniform("cm_depthSamples", lambda: max(1, int(
                window.GetRenderFramebuffer().GetDepthAttachmentAsTextureObject()
                .GetSamples())))
        defines["CM_DEPTH_MULTISAMPLED"] = multisampled
        if light_map is not None:
            light_map.bind(bindings)
            defines.update(light_map.defines)
        recipe = direct_recipe(defines, lit=light_map is not None, sampling=sampling)
    else:
        # The pass copies the opaque depth, which a multisampled framebuffer refuses.
        plotter.ren_win.SetMultiSamples(0)
        overlay, low_pass = _reduced_resolution(plotter, model, step_scale, stop_opacity,
                                                skip_empty, downsample, volume_texture,
                                                light_map)
        bindings = ShaderBindings(actor.GetMapper(), overlay.renderer)
        bindings.set_uniform("cm_dims", tuple(float(n) for n in model.dimensions))
        bindings.add_texture("cm_lowColor", low_pass.output(0))
        bindings.add_texture("cm_lowDepth", low_pass.output(1))
        bindings.add_texture("cm_sceneDepth", overlay.depth.shared())
        bindings.set_uniform("cm_lowSize", lambda: tuple(float(v) for v in low_pass.size))
        bindings.set_uniform("cm_depthSharpness", DEPTH_SHARPNESS)
        bindings.add_texture("cm_sceneColor", SceneDepth(overlay.renderer, color=True))
        recipe = upsample_recipe(march_defines(model, False))
        renderer = overlay.renderer
        overlay.add_user(actor)
        extra = [low_pass.release, lambda: overlay.remove_actor(actor),
                 lambda: overlay.release_user(actor)]
    _bind_camera(bindings, plotter.renderer, model)
    bindings.recipe = recipe
    recipe.apply(actor.GetShaderProperty())
    binding = VolumeBinding(model, bindings, recipe, step_scale, stop_opacity)
    binding.extra_release = extra
    binding.renderer = renderer
    binding.targets = [bindings] + ([low_pass] if downsample > 1 else [])
    binding.downsample = downsample
    pyvista.set_new_attribute(actor, "cubemarch", binding)
    return actor


#: Depth-aware upsampling: a low-resolution sample stops counting once its depth differs
#: from the pixel's by 1/DEPTH_SHARPNESS of the pixel's depth (5 %).
DEPTH_SHARPNESS = 20.0


def upsample_recipe(defines: dict) -> ShaderRecipe:
    """The box actor's replacements when it upsamples a reduced-resolution pass."""
    return ShaderRecipe(
        replacements=[
            Replacement("//VTK::Color::Dec",
                        ("ea_declarations", "volume_sample", "ea_direct_declarations",
                         "ea_march", "ea_screen_ray", "ea_upsample_declarations"),
                        keep_tag="after"),
            Replacement("//VTK::Light::Impl", "ea_upsample_fragment", keep_tag="before"),
            Replacement("//VTK::PositionVC::Impl", "ea_box_vertex", stage="vertex",
                        keep_tag="before"),
        ],
        defines=defines,
    )


def _reduced_resolution(plotter, model, step_scale, stop_opacity, skip_empty, downsample,
                        volume_texture, light_map=None):
    """The plotter's overlay and a low-resolution pass run at its start."""
    from .emission_absorption import bind_sampling
    from .gl_resources import RenderToTexturePass
    from .overlay import scene_overlay

    main = plotter.renderer
    overlay = scene_overlay(plotter)
    overlay.copy_depth = True

    def low_size():
        width, height = main.GetSize()
        return (-(-width // downsample), -(-height // downsample))

    low_pass = RenderToTexturePass(overlay.renderer, None, size=low_size,
                                   targets=("rgba16f", "r32f"), every_frame=True)
    sampling, defines = bind_sampling(low_pass, model, volume_texture, step_scale,
                                      stop_opacity, skip_empty)
    low_pass.add_texture("cm_sceneDepth", overlay.depth.shared())
    _bind_camera(low_pass, main, model)
    lit = ()
    if light_map is not None:
        light_map.bind(low_pass)
        defines.update(light_map.defines)
        lit = ("light_sample",)
    low_pass.set_recipe(ShaderRecipe(
        standalone=("pass_head", "ea_declarations", sampling, "ea_direct_declarations",
                    "ea_march", *lit, "ea_screen_ray", "ea_reduced_main"), defines=defines))
    return overlay, low_pass
