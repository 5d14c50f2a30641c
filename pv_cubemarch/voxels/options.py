"""The options of the voxel technique, validated in one place."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pyvista

from ..core.declared import (
    AUTO,
    Control,
    Option,
    blinn_terms,
    check_declared,
    declare,
    option,
    preset_or_number,
    scalar_bar_terms,
)
from ..core.gl_limits import MAX_TEXTURE_SIZE
from ..core.options import positive_number
from ..volume.clipping import clip_plane_list, plane_pairs

TRAVERSALS = ("dda", "fixed")
MODES = ("color", "id", "face")
SHADINGS = ("unlit", "flat", "blinn")
PROXIES = ("bricks", "box")
WORLD_TRAVERSALS = ("index", "per_chunk")
EDGE_MODES = ("voxels", "labels")
#: Most occupancy mipmap levels (cells of 2^12 voxels cover any grid a texture holds).
MAX_MIP_LEVELS = 12
#: Fewest levels of detail a grid gets with ``lod`` (cells up to 8 voxels wide), where
#: fewer levels would pay off for skipping alone.
LOD_LEVELS = 3
#: Largest radius of the neighbour distance field (1..3: 8, 124, 342 neighbours).
MAX_DISTANCE_FIELD = 3


DDA = ("voxels",)
#: Why the keywords of multiscale label sources have no CLI flag, USD attribute or knob yet.
PAGED_LABELS_ONLY = dict.fromkeys(
    ("usd", "knob"), "read only for a multiscale label source (an OME-Zarr pyramid, a list "
    "of levels) given to add_voxels or to pv-cubemarch render --technique voxels; USD and "
    "the live view's knobs read their grids whole")
#: Every option of the voxel technique, declared once (:mod:`pv_cubemarch.core.declared`).
(TRAVERSAL, VOXEL_STEP_SCALE, MIP_LEVELS, DISTANCE_FIELD, MODE, SHADING, AMBIENT, DIFFUSE,
 SPECULAR, SPECULAR_POWER, AMBIENT_OCCLUSION, OCCLUSION_STRENGTH, PROXY, LOD, LOD_BIAS,
 WORLD_TRAVERSAL, SHOW_EDGES, EDGE_COLOR, LINE_WIDTH, EDGE_OPACITY, EDGE_MODE,
 CLIP_PLANES, GPU_BYTES, HOST_BYTES, BRICK_SIZE, QUALITY, FRAME_BUDGET_MS) = declare(
    Option("traversal", "voxels", str, "dda", "dda (exact: every voxel a ray crosses) or "
           "fixed steps (may miss thin voxels)", choices=TRAVERSALS,
           control=Control("select", help="dda is exact; fixed steps may miss thin voxels")),
    Option("step_scale", "voxels", float, None, "the fixed traversal's step, in voxels "
           "(default 0.1)", optional=True, low=1e-3, high=1e3,
           control=Control("select", "fixed step (voxels)",
                           choices=(AUTO, 0.05, 0.1, 0.25, 0.5, 1.0))),
    Option("mip_levels", "voxels", int, None, "occupancy mipmap levels the DDA leaves empty "
           "space by (default: those that pay off)", low=0, high=MAX_MIP_LEVELS,
           optional=True, control=Control("select", "occupancy levels",
                                          choices=(AUTO, *range(MAX_MIP_LEVELS + 1)))),
    Option("distance_field", "voxels", int, 0, "largest radius of the neighbour distance "
           "field (0: off)", low=0, high=MAX_DISTANCE_FIELD,
           control=Control("select", "distance field", choices=(0, 1, 2, 3))),
    Option("mode", "voxels", str, "color", "what a pixel shows: the colour, the voxel id, "
           "the entered face", choices=MODES, control=Control("select")),
    Option("shading", "voxels", str, "blinn", "unlit, flat (Lambert) or blinn (plus a "
           "highlight), from the scene's lights", choices=SHADINGS,
           control=Control("select")),
    *blinn_terms("voxels"),
    Option("ambient_occlusion", "voxels", bool, False, "darken each face near the voxels "
           "around it", control=Control("switch", "ambient occlusion")),
    Option("occlusion_strength", "voxels", float, 0.5, "how dark full occlusion is", low=0.0,
           high=1.0, control=Control("slider", "occlusion strength", 0.0, 1.0, 0.05)),
    Option("proxy", "voxels", str, "bricks", "the geometry whose pixels run the traversal",
           choices=PROXIES, control=Control("select")),
    Option("lod", "voxels", bool, False, "draw coarser occupancy cells far away",
           control=Control("switch", "level of detail")),
    Option("lod_bias", "voxels", float, 0.0, "levels added to the level of detail (with lod; "
           "the range is lod's: a multiscale source takes any bias, -30 the finest "
           "everywhere)",
           low=-float(MAX_MIP_LEVELS), high=float(MAX_MIP_LEVELS),
           control=Control("slider", "lod bias", -2.0, 2.0, 0.25)),
    Option("world_traversal", "voxels", str, None, "chunked worlds: one traversal through "
           "a chunk index, or a box per chunk (default: index where it fits)",
           choices=WORLD_TRAVERSALS, optional=True,
           control=Control("select", "world traversal", choices=(AUTO, *WORLD_TRAVERSALS))),
    Option("show_edges", "voxels", bool, False, "outline every drawn face of every voxel, "
           "as PyVista's show_edges draws a mesh's cells", control=Control("switch", "edges")),
    Option("edge_color", "voxels", str, None, "the edges' colour (default: the theme's)",
           optional=True, usd_type="color3f",
           without={"knob": "any colour PyVista names; set in Python, the CLI or USD"}),
    Option("line_width", "voxels", float, None, "the edges' width in pixels (default: the "
           "theme's)", optional=True, low=0.0, high=100.0, closed_low=False,
           control=Control("slider", "edge width (px)", 1.0, 8.0, 0.5)),
    Option("edge_opacity", "voxels", float, None, "how much of the edges' colour covers a "
           "face (default: the theme's)", optional=True, low=0.0, high=1.0,
           control=Control("slider", "edge opacity", 0.0, 1.0, 0.05)),
    Option("edge_mode", "voxels", str, "voxels", "with show_edges: every voxel face's "
           "outline, or only the boundaries between different labels (on faces and on a "
           "clip plane's cut)", choices=EDGE_MODES,
           control=Control("select", "edges drawn")),
    Option("clip_planes", "voxels", tuple, None, "planes that cut the grid, six numbers "
           "each: a point, then the normal to the side kept (a voxel the cut crosses is "
           "drawn on the plane)", optional=True,
           without={"knob": "six numbers a plane; set in Python, the CLI or USD "
                            "(actor.cubemarch.set_clip_planes moves them)"}),
    # Multiscale label sources streamed by bricks (voxels/paged_labels.py): set on the pager.
    Option("gpu_bytes", "voxels", int, None, "GPU budget in bytes of a multiscale source's "
           "brick pool (256 MiB by default)", low=1, optional=True, model=True, usd=None,
           without=PAGED_LABELS_ONLY),
    Option("host_bytes", "voxels", int, None, "host budget in bytes of a multiscale source's "
           "read bricks (2 GiB by default)", low=1, optional=True, model=True, usd=None,
           without=PAGED_LABELS_ONLY),
    Option("brick_size", "voxels", int, None, "voxels along a brick's edge (32 by default)",
           low=1, high=1024, optional=True, model=True, usd=None,
           without=PAGED_LABELS_ONLY),
    # Read by add_voxels itself, not the technique (quality/voxels.py).
    Option("quality", "voxels", str, None, "error budget: exact (the DDA, its error "
           "measured and reported), a PSNR in dB, or fast / balanced / best",
           optional=True, parse=preset_or_number,
           control=Control("select", "quality", choices=(AUTO, "exact", "fast", "balanced",
                                                         "best"),
                           help="measured against the CPU reference")),
    Option("frame_budget_ms", "voxels", float, None, "while the view moves, the most pixels "
           "(the grid drawn at 1/2, 1/3 or 1/4 the viewport across) keeping frames within "
           "this many ms (full size when it stops)", low=0.0, closed_low=False,
           optional=True,
           control=Control("select", "frame budget (ms)", choices=(AUTO, 16, 33, 66, 100),
                           help="fewer pixels while the view moves")),
)
#: Options add_voxels reads itself: no technique's options hold them.
CALL_ONLY = ("quality", "frame_budget_ms")
#: The scalar bar's keywords, as every kind declares them.
declare(*scalar_bar_terms("voxels"))
#: VTK draws a surface's edges at least this wide (pixels), whatever smaller line_width is
#: asked: measured on its images (line_width 0.5 and 1 draw alike, the coverage at 0.5
#: pixel from the line 0.55, at 1 pixel 0.05; from 1.5 up the width asked).
VTK_THINNEST_EDGE = 1.1


@dataclass(frozen=True)
class VoxelOptions:
    """How a material grid is traversed and what each pixel shows.

    ``traversal``: ``'dda'`` (exact: every voxel a ray crosses) or ``'fixed'`` (samples
    ``step_scale`` voxels apart along the dominant axis; misses thin voxels). ``mode``:
    ``'color'`` (the palette colour, shaded), ``'id'`` (the voxel's linear index + 1 as
    24-bit RGB, for picking and exact tests) or ``'face'`` (the entered face as red,
    :func:`~pv_cubemarch.reference.voxels.face_colors`). ``shading``: ``'unlit'``, ``'flat'``
    (Lambert on the entered face, from the scene's lights) or ``'blinn'`` (plus a
    Blinn-Phong highlight), with ``ambient``, ``specular`` and ``specular_power``.
    ``mip_levels``: occupancy mipmap levels (0-12; a level's cells are ``2^L`` voxels wide)
    the DDA uses to leave empty space in one step; ``None``: the levels that pay off on the
    grid's labels with the DDA (:func:`~pv_cubemarch.models.voxel_levels.useful_levels`), none
    with the fixed step.
    ``distance_field``: the neighbour distance field (0 = off, 1-3 = its largest
    radius; one more byte per voxel): from a voxel whose surrounding cube is empty the ray
    leaves the cube in one step. Both are exact whatever their setting; they only change
    the speed. ``ambient_occlusion`` (``traversal='dda'``, mode ``'color'``, any shading):
    each entered face darkened near the drawn voxels around it (per-vertex voxel AO,
    bilinear over the face; formula in
    :func:`~pv_cubemarch.reference.voxels.occlusion_factor`) by a factor from 1 down to
    ``1 - occlusion_strength`` (0-1) that multiplies the unlit colour, or the ambient +
    diffuse term (not the highlight).
    ``proxy``: the geometry whose pixels run the traversal. ``'bricks'`` (default): the
    outer faces of the filled 2³, 4³ or 8³ bricks
    (:func:`~pv_cubemarch.models.voxel_shell.choose_shell`), so pixels that see no filled brick
    run nothing and rays start next to the voxels; on frames where the near plane reaches
    them, and with ``lod`` (a coarse cell reaches past the bricks), it falls back to
    ``'box'``: the grid's bounding box, every ray traversed from where
    it enters the box or from the near plane (kept to measure the traversal alone). Exact
    either way.
    ``world_traversal`` (grids drawn in chunks): ``'index'``, one box and one traversal over
    the whole world, stepping through a chunk index (empty chunks left in one step, stored
    ones read from a pool of slots); ``'per_chunk'``, a box per chunk, culled and ordered
    (:mod:`pv_cubemarch.voxels.per_chunk_world`); ``None``: ``'index'`` where its pool fits one
    texture and the options allow it (:func:`pv_cubemarch.voxels.indexed_world.why_not_indexed`
    says why not), else ``'per_chunk'``.
    """

    traversal: str = TRAVERSAL.field()
    step_scale: float | None = VOXEL_STEP_SCALE.field()
    mip_levels: int | None = MIP_LEVELS.field()
    distance_field: int = DISTANCE_FIELD.field()
    mode: str = MODE.field()
    shading: str = SHADING.field()
    ambient: float = AMBIENT.field()
    diffuse: float = DIFFUSE.field()
    specular: float = SPECULAR.field()
    specular_power: float = SPECULAR_POWER.field()
    ambient_occlusion: bool = AMBIENT_OCCLUSION.field()
    occlusion_strength: float = OCCLUSION_STRENGTH.field()
    proxy: str = PROXY.field()
    lod: bool = LOD.field()
    lod_bias: float = LOD_BIAS.field()
    world_traversal: str | None = WORLD_TRAVERSAL.field()
    show_edges: bool = SHOW_EDGES.field()
    edge_color: object = EDGE_COLOR.field()
    line_width: float | None = LINE_WIDTH.field()
    edge_opacity: float | None = EDGE_OPACITY.field()
    edge_mode: str = EDGE_MODE.field()
    clip_planes: tuple | None = CLIP_PLANES.field()

    def check(self) -> None:
        """Raise a clear error for a bad option (each alone, then how they go together)."""
        for name in ("traversal", "mode", "mip_levels", "distance_field"):
            option("voxels", name).check(getattr(self, name))
        for name in ("mip_levels", "distance_field"):
            if getattr(self, name) and self.traversal != "dda":
                raise ValueError(f"{name} skips empty space in traversal='dda'; the fixed step "
                                 f"has none: pass {name}=0 with traversal='fixed'.")
        for name in ("proxy", "world_traversal", "lod", "lod_bias"):
            option("voxels", name).check(getattr(self, name))
        if self.lod_bias and not self.lod:
            raise ValueError("lod_bias shifts the level of detail, which is off: pass "
                             "lod=True with it.")
        if self.lod and (self.traversal != "dda" or self.mip_levels == 0):
            raise ValueError("lod draws coarser occupancy levels, which only the DDA with "
                             "mip_levels has: use traversal='dda' and mip_levels=None (or "
                             "at least 1).")
        if self.lod and self.mode == "id":
            raise ValueError("mode='id' names the exact voxel of each pixel; lod draws "
                             "coarser cells: leave lod off with mode='id'.")
        for name in ("shading", "ambient", "diffuse", "specular", "specular_power",
                     "ambient_occlusion",
                     "occlusion_strength"):
            option("voxels", name).check(getattr(self, name))
        if self.ambient_occlusion and self.mode != "color":
            raise ValueError(f"ambient_occlusion darkens the colours of mode='color'; "
                             f"mode={self.mode!r} draws none: use mode='color', or leave "
                             "ambient_occlusion off.")
        if self.ambient_occlusion and self.traversal != "dda":
            raise ValueError("ambient_occlusion needs the face each ray entered, which "
                             "traversal='fixed' does not know: use traversal='dda'.")
        if self.step_scale is not None:
            if self.traversal != "fixed":
                raise ValueError("step_scale is for traversal='fixed' (the DDA visits every "
                                 "voxel and has no step); leave it out.")
            positive_number("step_scale", self.step_scale, 0.0, 1e3)
            if float(self.step_scale) < 1e-3:
                raise ValueError(f"step_scale={self.step_scale} would take over 1000 samples "
                                 "per voxel; use at least 0.001.")
        self.check_edges()
        option("voxels", "clip_planes").check(self.clip_planes)
        if self.clip_planes is not None:
            clip_plane_list(self.clip_planes)   # six finite numbers a plane, normals not 0
        check_declared(self)   # and nothing declared is left unchecked

    @property
    def world_planes(self) -> tuple:
        """The clip planes as ``(origin, normal)`` pairs in world coordinates."""
        return plane_pairs(self.clip_planes)

    def check_edges(self) -> None:
        """Refuse edge options that no edge would show, or edges on what has no voxel faces."""
        for name in ("show_edges", "line_width", "edge_opacity", "edge_mode"):
            option("voxels", name).check(getattr(self, name))
        if self.edge_color is not None:
            try:
                pyvista.Color(self.edge_color)
            except ValueError as error:
                raise ValueError(f"edge_color={self.edge_color!r} is not a colour: "
                                 f"{error}") from None
        given = [name for name in ("edge_color", "line_width", "edge_opacity")
                 if getattr(self, name) is not None]
        if self.edge_mode != "voxels":
            given.append("edge_mode")
        if not self.show_edges:
            if given:
                raise ValueError(f"{given[0]} styles the edges, which are off: pass "
                                 "show_edges=True with it.")
            return
        if self.mode != "color":
            raise ValueError(f"show_edges outlines the colours of mode='color'; mode="
                             f"{self.mode!r} draws none: use mode='color'.")
        if self.traversal != "dda":
            raise ValueError("show_edges needs the face and voxel each ray hit, which "
                             "traversal='fixed' does not know: use traversal='dda'.")
        if self.lod:
            raise ValueError("show_edges outlines single voxels; lod draws coarser cells "
                             "far away: leave lod off with show_edges.")

    @property
    def edge_style(self) -> tuple[tuple[float, float, float], float, float]:
        """The edges' RGB, half width in pixels (as VTK draws it) and opacity.

        The theme's colour, width and opacity (``pyvista.global_theme``) where unset.
        """
        theme = pyvista.global_theme
        color = theme.edge_color if self.edge_color is None else self.edge_color
        width = theme.line_width if self.line_width is None else self.line_width
        opacity = theme.edge_opacity if self.edge_opacity is None else self.edge_opacity
        return (tuple(float(v) for v in pyvista.Color(color).float_rgb),
                0.5 * max(float(width), VTK_THINNEST_EDGE), float(opacity))

    def check_model(self, model) -> None:
        """Refuse a grid no 3D texture holds, or whose ids 24-bit colour cannot hold."""
        if max(model.dimensions) > MAX_TEXTURE_SIZE:
            raise ValueError(f"A grid of {model.dimensions} voxels is over {MAX_TEXTURE_SIZE} "
                             "voxels on a side, the largest 3D texture assumed here; draw it "
                             "in chunks (add_voxels(..., chunk_size=256)).")
        self.check_ids(model.dimensions)

    def check_ids(self, dimensions) -> None:
        """Refuse ``mode='id'`` on a grid (or world) with more voxels than 24-bit ids."""
        voxels = int(np.prod([int(n) for n in dimensions], dtype=np.int64))
        if self.mode == "id" and voxels + 1 > 1 << 24:
            raise ValueError(f"mode='id' writes voxel ids as 24-bit colour; a grid of "
                             f"{voxels:,} voxels has more. Crop the grid or use pick().")

    def candidate_levels(self, dimensions) -> int:
        """How many occupancy levels to build for a grid of ``dimensions`` voxels.

        The chosen ``mip_levels``; with ``None``, every level up to the one whose single
        cell covers the grid for the DDA, none for the fixed step.
        """
        if self.mip_levels is not None:
            return int(self.mip_levels)
        if self.traversal != "dda":
            return 0
        largest = max(int(n) for n in dimensions)
        return min(max(largest - 1, 0).bit_length(), MAX_MIP_LEVELS)

    def for_grid(self, useful_levels: int, candidates: int) -> VoxelOptions:
        """These options with ``mip_levels`` settled when it is None.

        ``useful_levels``: how many of the ``candidates`` levels pay off on the grid's labels
        (:func:`~pv_cubemarch.models.voxel_levels.useful_levels`); with ``lod``, at least
        :data:`LOD_LEVELS` of them (levels of detail even where skipping would not pay).
        """
        if self.mip_levels is not None:
            return self
        if self.lod:
            return replace(self, mip_levels=max(int(useful_levels),
                                                min(int(candidates), LOD_LEVELS)))
        return replace(self, mip_levels=int(useful_levels))

    @property
    def step(self) -> float:
        """The fixed traversal's step in voxels (1/10 of a voxel by default)."""
        return float(self.step_scale) if self.step_scale is not None else 0.1


def drawn_level(options: VoxelOptions) -> int:
    """The coarsest level whose cells the traversal may draw: ``mip_levels`` with ``lod``."""
    return int(options.mip_levels or 0) if options.lod else 0
