"""Voxel worlds: a label grid in chunks.

Empty chunks are not stored, uniform ones are one label each.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..core.budgets import host_budget
from ..core.errors import VolumeDataError
from ..core.progress import progress
from .image_files import ARRAY_BYTES_ENV
from .label_ids import LabelIds
from .voxels import Palette, PlacedGrid, VoxelModel, checked_labels

#: Default chunk edge (the voxel report's): small enough that empty and uniform chunks take much of
#: a sparse volume, large enough that a hundred chunks cost little more than one grid.
DEFAULT_CHUNK_SIZE = 128


#: The most voxels a world spans (2^42: 16384² x 16384; its tables over the whole world,
#: one byte per 8³ voxels, then take 8 GB).
MAX_WORLD_VOXELS = 2 ** 42


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
    #: The labels' type, the same for every stored chunk: ``'uint8'`` or ``'uint16'``
    #: (``'uint32'``: the rows of compacted ids past 65535, fixed when the world is made).
    label_type: str = "uint8"
    #: Which label id each row stands for (a compacted grid's; by default rows are ids).
    label_ids: LabelIds | None = None

    def __post_init__(self):
        # tables over the whole world (its solid bricks, one byte per 8³ voxels) must fit:
        # a chunk keyed (3000, 3000, 3000) asked numpy for 680 GiB
        dims = [int(n) for n in self.dimensions]
        budget = host_budget(ARRAY_BYTES_ENV, VolumeDataError)
        tables = math.prod(-(-n // 8) for n in dims) if dims else 0
        if len(dims) != 3 or min(dims) < 1 or math.prod(dims) > MAX_WORLD_VOXELS or (
                budget is not None and tables > budget):
            raise VolumeDataError(
                f"Voxel world {self.name!r} spans {dims} voxels; a world holds at most "
                f"{MAX_WORLD_VOXELS:.3g}, and its tables over the whole world (a byte per 8³ "
                f"voxels, {tables:,} here) must fit the memory budget ({ARRAY_BYTES_ENV}): "
                "its chunks' keys reach too far (keys count chunks of "
                f"{self.chunk_size} voxels from the world's corner).")

    @property
    def n_labels(self) -> int:
        """Label ids other than the background the world's tables hold."""
        ids = self.ids
        return ids.n_labels if not ids.identity else self.palette.n_materials - 1

    @property
    def ids(self) -> LabelIds:
        """The id table: the grid's, or the identity over the palette's rows."""
        if self.label_ids is None or self.label_ids.identity:
            return LabelIds(None, 0, self.label_type, n_rows=self.palette.n_materials)
        return self.label_ids

    @classmethod
    def from_model(cls, model: VoxelModel, chunk_size: int = DEFAULT_CHUNK_SIZE) -> VoxelWorld:
        """Split ``model``'s labels into chunks (the stored ones copied, so the grid may go)."""
        size = int(chunk_size)
        if size < 1:
            raise ValueError(f"chunk_size must be at least 1, got {chunk_size!r}.")
        world = cls(model.dimensions, size, model.palette, grid_from_index=model.grid_from_index,
                    transform=model.transform, name=model.name,
                    label_type=str(model.labels.dtype), label_ids=model.ids)
        counts = [-(-n // size) for n in model.dimensions]
        for key in np.ndindex(*counts):
            world._keep(key, model.labels[tuple(slice(k * size, (k + 1) * size) for k in key)])
        return world

    def _keep(self, key, labels: np.ndarray, copy: bool = True) -> None:
        """File chunk ``key``'s labels: nothing when all 0, one label when all one, else a copy.

        Labels above 255 turn the world's (and its stored chunks') type to uint16.
        ``copy=False``: ``labels`` is the world's to keep (no copy when of its type).
        """
        low, high = int(labels.min()), int(labels.max())
        self.stored.pop(key, None)
        self.uniform.pop(key, None)
        if high > 255 and self.label_type == "uint8":
            self.label_type = "uint16"
            for other, kept in self.stored.items():
                self.stored[other] = kept.astype(np.uint16)
        if high == 0:
            return
        if low == high:
            self.uniform[key] = high
        else:
            self.stored[key] = np.array(labels, dtype=self.label_type, copy=copy or None)

    @classmethod
    def from_chunks(cls, chunks: dict, chunk_size: int, palette=None,
                    dimensions: Sequence[int] | None = None, **placement) -> VoxelWorld:
        """A world from chunks placed by hand: ``{(i, j, k): labels}``.

        Chunk ``(i, j, k)`` covers voxels ``i * chunk_size`` to ``(i + 1) * chunk_size`` on x
        (and so on); its labels have that shape (or less at the far sides). ``dimensions``:
        the world's voxels, by default up to the farthest chunk's far side. ``palette``: as
        :func:`~pv_cubemarch.models.voxels.make_voxels` takes it. ``placement``:
        ``grid_from_index``, ``transform``, ``name``.
        """
        size = int(chunk_size)
        if size < 1:
            raise ValueError(f"chunk_size must be at least 1, got {chunk_size!r}.")
        arrays = {}
        for key, labels in chunks.items():
            if len(tuple(key)) != 3 or any(int(k) != k or k < 0 for k in key):
                raise ValueError(f"A chunk key is three whole numbers >= 0, got {key!r}.")
            arrays[tuple(int(k) for k in key)] = checked_labels(labels, f"chunk {key}")
        if dimensions is None:
            far = [0, 0, 0]
            for key, labels in arrays.items():
                far = [max(f, k * size + n) for f, k, n in zip(far, key, labels.shape,
                                                               strict=True)]
            dimensions = tuple(max(f, 1) for f in far)
        top = max([int(a.max()) for a in arrays.values() if a.size] + [1])
        world = cls(tuple(int(n) for n in dimensions), size, Palette.make(palette, top + 1),
                    **placement)
        for key, labels in arrays.items():
            origin, shape = world.chunk_box(key)
            if labels.shape != shape or any(o >= n for o, n in zip(origin, world.dimensions,
                                                                    strict=True)):
                raise ValueError(f"Chunk {key} must have the shape {shape} (chunk_size "
                                 f"{size} cut at the world's far sides), got {labels.shape}.")
            world._keep(key, labels)
        return world

    @classmethod
    def from_function(cls, dimensions: Sequence[int], chunk_size: int, fill,
                      palette=None, progress_bar: bool | None = None,
                      **placement) -> VoxelWorld:
        """A world whose labels ``fill(box)`` gives chunk by chunk (never all at once).

        ``fill`` takes a box of voxels (three slices) and returns its labels (that shape,
        whole numbers); e.g. ``lambda box: terrain(dims, region=box)``. Only chunks that
        hold several labels are kept, so a sparse world larger than memory as one array
        can be made. ``palette``, ``placement``: as :meth:`from_chunks`.
        """
        size = int(chunk_size)
        if size < 1:
            raise ValueError(f"chunk_size must be at least 1, got {chunk_size!r}.")
        dims = tuple(int(n) for n in dimensions)
        counts = [-(-n // size) for n in dims]
        keys = list(np.ndindex(*counts))
        world = cls(dims, size, Palette.make(palette, 2), **placement)
        for key in progress(keys, total=len(keys), desc="filling chunks", enabled=progress_bar):
            box = tuple(slice(k * size, min((k + 1) * size, n)) for k, n in zip(key, dims,
                                                                               strict=True))
            labels = checked_labels(fill(box), f"fill{box}")
            if labels.shape != tuple(s.stop - s.start for s in box):
                raise ValueError(f"fill returned labels of shape {labels.shape} for the box "
                                 f"{box}; it must return that box's shape.")
            world._keep(key, labels)   # only mixed chunks kept as arrays, one at a time
        if palette is None or isinstance(palette, str):   # colours for every label found
            top = max([int(a.max()) for a in world.stored.values()]
                      + list(world.uniform.values()) + [1])
            world.palette = Palette.make(palette, top + 1)
        return world

    @property
    def dtype(self) -> np.dtype:
        """The labels' type (:attr:`label_type`)."""
        return np.dtype(self.label_type)

    def keys_in(self, box) -> list[tuple[int, int, int]]:
        """The chunk keys a box of voxels (three slices) touches."""
        ranges = [range(s.start // self.chunk_size, -(-s.stop // self.chunk_size))
                  for s in box]
        return [tuple(r[i] for r, i in zip(ranges, k, strict=True))
                for k in np.ndindex(*(len(r) for r in ranges))]

    def chunk_labels(self, key) -> np.ndarray:
        """Chunk ``key``'s labels as a full array (a new one for uniform and empty chunks)."""
        if key in self.stored:
            return self.stored[key]
        return np.full(self.chunk_box(key)[1], self.uniform.get(key, 0), self.dtype)

    def labels_in(self, box) -> np.ndarray:
        """A copy of the labels in a box of voxels (three slices), from the chunks."""
        out = np.zeros([s.stop - s.start for s in box], self.dtype)
        for key, inner, local in self.pieces(box):
            if key in self.stored:
                out[local] = self.stored[key][inner]
            elif key in self.uniform:
                out[local] = self.uniform[key]
        return out

    def write(self, box, values: np.ndarray) -> list[tuple[int, int, int]]:
        """Write ``values`` into a box of voxels; returns the chunks whose kind changed.

        A chunk changes kind when it goes from empty or uniform to stored (an edit of part
        of it), to another single label, or from stored to one label or empty; otherwise a
        stored chunk changes in place. Labels above 255 in a uint8 world change every
        stored chunk's type (all returned).
        """
        changed = []
        if values.size and int(values.max()) > 255 and self.label_type == "uint8":
            self.label_type = "uint16"   # every stored chunk's texture is made again
            changed += list(self.stored)
            for key, kept in self.stored.items():
                self.stored[key] = kept.astype(np.uint16)
        for key, inner, local in self.pieces(box):
            piece = values[local]
            if key in self.stored:
                labels = self.stored[key]
                labels[inner] = piece
                if labels.min() != labels.max():
                    continue
            elif not (piece != self.uniform.get(key, 0)).any():
                continue
            else:
                labels = self.chunk_labels(key)
                labels[inner] = piece
            self._keep(key, labels)   # a stored chunk all one label (or 0) is one no more
            if key not in changed:
                changed.append(key)
        return changed

    def pieces(self, box):
        """Per chunk a box touches: its key, the box's part in the chunk and in the box.

        Both parts are three slices: in the chunk's voxels and in the box's.
        """
        for key in self.keys_in(box):
            origin, shape = self.chunk_box(key)
            low = [max(s.start, o) for s, o in zip(box, origin, strict=True)]
            high = [min(s.stop, o + n) for s, o, n in zip(box, origin, shape, strict=True)]
            if any(h <= lo for lo, h in zip(low, high, strict=True)):
                continue
            inner = tuple(slice(lo - o, h - o) for lo, h, o in zip(low, high, origin,
                                                                   strict=True))
            local = tuple(slice(lo - s.start, h - s.start) for lo, h, s in zip(low, high, box,
                                                                               strict=True))
            yield key, inner, local

    def chunk_box(self, key) -> tuple[np.ndarray, tuple[int, int, int]]:
        """The index-space origin and the shape (voxels) of chunk ``key``."""
        origin = np.asarray(key, dtype=np.int64) * self.chunk_size
        shape = tuple(int(min(self.chunk_size, n - o))
                      for o, n in zip(origin, self.dimensions, strict=True))
        return origin, shape

    def chunk_model(self, key, whole: bool = False) -> VoxelModel:
        """Chunk ``key`` as a grid of its own, placed where it sits in the world.

        A uniform chunk is one voxel stretched over the chunk's box: drawn exactly the same,
        one byte on the GPU (``whole``: all its voxels, e.g. to export it).
        """
        origin, shape = self.chunk_box(key)
        local = np.eye(4)
        local[:3, 3] = origin
        if key in self.stored or whole:
            labels = self.chunk_labels(key)
        else:
            value = self.uniform[key]
            labels = np.full((1, 1, 1), value, np.uint8 if value < 256 else
                             np.uint16 if value < 65536 else np.uint32)
            local[:3, :3] = np.diag(shape)
        return VoxelModel(labels=labels, palette=self.palette,
                          grid_from_index=np.asarray(self.grid_from_index) @ local,
                          transform=self.transform, name=f"{self.name}{list(key)}")

    def drawn_labels(self, opaque_only: bool = False) -> np.ndarray:
        """Per label value the world's type holds: drawn (shown by the palette) or not.

        For 4-byte rows (compacted ids past 65535), per row of the palette. ``opaque_only``:
        translucent labels count as not drawn (they are composited apart).
        """
        size = int(np.iinfo(self.dtype).max) + 1 if self.dtype.itemsize <= 2 else max(
            self.palette.n_materials, 2)
        table = np.zeros(size, bool)
        visible = self.palette.visible
        if opaque_only:
            visible = visible & (self.palette.rgba[:, 3] >= 1.0)
        visible = visible[:len(table)]
        table[:len(visible)] = visible
        return table

    def solid_bricks(self, brick: int, opaque_only: bool = False) -> np.ndarray | None:
        """Per brick of ``brick``³ voxels, whether every voxel in it is drawn (shown label).

        A ray that reaches such a brick has hit a drawn voxel: the bricks' faces bound every
        ray's first hit (the world's occluders). Bricks cut by the grid's far sides count as
        not solid. ``None`` when ``brick`` does not divide the chunk size. ``opaque_only``:
        as :meth:`drawn_labels`.
        """
        if self.chunk_size % brick:
            return None
        per_chunk = self.chunk_size // brick
        solid = np.zeros([-(-n // brick) for n in self.dimensions], bool)
        shown = self.drawn_labels(opaque_only)
        for key in set(self.stored) | set(self.uniform):
            origin, shape = self.chunk_box(key)
            cells = [n // brick for n in shape]   # whole bricks only
            start = [k * per_chunk for k in key]
            where = tuple(slice(a, a + c) for a, c in zip(start, cells, strict=True))
            if key in self.uniform:
                solid[where] = bool(shown[self.uniform[key]])
                continue
            solid[where] = _all_drawn(shown[self.stored[key]], brick, cells)
        return solid

    def solid_bricks_in(self, brick: int, box, opaque_only: bool = False
                        ) -> tuple[tuple[slice, ...], np.ndarray]:
        """The whole bricks a box of voxels touches, and which are solid.

        As :meth:`solid_bricks` finds them; the bricks are three slices of brick cells.
        """
        cells = tuple(slice(s.start // brick, min(-(-s.stop // brick), n // brick))
                      for s, n in zip(box, self.dimensions, strict=True))
        counts = [max(c.stop - c.start, 0) for c in cells]
        if 0 in counts:
            return cells, np.zeros(counts, bool)
        region = tuple(slice(c.start * brick, c.stop * brick) for c in cells)
        return cells, _all_drawn(self.drawn_labels(opaque_only)[self.labels_in(region)], brick,
                                 counts)

    @property
    def nbytes(self) -> int:
        """Host bytes of the labels kept: the stored chunks (uniform ones: one label)."""
        return sum(int(c.nbytes) for c in self.stored.values()) + 2 * len(self.uniform)


def _all_drawn(drawn: np.ndarray, brick: int, cells) -> np.ndarray:
    """Per brick of the first ``cells`` bricks of a drawn-voxel mask: all of it drawn."""
    drawn = drawn[tuple(slice(0, c * brick) for c in cells)]
    return drawn.reshape(cells[0], brick, cells[1], brick, cells[2], brick).all(axis=(1, 3, 5))
