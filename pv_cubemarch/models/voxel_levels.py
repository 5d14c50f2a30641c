"""Occupancy levels of a label grid: the mipmap the traversal leaves empty space by.

Level *l* marks the 2^l-voxel cells holding anything; the level atlas packs every level
into one 3D texture; representative levels keep a label per cell for level of detail.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..core.array_copy import copy_tiled
from ..core.gl_limits import MAX_TEXTURE_SIZE
from ..core.parallel import core_pool


def block_any(mask: np.ndarray, block: int) -> np.ndarray:
    """Per block of ``block``³ cells (the last ones cut by the grid), whether any is true.

    One axis at a time, OR-ing the ``block`` strided slices of each: every pass streams
    through memory (a reshape's ``any(axis=(1, 3, 5))`` walks the innermost axis ``block``
    elements at a time, 15x slower for 256³).
    """
    mask = np.asarray(mask, dtype=bool)
    block = int(block)
    pad = [(0, -n % block) for n in mask.shape]
    if any(p for _, p in pad):
        mask = np.pad(mask, pad)
    for axis in range(mask.ndim):
        parts = [mask[(slice(None),) * axis + (slice(k, None, block),)] for k in range(block)]
        merged = parts[0].copy()
        for part in parts[1:]:
            merged |= part
        mask = merged
    return mask


#: Voxels from which the first occupancy level is found slab by slab on every core.
THREADED_VOXELS = 1 << 22


def occupancy_levels(labels: np.ndarray, levels: int) -> list[np.ndarray]:
    """Conservative occupancy mipmaps, levels ``1..levels`` (uint8 0/1).

    Level ``L`` marks, per cell of ``2^L`` voxels per axis, whether any voxel under it is
    filled: a cell is empty only if every voxel under it is. The first level, which reads
    every voxel, is found by slabs on every core for large grids.
    """
    labels = np.asarray(labels)
    result = []
    filled = None
    for _ in range(int(levels)):
        filled = first_level(labels) if filled is None else block_any(filled, 2)
        result.append(filled.view(np.uint8))
    return result


def first_level(labels: np.ndarray) -> np.ndarray:
    """Per cell of 2³ voxels, whether any is filled (non-zero).

    Large grids by slabs two voxels thick or more across their slowest axis (the first in
    C order, the last in Fortran order), on threads (numpy releases the GIL).
    """
    if labels.size < THREADED_VOXELS:
        return block_any(labels != 0, 2)
    axis = 2 if labels.flags.f_contiguous and not labels.flags.c_contiguous else 0
    n = labels.shape[axis]
    plane = labels.size // max(n, 1)
    thick = max(2, (THREADED_VOXELS // max(plane, 1)) // 2 * 2)
    shape = [-(-m // 2) for m in labels.shape]
    out = np.empty(shape, bool)

    def slab(start):
        part = [slice(None)] * 3
        cells = [slice(None)] * 3
        part[axis] = slice(start, start + thick)
        cells[axis] = slice(start // 2, -(-min(start + thick, n) // 2))
        out[tuple(cells)] = block_any(labels[tuple(part)] != 0, 2)

    starts = range(0, n, thick)
    with core_pool(len(starts)) as pool:
        list(pool.map(slab, starts))
    return out

def representative_levels(labels: np.ndarray, levels: int) -> list[np.ndarray]:
    """Levels ``1..levels`` holding, per cell, a label that stands for the voxels under it.

    For level of detail: a cell of level ``L`` holds the most frequent non-zero label of its
    8 cells of level ``L - 1`` (the smaller label on a tie; 0 only when all 8 are 0), so it
    is non-zero exactly where :func:`occupancy_levels` marks the cell filled. Labels' dtype.
    """
    grid = np.asarray(labels)
    result = []
    for _ in range(int(levels)):
        pad = [(0, n % 2) for n in grid.shape]
        grown = np.pad(grid, pad) if any(p for _, p in pad) else grid
        nx, ny, nz = (n // 2 for n in grown.shape)
        children = np.sort(grown.reshape(nx, 2, ny, 2, nz, 2).transpose(0, 2, 4, 1, 3, 5)
                           .reshape(-1, 8), axis=1)
        chosen = children[:, 7].copy()   # right where all 8 agree (most cells)
        mixed = np.flatnonzero(children[:, 0] != children[:, 7])
        some = children[mixed]
        counts = (some[:, :, None] == some[:, None, :]).sum(axis=2)
        counts[some == 0] = 0
        best = np.argmax(counts, axis=1)   # sorted: the first of the most frequent is smallest
        chosen[mixed] = some[np.arange(len(some)), best]
        grid = chosen.reshape(nx, ny, nz)
        result.append(grid)
    return result

def atlas_levels(labels: np.ndarray, levels: int, representative: bool) -> list[np.ndarray]:
    """The levels a level atlas holds: representative labels (level of detail) or occupancy."""
    return (representative_levels if representative else occupancy_levels)(labels, levels)

def grown_by_one(mask: np.ndarray) -> np.ndarray:
    """``mask`` grown by one cell in all 26 directions (separable, numpy only)."""
    grown = np.asarray(mask, dtype=bool)
    for axis in range(3):
        if grown.shape[axis] < 2:
            continue
        ahead = [slice(None)] * 3
        behind = [slice(None)] * 3
        ahead[axis], behind[axis] = slice(1, None), slice(None, -1)
        spread = grown.copy()
        spread[tuple(behind)] |= grown[tuple(ahead)]
        spread[tuple(ahead)] |= grown[tuple(behind)]
        grown = spread
    return grown

def level_offset(n: int, level: int) -> int:
    """Where level ``level >= 1`` starts along the atlas's row axis (``n`` voxels long).

    ``n - (n >> (level - 1)) + level - 1``: a formula the shader computes too (no table to
    index per step), leaving each level room for its ``ceil(n / 2^level)`` cells.
    """
    return 0 if level == 0 else n - (n >> (level - 1)) + level - 1

def level_shapes(dimensions: Sequence[int], count: int) -> list[tuple[int, int, int]]:
    """The cell counts of the labels (level 0) and of occupancy levels ``1..count``."""
    dims = tuple(int(n) for n in dimensions)
    return [tuple(-(-n // (1 << level)) for n in dims) for level in range(int(count) + 1)]

def level_origin(dimensions: Sequence[int], level: int, slab_axis: int,
                 row_axis: int) -> tuple[int, int, int]:
    """Where level ``level`` starts in its atlas (the labels, level 0, at the origin)."""
    origin = [0, 0, 0]
    if level:
        origin[row_axis] = level_offset(int(dimensions[row_axis]), level)
        origin[slab_axis] = int(dimensions[slab_axis])
    return tuple(origin)

def atlas_layout(dimensions: Sequence[int], count: int) -> tuple[int, int, tuple] | None:
    """The smallest level atlas within :data:`MAX_TEXTURE_SIZE`: ``(slab, row, shape)``.

    The levels lie in a slab past the labels along the ``slab`` axis, side by side along
    the ``row`` axis; tried with the slab along z, x, y (the first wins a tie). ``None``
    when none fits.
    """
    dims = tuple(int(n) for n in dimensions)
    shapes = level_shapes(dims, count)
    best = None
    for slab in (2, 0, 1):
        for row in (a for a in (0, 1, 2) if a != slab):
            shape = list(dims)
            if count:
                shape[slab] += shapes[1][slab]
                shape[row] = max(dims[row], level_offset(dims[row], count) + shapes[-1][row])
            if max(shape) <= MAX_TEXTURE_SIZE and (best is None
                                                   or np.prod(shape) < np.prod(best[2])):
                best = (slab, row, tuple(shape))
    return best

@dataclass(frozen=True)
class LevelAtlas:
    """The labels and their occupancy levels ``1..n`` in one 3D texture.

    Of the labels' type, or float32 for 4-byte rows (as GL reads them), x fastest.

    The traversal reads any level with one fetch of one texture (GLSL 1.50 indexes no
    sampler arrays, and llvmpipe runs both sides of a branch: a second texture would be
    read on every step). The labels sit at the origin, so a voxel's label is read where it
    always was; the levels lie in a slab past the labels along ``slab_axis``, side by side
    along ``row_axis`` (:func:`level_origin`). An occupied cell holds 1.
    """

    texels: np.ndarray
    slab_axis: int
    row_axis: int
    shapes: tuple[tuple[int, int, int], ...]

    def origin(self, number: int) -> tuple[int, int, int]:
        """Where level ``number`` starts in the atlas."""
        return level_origin(self.shapes[0], number, self.slab_axis, self.row_axis)

    def level(self, number: int) -> np.ndarray:
        """Level ``number`` (0: the labels; 1..levels: occupancy) cut back out of the atlas."""
        start, shape = self.origin(number), self.shapes[number]
        return self.texels[tuple(slice(o, o + n) for o, n in zip(start, shape, strict=True))]

def level_atlas(labels: np.ndarray, grids: list[np.ndarray]) -> LevelAtlas:
    """``labels`` and their occupancy levels ``grids`` (:func:`occupancy_levels`) packed.

    Raises ``ValueError`` when no layout fits :data:`MAX_TEXTURE_SIZE`.
    """
    labels = np.asarray(labels)
    layout = atlas_layout(labels.shape, len(grids))
    if layout is None:
        raise ValueError(f"A grid of {labels.shape} voxels with {len(grids)} occupancy levels "
                         f"needs a texture over {MAX_TEXTURE_SIZE} texels on a side; use "
                         "mip_levels=0 (or fewer levels), or a smaller grid.")
    slab, row, shape = layout
    # x fastest, and 4-byte rows as the float32 GL reads them (exact to 2^24): the upload
    # then converts and copies nothing more
    texels = np.float32 if labels.dtype.itemsize > 2 else labels.dtype
    atlas = LevelAtlas(np.empty(shape, texels, order="F"), slab, row,
                       tuple(level_shapes(labels.shape, len(grids))))
    copy_tiled(atlas.level(0), labels)
    for axis in range(3):   # the texels around the levels (the labels fill their own)
        past = [slice(None)] * 3
        past[axis] = slice(labels.shape[axis], None)
        atlas.texels[tuple(past)] = 0
    for number, grid in enumerate(grids, start=1):
        atlas.level(number)[...] = grid
    return atlas

def atlas_updates(labels: np.ndarray, box, count: int, representative: bool,
                  origin_of) -> list[tuple[tuple[int, int, int], np.ndarray]]:
    """What a level atlas changes where the labels in ``box`` (three slices) changed.

    Per level ``0..count``: the atlas texel where its changed block starts and the block
    (the labels, then each level's cells over the box, recomputed from the labels under
    them). ``origin_of(level)``: where that level starts in the atlas.
    """
    dims = labels.shape
    lower = [s.start for s in box]
    upper = [s.stop for s in box]
    updates = [(tuple(int(o + a) for o, a in zip(origin_of(0), lower, strict=True)),
                labels[tuple(box)])]
    for level in range(1, int(count) + 1):
        low = [a >> level for a in lower]
        high = [((b - 1) >> level) + 1 for b in upper]
        region = tuple(slice(a << level, min(b << level, n))
                       for a, b, n in zip(low, high, dims, strict=True))
        cells = atlas_levels(labels[region], level, representative)[-1]
        origin = origin_of(level)
        updates.append((tuple(int(o + a) for o, a in zip(origin, low, strict=True)),
                        cells.astype(labels.dtype)))
    return updates

#: A level the traversal climbs to by default must leave at least this share of its cells
#: empty, and at least 3 levels must: on denser grids (a 1 % random fill, a fine
#: checkerboard) climbing and descending cost more than the voxel steps they save.
USEFUL_EMPTY_SHARE = 0.3

USEFUL_FIRST_LEVEL = 3

def useful_levels(grids: list[np.ndarray]) -> int:
    """How many occupancy levels pay off by default (a rule of thumb from the bench).

    The highest level with at least :data:`USEFUL_EMPTY_SHARE` of its cells empty, or 0
    when that is below :data:`USEFUL_FIRST_LEVEL`.
    """
    useful = 0
    for number, grid in enumerate(grids, start=1):
        if 1.0 - float(grid.mean()) >= USEFUL_EMPTY_SHARE:
            useful = number
    return useful if useful >= USEFUL_FIRST_LEVEL else 0

def safe_radii(labels: np.ndarray, radius: int) -> np.ndarray:
    """Per voxel, the largest ``r <= radius`` with an empty ``(2r+1)^3`` cube around it.

    The neighbour distance field (uint8; 0 at filled voxels and next to them): a ray
    in that voxel may leave the whole cube in one step. Voxels outside the grid count as
    empty; any label counts as filled (hidden or not), so the field never changes with the
    palette.
    """
    filled = np.asarray(labels) != 0
    result = np.zeros(filled.shape, np.uint8)
    for _ in range(int(radius)):
        filled = grown_by_one(filled)
        result += ~filled
    return result

def bounds_in_cells(bounds, level: int, dimensions: Sequence[int]) -> tuple[np.ndarray,
                                                                          np.ndarray]:
    """``(lower, upper)`` grown to whole cells of ``2^level`` voxels, within the grid."""
    lower, upper = (np.asarray(b, dtype=np.float64) for b in bounds)
    if level <= 0 or not (upper > lower).all():
        return lower, upper
    cell = float(1 << int(level))
    return (np.floor(lower / cell) * cell,
            np.minimum(np.ceil(upper / cell) * cell, np.asarray(dimensions, np.float64)))

def filled_bounds(labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(lower, upper)`` corners (index space) of the box around the filled voxels.

    Both ``(0, 0, 0)`` for a grid with none.
    """
    filled = np.asarray(labels) != 0
    lower, upper = np.zeros(3), np.zeros(3)
    for axis in range(3):
        along = np.flatnonzero(filled.any(axis=tuple(a for a in range(3) if a != axis)))
        if not len(along):
            return np.zeros(3), np.zeros(3)
        lower[axis], upper[axis] = along[0], along[-1] + 1
    return lower, upper
