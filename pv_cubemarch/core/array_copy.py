"""Copies between arrays of different memory orders, tile by tile.

A 3D array copied into another order (a C-ordered grid into the x-fastest layout GL
textures take) is a strided transpose: element by element, each read a cache and TLB miss.
Copied in cubes of a few kilobytes both sides stay in cache: 3x faster for 512³ uint32.
"""

from __future__ import annotations

import itertools

import numpy as np

from .parallel import core_pool

#: Edge of the cubes copied at once: 16³ elements (16-64 KiB) kept in cache on both sides.
TILE = 16


def copy_tiled(destination: np.ndarray, source: np.ndarray, tile: int = TILE) -> None:
    """``destination[...] = source`` for 3D (or 3D + components) arrays, by cubes.

    A plain assignment when both have the same memory order (already streaming).
    """
    if source.shape != destination.shape:
        raise ValueError(f"copy_tiled: shapes differ, {source.shape} and {destination.shape}.")
    same = (destination.flags.c_contiguous and source.flags.c_contiguous) or (
        destination.flags.f_contiguous and source.flags.f_contiguous)
    if same or source.ndim < 3 or source.size <= tile ** 3:
        destination[...] = source
        return
    def rows(i):   # one slab of tiles along the first axis
        for j, k in itertools.product(*(range(0, n, tile) for n in source.shape[1:3])):
            box = (slice(i, i + tile), slice(j, j + tile), slice(k, k + tile))
            destination[box] = source[box]

    starts = range(0, source.shape[0], tile)
    with core_pool(len(starts)) as pool:
        list(pool.map(rows, starts))   # numpy copies release the GIL
