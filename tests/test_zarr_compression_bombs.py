"""A zarr chunk inflates to no more than the chunk it declares: compression bombs refused.

zarr's codecs decode whatever a chunk's bytes say: a 4 KB bz2 chunk of a 1 KB chunk
inflated to megabytes (gigabytes where bigger) before zarr saw its size was wrong, and a
blosc or lz4 header claiming more had it allocated. Each bomb here is checked to be one
(zarr's own read of it allocates at least ``BOMB`` bytes) before ours is checked to refuse
it without doing so. Expected values are by hand: the values written, byte counts.
"""

from __future__ import annotations

import bz2
import gzip
import lzma
import pickle
import struct
import tracemalloc
import zlib

import numpy as np
import pytest

zarr = pytest.importorskip("zarr")
numcodecs = pytest.importorskip("numcodecs")

try:   # zarr >= 3.1.3 holds numcodecs' zarr v3 codecs
    from zarr.codecs import numcodecs as numcodecs_v3
except ImportError:
    from numcodecs import zarr3 as numcodecs_v3
from zarr.codecs import BloscCodec, GzipCodec, ZstdCodec  # noqa: E402

from pv_cubemarch.core.errors import StoreReadError  # noqa: E402
from pv_cubemarch.models.multiscale import multiscale_source  # noqa: E402
from pv_cubemarch.models.zarr_codecs import zstd_frame_sizes  # noqa: E402

#: numcodecs' zarr v3 codecs warn that they are not in the zarr v3 specification.
pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")

#: What a bomb inflates to (a chunk here holds 8^3 int16 values: 1,024 bytes).
BOMB = 4 << 20
SHAPE, CHUNKS = (16, 12, 8), (8, 8, 8)
#: Values in Hounsfield units, negative and off 0, so a chunk read wrong shows.
DATA = (np.arange(np.prod(SHAPE)).reshape(SHAPE) % 1500 - 1024).astype(np.int16)


def _v3(name):
    return {"gzip": GzipCodec(), "zstd": ZstdCodec(), "blosc": BloscCodec(),
            "zlib": numcodecs_v3.Zlib(), "bz2": numcodecs_v3.BZ2(),
            "lzma": numcodecs_v3.LZMA(), "lz4": numcodecs_v3.LZ4()}[name]


def _v2(name):
    return {"gzip": numcodecs.GZip(), "zlib": numcodecs.Zlib(), "zstd": numcodecs.Zstd(),
            "blosc": numcodecs.Blosc(), "lz4": numcodecs.LZ4(), "bz2": numcodecs.BZ2(),
            "lzma": numcodecs.LZMA()}[name]


CODECS = ("gzip", "zlib", "bz2", "lzma", "zstd", "blosc", "lz4")


def _store(path, name, zarr_format, shards=None):
    """``DATA`` written by zarr with one compressor; returns the first chunk's file."""
    codec = _v3(name) if zarr_format == 3 else _v2(name)
    array = zarr.create_array(str(path), shape=SHAPE, chunks=CHUNKS, shards=shards,
                              dtype="int16", compressors=codec, zarr_format=zarr_format)
    array[:] = DATA
    return path / ("c/0/0/0" if zarr_format == 3 else "0.0.0")


def _read(path, shape=SHAPE):
    """The array's first ``shape`` points as the project reads them (a whole chunk: the
    first ``CHUNKS``), through ``multiscale_source`` of the path."""
    level = multiscale_source(str(path)).levels[0]
    return level.read(tuple(slice(0, n) for n in shape))


def _zstd_frame_of_unstated_size(nbytes, value=7, block=1 << 17):
    """A zstd frame of RLE blocks making ``nbytes`` bytes of ``value``, its size left out."""
    frame = struct.pack("<I", 0xFD2FB528) + bytes([0x00, (17 - 10) << 3])   # window 128 KiB
    count = -(-nbytes // block)
    for i in range(count):
        size = min(block, nbytes - i * block)
        frame += struct.pack("<I", (i == count - 1) | (1 << 1) | (size << 3))[:3]
        frame += bytes([value])
    return frame


def _bomb(name):
    """A chunk in ``name``'s format that inflates to (or claims) ``BOMB`` bytes."""
    zeros = bytes(BOMB)
    if name == "blosc":   # a real 1 KB chunk whose header claims BOMB bytes
        data = bytearray(numcodecs.Blosc().encode(bytes(1024)))
        struct.pack_into("<I", data, 4, BOMB)
        return bytes(data)
    if name == "lz4":
        data = bytearray(numcodecs.LZ4().encode(bytes(1024)))
        struct.pack_into("<i", data, 0, BOMB)
        return bytes(data)
    if name == "lzma":   # a small dictionary: the decoder's own memory is not the bomb's
        return lzma.compress(zeros, filters=[{"id": lzma.FILTER_LZMA2, "dict_size": 1 << 16}])
    return {"gzip": gzip.compress, "zlib": zlib.compress, "bz2": bz2.compress,
            "zstd": numcodecs.Zstd().encode}[name](zeros)


def _peak(call):
    """``call()``'s outcome (a value or the exception) and the most bytes it had allocated."""
    tracemalloc.start()
    try:
        outcome = call()
    except Exception as error:   # the outcome is checked by the caller
        outcome = error
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return outcome, peak


def _refused_as_bomb(path, says="compression bomb", their_least=BOMB, our_most=BOMB // 4):
    """Zarr's own read of ``path`` allocates ``their_least`` bytes (it is a bomb); ours of
    its first chunk is refused saying ``says``, below ``our_most``."""
    theirs, their_peak = _peak(lambda: zarr.open_array(str(path), mode="r")[:])
    assert their_peak >= their_least, their_peak
    ours, our_peak = _peak(lambda: _read(path, CHUNKS))
    assert isinstance(ours, StoreReadError) and says in str(ours), ours
    assert our_peak < our_most, our_peak


@pytest.mark.parametrize("zarr_format", [2, 3])
@pytest.mark.parametrize("name", CODECS)
def test_every_compressor_reads_what_zarr_wrote(tmp_path, name, zarr_format):
    # The bound refuses nothing zarr writes: every value read back, also once pickled (as
    # cluster workers and dask's schedulers receive it).
    _store(tmp_path / "a.zarr", name, zarr_format)
    np.testing.assert_array_equal(_read(tmp_path / "a.zarr"), DATA)
    level = pickle.loads(pickle.dumps(multiscale_source(str(tmp_path / "a.zarr")).levels[0]))
    np.testing.assert_array_equal(level.read((slice(3, 11), slice(2, 12), slice(1, 8))),
                                  DATA[3:11, 2:12, 1:8])


def test_a_sharded_store_reads_what_zarr_wrote(tmp_path):
    _store(tmp_path / "a.zarr", "gzip", 3, shards=(16, 8, 8))
    np.testing.assert_array_equal(_read(tmp_path / "a.zarr"), DATA)


@pytest.mark.parametrize("zarr_format", [2, 3])
@pytest.mark.parametrize("name", CODECS)
def test_a_compression_bomb_is_refused_before_it_inflates(tmp_path, name, zarr_format):
    # catches (seen failing): Level not bounding its array and open_zarr returning zarr's
    # array (the bomb inflated: peak 4-8 MB, a ValueError from zarr after the allocation).
    chunk = _store(tmp_path / "a.zarr", name, zarr_format)
    chunk.write_bytes(_bomb(name))
    _refused_as_bomb(tmp_path / "a.zarr")


def test_a_shard_s_inner_chunk_is_bounded_too(tmp_path):
    # catches (seen failing): a shard's inner codecs left unwrapped (the bomb inside read).
    _store(tmp_path / "a.zarr", "zlib", 3, shards=(8, 8, 8))
    shard = tmp_path / "a.zarr" / "c" / "0" / "0" / "0"
    bomb = zlib.compress(bytes(BOMB))
    index = struct.pack("<QQ", 0, len(bomb))   # one inner chunk, at the shard's start
    google_crc32c = pytest.importorskip("google_crc32c")
    shard.write_bytes(bomb + index + struct.pack("<I", google_crc32c.value(index)))
    _refused_as_bomb(tmp_path / "a.zarr")


@pytest.mark.parametrize("zarr_format", [2, 3])
def test_the_first_compressor_may_make_its_chunk_and_not_a_byte_more(tmp_path, zarr_format):
    # The compressor right after the chunk's bytes must make exactly them.
    # catches (seen failing): that compressor bounded as one inside a chain, in v2 and in
    # v3 apart (1,025 bytes let through to zarr, which said the store was damaged, not
    # that it was a bomb).
    chunk = _store(tmp_path / "a.zarr", "gzip", zarr_format)
    chunk.write_bytes(gzip.compress(np.full(CHUNKS, 5, "<i2").tobytes()))
    np.testing.assert_array_equal(_read(tmp_path / "a.zarr")[:8, :8, :8], 5)
    chunk.write_bytes(gzip.compress(bytes(1024 + 1)))
    with pytest.raises(StoreReadError, match="compression bomb"):
        _read(tmp_path / "a.zarr")


def test_a_zstd_frame_that_leaves_out_its_size_must_make_its_chunk_exactly(tmp_path):
    # catches (seen failing): such a frame handed to numcodecs unchecked (its 4 MB made).
    chunk = _store(tmp_path / "a.zarr", "zstd", 3)
    chunk.write_bytes(_zstd_frame_of_unstated_size(1024))   # 0x0707 = 1799 in each value
    np.testing.assert_array_equal(_read(tmp_path / "a.zarr")[:8, :8, :8], 1799)
    chunk.write_bytes(_zstd_frame_of_unstated_size(BOMB))
    _refused_as_bomb(tmp_path / "a.zarr", "did not make the 1,024 bytes")


def test_an_xz_stream_asking_for_a_huge_dictionary_is_refused(tmp_path):
    # catches (seen failing): the lzma decoder with no memory limit (zarr's own read
    # allocated the 128 MiB dictionary the header asked for, to make 1 KB).
    chunk = _store(tmp_path / "a.zarr", "lzma", 2)
    chunk.write_bytes(lzma.compress(bytes(1024), filters=[
        {"id": lzma.FILTER_LZMA2, "dict_size": 128 << 20}]))
    _refused_as_bomb(tmp_path / "a.zarr", "a dictionary of more than", 128 << 20, 32 << 20)


@pytest.mark.parametrize("nbytes", [0, 255, 256, 65791, 65792, 1 << 20, (1 << 32) + 5])
def test_the_zstd_content_size_is_read_from_every_width_of_its_field(nbytes):
    # The frame header stores the size in 1, 2 (less 256), 4 or 8 bytes by how large it is.
    # catches (seen failing): the 2-byte field read without its 256 offset (65791 -> 65535).
    if nbytes > 1 << 30:   # written by hand: single segment, 8-byte size, one empty block
        frame = struct.pack("<IB", 0xFD2FB528, 0xE0) + struct.pack("<Q", nbytes) \
            + struct.pack("<I", 1)[:3]
    else:
        frame = numcodecs.Zstd().encode(bytes(nbytes))
    assert zstd_frame_sizes(memoryview(frame)) == [nbytes]


def _uint16_bomb_store(path):
    """An 8^3 uint16 label store of one gzip chunk, that chunk a bomb."""
    array = zarr.create_array(str(path), shape=CHUNKS, chunks=CHUNKS, dtype="uint16",
                              compressors=GzipCodec())
    array[:] = 3
    (path / "c" / "0" / "0" / "0").write_bytes(gzip.compress(bytes(BOMB)))
    return zarr.open_array(str(path), mode="r")   # opened by the user, unchecked


def test_a_label_array_the_user_opened_is_bounded_too(tmp_path):
    # catches (seen failing): world_from_array reading the user's zarr array as given.
    from pv_cubemarch.models.array_sources import world_from_array

    array = _uint16_bomb_store(tmp_path / "labels.zarr")
    outcome, peak = _peak(lambda: world_from_array(array, chunk_size=8, progress_bar=False))
    assert isinstance(outcome, StoreReadError) and "compression bomb" in str(outcome), outcome
    assert peak < BOMB // 4, peak


def test_a_cluster_slab_of_a_zarr_array_is_bounded_too(tmp_path):
    # catches (seen failing): split_grid handing zarr's array to dask as given.
    pytest.importorskip("dask")
    from pv_cubemarch.cluster.split_grid import _volume_parts

    values = _volume_parts(_uint16_bomb_store(tmp_path / "v.zarr"), None, None, None)[0]
    _peak(lambda: values[:8, :8, :8].compute(scheduler="sync"))   # dask's imports, once
    outcome, peak = _peak(lambda: values[:8, :8, :8].compute(scheduler="sync"))
    assert isinstance(outcome, StoreReadError) and "compression bomb" in str(outcome), outcome
    assert peak < BOMB // 4, peak


@pytest.mark.parametrize("inline", [False, True])
@pytest.mark.parametrize("entry", ["labels", "volume", "cluster"])
def test_a_dask_array_over_a_zarr_store_reads_it_bounded(tmp_path, inline, entry):
    # da.from_zarr keeps the zarr array in a layer of its own, or inlines it into its reads
    # (inline_array=True); either, under further operations, is read bounded by the
    # labels' world, a volume's levels and cluster slabs, and the store's good chunks
    # read as zarr wrote them. catches (seen failing): the dask array taken as given (the
    # bomb inflated), the inlined array alone left unbounded.
    da = pytest.importorskip("dask.array")
    from pv_cubemarch.cluster.split_grid import _volume_parts
    from pv_cubemarch.models.array_sources import world_from_array

    good = da.from_zarr(_store(tmp_path / "good.zarr", "zlib", 3).parents[3],
                        inline_array=inline)
    bomb = da.from_zarr(_uint16_bomb_store(tmp_path / "bomb.zarr"),
                        inline_array=inline)
    read = {"labels": lambda array: world_from_array(array[:8, :8, :8] + 0, chunk_size=8,
                                                     progress_bar=False),
            "volume": lambda array: multiscale_source(array + 0).levels[0].read(
                (slice(0, 8),) * 3),
            "cluster": lambda array: _volume_parts(array + 0, None, None, None)[0][
                :8, :8, :8].compute(scheduler="sync")}[entry]
    if entry != "labels":
        np.testing.assert_array_equal(np.asarray(read(good)), DATA[:8, :8, :8])
    _peak(lambda: read(bomb))   # dask's and zarr's imports, once
    outcome, peak = _peak(lambda: read(bomb))
    assert isinstance(outcome, StoreReadError) and "compression bomb" in str(outcome), outcome
    assert peak < BOMB // 4, peak


def test_a_v2_filter_that_compresses_is_bounded_too(tmp_path):
    # zarr v2 filters run before the compressor and may compress too (found by a review:
    # filters [zlib] and no compressor, a 204 KB chunk file peaking at 459 MB).
    # catches (seen failing): only metadata.compressor wrapped.
    array = zarr.create_array(str(tmp_path / "a.zarr"), shape=SHAPE, chunks=CHUNKS,
                              dtype="int16", compressors=None, filters=[numcodecs.Zlib()],
                              zarr_format=2)
    array[:] = DATA
    np.testing.assert_array_equal(_read(tmp_path / "a.zarr"), DATA)
    (tmp_path / "a.zarr" / "0.0.0").write_bytes(zlib.compress(bytes(BOMB)))
    _refused_as_bomb(tmp_path / "a.zarr")


@pytest.mark.parametrize("zarr_format", [2, 3])
def test_a_zstd_chunk_of_several_frames_makes_only_its_chunk(tmp_path, zarr_format):
    # numcodecs decodes every frame; only the first one's size was checked (found by a
    # review: a first frame stating 2 bytes, a second 1 GiB). catches (seen failing): the
    # first frame's header alone checked (the second frame's 4 MB made).
    chunk = _store(tmp_path / "a.zarr", "zstd", zarr_format)
    zstd = numcodecs.Zstd()
    chunk.write_bytes(zstd.encode(bytes(512)) + zstd.encode(bytes(512)))   # 1,024 in two
    np.testing.assert_array_equal(_read(tmp_path / "a.zarr")[:8, :8, :8], 0)
    for bomb in (zstd.encode(b"\0\0") + _zstd_frame_of_unstated_size(BOMB),
                 zstd.encode(b"\0\0") + zstd.encode(bytes(BOMB))):
        chunk.write_bytes(bomb)
        _refused_as_bomb(tmp_path / "a.zarr", "zstd")


@pytest.mark.parametrize("chain", [("gzip", "zstd"), ("zstd", "gzip"), ("blosc", "zstd")])
def test_two_compressors_in_a_chain_read_what_zarr_wrote(tmp_path, chain):
    # The inner compressor's output of incompressible bytes is larger than the chunk (found
    # by a review: [gzip, zstd] refused, the zstd frame stating 262,242 bytes of 262,208).
    # catches (seen failing): the second compressor bounded by the chunk's bytes alone.
    values = np.random.default_rng(3).integers(0, 256, (64, 64, 64), dtype=np.uint8)
    array = zarr.create_array(str(tmp_path / "a.zarr"), shape=values.shape, chunks=(64,) * 3,
                              dtype="uint8", compressors=[_v3(name) for name in chain])
    array[:] = values
    level = multiscale_source(str(tmp_path / "a.zarr")).levels[0]
    np.testing.assert_array_equal(level.read((slice(0, 64),) * 3), values)


def test_a_stream_of_many_members_is_refused_not_read_for_a_minute(tmp_path):
    # Each member's rest was copied: 200,000 empty gzip members took 53 s a chunk (zarr:
    # 0.55 s). Two members read as gzip reads them. catches (seen failing): no limit on
    # the members (the 20,000 here took seconds, each copying the rest).
    chunk = _store(tmp_path / "a.zarr", "gzip", 2)
    half = np.full(CHUNKS, 9, "<i2").tobytes()
    chunk.write_bytes(gzip.compress(half[:512]) + bytes(8) + gzip.compress(half[512:]))
    np.testing.assert_array_equal(_read(tmp_path / "a.zarr")[:8, :8, :8], 9)
    chunk.write_bytes(gzip.compress(b"") * 20000 + gzip.compress(half))
    with pytest.raises(StoreReadError, match="holds more than 64 streams"):
        _read(tmp_path / "a.zarr")


def test_an_array_of_strings_is_left_to_its_codecs(tmp_path):
    # numpy's variable-width strings have no fixed size a chunk could be bounded by (found
    # by a review: refused as a bomb). catches (seen failing): kind 'T' sized as 16 bytes.
    from pv_cubemarch.models.zarr_codecs import bounded_array

    words = np.array([f"label {i:05d} " * 8 for i in range(4000)])   # 112 bytes each
    array = zarr.create_array(str(tmp_path / "s.zarr"), shape=(4000,), chunks=(4000,),
                              dtype=str)
    array[:] = words
    assert list(bounded_array(zarr.open_array(str(tmp_path / "s.zarr"), mode="r"))[:]) \
        == list(words)
