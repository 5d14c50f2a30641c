"""A file mapped read-only, for header checks that must not load what they check."""

from __future__ import annotations

import contextlib
import mmap


@contextlib.contextmanager
def mapped(path):
    """The file at ``path`` mapped read-only (bytes-like), or None where it is empty."""
    with open(path, "rb") as handle:
        try:
            data = mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ)
        except ValueError:   # empty: nothing to map (the reader says what is wrong)
            yield None
            return
        with data:
            yield data
