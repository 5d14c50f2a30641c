"""Label grids from chunked arrays (zarr, dask, h5py, memory maps), read a chunk at a time.

Any object with ``shape``, ``dtype`` and numpy slicing is a source: it is never read whole.
Ids that need compacting are read twice, chunk by chunk: once to find the ids present,
once to write each chunk's rows into a :class:`~pv_cubemarch.models.world.VoxelWorld`.
"""

from __future__ import annotations

import numpy as np

from ..core.budgets import host_budget
from ..core.errors import VolumeDataError
from ..core.parallel import core_pool
from ..core.progress import progress
from .label_ids import (
    IDENTITY_MAX,
    MAX_IDS,
    LabelIds,
    _checked_background,
    distinct,
    distinct_in_runs,
    row_type,
)
from .voxels import Palette
from .world import VoxelWorld
from .zarr_codecs import bounded_array


def is_array_source(value) -> bool:
    """Whether ``value`` is an array-like to read by slices (not a numpy array or a grid)."""
    return (not isinstance(value, np.ndarray) and hasattr(value, "shape")
            and hasattr(value, "dtype") and hasattr(value, "__getitem__")
            and len(getattr(value, "shape", ())) == 3)


def _boxes(shape, size: int):
    counts = [-(-int(n) // size) for n in shape]
    for key in np.ndindex(*counts):
        yield key, tuple(slice(k * size, min((k + 1) * size, int(n)))
                         for k, n in zip(key, shape, strict=True))


def _read(source, box, name: str) -> np.ndarray:
    """One box of the source as an integer numpy array, or a clear error."""
    block = np.asarray(source[box])
    if block.dtype.kind not in "iub":
        raise VolumeDataError(f"{name} has dtype {block.dtype}; label ids are integers.")
    return block.astype(np.uint8) if block.dtype.kind == "b" else block


#: Most chunks a world read from an array keeps (listed, read and indexed in memory).
MAX_WORLD_CHUNKS = 2**21
#: Environment variable: the host bytes a world's stored chunks may take (``4e9``); by
#: default 80 % of the memory the system can give when the world starts filling.
WORLD_BYTES_ENV = "PV_CUBEMARCH_WORLD_BYTES"


def world_bytes_budget() -> int | None:
    """The host bytes a world read from a chunked array may keep (None: no limit known)."""
    return host_budget(WORLD_BYTES_ENV, VolumeDataError)


#: Sources read on several threads at once: numpy arrays and memory maps, zarr and dask
#: arrays (thread-safe reads); any other (h5py, netCDF, a reader of the user's) on one.
THREADED_SOURCES = ("numpy", "zarr", "dask")


def thread_safe(source) -> bool:
    """Whether ``source`` may be read on several threads at once (:data:`THREADED_SOURCES`)."""
    module = type(source).__module__.split(".")[0]
    return isinstance(source, np.ndarray) or module in THREADED_SOURCES


def world_from_array(source, chunk_size: int = 128, background: int = 0, palette=None,
                     name: str = "voxels", progress_bar: bool | None = None,
                     **placement) -> VoxelWorld:
    """A chunked world of the labels in ``source``, read one chunk box at a time.

    ``source``: a zarr array, a dask array, an h5py dataset, a ``numpy.memmap`` or any
    object with ``shape`` (x, y, z), an integer ``dtype`` and slicing. Non-negative ids up
    to 65535 with background 0 are their own rows (one read); other ids are compacted
    across the whole source (two reads, each on several threads where the source allows:
    :func:`thread_safe`): 1, 2 or 4 bytes a voxel by how many there are. ``palette`` as
    :func:`~pv_cubemarch.models.voxels.make_voxels` takes it (by id).
    """
    source = bounded_array(source)   # a zarr array's compression bombs refused as decoded
    shape, size = tuple(int(n) for n in source.shape), int(chunk_size)
    count = int(np.prod([-(-n // max(size, 1)) for n in shape], dtype=np.float64))
    if count > MAX_WORLD_CHUNKS:   # before the boxes are listed (an absurd header's too)
        raise VolumeDataError(
            f"{name!r}: {shape} voxels make {count:,} chunks of {size}³, more than the "
            f"{MAX_WORLD_CHUNKS:,} a world read whole into memory keeps: stream it by bricks "
            "(add_voxels(plotter, [array]) or an OME-Zarr pyramid), or give a larger "
            "chunk_size.")
    boxes = list(_boxes(shape, size))
    with core_pool(len(boxes), most=1 if not thread_safe(source) else None) as threads:
        return _filled_world(threads, source, boxes, chunk_size, background, palette, name,
                             progress_bar, placement)


def _filled_world(threads, source, boxes, chunk_size, background, palette, name,
                  progress_bar, placement) -> VoxelWorld:
    """:func:`world_from_array`, its ``boxes`` read on ``threads``."""
    dtype = np.dtype(source.dtype)
    if dtype.kind not in "iub":
        raise VolumeDataError(f"{name} has dtype {dtype}; label ids are integers.")
    shape = tuple(int(n) for n in source.shape)
    size = int(chunk_size)
    ids = None
    identity = dtype.kind == "b" or (dtype.kind == "u" and dtype.itemsize <= 2
                                     and int(background) == 0)
    within = None
    if not identity:
        background = _checked_background(background, dtype, name)

        def find(box):   # the box's distinct ids, background included
            return distinct_in_runs(_read(source, box, name).ravel())[0]

        within = list(progress(threads.map(find, [box for _, box in boxes]),
                               desc=f"{name}: finding ids", total=len(boxes),
                               enabled=progress_bar))
        found = [values[values != background] for values in within]
        present = distinct(np.concatenate(found)) if found else np.zeros(0, dtype)
        if int(background) == 0 and (present.size == 0 or (
                present.min() >= 0 and present.max() <= IDENTITY_MAX)):
            identity = True
        elif present.size > MAX_IDS:
            raise VolumeDataError(f"{name} holds {present.size} distinct ids; at most "
                                  f"{MAX_IDS} are drawn (rows are read from float32 "
                                  "textures, exact to 2^24).")
        else:
            ids = LabelIds(present, background, dtype)
    if ids is not None:
        ids.lookup(np.zeros(0, dtype))   # its sorted table made once, not by every thread
    rows_type = str(row_type(ids.n_rows)) if ids else "uint8"   # fixed for compacted ids
    world = VoxelWorld(shape, size, Palette.make(None, 2), name=name, label_type=rows_type,
                       **placement)

    def fill(number):   # one box's rows (the world files them in order)
        box = boxes[number][1]
        block = _read(source, box, name)
        if ids is None:
            if block.size and (block.min() < 0 or block.max() > IDENTITY_MAX):
                raise VolumeDataError(f"{name} changed while it was read (ids outside "
                                      f"0..{IDENTITY_MAX} in {box}).")
            return block.astype(np.uint16 if block.size and block.max() > 255 else np.uint8)
        rows, held = ids.block_rows(block, rows_type, within[number])
        within[number] = None
        if not held:
            raise VolumeDataError(f"{name} changed while it was read (an id in {box} was "
                                  "not there on the first pass).")
        return rows

    budget, kept = world_bytes_budget(), 0
    for read, ((key, _), rows) in enumerate(zip(boxes, progress(
            threads.map(fill, range(len(boxes))), desc=f"{name}: filling chunks",
            total=len(boxes), enabled=progress_bar), strict=True)):
        world._keep(key, rows, copy=False)
        kept += world.stored[key].nbytes if key in world.stored else 0
        if budget is not None and kept > budget:
            raise VolumeDataError(
                f"{name}: its chunks need more than the {budget:,} bytes of host memory a "
                f"world may keep ({read + 1} of {len(boxes)} chunks read, {kept:,} bytes "
                "kept), since a grid drawn in chunks holds every chunk that is not one "
                "label. Stream it by bricks instead, reading only what is drawn: "
                "add_voxels(plotter, [array]) (or a pyramid of it: build_pyramid), or "
                f"raise {WORLD_BYTES_ENV}.")
    if ids is not None:
        world.label_ids = ids
        world.palette = Palette.make(palette, ids.n_rows, ids)
    else:
        top = max([int(a.max()) for a in world.stored.values()]
                  + list(world.uniform.values()) + [1])
        world.palette = Palette.make(palette, top + 1)
    return world
