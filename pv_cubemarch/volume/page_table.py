"""Which pool slot holds each brick of each level: a directory of blocks made on demand.

A flat table would hold an entry for every brick of every level (1020 x 512 x 128 of them
for a 2 TiB pyramid in bricks of 32: 128 MiB allocated and uploaded before the first
frame). Here the levels' bricks are grouped in blocks of ``BLOCK``³; a small directory (one
entry per block, every level side by side in one texture) gives each block holding a
resident brick its place in a block texture, whose entries give the bricks' slots. Blocks
are taken when their first brick arrives and given back when their last one leaves, so
both textures grow with what is resident, not with the data. Entries are ``index + 1`` (0:
none), uint16 read normalised while every index fits, else float32.
"""

from __future__ import annotations

import itertools

import numpy as np

from ..core.gl_limits import MAX_TEXTURE_SIZE
from ..gl.textures import Texture

#: Bricks along a block's edge.
BLOCK = 8


def block_grid(count: int, edge: int) -> tuple[int, int, int]:
    """Blocks along x, y, z of a texture holding at least ``count`` blocks of ``edge``³."""
    most = MAX_TEXTURE_SIZE // edge
    x = min(most, int(np.ceil(count ** (1 / 3))))
    y = min(most, int(np.ceil((count / x) ** 0.5)))
    z = int(np.ceil(count / (x * y)))
    if z > most:
        raise ValueError(f"{count} page-table blocks do not fit one texture.")
    return x, y, z


class PageTable:
    """The directory and the blocks of a brick pool's page table (module docstring)."""

    def __init__(self, counts, capacity: int, blocks: int | None = None):
        self.directory_counts = [tuple(-(-int(n) // BLOCK) for n in c) for c in counts]
        self.origins = list(itertools.accumulate(
            [0] + [c[0] for c in self.directory_counts[:-1]]))
        shape = (sum(c[0] for c in self.directory_counts),
                 max(c[1] for c in self.directory_counts),
                 max(c[2] for c in self.directory_counts))
        if max(shape) > MAX_TEXTURE_SIZE:
            raise ValueError(f"The page directory of {counts[0]} bricks at the finest level is "
                             f"over {MAX_TEXTURE_SIZE} texels a side: give a larger "
                             "brick_size.")
        total = sum(int(np.prod(c)) for c in self.directory_counts)
        self.block_capacity = max(1, min(int(capacity if blocks is None else blocks), total))
        self.grid = block_grid(self.block_capacity, BLOCK)
        # entries reach capacity + 1 (an empty brick: no slot, see BrickPager)
        self.dtype = np.uint16 if max(capacity + 1, self.block_capacity) < 65535 \
            else np.float32
        self.directory = Texture(np.zeros(shape, self.dtype), kind="3d", interpolate=False)
        self.blocks = Texture(np.zeros([n * BLOCK for n in self.grid], self.dtype), kind="3d",
                              interpolate=False)
        self.reset()

    def reset(self) -> None:
        """Nothing resident: empty directory and blocks."""
        self.block_of: dict = {}
        self.refs: dict = {}
        self.free = list(range(self.block_capacity - 1, -1, -1))
        if self.directory.array is not None and self.directory.array.any():
            self.directory.set_data(np.zeros(self.directory.array.shape, self.dtype))
            self.blocks.set_data(np.zeros(self.blocks.array.shape, self.dtype))

    def _block_origin(self, index: int) -> list[int]:
        x, y, _ = self.grid
        return [index % x * BLOCK, index // x % y * BLOCK, index // (x * y) * BLOCK]

    def has_room(self, key) -> bool:
        """Whether brick ``key`` can be set: its block is taken, or a block is free."""
        level, *ijk = key
        return (level, *(v // BLOCK for v in ijk)) in self.block_of or bool(self.free)

    def set(self, key, slot: int) -> None:
        """Brick ``key = (level, i, j, k)`` is in ``slot``."""
        level, *ijk = key
        block = (level, *(v // BLOCK for v in ijk))
        index = self.block_of.get(block)
        if index is None:
            index = self.block_of[block] = self.free.pop()
            self.refs[index] = 0
            self.directory.update_region([self.origins[level] + block[1], block[2], block[3]],
                                         np.full((1, 1, 1), index + 1, self.dtype))
        self.refs[index] += 1
        self._entry(index, ijk, slot + 1)

    def clear(self, key) -> None:
        """Brick ``key`` left its slot; its block goes back when it holds none."""
        level, *ijk = key
        block = (level, *(v // BLOCK for v in ijk))
        index = self.block_of[block]
        self._entry(index, ijk, 0)
        self.refs[index] -= 1
        if not self.refs[index]:
            del self.block_of[block], self.refs[index]
            self.free.append(index)
            self.directory.update_region([self.origins[level] + block[1], block[2], block[3]],
                                         np.zeros((1, 1, 1), self.dtype))

    def _entry(self, index: int, ijk, value: int) -> None:
        origin = [o + v % BLOCK for o, v in zip(self._block_origin(index), ijk, strict=True)]
        self.blocks.update_region(origin, np.full((1, 1, 1), value, self.dtype))

    def bind(self, target) -> None:
        """Give the sampling shader the directory, the blocks and how to read them."""
        target.add_texture("cm_pageDirectory", self.directory)
        target.add_texture("cm_pageBlocks", self.blocks)
        target.set_uniform("cm_pageScale", 65535.0 if self.dtype == np.uint16 else 1.0)
        target.set_uniform("cm_blockGrid", tuple(float(n) for n in self.grid))
        target.set_uniform("cm_blockBricks", float(BLOCK))

    @property
    def nbytes(self) -> int:
        """GPU bytes of the directory and the blocks."""
        return self.directory.nbytes + self.blocks.nbytes

    def release(self) -> None:
        """Free both textures."""
        self.directory.release()
        self.blocks.release()
