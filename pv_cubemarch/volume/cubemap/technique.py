"""Cube-map imposter marching: ray marching once per texel of the box's interior faces.

Three passes per volume and frame, each in its own GLSL file:

1. light map (:mod:`pv_cubemarch.volume.light_map`, ``light_map_main.glsl``): only with lights, and
   only when a light, the placement or the data change;
2. cube ray marching (``cube_march_main.glsl``): a full-screen pass over a 3 x 2 atlas of
   the six interior faces at this frame's level size ``S``, run at the start of the scene
   overlay, after every opaque prop was drawn, so each texel's ray stops at the opaque depth
   under its projection; faces the eye cannot see (the visible-face mask) are not marched,
   and a volume outside the view frustum is not marched at all;
3. cube resampling (``cube_resample_*.glsl``): the box's back faces, drawn by the overlay,
   fetch their pixel's result by cube mapping through the 2x2 bilateral depth filter.

The marching cost depends on ``S`` and the sample count, which the adaptive LOD
(:mod:`pv_cubemarch.volume.cubemap.lod`) derives from the volume's projected size under the
user's caps, not on the viewport's resolution.
"""

from __future__ import annotations

import numpy as np
import pyvista

from ...core.registry import Sweep, Technique, register_technique
from ...gl.bindings import ShaderBindings
from ...gl.box import bind_camera, box_actor, camera_matrices, drawn_viewport
from ...gl.frame_inputs import FramebufferDepth, frame_inputs
from ...gl.overlay import scene_overlay
from ...gl.passes import RenderToTexturePass
from ...gl.shaders import ShaderRecipe, box_recipe
from ...models.volume import VolumeModel
from ...reference.emission_absorption import render_emission_absorption
from ..binding import (
    DECLARATION_SNIPPETS,
    SCREEN_DECLARATIONS,
    VolumeBinding,
    VolumeData,
    VolumeSetup,
    bind_sampling,
    march_snippets,
    world_from_texture,
)
from ..options import CubeMapOptions, default_max_samples
from ..paged import PagedData, Streamed, bind_paged_sampling, follow_pager
from .lod import LodChoice, choose_lod, cube_corners, project_corners, visible_face_mask

CUBE_TARGETS = ("rgba16f", "r32f")  # colour (premultiplied), the view distance of each ray


def world_from_local(model: VolumeModel) -> np.ndarray:
    """4x4 from the cube's local [-1, 1]^3 (the box of grid points) to world."""
    upper = np.array(model.dimensions, dtype=np.float64) - 1.0
    index_from_local = np.eye(4)
    index_from_local[:3, :3] = np.diag(upper / 2.0)
    index_from_local[:3, 3] = upper / 2.0
    return model.world_from_index() @ index_from_local


class CubeFrame:
    """What the technique chooses for one volume at each frame: culling, face mask, LOD.

    :meth:`update` runs at the start of the pass; the chosen values stay readable for
    inspection (``actor.cubemarch.lod``, ``.face_mask``, ``.culled``).
    """

    def __init__(self, renderer, model: VolumeModel, options: CubeMapOptions):
        self.renderer = renderer
        self.model = model
        self.options = options
        self.max_samples = int(options.max_samples or default_max_samples(model))
        self.place()
        self.face_mask = 0
        self.culled = False
        self.frames = 0
        self.on_update = None  # called first at each frame (e.g. to follow the scene)
        size = int(options.face_size)
        self.lod = LodChoice(float(size), float(self.max_samples), self.max_samples,
                             float(size), 0, size)

    def place(self) -> None:
        """Take the volume's placement (at creation and after ``set_transform``)."""
        self.world_from_local = world_from_local(self.model)
        self.local_from_world = np.linalg.inv(self.world_from_local)
        self.edge_world = float(2.0 * np.linalg.norm(self.world_from_local[:3, :3], axis=0).max())

    def update(self) -> bool:
        """Choose this frame's face mask and LOD; ``False`` when the volume is out of view."""
        if self.on_update is not None:
            self.on_update()
        view, projection = camera_matrices(self.renderer)
        camera = self.renderer.GetActiveCamera()
        eye = np.array(camera.GetPosition(), dtype=np.float64)
        if camera.GetParallelProjection():
            forward = np.array(camera.GetDirectionOfProjection())
            eye = eye - forward * 1e6 * max(self.edge_world, 1e-30)
        eye_local = self.local_from_world @ np.append(eye, 1.0)
        self.face_mask = visible_face_mask(eye_local[:3] / eye_local[3])
        clip_from_world = projection @ view
        self.culled = _outside_frustum(clip_from_world @ self.world_from_local)
        if self.culled:
            return False
        corners = project_corners(self.world_from_local, clip_from_world,
                                  drawn_viewport(self.renderer)[2:])
        size = int(self.options.face_size)
        if corners is None:  # a corner behind the eye: unbounded projected size
            self.lod = LodChoice(float("inf"), float("inf"), self.max_samples, float(size), 0,
                                 size)
        else:
            self.lod = choose_lod(corners, self.max_samples, size, self.options.upscale,
                                  self.options.sample_factor)
        self.frames += 1
        return True

    def atlas_size(self) -> tuple[int, int]:
        """Texels of the face atlas at this frame's level: 3 x 2 faces, each with a border."""
        tile = self.lod.level_size + 2
        return (3 * tile, 2 * tile)

    @property
    def step_scale(self) -> float:
        """Step in texels along the dominant axis giving ``N`` samples on the diagonal."""
        return max(max(self.model.dimensions) - 1, 1) / float(self.lod.samples)

    @property
    def texel_world(self) -> float:
        """World length of one face texel at this level (the bilateral filter's depth unit)."""
        return self.edge_world / float(self.lod.level_size)


def _outside_frustum(clip_from_local: np.ndarray) -> bool:
    """Whether all 8 corners lie outside one clipping plane (the box cannot be seen)."""
    clip = np.column_stack([cube_corners(), np.ones(8)]) @ clip_from_local.T
    w = clip[:, 3]
    for axis in range(3):
        if (clip[:, axis] > w).all() or (clip[:, axis] < -w).all():
            return True
    return False


def _pass_snippets(lit: bool, sampling: tuple[str, ...], blending: str,
                   defines: dict) -> tuple[str, ...]:
    return ("pass_head", *DECLARATION_SNIPPETS, *sampling, *SCREEN_DECLARATIONS,
            *march_snippets(blending, defines), *(("light_sample",) if lit else ()),
            "pixel_ray", "screen_ray", "cube_faces", "cube_march_main")


def resample_recipe(occlusion: bool) -> ShaderRecipe:
    """The box actor's replacements: cube resampling on the interior faces.

    ``occlusion`` compiles the bilateral depth filter in (the scene has opaque props).
    """
    return box_recipe(
        (*SCREEN_DECLARATIONS, "cube_resample_declarations", "cube_faces",
         "cube_resample_filter"), "cube_resample_fragment",
        defines={"CM_DEPTH_FRAMEBUFFER": True, "CM_OCCLUSION": bool(occlusion)},
        vertex=("cube_resample_vertex", "ea_box_vertex"),
        vertex_declarations=("cube_resample_vertex_declarations",))


def build_cubemap_actor(plotter, data: VolumeData, setup: VolumeSetup):
    """The box actor of a cube-map volume, with its passes; returns its binding."""
    options, shading, light_map = setup.options, setup.shading, setup.light_map
    model = data.model
    main = plotter.renderer
    overlay = scene_overlay(plotter)
    frame = CubeFrame(main, model, options)
    lit = light_map is not None
    # Half-float colour is ample for 8-bit output; the depth needs float32 but one channel.
    # The targets keep their largest size: an LOD change reallocates nothing.
    cube_pass = RenderToTexturePass(overlay.renderer, None, size=frame.atlas_size,
                                    targets=CUBE_TARGETS, run_when=frame.update,
                                    grow_only=True)
    if isinstance(data, PagedData):   # a multiscale source: its brick pool
        sampling = ("paged_bricks", "paged_sample")
        defines = bind_paged_sampling(cube_pass, data, 1.0, shading.stop_opacity)
    else:
        sampling, defines = bind_sampling(cube_pass, data, 1.0, shading.stop_opacity,
                                          shading.skip_empty, blend=shading.blend)
        sampling = (sampling,)
    cube_pass.set_uniform("cm_stepScale", lambda: frame.step_scale)
    cube_pass.add_texture("cm_sceneDepth", FramebufferDepth())
    cube_pass.set_uniform("cm_viewFromTexture",
                          lambda: camera_matrices(main)[0] @ world_from_texture(model))
    cube_pass.set_uniform("cm_faceSize", lambda: float(frame.lod.level_size))
    cube_pass.set_uniform("cm_faceMask", lambda: int(frame.face_mask))
    bind_camera(cube_pass, main, lambda: world_from_texture(model))
    defines["CM_DEPTH_FRAMEBUFFER"] = True
    if lit:
        light_map.bind(cube_pass)
        defines.update(light_map.defines)
    cube_pass.set_recipe(ShaderRecipe(
        standalone=_pass_snippets(lit, sampling, shading.blending, defines), defines=defines))

    actor = box_actor([n - 1.0 for n in model.dimensions], model.world_from_index())
    actor.GetProperty().LightingOff()  # VTK's lighting code would run for nothing
    bindings = ShaderBindings(actor.GetMapper(), overlay.renderer)
    bindings.set_uniform("cm_dims", tuple(float(n) for n in model.dimensions))
    bindings.add_texture("cm_cubeColor", cube_pass.output(0))
    bindings.add_texture("cm_cubeDepth", cube_pass.output(1))
    bindings.add_texture("cm_sceneDepth", FramebufferDepth())
    bindings.set_uniform("cm_faceSize", lambda: float(frame.lod.level_size))
    bindings.set_uniform("cm_atlasAllocated", lambda: tuple(float(v) for v in
                                                             cube_pass.allocated))
    bindings.set_uniform("cm_occlusionSharpness", float(options.occlusion_sharpness))
    bindings.set_uniform("cm_texelWorld", lambda: frame.texel_world)
    bind_camera(bindings, main, lambda: world_from_texture(model))
    recipe = resample_recipe(frame_inputs(main).has_opaque_props())
    bindings.install(recipe, actor)
    kind = PagedCubeMapBinding if isinstance(data, PagedData) else CubeMapBinding
    binding = kind(model, data, bindings, recipe, frame, cube_pass, light_map,
                   shading.stop_opacity)
    binding.drawn = [actor]
    frame.on_update = binding.follow_occluders
    cube_pass.run_when = lambda: binding.shown and frame.update()
    binding.renderer = overlay.renderer
    overlay.add_user(actor)
    binding.extra_release = [cube_pass.release, lambda: overlay.remove_actor(actor),
                             lambda: overlay.release_user(actor)]
    if isinstance(data, PagedData):
        follow_pager(plotter, binding, data.pager)
    pyvista.set_new_attribute(actor, "cubemarch", binding)
    return binding


class CubeMapBinding(VolumeBinding):
    """Per-volume state of a cube-map volume: its passes and this frame's choices."""

    technique = "cubemap"
    needs_single_sample = True

    def __init__(self, model, data, bindings, recipe, frame: CubeFrame, cube_pass, light_map,
                 stop_opacity):
        super().__init__(model, data, bindings, recipe, float("nan"), stop_opacity)
        self.frame = frame
        self.cube_pass = cube_pass
        self.light_map = light_map
        self.targets = [bindings, cube_pass]

    def place(self, transform) -> None:
        """The box follows, and the frame's culling and level of detail."""
        super().place(transform)
        self.frame.place()

    def follow_occluders(self) -> None:
        """Compile the depth filter in or out when opaque props appear or leave the scene."""
        wanted = frame_inputs(self.frame.renderer).has_opaque_props()
        if bool(self.recipe.defines.get("CM_OCCLUSION")) != wanted:
            self.recompile(resample_recipe(wanted))

    @property
    def lod(self) -> LodChoice:
        """The last frame's LOD choice (``S_ideal``, ``N``, ``S``, level, level size)."""
        return self.frame.lod

    @property
    def face_mask(self) -> int:
        """The last frame's visible-face mask (bit i: face i of +x, -x, +y, -y, +z, -z)."""
        return self.frame.face_mask

    @property
    def culled(self) -> bool:
        """Whether the last frame skipped the volume as outside the view frustum."""
        return self.frame.culled

    @property
    def memory(self) -> dict[str, int]:
        """GPU bytes by resource: cube map, cube depth map, light map, data and tables."""
        texels = self.cube_pass.allocated[0] * self.cube_pass.allocated[1] \
            if self.cube_pass.outputs else 0
        data = self.data.nbytes
        return {"cube_map": texels * self.cube_pass.target_nbytes(0),
                "cube_depth_map": texels * self.cube_pass.target_nbytes(1),
                "light_map": self.light_map.nbytes if self.light_map else 0, "data": data}

    @property
    def nbytes(self) -> int:
        """All GPU bytes the volume holds."""
        return sum(self.memory.values())


class PagedCubeMapBinding(Streamed, CubeMapBinding):
    """A multiscale volume's cube map: its rays read the brick pool."""


def _describe(setting: dict) -> str:
    parts = [f"face_size={setting.get('face_size', 256)}"]
    for key in ("max_samples", "upscale", "sample_factor"):
        if key in setting:
            parts.append(f"{key}={setting[key]:g}")
    return ", ".join(parts)


register_technique(Technique(
    name="cubemap", kind="volume", options=CubeMapOptions, build=build_cubemap_actor,
    reference=render_emission_absorption,
    sweep=Sweep([{"face_size": s} for s in (64, 128, 256, 512)]
                + [{"max_samples": n} for n in (32, 64, 256)]
                + [{"upscale": k} for k in (2.0, 4.0)]
                + [{"sample_factor": k} for k in (0.5, 2.0)], _describe),
    summary="one ray per texel of a cube map on the box's interior faces"))
