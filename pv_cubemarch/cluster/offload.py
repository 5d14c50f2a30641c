"""Where a bench's slow, independent work runs: a Dask cluster's workers, or this process.

The benches time their rows side by side in one process (so the ratios between rows hold)
and compare each with a CPU reference that takes far longer than the frames. With a
client, the references are computed on the cluster's workers in parallel (a frame-wide
reference cut into bands of rows) and waited for before any row is timed, so no timed
frame shares the machine with them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from contextlib import contextmanager

import numpy as np

from .frames import local_client


class _Done:
    """A result computed here, with a future's ``result()``."""

    def __init__(self, value):
        self.value = value

    def result(self):
        return self.value


class Offload:
    """Runs functions on ``client``'s workers (``submit`` returns a future), or here."""

    def __init__(self, client=None):
        self.client = client

    @property
    def workers(self) -> int:
        """Workers that can take tasks at once (1 here)."""
        if self.client is None:
            return 1
        return max(1, len(self.client.scheduler_info()["workers"]))

    def submit(self, function: Callable, *args, **kwargs):
        """``function(*args, **kwargs)``: a future on the cluster, or computed now."""
        if self.client is None:
            return _Done(function(*args, **kwargs))
        return self.client.submit(function, *args, pure=False, **kwargs)

    def banded(self, function: Callable, size, *args, sliced: dict | None = None,
               **kwargs):
        """An image of ``size`` made by ``function(*args, crop=..., **kwargs)`` in bands.

        The image may be a record of per-pixel images (a dataclass whose fields are all
        ``(height, ...)`` arrays, as the voxel and surface references return).

        One band of rows per worker (twice as many, so a slow band is not waited for
        alone); ``sliced``: keyword arrays of the whole image's rows (opaque depth, colour),
        cut to each band. Here, one call over the whole image.
        """
        width, height = (int(v) for v in size)
        sliced = {k: v for k, v in (sliced or {}).items() if v is not None}
        if self.client is None:
            return _Done(function(*args, **sliced, **kwargs))
        cuts = np.linspace(0, height, min(height, 2 * self.workers) + 1).round().astype(int)
        parts = []
        for top, bottom in zip(cuts[:-1], cuts[1:], strict=True):
            if bottom > top:
                band = {k: v[top:bottom] for k, v in sliced.items()}
                parts.append(self.client.submit(function, *args, crop=(0, int(top), width,
                                                int(bottom - top)), pure=False, **band,
                                                **kwargs))
        return self.client.submit(_stacked, parts, pure=False)


def _stacked(parts):
    """Bands of rows stacked: images, or per-pixel records (dataclasses of images)."""
    if dataclasses.is_dataclass(parts[0]):
        return type(parts[0])(**{field.name: np.concatenate(
            [getattr(part, field.name) for part in parts], axis=0)
            for field in dataclasses.fields(parts[0])})
    return np.concatenate(parts, axis=0)


@contextmanager
def bench_offload(scheduler: str | None = None, workers: int | None = None):
    """An :class:`Offload` for a bench's ``--scheduler`` / ``--workers`` (else this process)."""
    if scheduler is not None and workers is not None:
        raise ValueError("--workers sizes a local cluster; a --scheduler brings its own "
                         "workers: give one of them.")
    if scheduler is None and workers is None:
        yield Offload()
        return
    from distributed import Client

    if scheduler is not None:
        with Client(scheduler) as client:
            yield Offload(client)
        return
    with local_client(None, workers) as client:
        yield Offload(client)
