"""Bricks of a multiscale source, read in background threads into a host cache.

A brick is ``brick³`` points of one level with one point of its neighbours around it (its
apron, the level's edge repeated past its sides), so trilinear reads inside a brick never
need another: ``(brick + 2)³`` values, float32. Labels, read nearest, take no apron and keep
their ids' type until ``prepare`` (run on the reading thread) turns them into what is
uploaded (an empty array: nothing to draw there). Requests come in priority order each frame;
reads run on threads (zarr, dask and numpy release the GIL while decompressing) and land in
the cache, which forgets the least recently used bricks beyond its byte budget. Nothing here
blocks the caller: a frame takes what has arrived.
"""

from __future__ import annotations

import threading
import time
from collections import OrderedDict
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .multiscale import MultiscaleSource

#: Default host budget for read bricks (bytes).
HOST_BYTES = 2 * 2**30
#: Reads running at once by default.
READ_THREADS = 4
#: Seconds wait() pauses when nothing is being read (a converging loop does not spin).
IDLE_WAIT_S = 0.01


def brick_counts(shape, brick: int) -> tuple[int, int, int]:
    """Bricks along x, y, z covering ``shape`` points (the last ones cut by the sides)."""
    return tuple(-(-int(n) // int(brick)) for n in shape)


def read_brick(source: MultiscaleSource, key, brick: int, apron: int = 1,
               dtype=np.float32) -> np.ndarray:
    """Brick ``key = (level, i, j, k)`` with its apron, ``(brick + 2 apron)³`` of ``dtype``.

    ``dtype=None`` keeps the source's type (label ids wider than float32 holds exactly).
    """
    level = source.levels[key[0]]
    side = brick + 2 * apron
    lower = [int(i) * brick - apron for i in key[1:]]
    box = tuple(slice(max(a, 0), min(a + side, n))
                for a, n in zip(lower, level.shape, strict=True))
    values = level.read(box)
    if dtype is not None:
        values = values.astype(dtype, copy=False)
    pad = [(s.start - a, a + side - s.stop) for s, a in zip(box, lower, strict=True)]
    return np.pad(values, pad, mode="edge") if any(p for pair in pad for p in pair) \
        else np.ascontiguousarray(values)


def _held_bytes(values: np.ndarray) -> int:
    """What a held brick counts against the budget: its bytes, an empty one a key's worth."""
    return max(int(values.nbytes), 128)


class BrickCache:
    """Read bricks of ``source`` (``brick`` points a side) within ``host_bytes``.

    ``apron``: points of the neighbours around each brick (1, or 0 for nearest reads);
    ``prepare(key, values)``: what is kept of a read brick (float32 values by default).
    """

    def __init__(self, source: MultiscaleSource, brick: int = 32, host_bytes: int = HOST_BYTES,
                 threads: int = READ_THREADS, apron: int = 1, prepare=None):
        self.source = source
        self.brick = int(brick)
        self.apron = int(apron)
        self.prepare = prepare
        self.host_bytes = int(host_bytes)
        self.brick_bytes = (self.brick + 2 * self.apron) ** 3 * 4
        if self.host_bytes < self.brick_bytes:
            raise ValueError(f"host_bytes={host_bytes} holds no brick of {self.brick_bytes} "
                             "bytes: give more.")
        self._cache: OrderedDict = OrderedDict()
        self._lock = threading.Lock()
        self._reading: dict = {}
        self._arrived: list = []
        self._pool = ThreadPoolExecutor(max(1, int(threads)), thread_name_prefix="bricks")
        self._changed = threading.Event()
        self._held = 0   # bytes of the bricks held
        #: Bytes read from the source so far, and bricks read.
        self.bytes_read = 0
        self.reads = 0
        self.errors: list[BaseException] = []
        #: Bricks whose read failed: not asked for again (drawn from a coarser level) until
        #: :meth:`retry`.
        self.failed: set = set()
        self._said = False   # a read error was raised: later ones are counted, not raised

    @property
    def capacity(self) -> int:
        """Bricks the cache holds at most."""
        return self.host_bytes // self.brick_bytes

    @property
    def pending(self) -> int:
        """Bricks being read."""
        with self._lock:
            return len(self._reading)

    @property
    def nbytes(self) -> int:
        """Host bytes of the bricks held."""
        with self._lock:
            return self._held

    def get(self, key) -> np.ndarray | None:
        """Brick ``key`` if held (and now the most recently used), else None."""
        with self._lock:
            values = self._cache.get(key)
            if values is not None:
                self._cache.move_to_end(key)
            return values

    def request(self, keys) -> None:
        """Read the bricks of ``keys`` not held or being read, in the order given.

        Reads queued earlier and not started are dropped first: what the last frame wanted
        comes before what an older one did. At most as many reads as the cache holds.
        """
        with self._lock:
            for key, future in list(self._reading.items()):
                if future.cancel():
                    del self._reading[key]
            room = self.capacity - len(self._reading)
            for key in keys:
                if room <= 0:
                    break
                if key in self._cache or key in self._reading or key in self.failed:
                    continue
                self._reading[key] = self._pool.submit(self._read, key)
                room -= 1

    def _read(self, key) -> None:
        try:
            if self.prepare is None:
                values = read_brick(self.source, key, self.brick, self.apron)
            else:
                values = read_brick(self.source, key, self.brick, self.apron, None)
                read = values.size * values.itemsize
                values = self.prepare(key, values)
        except BaseException as error:   # kept for the caller, not lost in a thread
            with self._lock:
                self._reading.pop(key, None)
                self.errors.append(error)
                self.failed.add(key)
            self._changed.set()
            return
        level = self.source.levels[key[0]]
        with self._lock:
            self._reading.pop(key, None)
            if key in self._cache:
                self._held -= _held_bytes(self._cache[key])
            self._cache[key] = values
            self._cache.move_to_end(key)
            self._held += _held_bytes(values)
            while self._held > self.host_bytes and len(self._cache) > 1:
                self._held -= _held_bytes(self._cache.popitem(last=False)[1])
            self._arrived.append(key)
            self.reads += 1
            self.bytes_read += read if self.prepare is not None else \
                values.size * np.dtype(level.array.dtype).itemsize
        self._changed.set()

    def arrived(self) -> list:
        """Keys read since the last call (some may have left the cache again)."""
        with self._lock:
            keys, self._arrived = self._arrived, []
            self._changed.clear()   # under the lock: a read ending now sets it again
        return keys

    def wait(self, timeout: float) -> bool:
        """Wait until a read ends (or ``timeout`` seconds); True if one did.

        At once when none is under way and none ended unseen: nothing would end.
        """
        with self._lock:
            idle = not self._reading and not self._arrived
        if idle:   # a moment, so a caller looping on it does not spin
            time.sleep(min(timeout, IDLE_WAIT_S))
            return False
        return self._changed.wait(timeout)

    def raise_errors(self) -> None:
        """Raise the first error a read met (an unreadable chunk is said, not drawn empty).

        Once: its brick and those failing after it are not asked for again, drawn from a
        coarser level and counted in ``failed``, until :meth:`retry`.
        """
        with self._lock:
            errors, self.errors = self.errors, []
            said, self._said = self._said, self._said or bool(errors)
        if errors and not said:
            first = errors[0]
            if hasattr(first, "add_note"):
                first.add_note("Bricks whose read fails are drawn from a coarser level and "
                               "counted in actor.cubemarch.stats()['failed']; "
                               "actor.cubemarch.pager.retry() asks for them again.")
            raise first

    def retry(self) -> None:
        """Ask again for the bricks whose read failed (e.g. after a network error)."""
        with self._lock:
            self.failed.clear()
            self._said = False

    def close(self) -> None:
        """Stop reading (reads not started are dropped)."""
        self._pool.shutdown(wait=False, cancel_futures=True)

