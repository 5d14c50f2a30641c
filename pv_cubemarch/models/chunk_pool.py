"""A world's stored chunks as slots of one 3D texture, found through a chunk index.

For a world drawn by one traversal (``world_traversal='index'``): every stored chunk's
labels and occupancy levels (its :class:`~pv_cubemarch.models.voxel_levels.LevelAtlas`, the chunk
padded to ``chunk_size``³) fill one slot of a pool texture; a small index texture holds, per
chunk, where to look: nothing, one label, or a slot. Empty and uniform chunks take no slot,
so the pool holds only what is stored. The index is the occupancy level of whole chunks:
the traversal skips an empty chunk in one step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.gl_limits import MAX_TEXTURE_SIZE
from . import voxels as grids
from .voxel_levels import atlas_layout, atlas_levels, filled_bounds, level_atlas, level_origin
from .world import VoxelWorld


def chunk_shift(chunk_size: int) -> int | None:
    """``log2(chunk_size)`` when the chunk edge is a power of two (at least 2), else None."""
    size = int(chunk_size)
    return size.bit_length() - 1 if size >= 2 and size & (size - 1) == 0 else None


@dataclass(frozen=True)
class PoolLayout:
    """Where slots lie in the pool: a ``grid`` of ``slot_shape`` blocks, slot 0 at the origin.

    Slot ``s`` sits at ``(s % gx, (s // gx) % gy, s // (gx * gy))`` blocks, the formula the
    shader computes; within it the chunk's level atlas (``levels`` occupancy levels along
    ``slab_axis`` / ``row_axis``, as :func:`~pv_cubemarch.models.voxel_levels.level_origin` says).
    """

    chunk_size: int
    levels: int
    slab_axis: int
    row_axis: int
    slot_shape: tuple[int, int, int]
    grid: tuple[int, int, int]

    @property
    def capacity(self) -> int:
        """Slots the pool holds."""
        return int(np.prod(self.grid))

    @property
    def shape(self) -> tuple[int, int, int]:
        """The pool texture's texels along x, y, z."""
        return tuple(int(g * s) for g, s in zip(self.grid, self.slot_shape, strict=True))

    def slot_origin(self, slot: int) -> tuple[int, int, int]:
        """The pool texel where slot ``slot`` starts."""
        gx, gy, _ = self.grid
        cell = (slot % gx, (slot // gx) % gy, slot // (gx * gy))
        return tuple(int(c * s) for c, s in zip(cell, self.slot_shape, strict=True))

    def level_origin(self, slot: int, level: int) -> tuple[int, int, int]:
        """The pool texel where level ``level`` of slot ``slot`` starts."""
        inside = level_origin((self.chunk_size,) * 3, level, self.slab_axis, self.row_axis)
        return tuple(a + b for a, b in zip(self.slot_origin(slot), inside, strict=True))


def slot_grid(slots: int, slot_shape) -> tuple[int, int, int] | None:
    """Slots along x, y, z of the smallest pool of ``slots`` blocks of ``slot_shape`` texels.

    Fewest slots, then the most even sides; no side over
    :data:`~pv_cubemarch.models.voxels.MAX_TEXTURE_SIZE` texels (None when none fits).
    """
    most = [MAX_TEXTURE_SIZE // int(n) for n in slot_shape]
    slots = max(int(slots), 1)
    best = None
    for gx in range(1, min(most[0], slots) + 1):
        for gy in range(1, min(most[1], -(-slots // gx)) + 1):
            gz = -(-slots // (gx * gy))
            if gz > most[2]:
                continue
            count = gx * gy * gz
            # fewest slots, then the most even sides (the nearest to a cube)
            rank = (count, max(gx, gy, gz) - min(gx, gy, gz))
            if best is None or rank < best[0]:
                best = (rank, (gx, gy, gz))
    return None if best is None else best[1]


def pool_layout(chunk_size: int, levels: int, slots: int, itemsize: int = 1,
                budget: int | None = None) -> PoolLayout | None:
    """The smallest pool of at least ``slots`` slots, or None when none fits one texture.

    A pool fits when no side is over :data:`~pv_cubemarch.models.voxels.MAX_TEXTURE_SIZE`
    and it holds at most ``budget`` bytes (``itemsize`` per texel; by default
    :data:`~pv_cubemarch.models.voxels.MAX_GRID_BYTES`, as one grid).
    """
    budget = grids.MAX_GRID_BYTES if budget is None else int(budget)
    layout = atlas_layout((int(chunk_size),) * 3, int(levels))
    if layout is None:
        return None
    slab, row, slot = layout
    grid = slot_grid(slots, slot)
    if grid is None:
        return None
    pool = PoolLayout(int(chunk_size), int(levels), slab, row, slot, grid)
    if int(np.prod(pool.shape, dtype=np.int64)) * int(itemsize) > budget:
        return None
    return pool


def slot_texels(world: VoxelWorld, key, layout: PoolLayout, representative: bool) -> np.ndarray:
    """Stored chunk ``key``'s level atlas, its labels padded with 0 to a whole chunk."""
    size = layout.chunk_size
    labels = np.zeros((size,) * 3, world.dtype)
    kept = world.stored[key]
    labels[:kept.shape[0], :kept.shape[1], :kept.shape[2]] = kept
    return level_atlas(labels, atlas_levels(labels, layout.levels, representative)).texels


def chunk_counts(world: VoxelWorld) -> tuple[int, int, int]:
    """Chunks along x, y, z (the last ones cut by the grid's far sides)."""
    return tuple(-(-int(n) // world.chunk_size) for n in world.dimensions)


def chunk_index(world: VoxelWorld, slots: dict, shown: np.ndarray,
                layout: PoolLayout) -> np.ndarray:
    """Per chunk (x, y, z, float32 RGBA): where its slot starts in the pool, and its kind.

    Kind (alpha): 0 nothing drawn, ``-m`` all of label ``m``, 1 stored (the slot's first
    pool texel in RGB, :meth:`PoolLayout.slot_origin`). ``slots``: each stored chunk's
    slot; ``shown``: per label, drawn or hidden (a uniform chunk of a hidden label is empty
    to the traversal, as hidden voxels are).
    """
    index = np.zeros((*chunk_counts(world), 4), np.float32)
    for key, label in world.uniform.items():
        index[key][3] = -float(label) if shown[label] else 0.0
    for key, slot in slots.items():
        index[key] = (*layout.slot_origin(slot), 1.0)
    return index


def world_filled_bounds(world: VoxelWorld) -> tuple[np.ndarray, np.ndarray]:
    """``(lower, upper)`` index-space corners of the box around the world's filled voxels.

    Both zero for a world with none.
    """
    lows, highs = [], []
    for key in world.uniform:
        origin, shape = world.chunk_box(key)
        lows.append(origin)
        highs.append(origin + shape)
    for key, labels in world.stored.items():   # a stored chunk holds a non-zero label
        origin, _ = world.chunk_box(key)
        low, high = filled_bounds(labels)
        lows.append(origin + low)
        highs.append(origin + high)
    if not lows:
        return np.zeros(3), np.zeros(3)
    return (np.min(lows, axis=0).astype(np.float64), np.max(highs, axis=0).astype(np.float64))
