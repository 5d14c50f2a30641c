"""The options of the voxel technique, validated in one place."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..core.options import positive_number, whole_number
from ..models.voxels import MAX_TEXTURE_SIZE

TRAVERSALS = ("dda", "fixed")
MODES = ("color", "id", "face")
SHADINGS = ("unlit", "flat", "blinn")
PROXIES = ("bricks", "box")
WORLD_TRAVERSALS = ("index", "per_chunk")
#: Most occupancy mipmap levels (cells of 2^12 voxels cover any grid a texture holds).
MAX_MIP_LEVELS = 12
#: Fewest levels of detail a grid gets with ``lod`` (cells up to 8 voxels wide), where
#: fewer levels would pay off for skipping alone.
LOD_LEVELS = 3
#: Largest radius of the neighbour distance field (the seed's 1..3: 8, 124, 342 neighbours).
MAX_DISTANCE_FIELD = 3


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
    grid's labels with the DDA (:func:`~pv_cubemarch.models.voxels.useful_levels`), none
    with the fixed step.
    ``distance_field``: the seed's neighbour distance field (0 = off, 1-3 = its largest
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
    (:func:`~pv_cubemarch.models.voxels.choose_shell`), so pixels that see no filled brick
    run nothing and rays start next to the voxels; on frames where the near plane reaches
    them it falls back to ``'box'``: the grid's bounding box, every ray traversed from where
    it enters the box or from the near plane (the seed's set-up, kept to measure the
    traversal alone). Exact either way.
    ``world_traversal`` (grids drawn in chunks): ``'index'``, one box and one traversal over
    the whole world, stepping through a chunk index (empty chunks left in one step, stored
    ones read from a pool of slots); ``'per_chunk'``, a box per chunk, culled and ordered
    (:mod:`pv_cubemarch.voxels.world`); ``None``: ``'index'`` where its pool fits one
    texture and the options allow it (:func:`pv_cubemarch.voxels.indexed.why_not_indexed`
    says why not), else ``'per_chunk'``.
    """

    traversal: str = "dda"
    step_scale: float | None = None
    mip_levels: int | None = None
    distance_field: int = 0
    mode: str = "color"
    shading: str = "blinn"
    ambient: float = 0.2
    specular: float = 0.3
    specular_power: float = 30.0
    ambient_occlusion: bool = False
    occlusion_strength: float = 0.5
    proxy: str = "bricks"
    lod: bool = False
    lod_bias: float = 0.0
    world_traversal: str | None = None

    def check(self) -> None:
        """Raise a clear error for a bad option."""
        if self.traversal not in TRAVERSALS:
            raise ValueError(f"traversal must be one of {TRAVERSALS}, got {self.traversal!r}.")
        if self.mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {self.mode!r}.")
        if self.mip_levels is not None:
            whole_number("mip_levels", self.mip_levels, 0, MAX_MIP_LEVELS)
        whole_number("distance_field", self.distance_field, 0, MAX_DISTANCE_FIELD)
        for name in ("mip_levels", "distance_field"):
            if getattr(self, name) and self.traversal != "dda":
                raise ValueError(f"{name} skips empty space in traversal='dda'; the fixed step "
                                 f"has none: pass {name}=0 with traversal='fixed'.")
        if self.proxy not in PROXIES:
            raise ValueError(f"proxy must be one of {PROXIES}, got {self.proxy!r}.")
        if self.world_traversal is not None and self.world_traversal not in WORLD_TRAVERSALS:
            raise ValueError(f"world_traversal must be one of {WORLD_TRAVERSALS} or None, got "
                             f"{self.world_traversal!r}.")
        if not isinstance(self.lod, (bool, np.bool_)):
            raise ValueError(f"lod must be True or False, got {self.lod!r}.")
        positive_number("lod_bias", self.lod_bias, -float(MAX_MIP_LEVELS),
                        float(MAX_MIP_LEVELS), closed_low=True)
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
        if self.shading not in SHADINGS:
            raise ValueError(f"shading must be one of {SHADINGS}, got {self.shading!r}.")
        positive_number("ambient", self.ambient, 0.0, 1.0, closed_low=True)
        positive_number("specular", self.specular, 0.0, 1.0, closed_low=True)
        positive_number("specular_power", self.specular_power, 0.0, 1e4)
        if not isinstance(self.ambient_occlusion, (bool, np.bool_)):
            raise ValueError(f"ambient_occlusion must be True or False, got "
                             f"{self.ambient_occlusion!r}.")
        positive_number("occlusion_strength", self.occlusion_strength, 0.0, 1.0,
                        closed_low=True)
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
        (:func:`~pv_cubemarch.models.voxels.useful_levels`); with ``lod``, at least
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
        """The fixed traversal's step in voxels (the seed's 1/10 of a voxel by default)."""
        return float(self.step_scale) if self.step_scale is not None else 0.1


def drawn_level(options: VoxelOptions) -> int:
    """The coarsest level whose cells the traversal may draw: ``mip_levels`` with ``lod``."""
    return int(options.mip_levels or 0) if options.lod else 0
