"""Emission/absorption ray casting (004) injected into VTK's GPU volume mapper.

VTK's ``vtkOpenGLGPUVolumeRayCastMapper`` sets up the ray (entry at the box or the near
plane, exit at the box or the opaque depth) and steps it; we replace its per-sample work
with front-to-back emission/absorption compositing from our own transfer table, with the
exponential opacity correction for the real segment length and early ray termination.
"""

from __future__ import annotations

import numpy as np
import pyvista
import vtk

from .gl_resources import ShaderBindings, Texture
from .shaders import Replacement, ShaderRecipe
from .skipping import DEFAULT_BRICK_SIZE, brick_extinction
from .volume import VolumeModel, make_volume

#: Default early-termination opacity (VTK's own loop also stops above 1 - 1/255).
DEFAULT_STOP_OPACITY = 0.99


#: Loop bound of the marcher: thousands of steps per ray are allowed, never an endless loop.
MAX_STEPS = 16384
TECHNIQUES = ("vtk", "direct", "cubemap", "auto")


def march_defines(model: VolumeModel, skip_empty: bool, light_map=None) -> dict:
    """The feature switches every marching shader of ``model`` needs."""
    defines = {"CM_TABLE_SIZE": model.transfer.n_colors, "CM_MAX_STEPS": MAX_STEPS,
               "CM_SKIP_EMPTY": bool(skip_empty)}
    if light_map is not None:
        defines.update(light_map.defines)
    return defines


def vtk_mapper_recipe(model: VolumeModel, skip_empty: bool, light_map=None) -> ShaderRecipe:
    """The shader replacements of the VTK-mapper path."""
    lit = ("light_sample",) if light_map is not None else ()
    return ShaderRecipe(
        replacements=[
            Replacement("//VTK::Base::Dec", "ea_declarations", keep_tag="after"),
            Replacement("//VTK::ComputeColor::Dec", ("ea_vtk_declarations", "ea_march", *lit),
                        keep_tag="after"),
            Replacement("//VTK::Shading::Init", "ea_vtk_ray_init"),
        ],
        defines=march_defines(model, skip_empty, light_map),
    )


def world_from_texture(model: VolumeModel) -> np.ndarray:
    """4x4 from texture coordinates (texel centres on the grid points) to world."""
    dims = np.array(model.dimensions, dtype=np.float64)
    index_from_texture = np.eye(4)
    index_from_texture[:3, :3] = np.diag(dims)
    index_from_texture[:3, 3] = -0.5
    return model.world_from_index() @ index_from_texture


def bind_march(bindings: ShaderBindings, model: VolumeModel, step_scale: float,
               stop_opacity: float, skip_empty: bool) -> bool:
    """Give ``bindings`` what the shared marcher reads; return whether skipping is on.

    Skipping is switched off (and its texture never made) when no brick is empty.
    """
    table = model.transfer.table.reshape(1, -1, 4)
    bindings.add_texture("cm_transferTable", Texture(table, kind="2d", interpolate=True))
    bindings.set_uniform("cm_clim", model.transfer.clim)
    bindings.set_uniform("cm_stopOpacity", stop_opacity)
    bindings.set_uniform("cm_dims", tuple(float(n) for n in model.dimensions))
    bindings.set_uniform("cm_stepScale", step_scale)
    bindings.set_uniform("cm_worldFromTexture", lambda: world_from_texture(model))
    if not skip_empty or getattr(model, "values", None) is None:
        return False
    bricks = brick_extinction(model.values, model.transfer, DEFAULT_BRICK_SIZE)
    if not (bricks <= 0).any():
        return False
    bindings.add_texture("cm_brickExtinction", Texture(bricks, kind="3d", interpolate=False))
    bindings.set_uniform("cm_brickCount", tuple(float(n) for n in bricks.shape))
    bindings.set_uniform("cm_brickSize", float(DEFAULT_BRICK_SIZE))
    return True


def bind_sampling(target, model, volume_texture, step_scale: float, stop_opacity: float,
                  skip_empty: bool) -> tuple[str, dict]:
    """Bind what a marching shader samples: one volume, or the members of a joint group.

    Returns the GLSL snippet that provides the sampling (``volume_sample`` or
    ``joint_sample``) and the feature switches it needs.
    """
    from .multi_volume import VolumeGroup

    if isinstance(model, VolumeGroup):
        bind_march(target, model, step_scale, stop_opacity, skip_empty=False)
        model.bind(target)
        return "joint_sample", dict(march_defines(model, False), **model.defines)
    skipping = bind_march(target, model, step_scale, stop_opacity, skip_empty)
    target.add_texture("cm_volume", volume_texture)
    return "volume_sample", march_defines(model, skipping)


def world_voxel_size(volume: VolumeModel) -> float:
    """The smallest edge of a voxel in world units."""
    lengths = np.linalg.norm(volume.world_from_index()[:3, :3], axis=0)
    return float(lengths.min())


def add_volume(
    plotter: pyvista.Plotter,
    volume,
    scalars: str | None = None,
    *,
    cmap="magma",
    opacity="linear",
    clim=None,
    opacity_unit_distance: float | None = None,
    technique: str = "vtk",
    step_scale: float = 0.5,
    stop_opacity: float = DEFAULT_STOP_OPACITY,
    skip_empty: bool = True,
    downsample: int = 1,
    face_size: int = 256,
    max_samples: int | None = None,
    upscale: float = 1.0,
    sample_factor: float = 1.0,
    occlusion_sharpness: float = 0.5,
    lights=None,
    light_map_size: int = 32,
    ambient: float = 0.2,
    transform=None,
    nan_policy: str = "raise",
    name: str | None = None,
) -> pyvista.Volume:
    """Add a volume rendered with emission/absorption compositing; return its actor.

    Parameters
    ----------
    plotter : pyvista.Plotter
        The plotter to draw in.
    volume : pyvista.ImageData, numpy.ndarray, VolumeModel or VolumeGroup
        Scalars on a uniform grid (a numpy array is indexed x, y, z with unit spacing), a
        :class:`VolumeModel` that already carries its transfer function and placement, or a
        :class:`VolumeGroup` of overlapping volumes marched jointly (see :func:`add_volumes`).
    scalars : str, optional
        Name of the point (or cell) array to draw; the active scalars by default.
    cmap : str or sequence
        Matplotlib colormap for the emitted colour.
    opacity : str, float or sequence of float
        PyVista opacity preset or values over ``clim``: the fraction absorbed over
        ``opacity_unit_distance``.
    clim : sequence of float, optional
        Scalar range of the transfer function; the data range by default.
    opacity_unit_distance : float, optional
        World length that ``opacity`` refers to; the mean grid spacing by default.
    technique : str
        ``'vtk'``: marched inside VTK's GPU volume mapper (it sets up the ray). ``'direct'``:
        the direct screen-space marcher on a box actor, one ray per pixel. ``'cubemap'``:
        one ray per texel of a cube map on the box's interior faces, resampled on screen,
        so the cost stops growing with the viewport's resolution (000). ``'auto'``: each
        frame, the cube map when its visible texels are fewer than the volume's projected
        pixels, else the direct marcher (000 section 3.4; ``actor.cubemarch.force`` pins
        one, ``actor.cubemarch.choice`` tells which was drawn). All run the same marching
        GLSL.
    step_scale : float
        ``'vtk'`` and ``'direct'``: step length in texels along the ray's dominant texture
        axis (texel-spaced sampling). Smaller is more accurate and slower (cost grows as
        ``1 / step_scale``). ``'cubemap'`` sets its step from ``max_samples`` instead.
    stop_opacity : float
        Early ray termination: stop once the accumulated opacity exceeds this (in (0, 1]).
    skip_empty : bool
        Step over 8^3 bricks whose values map to zero extinction. Exact (it skips only what
        adds nothing); costs one small texture, and is left out when no brick is empty.
    downsample : int
        ``technique='direct'`` only: march at 1/downsample of the viewport resolution in each
        direction (1, 2, 4 ...) and upsample with a depth-aware filter, so edges against
        meshes stay sharp. Cost falls about as ``1 / downsample**2``.
    face_size : int
        ``'cubemap'``: the largest cube-map face, in texels per edge (a power of two, the
        size at MIP level 0). Caps the marching cost at ``6 * face_size**2`` rays; a
        volume far away uses a smaller level. Larger is sharper when the volume fills a
        big viewport.
    max_samples : int, optional
        ``'cubemap'``: most samples along a ray crossing the whole box diagonally; shorter
        rays take proportionally fewer. Cost grows linearly with it. By default two per
        texel of the grid's longest axis (the ``step_scale=0.5`` of the other techniques).
    upscale : float
        ``'cubemap'``: screen pixels per cube-map texel the LOD aims at (``k_u``): 2 marches
        a quarter of the texels for a softer image.
    sample_factor : float
        ``'cubemap'``: samples per cube-map texel along the box diagonal (``k_c``). The
        LOD asks for ``k_c`` times the face's texels, capped by ``max_samples``, then sizes
        the face from the samples it got (``S = sqrt(3) N / k_c``, 000 section 3.3): above
        1, fewer texels and finer steps; below 1, more texels and coarser steps.
    occlusion_sharpness : float
        ``'cubemap'``: ``k_z`` of the bilateral depth filter against opaque meshes: a cube
        texel stops counting for a pixel once their ray ends differ by ``1/k_z`` cube-map
        texels. 0 is plain bilinear filtering (halos at mesh edges).
    lights : None, 'scene', pyvista.Light or list of them
        Light the medium: each sample's colour is scaled by ``ambient + (1 - ambient) *
        sum(colour * intensity * transmittance toward the light)``, the transmittances kept
        in a light map recomputed only when a light, the placement or the data change.
        ``'scene'`` takes the plotter's switched-on lights; at most 4. ``None``: unlit
        (the light-map pass does not exist).
    light_map_size : int
        Light-map points per axis (2 to 128): finer shadows for ``light_map_size**3 * 16``
        bytes and a longer light pass.
    ambient : float
        Share of the emission no light modulates, in [0, 1] (with ``lights``).
    transform : array_like, optional
        4x4 matrix placing the grid in the world.
    nan_policy : str
        ``'raise'`` (default) for NaN/Inf in the data, or ``'zero'`` to draw them as 0.
    name : str, optional
        Actor name in the plotter (replaces an actor of the same name).

    Returns
    -------
    pyvista.Volume
        The volume actor; ``actor.cubemarch`` holds the bindings and the model.

    Examples
    --------
    >>> import numpy as np, pyvista as pv, pv_cubemarch
    >>> x, y, z = np.mgrid[-1:1:32j, -1:1:32j, -1:1:32j]
    >>> density = np.exp(-4 * (x**2 + y**2 + z**2))
    >>> pl = pv.Plotter(off_screen=True)
    >>> actor = pv_cubemarch.add_volume(pl, density, cmap="inferno", step_scale=0.5)
    >>> image = pv_cubemarch.render_image(pl)  # doctest: +SKIP
    """
    if not 0 < float(step_scale) <= 1e3 or not np.isfinite(step_scale):
        raise ValueError(f"step_scale must be a positive number, got {step_scale}.")
    if not 0 < float(stop_opacity) <= 1:
        raise ValueError(f"stop_opacity must be in (0, 1], got {stop_opacity}.")
    if technique not in TECHNIQUES:
        raise ValueError(f"technique must be one of {TECHNIQUES}, got {technique!r}.")
    if int(downsample) != downsample or downsample < 1:
        raise ValueError(f"downsample must be a whole number >= 1, got {downsample}.")
    if downsample > 1 and technique != "direct":
        raise ValueError("downsample > 1 needs technique='direct' (VTK's mapper marches at "
                         "full resolution; the cube map sets its own resolution).")
    from .cubemap import CubeMapOptions
    from .lighting import LightMap, check_light_options, light_source

    options = CubeMapOptions(face_size, max_samples, upscale, sample_factor,
                             occlusion_sharpness)
    options.check()
    check_light_options(light_map_size, ambient)
    from .multi_volume import VolumeGroup

    if isinstance(volume, (VolumeModel, VolumeGroup)):
        model = volume
    else:
        model = make_volume(volume, scalars, cmap=cmap, opacity=opacity, clim=clim,
                            opacity_unit_distance=opacity_unit_distance, transform=transform,
                            nan_policy=nan_policy, name=name or "volume")
    component = plotter.cubemarch  # created now so its close hook frees our GPU resources
    source = light_source(lights, plotter.renderer)
    group = isinstance(model, VolumeGroup)
    if group and technique == "vtk":
        raise ValueError("technique='vtk' cannot march overlapping volumes jointly; use "
                         "'direct', 'cubemap' or 'auto' (pv_cubemarch.add_volumes does).")
    volume_texture = None if group else Texture(model.values, kind="3d", interpolate=True)
    light_map = None if source is None else LightMap(
        plotter.renderer, model, source, volume_texture, int(light_map_size), float(ambient))
    if technique == "direct":
        from .direct_march import build_direct_actor

        actor = build_direct_actor(plotter, model, float(step_scale), float(stop_opacity),
                                   bool(skip_empty), int(downsample), light_map, volume_texture)
    elif technique == "cubemap":
        from .cubemap import build_cubemap_actor

        actor = build_cubemap_actor(plotter, model, options, float(stop_opacity),
                                    bool(skip_empty), light_map, volume_texture)
    elif technique == "auto":
        from .multi_volume import build_auto_actor

        actor = build_auto_actor(plotter, model, options, float(step_scale),
                                 float(stop_opacity), bool(skip_empty), light_map,
                                 volume_texture)
    else:
        actor = _build_actor(plotter, model, float(step_scale), float(stop_opacity),
                             bool(skip_empty), light_map)
    actor.cubemarch.light_map = light_map
    target = getattr(actor.cubemarch, "renderer", None)
    if technique == "auto":
        from .overlay import bounds_proxy

        plotter.add_actor(actor, name=name or model.name, reset_camera=False)
        proxy = bounds_proxy(model)  # the direct box is hidden on cube-map frames
        plotter.renderer.AddActor(proxy)
        actor.cubemarch.bounds_proxy = proxy
        actor.cubemarch.extra_release.append(lambda: plotter.renderer.RemoveActor(proxy))
    elif target is not None and target is not plotter.renderer:
        target.AddActor(actor)  # drawn by the overlay renderer, after the scene
        from .overlay import bounds_proxy

        # The plotter's renderer frames the camera and its clipping range from its own props.
        proxy = bounds_proxy(model)
        plotter.renderer.AddActor(proxy)
        actor.cubemarch.bounds_proxy = proxy
        actor.cubemarch.extra_release.append(lambda: plotter.renderer.RemoveActor(proxy))
    else:
        plotter.add_actor(actor, name=name or model.name, reset_camera=False)
    actor.cubemarch.actor = actor
    actor.cubemarch.main_renderer = plotter.renderer
    component.track(actor.cubemarch)
    if not plotter.camera_set:
        plotter.reset_camera()
    else:
        plotter.renderer.ResetCameraClippingRange()  # the near/far planes take the box in
    return actor


class VolumeBinding:
    """What we keep per volume actor: the model, the shader bindings, the settings."""

    def __init__(self, model: VolumeModel, bindings: ShaderBindings, recipe: ShaderRecipe,
                 step_scale: float, stop_opacity: float):
        self.model = model
        self.bindings = bindings
        self.recipe = recipe
        self.step_scale = step_scale
        self.stop_opacity = stop_opacity
        self.actor = None
        self.vtk_input: pyvista.ImageData | None = None
        self.extra_release: list = []
        self.targets: list = [bindings]
        self.downsample = 1
        self.light_map = None
        self._brick_rebuilds = 0

    @property
    def skips_empty(self) -> bool:
        """Whether the marching shaders step over empty bricks (a brick texture is bound)."""
        return bool(self._textures("cm_brickExtinction"))

    @property
    def brick_builds(self) -> int:
        """How many times the empty-space bricks were built (once at add, once per data change)."""
        return int(self.skips_empty) + self._brick_rebuilds

    @property
    def name(self) -> str:
        """The volume's name."""
        return self.model.name

    @property
    def nbytes(self) -> int:
        """GPU bytes we added (VTK owns the volume texture of its mapper path)."""
        return self.bindings.nbytes + (self.light_map.nbytes if self.light_map else 0)

    def release(self) -> None:
        """Free our GPU resources and observers (and any pass or overlay renderer)."""
        self.bindings.release()
        for release in self.extra_release:
            release()
        self.extra_release = []
        if self.light_map is not None:
            self.light_map.release()

    def set_transform(self, transform) -> None:
        """Move the volume: ``transform`` is its new 4x4 placement in the world.

        The actor follows at once and the light map is marched again at the next frame;
        nothing is uploaded again. Volumes marched jointly cannot move one by one.
        """
        from .volume import checked_transform

        if hasattr(self.model, "members"):
            raise ValueError("Volumes marched jointly cannot move one by one; add them again "
                             "with their new transforms (pv_cubemarch.add_volumes).")
        self.model.transform = checked_transform(transform)
        if self.actor is not None:
            # VTK's mapper places its grid (origin, spacing) itself; a box spans index space.
            placement = self.model.transform if self.vtk_input is not None \
                else self.model.world_from_index()
            matrix = vtk.vtkMatrix4x4()
            matrix.DeepCopy(np.ascontiguousarray(placement).ravel().tolist())
            self.actor.SetUserMatrix(matrix)
        follow_placement(self)

    def _textures(self, name: str) -> list:
        return [t.textures[name] for t in self.targets if name in t.textures]

    def set_values(self, values, member: str | None = None) -> None:
        """Replace the volume's data (same shape); its GPU copy and skip bricks follow.

        The empty-space bricks are rebuilt here, once per change of the data, never per frame.
        For volumes marched jointly (a :class:`~pv_cubemarch.VolumeGroup`), ``member`` names
        the one whose data changes.
        """
        from .volume import _checked_values

        if hasattr(self.model, "members"):
            self.model.set_member_values(member, values)
            if self.light_map is not None:
                self.light_map.invalidate()
            return
        if member is not None:
            raise ValueError(f"member is for volumes marched jointly; {self.model.name!r} is "
                             "a single volume.")
        values = _checked_values(np.asarray(values), self.model.name, "raise")
        if values.shape != self.model.values.shape:
            raise ValueError(f"values must keep the volume's shape {self.model.values.shape}, "
                             f"got {values.shape}.")
        self.model.values = np.ascontiguousarray(values, dtype=np.float32)
        for texture in self._textures("cm_volume"):
            texture.set_data(self.model.values)
        if self.vtk_input is not None:
            self.vtk_input.point_data["scalars"] = self.model.values.ravel(order="F")
            self.vtk_input.Modified()
        bricks = self._textures("cm_brickExtinction")
        if bricks:
            rebuilt = brick_extinction(self.model.values, self.model.transfer,
                                       DEFAULT_BRICK_SIZE)
            for texture in bricks:
                texture.set_data(rebuilt)
            self._brick_rebuilds += 1
        if self.light_map is not None:
            self.light_map.invalidate()


def follow_placement(binding) -> None:
    """After a volume moved: its bounds proxy and the plotter's clipping range follow."""
    from .overlay import place_bounds_proxy

    if getattr(binding, "bounds_proxy", None) is not None:
        place_bounds_proxy(binding.bounds_proxy, binding.model)
    if getattr(binding, "main_renderer", None) is not None:
        binding.main_renderer.ResetCameraClippingRange()


def _build_actor(plotter, model: VolumeModel, step_scale: float, stop_opacity: float,
                 skip_empty: bool, light_map=None):
    grid = pyvista.ImageData(dimensions=model.dimensions, spacing=model.grid.spacing,
                             origin=model.grid.origin)
    grid.direction_matrix = model.grid.direction_matrix
    grid.point_data["scalars"] = model.values.ravel(order="F")
    mapper = vtk.vtkOpenGLGPUVolumeRayCastMapper()
    mapper.SetInputData(grid)
    mapper.SetBlendModeToComposite()
    mapper.SetAutoAdjustSampleDistances(False)
    mapper.SetLockSampleDistanceToInputSpacing(False)
    mapper.SetUseJittering(False)
    mapper.SetSampleDistance(step_scale * float(np.min(model.grid.spacing)))
    prop = vtk.vtkVolumeProperty()
    prop.SetInterpolationTypeToLinear()
    prop.ShadeOff()
    actor = pyvista.Volume()
    actor.SetMapper(mapper)
    actor.SetProperty(prop)
    matrix = vtk.vtkMatrix4x4()
    matrix.DeepCopy(np.asarray(model.transform, dtype=np.float64).ravel().tolist())
    actor.SetUserMatrix(matrix)
    bindings = ShaderBindings(mapper, plotter.renderer)
    skipping = bind_march(bindings, model, step_scale, stop_opacity, skip_empty)
    recipe = vtk_mapper_recipe(model, skipping, light_map)
    if light_map is not None:
        light_map.bind(bindings)
    bindings.recipe = recipe
    recipe.apply(actor.GetShaderProperty())
    binding = VolumeBinding(model, bindings, recipe, step_scale, stop_opacity)
    binding.vtk_input = grid
    pyvista.set_new_attribute(actor, "cubemarch", binding)
    return actor
