"""Emission/absorption ray casting inside VTK's GPU volume mapper (``technique='vtk'``).

VTK's ``vtkOpenGLGPUVolumeRayCastMapper`` draws the volume's box and copies the opaque
depth; the box's clip position and each fragment's ray (entry at the box or the near plane,
exit at the box or the opaque depth) come from our own camera-relative matrices, made in
double precision, so volumes far from the origin stay exact. Its per-sample work is the
shared marcher: front-to-back emission/absorption from our own transfer table, the
exponential opacity correction for the real segment length and early ray termination.
"""

from __future__ import annotations

import pyvista
from vtkmodules.vtkRenderingOpenGL2 import vtkTextureObject

from ..core import vtk_classes as vtk
from ..core.frame_errors import observe
from ..core.registry import Sweep, Technique, register_technique
from ..core.user_warnings import warn_user
from ..gl.bindings import ShaderBindings
from ..gl.box import (
    bind_camera,
    camera_matrices,
    drawn_viewport,
    fragment_viewport,
    place_box,
    supersampling_pass,
)
from ..gl.frame_inputs import frame_inputs
from ..gl.lights import hold_headlights_steady
from ..gl.shaders import Replacement, ShaderRecipe
from ..models.volume import VolumeModel
from ..reference.emission_absorption import render_emission_absorption
from .binding import (
    DECLARATION_SNIPPETS,
    SCREEN_DECLARATIONS,
    VolumeBinding,
    VolumeData,
    VolumeSetup,
    bind_sampling,
    march_snippets,
    vtk_scalars,
    world_from_texture,
)
from .options import STEP_SCALES, MarchOptions


def vtk_mapper_recipe(defines: dict, lit: bool, blending: str = "composite") -> ShaderRecipe:
    """The shader replacements of the VTK-mapper path.

    VTK's mapper draws the box and copies the opaque depth; the box's clip position and each
    fragment's ray come from our own camera-relative matrices (``ea_vtk_clip_position``,
    ``ea_vtk_ray_init`` with the direct marcher's ray code), not from VTK's float32 set-up.
    """
    return ShaderRecipe(
        replacements=[
            Replacement("//VTK::Base::Dec", (*DECLARATION_SNIPPETS, "ea_vtk_shading_gradient"),
                        keep_tag="after"),
            Replacement("//VTK::ComputeColor::Dec",
                        ("ea_vtk_declarations", *SCREEN_DECLARATIONS,
                         *march_snippets(blending, defines),
                         *(("light_sample",) if lit else ()), "pixel_ray", "screen_ray"),
                        keep_tag="after"),
            Replacement("//VTK::Shading::Init", "ea_vtk_ray_init"),
            Replacement("//VTK::Base::Dec", "ea_vtk_vertex_declarations", stage="vertex",
                        keep_tag="after"),
            Replacement("//VTK::ComputeClipPos::Impl", "ea_vtk_clip_position",
                        stage="vertex", keep_tag="before"),
        ],
        defines=dict(defines, CM_VTK_MAPPER=True),
    )


def build_vtk_actor(plotter, data: VolumeData, setup: VolumeSetup):
    """A ``pyvista.Volume`` drawn by VTK's GPU mapper with our marcher; returns its binding."""
    options, shading, light_map = setup.options, setup.shading, setup.light_map
    model: VolumeModel = data.model
    step_scale = options.step_scale
    # VTK's mapper gets the grid in index space (origin 0, spacing 1, no rotation) and the
    # whole placement in the actor's matrix: a mirrored grid (negative spacing, a direction
    # with determinant -1) is then an ordinary grid under a mirroring matrix, which VTK draws,
    # and vertex positions stay small. Far from the origin VTK's float32 set-up still fails
    # (its clip position multiplies world-sized matrices on the GPU, its rays end at the
    # opaque depth through their inverses), so the clip position and the rays come from our
    # camera-relative matrices, made in double precision (vtk_mapper_recipe).
    grid = pyvista.ImageData(dimensions=model.dimensions)
    grid.point_data["scalars"] = vtk_scalars(model)
    mapper = vtk.vtkOpenGLGPUVolumeRayCastMapper()
    mapper.SetInputData(grid)
    mapper.SetBlendModeToComposite()
    mapper.SetAutoAdjustSampleDistances(False)
    mapper.SetLockSampleDistanceToInputSpacing(False)
    mapper.SetUseJittering(False)
    mapper.SetSampleDistance(step_scale)  # index units; VTK's own loop never runs
    prop = vtk.vtkVolumeProperty()
    if model.interpolation == "nearest":
        prop.SetInterpolationTypeToNearest()
    else:
        prop.SetInterpolationTypeToLinear()
    prop.ShadeOff()
    if model.colors is not None:   # VTK's 4 dependent components: its texture is RGBA
        prop.IndependentComponentsOff()
    actor = pyvista.Volume()
    actor.SetMapper(mapper)
    actor.SetProperty(prop)
    place_box(actor, model.world_from_index(), culling=False)
    renderer = plotter.renderer
    bindings = ShaderBindings(mapper, renderer)
    bind_camera(bindings, renderer, lambda: world_from_texture(model))

    def clip_from_index():
        view, projection = camera_matrices(renderer)
        return projection @ view @ model.world_from_index()

    bindings.set_uniform("cm_clipFromIndex", clip_from_index)
    bindings.set_uniform("cm_viewport", lambda: sampled_viewport(mapper, renderer))
    _, defines = bind_sampling(bindings, data, step_scale, shading.stop_opacity,
                               shading.skip_empty, sample_data=False,
                               blend=shading.blend)
    if light_map is not None:
        light_map.bind(bindings)
        defines.update(light_map.defines)
    recipe = vtk_mapper_recipe(defines, lit=light_map is not None, blending=shading.blending)
    bindings.install(recipe, actor)
    binding = VolumeBinding(model, data, bindings, recipe, step_scale, shading.stop_opacity)
    binding.technique = "vtk"
    binding.vtk_input = grid
    binding.drawn = [actor]
    binding.renderer = plotter.renderer
    binding.extra_release.append(hold_headlights_steady(renderer))
    said = []
    binding.sample_distances = SampleDistances(mapper)

    def before_draw(*_) -> None:
        """Each frame: the sample distance the mapper may take; warn of SSAA with meshes."""
        stand_in = getattr(binding, "actor", None)   # the volume add_volume returned
        full_only = supersampling_pass(renderer) is not None or \
            drawn_viewport(renderer)[:2] != (0, 0)
        binding.sample_distances.follow(
            stand_in.GetMapper() if stand_in is not None and stand_in is not actor else None,
            full_only)
        if match_supersampling_depth(renderer) and binding.shown and not said \
                and frame_inputs(renderer).has_opaque_props():
            said.append(True)
            warn_user(f"{binding.name!r}: under supersampling (enable_anti_aliasing('ssaa'), "
                      "and 'fxaa' on EGL builds) VTK's volume mapper reads the meshes' depth "
                      "at the window's size, not the supersampled one, so meshes hide "
                      "technique='vtk' volumes in the wrong places; use technique='direct', "
                      "or MSAA (enable_anti_aliasing('msaa')).")
    tag = observe(renderer, vtk.vtkCommand.StartEvent, before_draw)
    binding.extra_release.append(lambda: renderer.RemoveObserver(tag))
    pyvista.set_new_attribute(actor, "cubemarch", binding)
    return binding


def sampled_viewport(mapper, renderer) -> tuple[int, int, int, int]:
    """The viewport of ``gl_FragCoord`` while VTK's mapper draws: reduced, at a sample distance.

    With ``ImageSampleDistance`` d above 1 VTK draws the volume into a framebuffer of its
    own, ``int(width / d)`` by ``int(height / d)`` from (0, 0), then stretches it over the
    viewport: the rays are made for those pixels.
    """
    distance = float(mapper.GetImageSampleDistance())
    if distance == 1.0:
        return fragment_viewport(renderer)
    width, height = drawn_viewport(renderer)[2:]
    return (0, 0, max(1, int(width / distance)), max(1, int(height / distance)))


class SampleDistances:
    """The ``ImageSampleDistance`` the drawing mapper takes: the user's, or a budget's.

    ``vol.mapper.SetImageSampleDistance(d)`` on the returned volume draws the volume at
    1/d of the viewport across, as on PyVista's own GPU mapper; a frame budget asks for
    coarser ones while the view moves (the coarser of the two is drawn). It is 1 under
    supersampling (VTK would shrink the window's size, not the pass's) and in a renderer
    that does not start at the window's lower-left corner (a subplot right of or above
    another: the volume vanished there, and VTK's own mapper loses it from d=3).
    """

    def __init__(self, mapper):
        self.mapper = mapper
        self.user = 1.0
        self.budget = 1.0
        #: Whether only 1 draws now (supersampling, a subplot off the window's corner).
        self.full_only = False

    def follow(self, returned_mapper, full_only: bool) -> None:
        """At each frame: take the returned volume's distance, and whether only 1 draws."""
        if returned_mapper is not None:
            self.user = max(float(returned_mapper.GetImageSampleDistance()), 1.0)
        self.full_only = full_only
        self.apply()

    def ask(self, distance: float) -> None:
        """A budget's distance (1: none)."""
        self.budget = float(distance)
        self.apply()

    def apply(self) -> None:
        wanted = 1.0 if self.full_only else max(self.user, self.budget)
        if float(self.mapper.GetImageSampleDistance()) != wanted:
            self.mapper.SetImageSampleDistance(wanted)


def match_supersampling_depth(renderer) -> bool:
    """Give a ``vtkSSAAPass`` drawing ``renderer`` the depth VTK's volume mapper copies.

    The mapper blits the framebuffer's depth into a 32-bit depth texture (a depth-stencil
    one in a stencil-capable window); the pass's depth is 24-bit by default, and a blit
    between depth formats fails (``GL_INVALID_OPERATION``): the volume drew nothing under
    supersampling. Returns whether such a pass draws the renderer.
    """
    ssaa = supersampling_pass(renderer)
    if ssaa is None:
        return False
    window = renderer.GetRenderWindow()
    if not window.GetStencilCapable() and ssaa.GetDepthFormat() != vtkTextureObject.Fixed32:
        ssaa.SetDepthFormat(vtkTextureObject.Fixed32)
        ssaa.ReleaseGraphicsResources(window)   # allocated again, in that format
    return True


register_technique(Technique(
    name="vtk", kind="volume", options=MarchOptions, build=build_vtk_actor,
    reference=render_emission_absorption,
    sweep=Sweep([{"step_scale": s} for s in STEP_SCALES]),
    summary="marched inside VTK's GPU volume mapper, which sets up each ray", groups=False))
