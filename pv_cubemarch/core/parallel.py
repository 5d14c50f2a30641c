"""A pool of threads, one per core, for numpy work that releases the GIL."""

from __future__ import annotations

import os
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager


@contextmanager
def core_pool(tasks: int, most: int | None = None) -> Iterator[ThreadPoolExecutor]:
    """Threads for ``tasks`` tasks: one per core, at most ``most`` and the tasks.

    Work not started is cancelled on leaving, after an error too.
    """
    threads = max(1, min(int(tasks), os.cpu_count() or 1, most or tasks or 1))
    pool = ThreadPoolExecutor(threads)
    try:
        yield pool
    finally:
        pool.shutdown(cancel_futures=True)
