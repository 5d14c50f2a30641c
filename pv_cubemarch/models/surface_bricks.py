"""A surface's active cells as bricks of shared spline coefficients, found through an index.

For ``technique='active'`` drawn by one traversal per pixel (``traversal='index'``): the
grid of cells is cut into bricks of :data:`BRICK_SIZE`³ cells. A brick holding an active
cell takes a slot in two pools: the ``(BRICK_SIZE + 2)``³ B-spline coefficients its cells
read (neighbouring cells share 26 of their 27, so a brick keeps about 9 floats per active
cell where per-cell records keep 27), and one byte per cell saying whether the cell is
active. A small index holds, per brick, its slot or nothing: the traversal leaves a brick
without active cells in one step, steps cell by cell through the others, and loads and
marches only active cells. Above the bricks, blocks of :data:`BLOCK_SIZE`³ cells say
whether any of their bricks is stored: a ray that misses the surface crosses a 512³ grid in
about 100 steps instead of about 400.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .chunk_pool import slot_grid
from .surface import SplineField

#: Cells per brick edge (a power of two: the shader finds a cell's brick by a shift).
BRICK_SIZE = 4
#: Coefficients per brick edge: a cell reads its own 3 along each axis.
BRICK_COEFFICIENTS = BRICK_SIZE + 2
#: Cells per block edge (a power of two, a whole number of bricks).
BLOCK_SIZE = 16


@dataclass(frozen=True)
class SurfaceBricks:
    """The arrays a surface's index traversal reads, laid out as the shader expects.

    ``index``: ``(bx, by, bz, 4)`` float32 per brick: its slot's place in the slot grid
    (x, y, z) and 1, or zeros (no active cell). ``coefficients``: the pool of slots of
    ``BRICK_COEFFICIENTS``³ B-spline coefficients (float32, indexed x, y, z): slot
    ``(sx, sy, sz)`` holds ``c[4 bx + a, 4 by + b, 4 bz + c]`` at ``6 (sx, sy, sz) + (a, b,
    c)``. ``active``: the pool of slots of ``BRICK_SIZE``³ bytes, 1 where the cell is
    active. ``colors``: the second field's coefficients in the coefficients' layout, or None.
    ``blocks``: ``(kx, ky, kz)`` bytes per block of ``BLOCK_SIZE``³ cells, 1 where a brick
    of it is stored.
    """

    index: np.ndarray
    coefficients: np.ndarray
    active: np.ndarray
    colors: np.ndarray | None
    blocks: np.ndarray

    @property
    def slots(self) -> int:
        """Bricks stored."""
        return int(np.count_nonzero(self.index[..., 3]))

    @property
    def nbytes(self) -> int:
        """Bytes of every array (what the GPU holds)."""
        parts = (self.index, self.coefficients, self.active, self.colors, self.blocks)
        return int(sum(p.nbytes for p in parts if p is not None))


def _pool(blocks: np.ndarray, places: np.ndarray, grid, edge: int, dtype) -> np.ndarray:
    """The pool texture (x, y, z) with ``blocks[n]`` (edge³) at slot ``places[n]``."""
    gx, gy, gz = grid
    pool = np.zeros((gx, edge, gy, edge, gz, edge), dtype)
    pool[places[:, 0], :, places[:, 1], :, places[:, 2], :] = blocks
    return pool.reshape(gx * edge, gy * edge, gz * edge)


def _brick_blocks(coefficients: np.ndarray, bricks: np.ndarray) -> np.ndarray:
    """``(n, 6, 6, 6)`` float32: each brick's coefficients.

    Past the grid's far sides the last coefficient is repeated: no cell of the grid reads
    those texels (cell ``i`` reads ``i .. i + 2``, at most the last).
    """
    offsets = np.arange(BRICK_COEFFICIENTS)
    first = bricks * BRICK_SIZE
    last = np.asarray(coefficients.shape) - 1
    i, j, k = (np.minimum(first[:, a, None] + offsets[None, :], last[a]) for a in range(3))
    return coefficients[i[:, :, None, None], j[:, None, :, None],
                        k[:, None, None, :]].astype(np.float32)


def surface_bricks(field: SplineField, cells: np.ndarray, colors: bool = False) -> SurfaceBricks:
    """The bricks of ``field`` holding ``cells`` (``(n, 3)`` active cells).

    ``colors``: also pool the field's ``color_values`` (``color_by='field'``).
    """
    dims = np.asarray(field.dimensions)
    counts = -(-dims // BRICK_SIZE)
    cells = np.asarray(cells, dtype=np.int64).reshape(-1, 3)
    bricks, owner = np.unique(cells // BRICK_SIZE, axis=0, return_inverse=True)
    owner = owner.reshape(-1)
    grid = slot_grid(len(bricks), (BRICK_COEFFICIENTS,) * 3)
    if grid is None:
        raise MemoryError(f"{len(bricks)} bricks of active cells do not fit one 3D texture: "
                          "use a coarser grid (fewer cells).")
    number = np.arange(len(bricks))
    places = np.stack([number % grid[0], (number // grid[0]) % grid[1],
                       number // (grid[0] * grid[1])], axis=1)
    index = np.zeros((*counts, 4), np.float32)
    index[bricks[:, 0], bricks[:, 1], bricks[:, 2]] = np.hstack(
        [places, np.ones((len(bricks), 1))])
    flags = np.zeros((len(bricks), BRICK_SIZE, BRICK_SIZE, BRICK_SIZE), np.uint8)
    inside = cells - bricks[owner] * BRICK_SIZE
    flags[owner, inside[:, 0], inside[:, 1], inside[:, 2]] = 1
    coefficients = _pool(_brick_blocks(field.coefficients, bricks), places, grid,
                         BRICK_COEFFICIENTS, np.float32)
    color_pool = None
    if colors:
        color_pool = _pool(_brick_blocks(field.color_values, bricks), places, grid,
                           BRICK_COEFFICIENTS, np.float32)
    return SurfaceBricks(index, coefficients, _pool(flags, places, grid, BRICK_SIZE, np.uint8),
                         color_pool, block_occupancy(index[..., 3] > 0))


def block_occupancy(stored: np.ndarray) -> np.ndarray:
    """Per block of ``BLOCK_SIZE``³ cells (uint8): 1 where any of its bricks is ``stored``."""
    per = BLOCK_SIZE // BRICK_SIZE
    counts = -(-np.asarray(stored.shape) // per)
    padded = np.zeros(tuple(counts * per), bool)
    padded[:stored.shape[0], :stored.shape[1], :stored.shape[2]] = stored
    blocks = padded.reshape(counts[0], per, counts[1], per, counts[2], per).any(axis=(1, 3, 5))
    return blocks.astype(np.uint8)
