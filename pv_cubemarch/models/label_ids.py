"""Label ids of any integer type, stored on the GPU as dense rows of a per-id table.

A segmentation's ids (uint32 cell ids, uint64 connectome segments, negative grain ids) are
compacted on upload: row 0 is the background, rows ``1..n`` the present ids, sorted. The
grid the GPU reads holds rows (1, 2 or 4 bytes a voxel, whatever the ids' width), and every
per-label property (colour, opacity, hidden, highlighted) is one entry of a table indexed by
row, so changing it never touches the labels. Grids of small non-negative ids with
background 0 keep their ids as rows (the identity table): palettes indexed by material
number read as before.
"""

from __future__ import annotations

import numbers

import numpy as np

from ..core.errors import VolumeDataError
from ..core.parallel import core_pool
from ..core.progress import progress

#: Largest id an identity table holds (ids stored as uint16).
IDENTITY_MAX = 65535

#: Most distinct ids a grid may hold: rows are read from a float32 texture, exact to 2^24.
MAX_IDS = 2**24 - 1

#: Distinct ids up to which a random binary search per voxel stays in cache.
CACHED_KEYS = 1 << 16

#: Voxels per slab when ids are compacted (bounds the temporary memory to a few slabs, one
#: per core at a time).
SLAB_VOXELS = 1 << 22

#: Largest grid of incoherent ids compacted by one sort of the whole grid.
AT_ONCE_VOXELS = 1 << 24


def row_type(n_rows: int) -> np.dtype:
    """The narrowest unsigned type whose values reach row ``n_rows - 1``."""
    if n_rows <= 256:
        return np.dtype(np.uint8)
    if n_rows <= 65536:
        return np.dtype(np.uint16)
    return np.dtype(np.uint32)


class LabelIds:
    """Which label id each row of a grid's tables stands for.

    Parameters
    ----------
    ids : numpy.ndarray or None
        The present ids other than the background, one per row from 1 on (sorted when made
        by :func:`compact_labels`; edits may append). ``None``: the identity table (row ``m``
        is id ``m``, background 0).
    background : int
        The id drawn as empty (row 0).
    dtype : numpy.dtype
        The ids' type as the user gave them (what :meth:`ids_of` returns).
    """

    def __init__(self, ids: np.ndarray | None = None, background: int = 0,
                 dtype=np.uint16, n_rows: int | None = None):
        self.dtype = np.dtype(dtype)
        self.background = background
        self._ids = None if ids is None else np.asarray(ids, dtype=self.dtype).ravel()
        #: For the identity table: its rows (the palette's length, which may exceed the ids).
        self.identity_rows = n_rows
        self._sorted: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def identity(self) -> bool:
        """Whether rows are the ids themselves (non-negative ids, background 0)."""
        return self._ids is None

    @property
    def ids(self) -> np.ndarray:
        """The id of each row from 1 on (for the identity table: ``1..n_rows - 1``)."""
        if self._ids is None:
            return np.arange(1, self.n_rows, dtype=np.int64)
        return self._ids

    @property
    def n_rows(self) -> int:
        """Rows of the per-label tables, background included."""
        if self._ids is None:
            return int(self.identity_rows or 2)
        return int(self._ids.size) + 1

    @property
    def n_labels(self) -> int:
        """Ids other than the background."""
        return self.n_rows - 1

    def ids_of(self, rows) -> np.ndarray:
        """The ids of ``rows`` (row 0: the background), in the ids' own type."""
        rows = np.asarray(rows, dtype=np.int64)
        if self._ids is None:
            return rows.astype(self.dtype if self.dtype.kind in "iu" else np.int64)
        table = np.concatenate([np.array([self.background], self.dtype), self._ids])
        return table[rows]

    def id_of(self, row: int):
        """One row's id, as a Python int."""
        return int(self.ids_of([int(row)])[0])

    def rows_of(self, ids, name: str = "ids") -> np.ndarray:
        """The rows of ``ids``; an id the grid does not hold is an error naming it."""
        values = _as_ids(ids, name)
        if self._ids is None:
            bad = (values < 0) | (values >= self.n_rows)
            if bad.any():
                raise ValueError(f"{name}: label {values[bad][0]} is not in the grid (its "
                                 f"labels are 0..{self.n_rows - 1}).")
            return values.astype(np.int64)
        rows, found = self.lookup(values)
        if not found.all():
            missing = values[~found][0]
            raise ValueError(f"{name}: label {missing} is not in the grid ({self.n_labels} "
                             "labels; actor.cubemarch.label_ids lists them).")
        return rows

    def has(self, ids) -> np.ndarray:
        """Per id: whether the grid holds it (the background counts)."""
        values = _as_ids(ids, "ids")
        if self._ids is None:
            return (values >= 0) & (values < self.n_rows)
        return self.lookup(values)[1]

    def _sorted_table(self) -> tuple[np.ndarray, np.ndarray]:
        """Background and ids sorted, and the row of each (made once)."""
        if self._sorted is None:
            table = np.concatenate([np.array([self.background], self.dtype), self._ids])
            order = np.argsort(table, kind="stable")
            self._sorted = (table[order], order)
        return self._sorted

    def block_rows(self, block: np.ndarray, dtype,
                   within: np.ndarray | None = None) -> tuple[np.ndarray, bool]:
        """Rows (``dtype``) of a block of a compacted grid's ids, and whether all are held.

        One search per run of equal ids, as compaction does. ``within``: the block's
        distinct ids (sorted), if known: each run is then searched among those few (in
        cache), and only they in the whole table (4x faster for 10^6 ids).
        """
        flat = block.reshape(-1, order="A") if block.flags.forc else block.ravel()
        heads = run_heads(flat)
        values = flat[heads]
        if within is None:
            keys, order = self._sorted_table()
            values, fits = _fitted(values, keys.dtype)
        else:
            keys = np.asarray(within, dtype=flat.dtype)
            order, found = self.lookup(keys)
            fits = np.array([found.all()])
        at = np.clip(np.searchsorted(keys, values), 0, len(keys) - 1)
        held = bool(fits.all() and (keys[at] == values).all())
        rows = np.repeat(order[at].astype(dtype), np.diff(np.append(heads, flat.size)))
        return rows.reshape(block.shape, order="F" if block.flags.f_contiguous
                            and not block.flags.c_contiguous else "C"), held

    def lookup(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rows of integer ``values`` and whether each is held (background: row 0)."""
        keys, order = self._sorted_table()
        values, fits = _fitted(values, keys.dtype)
        at = np.clip(np.searchsorted(keys, values), 0, len(keys) - 1)
        return order[at].astype(np.int64), fits & (keys[at] == values)


def _as_ids(ids, name: str) -> np.ndarray:
    """``ids`` (an int, a sequence, an array) as a 1D integer array, or an error naming it.

    Python ints keep their value whatever it is: int64 where all fit, else uint64.
    """
    if isinstance(ids, np.ndarray) and ids.dtype.kind in "iu":
        return ids.ravel()
    if isinstance(ids, (set, frozenset)):
        ids = sorted(ids)
    items = np.asarray(ids, dtype=object).ravel()
    try:
        values = [_whole(v) for v in items]
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name} must be integer label ids, got {ids!r}.") from None
    if all(-2**63 <= v < 2**63 for v in values):
        return np.asarray(values, dtype=np.int64)
    if all(0 <= v < 2**64 for v in values):
        return np.asarray(values, dtype=np.uint64)
    return np.asarray(values, dtype=object)   # past either type: matched one by one


def _whole(value) -> int:
    """One id as a Python int; bools and non-integer numbers are refused."""
    if isinstance(value, (bool, np.bool_, str, bytes)):
        raise TypeError(value)
    if isinstance(value, (float, np.floating)):
        if not float(value).is_integer():
            raise ValueError(value)
        return int(value)
    return int(np.asarray(value).item()) if isinstance(value, np.generic) else int(value)


def _fitted(values: np.ndarray, dtype) -> tuple[np.ndarray, np.ndarray]:
    """``values`` cast to ``dtype``, and per value whether it fits (one that does not is no id)."""
    dtype = np.dtype(dtype)
    if values.dtype.kind == "O":
        info = np.iinfo(dtype)
        fits = np.array([info.min <= v <= info.max for v in values], dtype=bool)
        return np.array([v if ok else 0 for v, ok in zip(values, fits, strict=True)],
                        dtype=dtype), fits
    if np.can_cast(values.dtype, dtype):
        return values.astype(dtype), np.ones(values.shape, bool)
    info, own = np.iinfo(dtype), np.iinfo(values.dtype)
    fits = np.ones(values.shape, bool)
    if own.min < info.min:
        fits &= values >= info.min
    if own.max > info.max:
        fits &= values <= info.max
    return np.where(fits, values, 0).astype(dtype), fits


def _check_count(count: int, name: str) -> None:
    """Refuse more distinct ids than float32 rows read back exactly."""
    if count > MAX_IDS:
        raise VolumeDataError(f"{name} holds {count} distinct labels; at most {MAX_IDS} are "
                              "drawn (their rows are read exactly from a float32 texture).")


def sorted_unique(values: np.ndarray) -> np.ndarray:
    """Distinct integer rows, ascending; no work where they already are (changed rows)."""
    values = np.asarray(values, dtype=np.int64).ravel()
    if values.size < 2 or bool(np.all(values[1:] > values[:-1])):
        return values
    return distinct(values)


def distinct(values: np.ndarray) -> np.ndarray:
    """The sorted distinct values of a flat integer array, by the faster of two ways.

    numpy's ``unique`` hashes, fast for few distinct values and many times slower than a
    sort for millions (20x for 2^24 random uint64 here); a sample decides.
    """
    sample = values[:65536]
    if np.unique(sample).size < 4096:
        return np.unique(values)
    ordered = np.sort(values)
    return ordered[np.concatenate([[True], ordered[1:] != ordered[:-1]])]


def compact_labels(values: np.ndarray, background: int = 0,
                   name: str = "labels") -> tuple[np.ndarray, LabelIds]:
    """Label ids of any integer type as dense rows, and the table of which id each row is.

    Segmentations are coherent: a cell's voxels come in runs, so the distinct ids are found
    among the runs' first values and each run's row by one binary search, slab by slab on
    every core (0.13 s against 0.6 s for one sort of a 256³ Voronoi grid of 30,000 uint32
    ids); only a small grid of incoherent ids (no runs) is sorted whole, which gives its ids
    and rows at once. Memory beyond the input is the rows (1-4 bytes a voxel), the runs'
    starts where runs are long (at most a byte a voxel) and a few slabs' temporaries. Rows
    keep the order of the ids.
    """
    values = np.asarray(values)
    if values.dtype.kind not in "iu":
        raise VolumeDataError(f"{name} has dtype {values.dtype}; label ids are integers.")
    background = _checked_background(background, values.dtype, name)
    flat = values.reshape(-1, order="A") if values.flags.forc else values.ravel()
    if flat.size <= AT_ONCE_VOXELS and values.dtype.itemsize >= 4 and 2 * run_heads(
            flat).size > flat.size:
        # incoherent ids in a small grid: one sort gives the ids and the rows together
        return _compact_at_once(values, flat, background, name)
    bar = None if flat.size > 4 * SLAB_VOXELS else False

    def find(part):
        present, heads = distinct_in_runs(part)
        return present, (heads if 8 * heads.size <= part.size else None)   # kept if short

    found = each_slab(find, flat, f"{name}: finding ids", bar)
    present = distinct(np.concatenate([f[0] for f in found])) if len(found) > 1 \
        else found[0][0]
    present = present[present != background]
    _check_count(present.size, name)
    dtype = row_type(present.size + 1)
    table = np.concatenate([np.array([background], values.dtype), present])
    order = np.argsort(table, kind="stable")
    keys = table[order]
    rows = np.empty(values.shape, dtype=dtype, order="F" if values.flags.f_contiguous
                    and not values.flags.c_contiguous else "C")
    out = rows.reshape(-1, order="A") if rows.flags.forc else rows.ravel()

    def write(part, number):
        start = number * SLAB_VOXELS
        out[start:start + part.size] = _rows_of_slab(part, keys, order, dtype,
                                                     found[number][1])
        found[number] = None   # its runs' starts are done with

    each_slab(write, flat, f"{name}: compacting ids", bar, numbered=True)
    return rows, LabelIds(present, background, values.dtype)


def each_slab(function, flat: np.ndarray, desc: str, bar: bool | None,
              numbered: bool = False) -> list:
    """``function(slab)`` for every slab of :data:`SLAB_VOXELS` of ``flat``, in slab order.

    On a thread per core (numpy's loops release the GIL), with a progress bar;
    ``numbered``: ``function(slab, number)``.
    """
    starts = range(0, flat.size, SLAB_VOXELS)

    def one(number):
        part = flat[starts[number]:starts[number] + SLAB_VOXELS]
        return function(part, number) if numbered else function(part)

    if len(starts) == 1:
        return [one(0)]
    with core_pool(len(starts)) as pool:
        return list(progress(pool.map(one, range(len(starts))), desc=desc,
                             total=len(starts), enabled=bar))


def distinct_in_runs(part: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The sorted distinct values of a flat array, and :func:`run_heads` of it.

    Found among the runs' first values when runs are long (a segmentation's cells).
    """
    heads = run_heads(part)
    return distinct(part[heads] if 2 * heads.size <= part.size else part), heads


def run_heads(part: np.ndarray) -> np.ndarray:
    """Where each run of equal values in a flat array starts (index 0 always)."""
    change = np.empty(part.size, bool)
    change[:1] = True
    np.not_equal(part[1:], part[:-1], out=change[1:])
    return np.flatnonzero(change)


def _compact_at_once(values: np.ndarray, flat: np.ndarray, background,
                     name: str) -> tuple[np.ndarray, LabelIds]:
    """:func:`compact_labels` of a small grid of incoherent ids: one stable sort at once.

    It gives the ids and every voxel's rank together: half the time of two passes for a
    million ids in 7 million voxels.
    """
    within = np.argsort(flat, kind="stable")
    ordered = flat[within]
    heads = np.empty(flat.size, bool)
    heads[0] = True
    heads[1:] = ordered[1:] != ordered[:-1]
    table = ordered[heads]                      # the distinct ids, ascending
    rank = np.cumsum(heads) - 1                  # each sorted voxel's id among them
    where = int(np.searchsorted(table, background))
    has_background = where < table.size and table[where] == background
    present = np.delete(table, where) if has_background else table
    _check_count(present.size, name)
    # rows: background 0, present ids 1.. in ascending order (the rank, past the background)
    row = np.arange(table.size) + 1
    if has_background:
        row[where] = 0
        row[where + 1:] -= 1
    dtype = row_type(present.size + 1)
    out = np.empty(flat.size, dtype)
    out[within] = row.astype(dtype)[rank]
    order = "F" if values.flags.f_contiguous and not values.flags.c_contiguous else "C"
    rows = out.reshape(values.shape, order=order)
    return rows, LabelIds(present, background, values.dtype)


def _rows_of_slab(part: np.ndarray, keys: np.ndarray, order: np.ndarray, dtype,
                  heads: np.ndarray | None = None) -> np.ndarray:
    """Rows of one slab's ids: one binary search per run of equal ids.

    Segmentations are coherent (runs of a cell's voxels), so runs are few; where they are
    not and the ids are many (random access into a large table misses the cache), the
    search runs in the slab's sorted order instead. ``heads``: :func:`run_heads` of
    ``part``, if already found.
    """
    heads = run_heads(part) if heads is None else heads
    if keys.size > CACHED_KEYS and 2 * heads.size > part.size:
        within = np.argsort(part)
        rows = np.empty(part.size, dtype)
        rows[within] = order[np.searchsorted(keys, part[within])]
        return rows
    lengths = np.diff(np.append(heads, part.size))
    return np.repeat(order[np.searchsorted(keys, part[heads])].astype(dtype), lengths)


def _checked_background(background, dtype: np.dtype, name: str):
    """``background`` as an int the ids' type holds, or an error naming it."""
    check_background_id(background)
    info = np.iinfo(dtype)
    if not info.min <= int(background) <= info.max:
        raise ValueError(f"background={background} is outside the range of {name} "
                         f"({dtype}: {info.min}..{info.max}); give an id the labels' type "
                         "holds (0 by default).")
    return dtype.type(int(background))


def check_background_id(background) -> None:
    """Refuse a ``background`` that is not an integer id (NaN, 2.5, "0", True)."""
    if isinstance(background, (bool, np.bool_)) or not isinstance(background, numbers.Integral):
        raise VolumeDataError(f"background={background!r}: the id drawn as empty is an "
                              "integer label id (0 by default).")


def label_rows(values: np.ndarray, background: int = 0,
               name: str = "labels") -> tuple[np.ndarray, LabelIds]:
    """Rows and their id table for integer labels: the ids themselves when they can be.

    Non-negative ids up to :data:`IDENTITY_MAX` with background 0 are their own rows
    (uint8 up to 255, else uint16, as material grids always were); anything else
    (wider types with large ids, negative ids, another background) is compacted.
    """
    values = np.asarray(values)
    if values.dtype.kind == "b":
        values = values.astype(np.uint8)
    check_background_id(background)
    low, high = values.min(), values.max()
    if int(background) == 0 and low >= 0 and high <= IDENTITY_MAX:
        dtype = np.uint8 if high <= 255 else np.uint16
        ids = LabelIds(None, 0, values.dtype, n_rows=int(high) + 1)
        return np.ascontiguousarray(values.astype(dtype)), ids
    return compact_labels(values, background, name)
