"""A zarr store in a local folder, opened so that each key it reads is a file of the store.

zarr's ``LocalStore`` reads whatever a key's path names: a chunk that is a link to
``/dev/zero`` read until memory ran out, and one linked to a file elsewhere was decoded
as data (``/etc/passwd`` drawn as a volume where its size matched a chunk's). Here a key
must resolve to a regular file inside the store's folder, no larger than the memory
budget; anything else is refused naming the key. Links inside the folder are followed.
"""

from __future__ import annotations

import functools
import importlib
import os
import stat
from pathlib import Path

from ..core.budgets import host_budget
from ..core.errors import StoreReadError
from .image_files import ARRAY_BYTES_ENV
from .zarr_codecs import bounded_array


def open_zarr(path, mode: str = "r"):
    """``zarr.open`` of ``path``: a local folder through :func:`checked_local_store`.

    A URL (``s3://``, ``https://``, ...) is opened as zarr opens it. An array opened to be
    read has its compressors bounded (:func:`~.zarr_codecs.bounded_array`).
    """
    zarr = _zarr()
    text = os.fspath(path)
    if "://" in text:
        opened = zarr.open(text, mode=mode)
    else:
        opened = zarr.open(store=checked_local_store(text, read_only=mode == "r"), mode=mode)
    return bounded_array(opened) if mode == "r" else opened


def checked_local_store(root, read_only: bool = True):
    """A ``zarr.storage.LocalStore`` of ``root`` whose reads are checked (module docstring)."""
    return _store_class()(root, read_only=read_only)


def _zarr():
    """zarr, or an ImportError saying how to install it."""
    try:
        return importlib.import_module("zarr")
    except ImportError as error:
        raise ImportError("zarr is needed to read zarr stores: pip install "
                          "'pv_cubemarch[zarr]'.") from error


@functools.cache
def _store_class():
    """The checked store class (made once zarr is imported: it is an optional dependency)."""
    zarr = _zarr()

    class CheckedLocalStore(zarr.storage.LocalStore):
        """A ``LocalStore`` whose every read key is a regular file inside its folder."""

        def _check(self, key: str, byte_range=None) -> None:
            """Raise :class:`StoreReadError` unless ``key`` may be read (or is absent).

            A read of a range (a shard's index or one of its chunks) is bounded by the
            range's length, not by the file's size (the range comes from the shard's own
            index: one claiming a 1.5 GB chunk is refused all the same).
            """
            path = Path(self.root) / key
            try:
                if not hasattr(self, "_real_root"):   # once a store
                    self._real_root = Path(self.root).resolve()
                real_root = self._real_root
                target = path.resolve()
                if not target.exists():
                    return   # absent: zarr reads the fill value
                mode = target.stat()
            except (OSError, RuntimeError, ValueError) as exc:   # a loop, a null byte
                raise StoreReadError(f"{self.root}: the key {key!r} cannot be followed "
                                     f"({type(exc).__name__}: {exc}): refused.") from exc
            if real_root != target and real_root not in target.parents:
                raise StoreReadError(
                    f"{self.root}: the key {key!r} is a link to {str(target)!r}, outside the "
                    "store's folder: refused (copy the store, or link to files inside it).")
            if not stat.S_ISREG(mode.st_mode):
                raise StoreReadError(f"{self.root}: the key {key!r} is not a regular file "
                                     "(a device, a pipe or a socket): refused.")
            if not hasattr(self, "_budget"):   # once a store: it reads /proc/meminfo
                self._budget = host_budget(ARRAY_BYTES_ENV, StoreReadError)
            budget = self._budget
            length = _range_length(byte_range, mode.st_size)
            if budget is not None and length > budget:
                raise StoreReadError(
                    f"{self.root}: the key {key!r} would be read as {length:,} bytes (of a file "
                    f"of {mode.st_size:,}), more than the {budget:,} a store's read may take "
                    f"({ARRAY_BYTES_ENV}): refused.")

        def get_sync(self, key, prototype=None, byte_range=None):
            self._check(key, byte_range)
            return super().get_sync(key, prototype=prototype, byte_range=byte_range)

        async def get(self, key, prototype=None, byte_range=None):
            self._check(key, byte_range)
            return await super().get(key, prototype, byte_range)

        async def get_partial_values(self, prototype, key_ranges):
            key_ranges = list(key_ranges)
            for key, byte_range in key_ranges:
                self._check(key, byte_range)
            return await super().get_partial_values(prototype, key_ranges)

        def with_read_only(self, read_only: bool = False):
            return type(self)(self.root, read_only=read_only)

    CheckedLocalStore.__module__ = __name__   # pickled by name: found by __getattr__ below
    CheckedLocalStore.__qualname__ = "CheckedLocalStore"
    return CheckedLocalStore


def _range_length(byte_range, size: int) -> int:
    """The bytes a read of ``byte_range`` (a zarr ``ByteRequest``, or None) of a file reads."""
    kind = type(byte_range).__name__
    if kind == "RangeByteRequest":
        return max(min(int(byte_range.end), size) - int(byte_range.start), 0)
    if kind == "SuffixByteRequest":
        return min(int(byte_range.suffix), size)
    if kind == "OffsetByteRequest":
        return max(size - int(byte_range.offset), 0)
    return size


def __getattr__(name: str):
    """``CheckedLocalStore``, made on first use (so pickles of its stores load anywhere)."""
    if name == "CheckedLocalStore":
        return _store_class()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
