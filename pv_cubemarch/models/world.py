"""Voxel worlds (002): a label grid in chunks.

Empty chunks are not stored, uniform ones are one label each.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .voxels import Palette, PlacedGrid, VoxelModel

#: Default chunk edge: well within the largest 3D texture, small enough to skip empty space.
DEFAULT_CHUNK_SIZE = 256


@dataclass(eq=False)
class VoxelWorld(PlacedGrid):
    """Chunks of ``chunk_size``³ voxels (cut at the grid's far sides) of one label grid.

    ``stored``: the chunks that hold several labels (their own arrays); ``uniform``: the
    chunks of one non-zero label; chunks of 0 are neither. Placed like a
    :class:`~pv_cubemarch.models.voxels.VoxelModel` (``grid_from_index``, ``transform``).
    """

    dimensions: tuple[int, int, int]
    chunk_size: int
    palette: Palette
    stored: dict[tuple[int, int, int], np.ndarray] = field(default_factory=dict)
    uniform: dict[tuple[int, int, int], int] = field(default_factory=dict)
    grid_from_index: np.ndarray = field(default_factory=lambda: np.eye(4))
    transform: np.ndarray = field(default_factory=lambda: np.eye(4))
    name: str = "voxels"

    @classmethod
    def from_model(cls, model: VoxelModel, chunk_size: int = DEFAULT_CHUNK_SIZE) -> VoxelWorld:
        """Split ``model``'s labels into chunks (the stored ones copied, so the grid may go)."""
        size = int(chunk_size)
        if size < 1:
            raise ValueError(f"chunk_size must be at least 1, got {chunk_size!r}.")
        world = cls(model.dimensions, size, model.palette, grid_from_index=model.grid_from_index,
                    transform=model.transform, name=model.name)
        counts = [-(-n // size) for n in model.dimensions]
        for key in np.ndindex(*counts):
            block = model.labels[tuple(slice(k * size, (k + 1) * size) for k in key)]
            low, high = int(block.min()), int(block.max())
            if high == 0:
                continue
            if low == high:
                world.uniform[key] = low
            else:
                world.stored[key] = block.copy()
        return world

    def chunk_box(self, key) -> tuple[np.ndarray, tuple[int, int, int]]:
        """The index-space origin and the shape (voxels) of chunk ``key``."""
        origin = np.asarray(key, dtype=np.int64) * self.chunk_size
        shape = tuple(int(min(self.chunk_size, n - o))
                      for o, n in zip(origin, self.dimensions, strict=True))
        return origin, shape

    def chunk_model(self, key) -> VoxelModel:
        """Chunk ``key`` as a grid of its own, placed where it sits in the world.

        A uniform chunk is one voxel stretched over the chunk's box: drawn exactly the same,
        one byte on the GPU.
        """
        origin, shape = self.chunk_box(key)
        local = np.eye(4)
        local[:3, 3] = origin
        if key in self.stored:
            labels = self.stored[key]
        else:
            labels = np.full((1, 1, 1), self.uniform[key],
                             np.uint8 if self.uniform[key] < 256 else np.uint16)
            local[:3, :3] = np.diag(shape)
        return VoxelModel(labels=labels, palette=self.palette,
                          grid_from_index=np.asarray(self.grid_from_index) @ local,
                          transform=self.transform, name=f"{self.name}{list(key)}")

    @property
    def nbytes(self) -> int:
        """Host bytes of the labels kept: the stored chunks (uniform ones: one label)."""
        return sum(int(c.nbytes) for c in self.stored.values()) + 2 * len(self.uniform)
