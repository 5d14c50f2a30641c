"""A local zarr store reads only its own files: links out of it, devices and huge files refused.

zarr's ``LocalStore`` read whatever a key's path named: a chunk linked to ``/dev/zero``
read until memory ran out, and one linked to a file elsewhere of a chunk's size was drawn
as data. Expected values here are by hand (a raw uint8 chunk of 4^3 bytes).
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys

import numpy as np
import pytest

zarr = pytest.importorskip("zarr")

from pv_cubemarch.core.errors import StoreReadError  # noqa: E402
from pv_cubemarch.models.multiscale import multiscale_source  # noqa: E402
from pv_cubemarch.models.zarr_store import open_zarr  # noqa: E402


def _store(path):
    """An 8^3 uint8 store of 4^3 raw chunks, every value 1 (a chunk file is 64 bytes)."""
    array = zarr.create_array(str(path), shape=(8, 8, 8), chunks=(4, 4, 4), dtype="uint8",
                              compressors=None, fill_value=0)
    array[:] = 1
    return path


def _chunk(store, i, j, k):
    return store / "c" / str(i) / str(j) / str(k)


def test_a_chunk_linked_outside_the_store_is_refused_not_drawn(tmp_path):
    # catches (seen failing): the store not checked (multiscale_source opening the path with
    # zarr.open): the outside file's 64 bytes were read as the chunk's values (sum 64 * 7).
    store = _store(tmp_path / "a.zarr")
    outside = tmp_path / "secret.bin"
    outside.write_bytes(bytes([7]) * 64)
    _chunk(store, 0, 0, 0).unlink()
    _chunk(store, 0, 0, 0).symlink_to(outside)
    level = multiscale_source(store).levels[0]
    with pytest.raises(StoreReadError, match=r"'c/0/0/0' is a link to .*secret.bin.*outside"):
        level.read((slice(0, 4),) * 3)
    assert level.read((slice(4, 8),) * 3).sum() == 64   # the store's own chunks still read
    with pytest.raises(StoreReadError, match="outside the store's folder"):
        open_zarr(store)[:4, :4, :4]


def test_a_link_inside_the_store_and_an_absent_chunk_read_as_they_are(tmp_path):
    # The check refuses nothing a store may hold: a chunk linked to another of its chunks
    # reads that chunk's values; an absent chunk reads the fill value; a store reached
    # through a linked folder reads whole.
    store = _store(tmp_path / "b.zarr")
    open_zarr(store, mode="r+")[4:, 4:, 4:] = 5
    _chunk(store, 0, 0, 0).unlink()
    _chunk(store, 0, 0, 0).symlink_to(_chunk(store, 1, 1, 1))
    _chunk(store, 0, 0, 1).unlink()
    (tmp_path / "linked.zarr").symlink_to(store)
    for path in (store, tmp_path / "linked.zarr"):
        values = np.asarray(open_zarr(path)[:])
        assert values[:4, :4, :4].sum() == 5 * 64
        assert values[:4, :4, 4:].sum() == 0
        assert values.sum() == 5 * 64 + 5 * 64 + 5 * 64   # (1 everywhere else)


@pytest.mark.slow   # long (a fresh process, or seconds of frames): pytest -m slow
def test_a_chunk_that_is_a_device_is_refused_before_it_is_read(tmp_path):
    # catches (seen failing): get/get_sync not checking the key: reading /dev/zero under a
    # 3 GB address-space limit raised MemoryError after filling it (no limit: the machine's).
    store = _store(tmp_path / "c.zarr")
    _chunk(store, 1, 0, 0).unlink()
    _chunk(store, 1, 0, 0).symlink_to("/dev/zero")
    os.mkfifo(_chunk(store, 0, 1, 0).with_name("pipe"))
    code = ("import resource, sys\n"
            "resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))\n"
            "from pv_cubemarch.models.zarr_store import open_zarr\n"
            "try:\n    open_zarr(sys.argv[1])[4:, :4, :4]\n"
            "except Exception as exc:\n    print(type(exc).__name__, exc)\n")
    run = subprocess.run([sys.executable, "-c", code, str(store)], capture_output=True,
                         text=True, timeout=120)
    assert "StoreReadError" in run.stdout and "/dev/zero" in run.stdout, run.stdout + run.stderr
    with pytest.raises(StoreReadError, match="'c/0/1/pipe' is not a regular file"):
        open_zarr(store).store.get_sync("c/0/1/pipe")


def test_a_file_larger_than_the_budget_is_refused(tmp_path, monkeypatch):
    # catches (seen failing): the size not compared with PV_CUBEMARCH_ARRAY_MAX_BYTES.
    store = tmp_path / "d.zarr"   # one raw chunk of 4096 bytes; its metadata is smaller
    zarr.create_array(str(store), shape=(16, 16, 16), chunks=(16, 16, 16), dtype="uint8",
                      compressors=None)[:] = 1
    monkeypatch.setenv("PV_CUBEMARCH_ARRAY_MAX_BYTES", "4095")
    with pytest.raises(StoreReadError, match="'c/0/0/0' would be read as 4,096 bytes .*more "
                                             "than the 4,095"):
        open_zarr(store)[:]
    monkeypatch.setenv("PV_CUBEMARCH_ARRAY_MAX_BYTES", "4096")
    assert open_zarr(store)[:].sum() == 4096


@pytest.mark.slow   # long (a fresh process, or seconds of frames): pytest -m slow
def test_a_shard_larger_than_the_budget_is_read_by_its_ranges(tmp_path, monkeypatch):
    # A sharded array reads a shard's index and one chunk's bytes (ranges), never the whole
    # shard: a shard file past the budget is read as long as what is read fits.
    # catches (seen failing, found by a review): the file's size checked for range reads
    # too: the shard (4 KB of 4^3 chunks) refused under a 3,000-byte budget.
    store = tmp_path / "s.zarr"
    array = zarr.create_array(str(store), shape=(16, 16, 16), chunks=(4, 4, 4),
                              shards=(16, 16, 16), dtype="uint8", compressors=None)
    array[:] = np.arange(16 ** 3, dtype=np.uint64).reshape(16, 16, 16) % 251
    shard = next(p for p in store.rglob("*") if p.is_file() and p.name != "zarr.json")
    assert shard.stat().st_size > 4096
    monkeypatch.setenv("PV_CUBEMARCH_ARRAY_MAX_BYTES", "3000")
    block = np.asarray(open_zarr(store)[4:8, 0:4, 8:12])
    expected = (np.arange(16 ** 3, dtype=np.uint64).reshape(16, 16, 16) % 251)[4:8, 0:4, 8:12]
    assert np.array_equal(block, expected)
    # a range is bounded by its own length: a shard index claiming a chunk that spans the
    # whole shard (found by a review: 1.5 GB read) is refused as the whole file was.
    # catches (seen failing): range reads let through whatever their length.
    from zarr.abc.store import RangeByteRequest
    key = shard.relative_to(store).as_posix()
    with pytest.raises(StoreReadError, match="would be read as 5,"):
        open_zarr(store).store.get_sync(key, byte_range=RangeByteRequest(0, 1 << 40))


def test_a_chunk_decoding_past_the_budget_is_refused_when_opened(tmp_path, monkeypatch):
    # zarr decodes a whole chunk to read any point of it: one 64³ uint8 chunk (262,144
    # bytes decoded, a few hundred compressed) is refused under a 100,000-byte budget when
    # the store is opened, naming the chunk and what to do; the same store in 16³ chunks
    # reads. (A review's 33 KB store of one 1024³ chunk took 1.5 GB to read two points.)
    # catches (seen failing): Level.__post_init__ not checking the chunk's bytes.
    monkeypatch.setenv("PV_CUBEMARCH_ARRAY_MAX_BYTES", "100000")
    for chunk, refused in ((64, True), (16, False)):
        store = tmp_path / f"c{chunk}.zarr"
        zarr.create_array(str(store), shape=(64, 64, 64), chunks=(chunk,) * 3,
                          dtype="uint8")[:] = 3
        if refused:
            with pytest.raises(StoreReadError, match=r"one chunk of \(64, 64, 64\) takes "
                                                     "262,144 bytes decoded.*Rechunk"):
                multiscale_source(store)
        else:
            level = multiscale_source(store).levels[0]
            assert level.read((slice(0, 2),) * 3).sum() == 3 * 8


def test_an_opened_store_travels_to_another_process_still_checked(tmp_path):
    # Cluster workers receive the opened array pickled: the checked store must load in a
    # fresh interpreter (found there by name) and still refuse a link out of the store.
    # catches (seen failing): the class left local to _store_class (pickle: "Can't pickle
    # local object").
    store = _store(tmp_path / "e.zarr")
    (tmp_path / "out.bin").write_bytes(bytes(64))
    _chunk(store, 0, 0, 0).unlink()
    _chunk(store, 0, 0, 0).symlink_to(tmp_path / "out.bin")
    code = ("import pickle, sys\narray = pickle.loads(sys.stdin.buffer.read())\n"
            "print(type(array.store).__name__, int(array[4:, 4:, 4:].sum()))\n"
            "try:\n    array[:4, :4, :4]\nexcept Exception as exc:\n"
            "    print(type(exc).__name__)\n")
    run = subprocess.run([sys.executable, "-c", code], input=pickle.dumps(open_zarr(store)),
                         capture_output=True, timeout=120)
    assert run.stdout.decode().split() == ["CheckedLocalStore", "64", "StoreReadError"], \
        run.stdout + run.stderr
