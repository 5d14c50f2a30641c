"""Empty-space skipping: per-brick largest extinction, built once per volume and table.

A brick covers ``brick_size`` cells per axis; a sample in those cells interpolates points of
the brick's closed range, so the brick's min and max over that range bound every value the
ray can read there. Mapped through the transfer table, a zero maximum means the brick adds
nothing to the image and the marcher steps over it in one go.
"""

from __future__ import annotations

import numpy as np

from ..models.transfer import TransferFunction

DEFAULT_BRICK_SIZE = 8


def _block_reduce(values: np.ndarray, brick: int, reduce) -> np.ndarray:
    """Reduce each axis over closed ranges [b*brick, (b+1)*brick] of point indices."""
    out = values
    for axis in range(3):
        n = out.shape[axis]
        count = max(1, int(np.ceil((n - 1) / brick)))
        pad = count * brick + 1 - n
        if pad > 0:
            widths = [(0, 0)] * 3
            widths[axis] = (0, pad)
            out = np.pad(out, widths, mode="edge")
        moved = np.moveaxis(out, axis, 0)
        body = moved[:-1].reshape((count, brick) + moved.shape[1:])
        reduced = reduce(reduce.reduce(body, axis=1), moved[brick::brick][:count])
        out = np.moveaxis(reduced, 0, axis)
    return out


def brick_extinction(values: np.ndarray, transfer: TransferFunction,
                     brick_size: int = DEFAULT_BRICK_SIZE) -> np.ndarray:
    """Largest extinction each brick can produce, ``(bx, by, bz)`` float32 (0 = empty)."""
    values = np.asarray(values, dtype=np.float32)
    low = _block_reduce(values, brick_size, np.minimum)
    high = _block_reduce(values, brick_size, np.maximum)
    lo, hi = transfer.clim
    rows = transfer.n_colors - 1
    first = np.floor(np.clip((low - lo) / (hi - lo), 0, 1) * rows).astype(np.int64)
    last = np.ceil(np.clip((high - lo) / (hi - lo), 0, 1) * rows).astype(np.int64)
    sigma = transfer.table[:, 3].astype(np.float64)
    # the largest sigma over rows first..last, by a sparse table of range maxima
    levels = [sigma]
    while (1 << len(levels)) <= len(sigma):
        prev, width = levels[-1], 1 << (len(levels) - 1)
        levels.append(np.maximum(prev[:-width], prev[width:]))
    length = last - first + 1
    level = np.floor(np.log2(np.maximum(length, 1))).astype(np.int64)
    result = np.zeros(first.shape)
    for k in np.unique(level):
        mask = level == k
        table = levels[k]
        result[mask] = np.maximum(table[first[mask]], table[last[mask] - (1 << k) + 1])
    return result.astype(np.float32)


def range_extinction(low: float, high: float, transfer: TransferFunction) -> float:
    """Largest extinction any value in ``[low, high]`` reads through ``transfer``'s table.

    As :func:`brick_extinction` for one brick (rows from the floor of the lowest to the
    ceiling of the highest, values clamped to ``clim``).
    """
    lo, hi = transfer.clim
    rows = transfer.n_colors - 1
    first = int(np.floor(np.clip((low - lo) / (hi - lo), 0, 1) * rows))
    last = int(np.ceil(np.clip((high - lo) / (hi - lo), 0, 1) * rows))
    return float(np.max(transfer.table[first:last + 1, 3]))


def transparent_value(transfer: TransferFunction) -> float | None:
    """A value whose table row has zero extinction (None: every row has some)."""
    rows = np.flatnonzero(transfer.table[:, 3] <= 0)
    if not rows.size:
        return None
    lo, hi = transfer.clim
    return float(lo + rows[0] / (transfer.n_colors - 1) * (hi - lo))


def empty_fraction(bricks: np.ndarray) -> float:
    """Share of bricks the marcher can skip."""
    return float((bricks <= 0).mean())
