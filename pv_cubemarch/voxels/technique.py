"""Material grids on a box actor: Amanatides & Woo traversal in the fragment shader.

The box's back faces are drawn in the opaque pass; each fragment rebuilds its ray from the
near plane (camera-relative matrices made in double precision, so far grids stay exact),
traverses the grid in index space to the first drawn voxel, and writes its colour and the
hit's real depth: meshes and other techniques occlude and are occluded voxel-exactly. One
byte (or two, above 255 materials) per voxel on the GPU; the palette is a small table that
changes without touching the labels.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import numpy as np
import pyvista

from ..core.camera import Camera
from ..core.gl_limits import MAX_TEXTURE_SIZE
from ..core.registry import Technique, register_technique
from ..core.rendering import needs_open_plotter
from ..gl.bindings import ShaderBindings
from ..gl.box import bind_camera, box_actor, camera_matrices, drawing_reduced
from ..gl.face_depth import FaceDepthPass
from ..gl.handle import DrawnBinding
from ..gl.lights import bind_scene_lights
from ..gl.shaders import ShaderRecipe, box_recipe
from ..gl.textures import Texture
from ..models.voxel_levels import (
    atlas_layout,
    atlas_levels,
    bounds_in_cells,
    filled_bounds,
    level_atlas,
    occupancy_levels,
    safe_radii,
    useful_levels,
)
from ..models.voxel_shell import choose_shell
from ..models.voxels import VoxelModel, palette_texels
from ..reference.voxels import render_voxels, trace_voxels
from . import editing
from .clipping import ClipPlaneSetting, bind_clip_planes, clip_count
from .label_state import LabelState, upload_palette_rows
from .layers import LayerHost, TranslucentLayers
from .occluders import WorldOccluders
from .options import VoxelOptions, drawn_level
from .proxy import ShellStart


def voxel_recipe(options: VoxelOptions, shell_level: int | None = None,
                 level_axes: tuple[int, int] = (2, 0), occluders: bool = False,
                 chunk_shift: int | None = None, brick: bool = False) -> ShaderRecipe:
    """The box actor's replacements for the chosen traversal, mode, shading and occlusion.

    ``shell_level``: the occupancy level of the brick shell that starts the rays, if any;
    ``level_axes``: the level atlas's slab and row axes (:func:`atlas_layout`);
    ``occluders``: rays end at a world's solid faces (:mod:`.occluders`);
    ``chunk_shift``: a world drawn by one traversal, labels read through its chunk index
    (chunks of ``2^chunk_shift`` voxels, :mod:`pv_cubemarch.models.chunk_pool`).
    ``brick``: the grid is a brick of a larger one, traversed in its frame
    (:meth:`VoxelBinding.traverse_as_brick`).
    """
    traversal = "voxel_dda" if options.traversal == "dda" else "voxel_fixed"
    lit = options.mode == "color" and options.shading != "unlit"
    lod = bool(options.lod and options.mip_levels)
    skipping = (("voxel_mip",) if options.mip_levels else ()) + (
        ("voxel_distance",) if options.distance_field else ()) + (
        ("voxel_lod",) if lod else ())
    occlusion = options.mode == "color" and options.ambient_occlusion
    return box_recipe(
        ("camera_declarations", "slab", "pixel_ray", "voxel_declarations",
         *(("clip_planes",) if clip_count(options) else ()),
         *(("voxel_chunk_index",) if chunk_shift else ()), *skipping, traversal,
         *(("blinn_phong", "voxel_shading") if lit else ()),
         *(("voxel_occlusion",) if occlusion else ()),
         *(("voxel_edges",) if options.show_edges else ())), "voxel_fragment",
        defines={"CM_VOXEL_ID": options.mode == "id", "CM_VOXEL_FACE": options.mode == "face",
                 "CM_LIGHTING": lit,
                 "CM_MIP_LEVELS": options.mip_levels or None,
                 "CM_LEVEL_SLAB_AXIS": level_axes[0] if options.mip_levels else None,
                 "CM_LEVEL_ROW_AXIS": level_axes[1] if options.mip_levels else None,
                 "CM_SHELL_LEVEL": shell_level, "CM_LOD": lod, "CM_OCCLUDERS": occluders,
                 "CM_CHUNK_INDEX": chunk_shift, "CM_WHOLE_GRID": brick,
                 "CM_CLIP_PLANES": clip_count(options),
                 "CM_DISTANCE_FIELD": options.distance_field or None,
                 "CM_SPECULAR": lit and options.shading == "blinn", "CM_OCCLUSION": occlusion,
                 "CM_EDGES": options.show_edges,
                 "CM_EDGE_LABELS": options.show_edges and options.edge_mode == "labels"})


def bind_lights(bindings: ShaderBindings, renderer, model: VoxelModel,
                options: VoxelOptions) -> None:
    """The scene's lights (:func:`~pv_cubemarch.gl.lights.bind_scene_lights`) on a grid."""
    bind_scene_lights(bindings, renderer, model.world_from_index)
    bindings.set_uniform("cm_ambient", float(options.ambient))
    bindings.set_uniform("cm_diffuse", float(options.diffuse))
    bindings.set_uniform("cm_specular", float(options.specular))
    bindings.set_uniform("cm_specularPower", float(options.specular_power))


def label_scale(dtype) -> float:
    """What a label texel read is multiplied by to give its row back.

    8- and 16-bit rows are normalised textures (255, 65535); wider rows go up as float32
    (1), exact to 2^24.
    """
    dtype = np.dtype(dtype)
    return float(np.iinfo(dtype).max) if dtype.itemsize <= 2 else 1.0


def bind_grid(bindings: ShaderBindings, renderer, model, options: VoxelOptions) -> None:
    """The uniforms every traversal of a grid (or world) reads: sizes, camera, lights, LOD.

    ``model``: a placed grid or world (``dimensions``, ``world_from_index``, ``dtype``);
    the label scale is read at each draw, as a world's labels may widen to uint16.
    """
    bindings.set_uniform("cm_labelScale", lambda: label_scale(model.dtype))
    bindings.set_uniform("cm_gridDims", tuple(float(n) for n in model.dimensions))
    if options.traversal == "fixed":
        bindings.set_uniform("cm_voxelStep", options.step)
    bind_camera(bindings, renderer, model.world_from_index)
    if options.mode == "color" and options.shading != "unlit":
        bind_lights(bindings, renderer, model, options)
    if options.lod and options.mip_levels:
        bindings.set_uniform("cm_lodBias", float(options.lod_bias))
        bindings.set_uniform("cm_voxelSize", lambda: float(np.linalg.norm(
            model.world_from_index()[:3, :3], axis=0).max()))
    if options.mode == "color" and options.ambient_occlusion:
        bindings.set_uniform("cm_occlusionStrength", float(options.occlusion_strength))
    bindings.set_uniform("cm_near", lambda: renderer.GetActiveCamera().GetClippingRange()[0])
    if options.show_edges:
        bind_edges(bindings, renderer, model, options)


def bind_edges(bindings: ShaderBindings, renderer, model, options: VoxelOptions) -> None:
    """The edges' style and the index-to-clip matrix their window distances need."""
    color, half_width, opacity = options.edge_style
    def clip_from_texture():
        view, projection = camera_matrices(renderer)
        return projection @ view @ model.world_from_index()
    bindings.set_uniform("cm_clipFromTexture", clip_from_texture)
    bindings.set_uniform("cm_edgeColor", color)
    bindings.set_uniform("cm_edgeHalfWidth", half_width)
    bindings.set_uniform("cm_edgeOpacity", opacity)


def bind_labels(bindings: ShaderBindings, model: VoxelModel, options: VoxelOptions,
                levels: list[np.ndarray]) -> Texture:
    """Bind the labels, with their occupancy levels beside them when ``mip_levels`` asks.

    ``levels``: the grid's occupancy levels (at least ``options.mip_levels`` of them). With
    levels, ``cm_labels`` is their :class:`~pv_cubemarch.models.voxel_levels.LevelAtlas` (one fetch
    reads any level; with ``lod`` the levels hold representative labels); its host copy goes
    once uploaded and is remade from the labels, which the host keeps, only if a new window
    needs it. Without, it is the labels themselves.
    """
    labels, count, lod = model.labels, options.mip_levels, options.lod
    if not count:
        return bindings.add_texture("cm_labels", Texture(labels, kind="3d", interpolate=False))
    atlas = level_atlas(labels, atlas_levels(labels, count, lod) if lod else levels[:count])
    return bindings.add_texture(
        "cm_labels", Texture(atlas.texels, kind="3d", interpolate=False, rebuild=lambda:
                             level_atlas(labels, atlas_levels(labels, count, lod)).texels))


def bind_distance_field(bindings: ShaderBindings, model: VoxelModel,
                        options: VoxelOptions) -> list[Texture]:
    """Bind the neighbour distance field when ``distance_field`` asks; returns its texture.

    Any label counts as filled, so palette changes never rebuild it; its host copy goes once
    uploaded and is remade from the labels only if a new window needs it.
    """
    labels, radius = model.labels, options.distance_field
    if not radius:
        return []
    return [bindings.add_texture(
        "cm_safeRadius", Texture(safe_radii(labels, radius), kind="3d", interpolate=False,
                                 rebuild=lambda: safe_radii(labels, radius)), owned=True)]


@dataclass(frozen=True)
class VoxelPick:
    """What a pixel shows: its voxel, label id, entry face, depth and world point.

    ``label``: the id the user's labels hold there; ``material``: its row of the per-label
    tables (the id itself unless the ids were compacted). ``face``: ``2 * axis + 1`` when the
    ray entered moving +axis, ``2 * axis`` moving -axis, -1 when it starts inside the voxel;
    ``depth``: the distance along the ray.
    """

    index: tuple[int, int, int]
    material: int
    face: int
    depth: float
    point: tuple[float, float, float]
    label: int | None = None

    def __post_init__(self):
        if self.label is None:
            object.__setattr__(self, "label", self.material)


class VoxelBinding(LabelState, ClipPlaneSetting, LayerHost, DrawnBinding):
    """What ``actor.cubemarch`` holds for a material grid: model, textures, bindings."""

    follows_mapper_planes = True
    look_hint = ("each label's colour and opacity are the palette's: "
                 "actor.cubemarch.set_label_color(ids, color=..., opacity=...)")

    technique = "voxels"
    # Under multisampling, a few pixels on the box's triangle edges kept one sample of four
    # from the background (tests/test_voxel_scenes.py): the window draws single-sampled
    # while a grid is shown, as for the cube map.
    needs_single_sample = True

    def __init__(self, model: VoxelModel, bindings: ShaderBindings, recipe: ShaderRecipe,
                 labels: Texture, palette: Texture, options: VoxelOptions):
        super().__init__(model, bindings, recipe)
        self.labels = labels
        self.palette_texture = palette
        #: Whether the palette texture is this grid's own (a world's chunks share one).
        self.owns_palette = True
        self.options = options
        #: The distance field's texture, when used (the levels live in ``labels``).
        self.skipping: list[Texture] = []
        #: The brick shell whose depth pass starts the rays (``proxy='bricks'``).
        self.shell: ShellStart | None = None
        #: The level atlas's slab and row axes (where levels sit beside the labels).
        self.level_axes: tuple[int, int] = (2, 0)
        #: Index-space corners of the box the actor draws.
        self.drawn_bounds: tuple[np.ndarray, np.ndarray] | None = None
        #: Whether that box follows the filled voxels (edits grow it), or is the grid's.
        self.box_follows_voxels = False
        #: What :func:`voxel_recipe` takes besides the options (shell level, level axes,
        #: occluders, chunk shift, brick), to remake the shaders when the clip planes'
        #: number changes.
        self.recipe_args: tuple = (None, (2, 0), False)

    def traverse_as_brick(self, origin, whole_dims, whole_grid_from_index) -> None:
        """Traverse this grid as the brick at voxel ``origin`` of a grid of ``whole_dims``.

        Sort-last rendering draws each brick of a label grid in a plotter of its own. Its
        rays are traversed in the whole grid's index space (``whole_grid_from_index``, as
        the whole grid's plotter makes it) and through the voxels outside the brick as
        empty space: a ray meets the voxels the whole grid's ray meets, to the bit, so the
        nearest brick's first hit is the whole grid's (ids equal at grazing rays too).
        """
        refused = {"traversal='fixed'": self.options.traversal != "dda",
                   "lod": self.options.lod, "show_edges": self.options.show_edges,
                   "ambient_occlusion": self.options.ambient_occlusion,
                   "clip_planes": bool(self.options.world_planes)}
        if any(refused.values()):
            raise ValueError(f"a brick of a split grid is drawn without "
                             f"{', '.join(k for k, v in refused.items() if v)}: each reads "
                             "or decides beyond the brick; leave them out.")
        whole_grid_from_index = np.asarray(whole_grid_from_index, dtype=np.float64)
        self.recipe_args = (*self.recipe_args[:3], None, True)
        self.recipe = voxel_recipe(self.options, *self.recipe_args)
        self.bindings.install(self.recipe, self.drawn[0])
        self.bindings.set_uniform("cm_wholeDims", tuple(float(n) for n in whole_dims))
        self.bindings.set_uniform("cm_brickOrigin", tuple(float(n) for n in origin))
        bind_camera(self.bindings, self.renderer, lambda: np.asarray(
            self.model.transform, dtype=np.float64) @ whole_grid_from_index)

    def follow_clip_planes(self, remake: bool) -> None:
        """Remake the shaders (and the translucent layers') for another number of planes."""
        if remake:
            self.recipe = voxel_recipe(self.options, *self.recipe_args)
            self.bindings.install(self.recipe, self.drawn[0])   # a chunk's, not its world's
            if self.layers is not None:
                self.layers.follow_clip_planes(self.options, self)

    @property
    def palette(self):
        """The grid's :class:`~pv_cubemarch.models.voxels.Palette`."""
        return self.model.palette

    @property
    def nbytes(self) -> int:
        """GPU bytes: labels (with levels), palette, distance field, shell and its pass."""
        return (self.labels.nbytes + (self.palette_texture.nbytes if self.owns_palette else 0)
                + sum(t.nbytes for t in self.skipping)
                + (self.shell.nbytes if self.shell is not None else 0)
                + (self.layers.nbytes if self.layers is not None else 0))

    @property
    def uploaded_bytes(self) -> int:
        """Bytes of labels, levels and distance field sent to the GPU so far."""
        return sum(t.uploaded_bytes for t in (self.labels, *self.skipping))

    @property
    def derived_textures(self) -> list[Texture]:
        """Textures made from the labels (level atlas, distance field).

        Their host copies go once uploaded and are remade from the labels if a new window
        needs them.
        """
        return [t for t in (self.labels, *self.skipping) if t.rebuild is not None]

    @needs_open_plotter
    def set_material(self, material: int, color=None, opacity: float | None = None) -> None:
        """Change a material's colour and/or opacity (0 hides it); the labels stay uploaded.

        Only the palette, a few bytes per material, goes to the GPU again.
        """
        self.model.palette.set_color(self.material_row(material), color, opacity)
        self.follow_palette()

    def follow_palette_rows(self) -> None:
        """The rows the palette says changed go to the GPU (:class:`LabelState`)."""
        self.follow_palette()

    def follow_palette(self, whole: bool = False) -> None:
        """The palette changed: the opaque actor's copy, and the translucent layers.

        Only the changed entries go up (the whole table with ``whole``). The layer actor
        is made when a material first turns translucent and goes when none is left.
        """
        rows = self.model.palette.take_changes()
        rows = None if whole else rows
        rgba = self.model.palette.rgba
        upload_palette_rows(self.palette_texture, self.opaque_entries(rgba), rows)
        self.say_drawn_opaque()
        if self.follow_layers(rgba, rows):
            extras = [name for name in ("show_edges", "ambient_occlusion")
                      if getattr(self.options, name)]
            if extras:
                warnings.warn(f"Voxels {self.model.name!r}: {' and '.join(extras)} "
                              f"{'is' if len(extras) == 1 else 'are'} drawn on the opaque "
                              "materials only; the translucent ones are plain faces.",
                              stacklevel=3)

    def make_layers(self) -> TranslucentLayers:
        """The layer actor of this grid (:class:`LayerHost`)."""
        return TranslucentLayers(self, self.renderer, bind_grid)

    def follow_anchor(self) -> None:
        """At each frame: drawn actors, layers and clipping planes follow the returned one."""
        super().follow_anchor()
        self.follow_layers_anchor()

    def place(self, transform) -> None:
        """The box, the brick shell and the translucent layers follow the grid."""
        if self.shell is not None:
            self.shell.place()
        super().place(transform)
        if self.layers is not None:
            self.layers.place()

    @needs_open_plotter
    def set_voxels(self, where, material: int) -> None:
        """Set voxels to ``material`` (0 empties them); shown at the next frame.

        ``where``: an ``(i, j, k)`` index, a tuple of three slices, or a boolean mask of
        the grid's shape. Only the touched box of the labels, the occupancy cells above
        it and the distance field around it are uploaded (sub-texture uploads).

        Examples
        --------
        >>> actor.cubemarch.set_voxels((3, 4, 5), 2)                    # doctest: +SKIP
        >>> actor.cubemarch.set_voxels(np.s_[0:8, 0:8, 10:12], 0)      # doctest: +SKIP
        """
        editing.set_voxels(self, where, material)

    @needs_open_plotter
    def fill_sphere(self, center, radius: float, material: int) -> None:
        """Set the voxels whose centre is within ``radius`` of ``center`` (index space)."""
        editing.fill_sphere(self, center, radius, material)

    @needs_open_plotter
    def fill_box(self, lower, upper, material: int) -> None:
        """Set the voxels ``lower <= (i, j, k) < upper`` to ``material``."""
        editing.fill_box(self, lower, upper, material)

    @needs_open_plotter
    def set_block(self, where, values) -> None:
        """Write the labels ``values`` into the box ``where`` (a tuple of three slices).

        For a region of many materials at once, e.g. the box an automaton step changed.
        """
        editing.set_block(self, where, values)

    @needs_open_plotter
    def set_values(self, labels) -> None:
        """Replace every label (same shape; values within the palette); uploaded whole."""
        editing.set_values(self, labels)

    @needs_open_plotter
    def pick(self, x: int, y: int) -> VoxelPick | None:
        """The voxel under pixel ``(x, y)``, or ``None`` where the grid shows nothing.

        ``x``, ``y`` count from the top-left, as image arrays index. Computed as the image
        is (the exact traversal with the renderer's camera, near plane and palette), so it
        returns what is drawn.
        """
        renderer = self.main_renderer or self.renderer
        width, height = renderer.GetSize()
        if not (0 <= int(x) < width and 0 <= int(y) < height):
            raise ValueError(f"(x, y) must be a pixel of the {width}x{height} renderer, got "
                             f"({x}, {y}).")
        camera = Camera.from_pyvista(renderer.GetActiveCamera())
        hits = trace_voxels(self.model.labels, self.model.world_from_index(), camera,
                            (width, height), near=camera.clipping_range[0],
                            visible=self.model.palette.visible, crop=(int(x), int(y), 1, 1),
                            clip_planes=self.options.world_planes)
        if hits.material[0, 0] == 0:
            return None
        origins, directions = camera.rays((width, height))
        depth = float(hits.depth[0, 0])
        point = origins[int(y), int(x)] + directions[int(y), int(x)] * depth
        row = int(hits.material[0, 0])
        return VoxelPick(tuple(int(v) for v in hits.index[0, 0]), row,
                         int(hits.face[0, 0]), depth, tuple(float(v) for v in point),
                         self.model.ids.id_of(row))

    def release_resources(self) -> None:
        """The bindings, the brick shell, the layers and the label and palette textures."""
        super().release_resources()
        if self.shell is not None:
            self.shell.release()
        for actor in self.drawn:   # a world's chunk: its actor stands behind the world's
            if actor is not self.actor and self.renderer is not None:
                self.renderer.RemoveActor(actor)
        self.release_layers()
        self.labels.release()
        if self.owns_palette:
            self.palette_texture.release()


def build_voxel_actor(plotter, model: VoxelModel, options: VoxelOptions,
                      shared_depth: FaceDepthPass | None = None,
                      occluders: WorldOccluders | None = None,
                      palette_texture: Texture | None = None) -> VoxelBinding:
    """The opaque box actor of a material grid; returns its binding.

    ``shared_depth``: a brick-shell depth pass shared with other grids (a world's chunks);
    ``occluders``: the solid faces of the world the grid is a chunk of, where rays end;
    ``palette_texture``: a palette shared with other grids (a world's chunks: one table of
    every id, kept current by the world, not one per chunk).
    """
    renderer = plotter.renderer
    levels = occupancy_levels(model.labels, options.candidate_levels(model.dimensions))
    chosen_levels = options.mip_levels is not None
    options = options.for_grid(useful_levels(levels), len(levels))
    layout = atlas_layout(model.dimensions, options.mip_levels)
    if layout is None and chosen_levels:
        raise ValueError(f"mip_levels={options.mip_levels} on a grid of {model.dimensions} "
                         f"voxels needs a texture over {MAX_TEXTURE_SIZE} texels on a side; "
                         "use mip_levels=0 or fewer levels.")
    if layout is None:   # the default levels do not fit beside the labels: draw without
        options = replace(options, mip_levels=0)
        layout = atlas_layout(model.dimensions, 0)
    # 1 % larger on every side: the shader clips each ray to the exact grid box, so pixels
    # whose rays graze the box's edges are covered and decided there, not by rasterisation.
    # With the brick shell, rays meet filled voxels only inside the box around its bricks.
    # With level of detail a coarse cell reaches past the shell's bricks: rays started at
    # the shell missed its near part (2 pixels wrong on a parallel view), so they start at
    # the box around the coarse cells instead.
    bricks = choose_shell(model.labels, levels) \
        if options.proxy == "bricks" and not drawn_level(options) else None
    shell = ShellStart(model, renderer, bricks, shared_depth) if bricks is not None else None
    if options.proxy == "box" and occluders is None:
        lower, upper = np.zeros(3), np.asarray(model.dimensions, dtype=np.float64)
    elif shell is None:   # the box around the voxels (a world's chunk: less overdraw)
        # With level of detail, whole cells of the coarsest level: a coarse cell reaches past
        # its voxels, and a box cut at them would cut its silhouette (seen: 54 pixels).
        lower, upper = bounds_in_cells(filled_bounds(model.labels), drawn_level(options),
                                       model.dimensions)
    else:   # the filled voxels' own box (the shell's bricks reach past it): the returned
        # actor's bounds are then threshold's mesh's, and no voxel lies outside it
        lower, upper = filled_bounds(model.labels)
    actor = box_actor(upper, model.world_from_index(), margin=0.01 * max(model.dimensions),
                      lower=lower)
    actor.ForceTranslucentOff()
    actor.ForceOpaqueOn()
    actor.GetProperty().LightingOff()   # VTK's lighting code would run for nothing
    palette = palette_texture or Texture(palette_texels(model.palette.rgba), kind="2d",
                                         interpolate=False)
    bindings = ShaderBindings(actor.GetMapper(), renderer)
    labels = bind_labels(bindings, model, options, levels)
    bindings.add_texture("cm_palette", palette)
    skipping = bind_distance_field(bindings, model, options)
    bind_grid(bindings, renderer, model, options)
    if shell is not None:
        bindings.add_texture("cm_shellDepth", shell.depth)
        # a reduced draw's rays start at the box: the shell's depth is the full viewport's
        bindings.set_uniform("cm_startAtProxy",
                             lambda: 0.0 if drawing_reduced() else shell.start_at_shell)
    if occluders is not None:
        bindings.add_texture("cm_occluderDepth", occluders.depth)
        # a reduced draw's rays run on: the occluders' depth is the full viewport's
        bindings.set_uniform("cm_useOccluders",
                             lambda: 0.0 if drawing_reduced() else occluders.use)
    recipe_args = (shell.level if shell is not None else None, layout[:2], occluders is not None)
    recipe = voxel_recipe(options, *recipe_args)
    bindings.install(recipe, actor)
    binding = VoxelBinding(model, bindings, recipe, labels, palette, options)
    binding.recipe_args = recipe_args
    # the planes as the binding holds them now (set_clip_planes moves them)
    bind_clip_planes(bindings, model, lambda: binding.options.world_planes)
    binding.skipping = skipping
    binding.shell = shell
    if shell is not None:
        shell.shown = lambda: binding.shown
    binding.level_axes = layout[:2]
    binding.drawn_bounds = (lower, upper)
    binding.box_follows_voxels = options.proxy == "bricks" or occluders is not None
    binding.drawn = [actor]
    binding.renderer = renderer
    # A single grid in colour composites its translucent materials (a world's chunks, the
    # id and face modes and level of detail draw them opaque: add_voxels warns).
    binding.composites = shared_depth is None and occluders is None and \
        options.mode == "color" and not (options.lod and options.mip_levels)
    binding.owns_palette = palette_texture is None
    if binding.owns_palette:
        binding.follow_palette(whole=True)
    pyvista.set_new_attribute(actor, "cubemarch", binding)
    return binding


register_technique(Technique(
    name="voxels", kind="voxels", options=VoxelOptions, build=build_voxel_actor,
    reference=render_voxels,
    summary="a material grid drawn exactly by Amanatides & Woo traversal"))
