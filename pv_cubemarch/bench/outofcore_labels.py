"""``bench outofcore``'s label scenes: a procedural segmentation streamed by bricks.

``labels`` (by default 16384 x 16384 x 4096 uint32 ids, 4 TiB) and ``labels-small`` (the
same field, 384³: drawn whole in memory by ``add_voxels`` too, the image every row is
compared with, pixel by pixel). The field: cells of a lattice (45 voxels a side), each filled
with an id hashed from its position where a few octaves of waves at its centre are positive,
else empty, computed when sliced, never stored. A coarse level's point holds the id at the
centre of its block, a real label (the most frequent id would mean reading the whole block;
below the lattice's size the two are the same).
"""

from __future__ import annotations

import numpy as np

from ..api import add_voxels
from ..models.multiscale import Level, MultiscaleSource
from .outofcore_rows import (
    OutOfCoreRow,
    halved_pyramid,
    separable_waves,
    stream_row,
    wave_octaves,
    whole_row,
)

LABEL_SCENES = ("labels", "labels-small")
#: Voxels along a lattice cell's edge: no power of two divides it, so the cells' borders
#: fall inside coarse voxels (a multiple of the levels' factors would make every level
#: draw the finest image exactly).
CELL = 45


class CellLevel:
    """One level of the procedural segmentation (module docstring), computed when sliced."""

    def __init__(self, shape, finest, level: int, seed: int = 1, octaves: int = 3):
        self.shape = tuple(int(n) for n in shape)
        self.finest = tuple(int(n) for n in finest)
        self.dtype = np.dtype(np.uint32)
        self.ndim = 3
        self.level = int(level)
        self.waves = wave_octaves(1.0, 1.6, (0.1, 0.3), octaves, seed)

    def __getitem__(self, box):
        box = tuple(slice(*s.indices(n)) for s, n in zip(box, self.shape, strict=True))
        factor = 2 ** self.level
        voxels = [np.minimum((np.arange(s.start, s.stop, s.step) * factor + factor // 2), n - 1)
                  for s, n in zip(box, self.finest, strict=True)]
        cells = [v // CELL for v in voxels]
        wave = separable_waves(self.waves, [c + 0.5 for c in cells])
        cx, cy, cz = (c.astype(np.uint64) for c in cells)
        with np.errstate(over="ignore"):
            ids = ((cx[:, None, None] * np.uint64(0x9E3779B1))
                   ^ (cy[None, :, None] * np.uint64(0x85EBCA77))
                   ^ (cz[None, None, :] * np.uint64(0xC2B2AE3D))) & np.uint64(0x7FFFFFFF)
        return np.where(wave > 0.2, ids.astype(np.uint32) + 1, 0).astype(np.uint32)


def cell_source(shape, coarsest: int = 256) -> MultiscaleSource:
    """The segmentation's pyramid: levels halved until the largest side is ``coarsest``."""
    finest = tuple(int(n) for n in shape)
    return halved_pyramid(lambda size, number: CellLevel(size, finest, number), finest,
                          coarsest, "cells")


def wrong_pixels(row: OutOfCoreRow, image: np.ndarray, expected: np.ndarray) -> None:
    """The share of pixels whose colour differs from the in-memory image (> 2/255)."""
    differs = np.abs(image.astype(int) - expected.astype(int)).max(axis=-1) > 2
    row.wrong_percent = 100.0 * float(differs.mean())


def in_memory_labels_row(scene, view, source, extent, size) -> tuple[OutOfCoreRow, np.ndarray]:
    """The finest level read whole and drawn by ``add_voxels``: the reference image."""
    def draw(pl):
        finest = source.levels[0]
        labels = finest.read(tuple(slice(0, n) for n in finest.shape))
        return add_voxels(pl, labels, transform=_index_to_world(finest)), labels.nbytes

    return whole_row(scene, view, extent, size, draw)


def _index_to_world(level: Level) -> np.ndarray:
    """A grid drawn whole: voxel i spans [i, i + 1], centred as the level places point i."""
    matrix = level.physical_from_index()
    shift = np.eye(4)
    shift[:3, 3] = -0.5
    return matrix @ shift


def label_rows(scene: str, views, size, shape, small: int, gpu_bytes: int, host_bytes: int,
               timeout: float) -> list[OutOfCoreRow]:
    """Every row of a label scene and its views (the module docstring's)."""
    source = cell_source(shape) if scene == "labels" else cell_source((small,) * 3, 48)
    finest = source.levels[0]
    extent = (np.asarray(finest.shape) - 1) * finest.scale + finest.translation
    fits = source.nbytes <= 2**30
    rows = []
    for view in views:
        expected = None
        if fits:
            row, expected = in_memory_labels_row(scene, view, source, extent, size)
            rows.append(row)
        for name, bias in (("ours", 0.0), ("ours, finest everywhere", -64.0),
                           ("coarsest level only", 64.0)):
            if bias < -1 and not fits:
                continue

            def add(pl, bias=bias):
                return add_voxels(pl, source, lod_bias=bias, gpu_bytes=gpu_bytes,
                                  host_bytes=host_bytes)

            rows.append(stream_row(scene, view, name, add, source, extent, size, timeout,
                                   expected, wrong_pixels)[0])
    return rows
