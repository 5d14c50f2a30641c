"""The direct screen-space ray marcher (``technique='direct'``): the shared marcher on a box.

The box's back faces are drawn in the translucent pass, after every opaque prop, so the
opaque depth of the frame is complete when the box is drawn and bounds each ray: read in
place from a multisampled framebuffer, or from the renderer's shared copy of a
single-sampled one; which of the two is decided at every frame. With ``downsample`` > 1 a
low-resolution pass marches in the overlay renderer drawn after the scene, and the box
upsamples its result. This is the baseline the cube-map technique is measured against.
"""

from __future__ import annotations

import pyvista

from ..core import vtk_classes as vtk
from ..core.frame_errors import observe
from ..core.registry import Sweep, Technique, register_technique
from ..gl.bindings import ShaderBindings
from ..gl.box import (
    bind_camera,
    box_actor,
    drawn_viewport,
    framebuffer_viewport,
    render_pass_of,
)
from ..gl.frame_inputs import FramebufferDepth, SceneDepth, frame_inputs
from ..gl.overlay import scene_overlay
from ..gl.passes import RenderToTexturePass
from ..gl.shaders import ShaderRecipe, box_recipe
from ..reference.emission_absorption import render_emission_absorption
from .binding import (
    DECLARATION_SNIPPETS,
    SCREEN_DECLARATIONS,
    VolumeBinding,
    VolumeData,
    VolumeSetup,
    bind_sampling,
    march_snippets,
    world_from_texture,
)
from .options import STEP_SCALES, DirectOptions

#: Depth-aware upsampling: a low-resolution sample stops counting once its depth differs
#: from the pixel's by 1/DEPTH_SHARPNESS of the pixel's depth (5 %).
DEPTH_SHARPNESS = 20.0


def direct_recipe(defines: dict, lit: bool = False,
                  sampling: str | tuple[str, ...] = "volume_sample",
                  blending: str = "composite", peeled: bool = False) -> ShaderRecipe:
    """The polydata-shader replacements of the direct marcher.

    ``sampling``: the snippet (or snippets, in order) defining ``cm_sampleScalar``.
    ``peeled``: under VTK's depth peeling the march runs where VTK sets the depth, so the
    peeling tests and sorts the box's fragment by the ray's entry, not the box's back face
    (which lies behind an opaque mesh inside the volume: the volume before it was lost).
    """
    sampling = (sampling,) if isinstance(sampling, str) else tuple(sampling)
    return box_recipe(
        (*DECLARATION_SNIPPETS, *sampling, *SCREEN_DECLARATIONS,
         *march_snippets(blending, defines), *(("light_sample",) if lit else ()),
         "pixel_ray", "screen_ray"), "ea_direct_fragment",
        defines={**defines, "CM_PEELED_LAYER": peeled}, layers=peeled)


def upsample_recipe() -> ShaderRecipe:
    """The box actor's replacements when it upsamples a reduced-resolution pass.

    The box marches nothing: it finds its pixel's ray (for the depth the filter compares)
    and filters the low-resolution result, so no sampling or marching code is compiled in.
    """
    return box_recipe((*SCREEN_DECLARATIONS, "ea_upsample_declarations", "slab", "pixel_ray",
                       "screen_ray"), "ea_upsample_fragment")


class DirectBinding(VolumeBinding):
    """A directly marched volume; at full resolution it follows the frame's multisampling."""

    technique = "direct"

    def __init__(self, *args, window=None, lit: bool = False,
                 sampling: str | tuple[str, ...] = "",
                 defines: dict | None = None):
        super().__init__(*args)
        self.window = window
        self._lit, self._sampling, self._defines = lit, sampling, dict(defines or {})
        self.multisampled: bool | None = None
        self.peeled: bool | None = None
        self._tag = None

    @property
    def blends_in_main_renderer(self) -> bool:
        """At full resolution the box draws in the plotter's translucent pass."""
        return self.downsample == 1

    @property
    def needs_single_sample(self) -> bool:
        """Whether this frame needs the window single-sampled.

        The reduced-resolution pass copies the depth, which needs a single sample; under
        VTK's depth peeling the box is peeled, and the peeling's copy of the opaque depth
        from a multisampled framebuffer gives none: every translucent prop is lost then
        (PyVista's meshes too), where ``add_volume``'s volume is not peeled. Under a VTK
        pass (eye-dome lighting, SSAO) the box draws into the pass's single-sampled
        framebuffer, whose depth only the shared copy reads, and VTK's copy resolves (into
        a fixed-point depth: zeros from the pass's float depth) whenever the window is
        multisampled.
        """
        renderer = self.bindings.renderer
        return self.downsample > 1 or bool(renderer.GetUseDepthPeeling()) \
            or render_pass_of(renderer, "vtkRenderPass") is not None

    def follow_multisampling(self, *_) -> None:
        """At each frame: read the depth in place if multisampled, else the shared copy.

        The shader is rebuilt only when the framebuffer's kind, or the renderer's depth
        peeling (:func:`direct_recipe`'s ``peeled``), changes.
        """
        multisampled = self.window.GetMultiSamples() > 1
        peeled = bool(self.bindings.renderer.GetUseDepthPeeling())
        if (multisampled, peeled) == (self.multisampled, self.peeled):
            return
        self.multisampled, self.peeled = multisampled, peeled
        depth = FramebufferDepth() if multisampled else frame_inputs(self.bindings.renderer).depth
        self.bindings.add_texture("cm_sceneDepth", depth)
        window = self.window
        if multisampled:
            self.bindings.set_uniform("cm_depthSamples", lambda: max(1, int(
                window.GetRenderFramebuffer().GetDepthAttachmentAsTextureObject()
                .GetSamples())))
            renderer = self.bindings.renderer
            self.bindings.set_uniform("cm_depthViewport",
                                      lambda: framebuffer_viewport(renderer))
        else:
            self.bindings.uniforms.pop("cm_depthSamples", None)
            self.bindings.uniforms.pop("cm_depthViewport", None)
        self.recompile(direct_recipe(dict(self._defines, CM_DEPTH_MULTISAMPLED=multisampled),
                                     lit=self._lit, sampling=self._sampling,
                                     blending=self.blending, peeled=peeled))

    def recompile_marchers(self, change, light_map: bool = True) -> None:
        """Compile the marchers again (see ``VolumeBinding``), switches kept.

        A multisampling change builds its shader from them.
        """
        super().recompile_marchers(change, light_map)
        recipe = self.bindings.recipe
        if self.downsample == 1 and recipe is not None:
            self._defines = {key: value for key, value in recipe.defines.items()
                             if key not in ("CM_DEPTH_MULTISAMPLED", "CM_PEELED_LAYER")}

    def release_resources(self) -> None:
        """Stop following the frame, then free what a volume holds."""
        if self._tag is not None:
            self.bindings.renderer.RemoveObserver(self._tag)
            self._tag = None
        super().release_resources()


def build_direct_actor(plotter, data: VolumeData, setup: VolumeSetup):
    """A box actor that marches the volume with the shared GLSL; returns its binding.

    With ``options.downsample`` > 1 the rays are marched by a full-screen pass at
    1/downsample of the viewport, and the box only upsamples the result with a
    depth-aware filter.
    """
    options, shading, light_map = setup.options, setup.shading, setup.light_map
    model = data.model
    renderer = plotter.renderer
    actor = box_actor([n - 1.0 for n in model.dimensions], model.world_from_index())
    step_scale, downsample = float(options.step_scale), int(options.downsample)
    if downsample == 1:
        bindings = ShaderBindings(actor.GetMapper(), renderer)
        sampling, defines = bind_sampling(bindings, data, step_scale, shading.stop_opacity,
                                          shading.skip_empty, blend=shading.blend)
        if light_map is not None:
            light_map.bind(bindings)
            defines.update(light_map.defines)
        bind_camera(bindings, renderer, lambda: world_from_texture(model))
        binding = DirectBinding(model, data, bindings, None, step_scale, shading.stop_opacity,
                                window=plotter.ren_win, lit=light_map is not None,
                                sampling=sampling, defines=defines)
        binding.blending = shading.blending
        binding.drawn = [actor]
        binding.renderer = renderer
        binding.follow_multisampling()
        # After the window decided this frame's multisampling, before any prop draws.
        binding._tag = observe(renderer, vtk.vtkCommand.StartEvent,
                               binding.follow_multisampling, 5.0)
    else:
        low_size = LowSize(plotter.renderer, downsample)
        overlay, low_pass = _reduced_resolution(plotter, data, step_scale, shading,
                                                low_size, light_map)
        bindings = ShaderBindings(actor.GetMapper(), overlay.renderer)
        bindings.set_uniform("cm_dims", tuple(float(n) for n in model.dimensions))
        bindings.add_texture("cm_lowColor", low_pass.output(0))
        bindings.add_texture("cm_lowDepth", low_pass.output(1))
        bindings.add_texture("cm_sceneDepth", overlay.depth)
        bindings.set_uniform("cm_lowSize", lambda: tuple(float(v) for v in low_pass.size))
        bindings.set_uniform("cm_depthSharpness", DEPTH_SHARPNESS)
        bindings.add_texture("cm_sceneColor",
                             SceneDepth(overlay.renderer, color=True, each_use=True), owned=True)
        bind_camera(bindings, renderer, lambda: world_from_texture(model))
        recipe = upsample_recipe()
        bindings.install(recipe, actor)
        binding = DirectBinding(model, data, bindings, recipe, step_scale,
                                shading.stop_opacity)
        binding.drawn = [actor]
        binding.renderer = overlay.renderer
        overlay.add_user(actor, reads_depth=True)
        binding.extra_release = [low_pass.release, lambda: overlay.remove_actor(actor),
                                 lambda: overlay.release_user(actor)]
        binding.targets = [bindings, low_pass]
        binding.low_size = low_size
        low_pass.run_when = lambda: binding.shown   # every frame the volume is shown
    binding.downsample = downsample
    pyvista.set_new_attribute(actor, "cubemarch", binding)
    return binding


class LowSize:
    """The low-resolution pass's size: 1/``factor`` of the viewport, rounded up.

    ``factor`` is the volume's ``downsample``, or more while a frame budget coarsens a
    moving view (the pass's targets follow at its next run).
    """

    def __init__(self, renderer, factor: int):
        self.renderer, self.factor = renderer, int(factor)

    def __call__(self) -> tuple[int, int]:
        width, height = drawn_viewport(self.renderer)[2:]
        return (-(-width // self.factor), -(-height // self.factor))


def _reduced_resolution(plotter, data: VolumeData, step_scale: float, shading,
                        low_size: LowSize, light_map=None):
    """The plotter's overlay and a low-resolution pass run at its start."""
    model = data.model
    main = plotter.renderer
    overlay = scene_overlay(plotter)
    low_pass = RenderToTexturePass(overlay.renderer, None, size=low_size,
                                   targets=("rgba16f", "r32f"))
    sampling, defines = bind_sampling(low_pass, data, step_scale, shading.stop_opacity,
                                      shading.skip_empty, blend=shading.blend)
    low_pass.add_texture("cm_sceneDepth", overlay.depth)
    bind_camera(low_pass, main, lambda: world_from_texture(model))
    lit = ()
    if light_map is not None:
        light_map.bind(low_pass)
        defines.update(light_map.defines)
        lit = ("light_sample",)
    low_pass.set_recipe(ShaderRecipe(
        standalone=("pass_head", *DECLARATION_SNIPPETS, sampling, *SCREEN_DECLARATIONS,
                    *march_snippets(shading.blending, defines), *lit, "pixel_ray", "screen_ray",
                    "ea_reduced_main"),
        defines=defines))
    return overlay, low_pass


def _describe(setting: dict) -> str:
    down = setting.get("downsample", 1)
    return f"step_scale={setting['step_scale']}" + (f", downsample={down}" if down > 1 else "")


register_technique(Technique(
    name="direct", kind="volume", options=DirectOptions, build=build_direct_actor,
    reference=render_emission_absorption,
    sweep=Sweep([{"step_scale": s} for s in STEP_SCALES]
                + [{"step_scale": 0.5, "downsample": k} for k in (2, 4)], _describe),
    summary="the direct screen-space marcher on a box actor, one ray per pixel"))
