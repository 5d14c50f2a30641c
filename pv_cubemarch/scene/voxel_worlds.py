"""Voxel worlds from a stage: Volume prims that are chunks of one world, joined.

A voxels ``Volume`` with ``cubemarch:world`` (the world's name) and ``cubemarch:chunk``
(``int3``, the chunk's place in the world's layout) is one chunk; ``cubemarch:chunkSize``
(``int``) gives the layout's edge, by default the largest chunk's longest side. Every chunk
of a world must sit where its key says in one placement (the same voxel size and axes, its
corner at ``key * chunkSize`` voxels from the world's), share the palette and options; the
world is then one :class:`~pv_cubemarch.models.world.VoxelWorld`, drawn as add_voxels draws
worlds.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..core.errors import SceneLoadError
from ..models.voxels import VoxelModel
from ..models.world import VoxelWorld


@dataclass
class ChunkPrim:
    """One chunk as a stage gives it: its key, grid, options and prim path."""

    key: tuple[int, int, int]
    model: VoxelModel
    options: dict
    path: str
    chunk_size: int | None = None
    #: The chunk's palette for a world whose largest label is the argument (its own
    #: authored palette, or a colormap's that many colours): chunks compare them on one
    #: footing, whatever labels each happens to hold.
    palette_for: Callable | None = None


def join_world(name: str, chunks: list[ChunkPrim]) -> tuple[VoxelWorld, dict]:
    """The world the chunks make, and its options.

    A SceneLoadError names a chunk that does not fit.
    """
    sizes = {c.chunk_size for c in chunks if c.chunk_size is not None}
    if len(sizes) > 1:
        raise SceneLoadError(f"Voxel world {name!r}: its chunks give different "
                             f"cubemarch:chunkSize values {sorted(sizes)}; give one.")
    size = sizes.pop() if sizes else max(max(c.model.dimensions) for c in chunks)
    first = chunks[0]
    placement = _world_placement(first, size)
    seen = set()
    for chunk in chunks:
        if chunk.key in seen:
            raise SceneLoadError(f"Voxel world {name!r}: two chunks at {chunk.key} "
                                 f"(one is {chunk.path}).")
        seen.add(chunk.key)
        if not np.allclose(_world_placement(chunk, size), placement,
                           atol=1e-6 * max(1.0, float(np.abs(placement).max()))):
            raise SceneLoadError(f"Voxel world {name!r}: chunk {chunk.path} at {chunk.key} is "
                                 f"not where chunk {first.path} puts it (its corner must be "
                                 f"{size} voxels per key step from the world's, with the same "
                                 "voxel size and axes).")
        if chunk.options != first.options:
            raise SceneLoadError(f"Voxel world {name!r}: chunk {chunk.path} has options "
                                 f"{chunk.options}, chunk {first.path} {first.options}; the "
                                 "chunks of a world share them.")
    top = max(int(c.model.labels.max()) for c in chunks)
    palettes = [c.palette_for(top) if c.palette_for is not None else c.model.palette
                for c in chunks]
    for chunk, palette in zip(chunks, palettes, strict=True):
        if not np.array_equal(palette.rgba, palettes[0].rgba):
            raise SceneLoadError(f"Voxel world {name!r}: chunk {chunk.path} has another "
                                 f"palette than {first.path}; the chunks of a world share it.")
    world = VoxelWorld.from_chunks({c.key: c.model.labels for c in chunks}, size,
                                   palette=palettes[0], grid_from_index=placement, name=name)
    return world, dict(first.options)


def _world_placement(chunk: ChunkPrim, size: int) -> np.ndarray:
    """The world's index-to-world matrix as this chunk's placement and key imply it."""
    shift = np.eye(4)
    shift[:3, 3] = -np.asarray(chunk.key, dtype=np.float64) * size
    return chunk.model.world_from_index() @ shift
