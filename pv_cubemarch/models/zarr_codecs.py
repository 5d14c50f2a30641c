"""zarr arrays whose compressed chunks inflate to no more than the chunk they declare.

zarr's codecs decode whatever a chunk's bytes say: a 1 KB zlib or bz2 chunk inflated to
gigabytes before zarr saw it was the wrong size, and a blosc, lz4 or zstd header claiming
2 GB had that much allocated. :func:`bounded_array` opens the same array with each
compressor wrapped: a stream (gzip, zlib, bz2, lzma) is inflated to at most the chunk's
bytes, a header that states its size (blosc, lz4, zstd) must state no more before the
chunk is decoded, and a zstd frame that does not state it is decoded into a buffer of
exactly the chunk's bytes. Other codecs decode as zarr decodes them.
"""

from __future__ import annotations

import asyncio
import bz2
import dataclasses
import functools
import importlib
import lzma
import math
import struct
import zlib

import numpy as np

from ..core.errors import StoreReadError

#: Bytes a compressor's output may exceed the chunk by: a checksum codec's few bytes.
SLACK = 64

#: How many times the chunk's bytes a zarr v2 compressor may make when filters follow it
#: (an ``astype`` filter may widen a float16 chunk into float64 values).
FILTER_WIDENING = 8

#: The memory an lzma stream's decoder may take (its dictionary): xz's largest preset needs
#: 65 MiB; a header may ask for 4 GiB.
LZMA_MEMORY = 96 << 20

#: Compressor names (zarr v3's ``name``, numcodecs' ``codec_id``) and the format each writes.
FORMATS = {"gzip": "gzip", "numcodecs.gzip": "gzip", "zlib": "zlib", "numcodecs.zlib": "zlib",
           "bz2": "bz2", "numcodecs.bz2": "bz2", "lzma": "lzma", "numcodecs.lzma": "lzma",
           "zstd": "zstd", "numcodecs.zstd": "zstd", "blosc": "blosc",
           "numcodecs.blosc": "blosc", "lz4": "lz4", "numcodecs.lz4": "lz4"}


def inflate(kind: str, data, ceiling: int, *, exact: int | None = None,
            config: dict | None = None) -> bytes | None:
    """``data`` of format ``kind`` inflated, refused past ``ceiling`` bytes.

    Returns the bytes for a stream format, ``None`` once a sized header has been checked
    (its codec then decodes it). ``exact``: the bytes a zstd frame of unstated size must
    make (``None``: such a frame is refused). ``config``: an lzma codec's settings.
    """
    data = memoryview(data).cast("B")
    if kind in ("gzip", "zlib", "bz2", "lzma"):
        return _stream(kind, bytes(data), ceiling, config or {})
    claimed = _claimed_size(kind, data)
    if claimed is None and kind == "zstd":
        if exact is None:
            raise StoreReadError("a zstd chunk does not say its size, and what it must make "
                                 "is not known here: refused (a compression bomb cannot be "
                                 "told from it).")
        return _zstd_exact(data, exact)
    if claimed is not None and claimed > ceiling:
        raise _bomb(kind, f"says it makes {claimed:,} bytes", ceiling)
    return None


def _bomb(kind: str, what: str, ceiling: int) -> StoreReadError:
    return StoreReadError(f"a chunk compressed with {kind} {what}, more than the {ceiling:,} "
                          "its chunk holds: refused (a compression bomb, or metadata that lies).")


def _stream(kind: str, data: bytes, ceiling: int, config: dict) -> bytes:
    """A stream inflated member by member (gzip, bz2, xz concatenate them), to ``ceiling``."""
    pieces, total = [], 0
    while True:
        decoder = _decoder(kind, config)
        try:
            piece = decoder.decompress(data, ceiling + 1 - total)
        except lzma.LZMAError as error:   # past the memory limit, or not a stream
            raise StoreReadError(f"an lzma chunk could not be decoded ({error}): "
                                 "refused.") from error
        total += len(piece)
        pieces.append(piece)
        if total > ceiling:
            raise _bomb(kind, f"inflates past {ceiling:,} bytes", ceiling)
        if not decoder.eof:
            raise StoreReadError(f"a chunk compressed with {kind} ends before its stream does: "
                                 "the store is damaged there.")
        data = decoder.unused_data
        if kind == "zlib" or not data.strip(b"\0"):   # zlib reads one stream; padding ends
            return b"".join(pieces)


def _decoder(kind: str, config: dict):
    if kind == "gzip":
        return zlib.decompressobj(wbits=16 + zlib.MAX_WBITS)
    if kind == "zlib":
        return zlib.decompressobj()
    if kind == "bz2":
        return bz2.BZ2Decompressor()
    fmt = config.get("format", lzma.FORMAT_AUTO)
    if fmt != lzma.FORMAT_RAW:   # the stream's header sets the dictionary's size
        return lzma.LZMADecompressor(format=fmt, memlimit=LZMA_MEMORY)
    filters = config.get("filters") or []
    if any(int(f.get("dict_size", 0)) > LZMA_MEMORY for f in filters):
        raise StoreReadError(f"a raw lzma codec's filters ask for a dictionary of more than "
                             f"{LZMA_MEMORY:,} bytes: refused.")
    return lzma.LZMADecompressor(format=fmt, filters=filters)


def _claimed_size(kind: str, data: memoryview) -> int | None:
    """The decoded size a sized format's header states (``None``: a zstd frame's is unset)."""
    if kind == "blosc":
        if len(data) < 16:
            raise StoreReadError("a blosc chunk is shorter than its 16-byte header: damaged.")
        return struct.unpack_from("<I", data, 4)[0]
    if kind == "lz4":
        if len(data) < 4:
            raise StoreReadError("an lz4 chunk is shorter than its 4-byte size: damaged.")
        return struct.unpack_from("<i", data, 0)[0]
    return _zstd_content_size(data)


def _zstd_content_size(data: memoryview) -> int | None:
    """A zstd frame header's content size, or ``None`` where the frame leaves it out."""
    if len(data) < 6 or struct.unpack_from("<I", data, 0)[0] != 0xFD2FB528:
        raise StoreReadError("a zstd chunk does not start with a zstd frame: damaged.")
    descriptor = data[4]
    size_flag, single_segment, dict_flag = descriptor >> 6, (descriptor >> 5) & 1, descriptor & 3
    at = 5 + (0 if single_segment else 1) + (0, 1, 2, 4)[dict_flag]
    width = (1 if single_segment else 0, 2, 4, 8)[size_flag]
    if width == 0:
        return None
    if len(data) < at + width:
        raise StoreReadError("a zstd chunk is shorter than its frame header: damaged.")
    value = int.from_bytes(data[at:at + width], "little")
    return value + 256 if width == 2 else value


def _zstd_exact(data: memoryview, exact: int) -> bytes:
    """A zstd frame of unstated size decoded into exactly ``exact`` bytes, or refused."""
    out = np.empty(exact, np.uint8)
    try:
        importlib.import_module("numcodecs").Zstd().decode(bytes(data), out=out)
    except (RuntimeError, ValueError) as error:
        raise StoreReadError(f"a zstd chunk that does not say its size did not make the "
                             f"{exact:,} bytes of its chunk ({error}): refused.") from error
    return out.tobytes()


def bounded_array(array):
    """``array`` (a zarr array) reopened with its compressors bounded; anything else as is."""
    if type(array).__module__.split(".")[0] != "zarr":
        return array
    zarr = importlib.import_module("zarr")
    if not isinstance(array, zarr.Array):   # a group: its arrays are bounded as levels
        return array
    metadata = array.metadata
    if getattr(metadata, "zarr_format", None) == 3:
        codecs = tuple(_bounded_v3(codec) for codec in metadata.codecs)
        if codecs == tuple(metadata.codecs):
            return array
        metadata = dataclasses.replace(metadata, codecs=codecs)
    elif getattr(metadata, "zarr_format", None) == 2 and metadata.compressor is not None:
        if isinstance(metadata.compressor, _classes()["BoundedCompressor"]):
            return array
        nbytes = _chunk_bytes(metadata.chunks, metadata.dtype)
        if nbytes is None:
            return array
        exact = None if metadata.filters else nbytes
        ceiling = nbytes * (FILTER_WIDENING if metadata.filters else 1) + SLACK
        compressor = _classes()["BoundedCompressor"](metadata.compressor, ceiling, exact)
        metadata = dataclasses.replace(metadata, compressor=compressor)
    else:
        return array
    old = array.async_array
    new = type(old)(metadata=metadata, store_path=old.store_path, config=old.config)
    return zarr.Array(new)


def _bounded_v3(codec):
    """A v3 codec with every compressor in it wrapped (a shard's inner codecs too)."""
    classes = _classes()
    name = codec.to_dict().get("name") if hasattr(codec, "to_dict") else None
    if name == "sharding_indexed":
        inner = tuple(_bounded_v3(c) for c in codec.codecs)
        if inner == tuple(codec.codecs):
            return codec
        return type(codec)(chunk_shape=codec.chunk_shape, codecs=inner,
                           index_codecs=codec.index_codecs,
                           index_location=codec.index_location)
    if name in FORMATS and not isinstance(codec, classes["BoundedBytesCodec"]):
        return classes["BoundedBytesCodec"](codec)
    return codec


def _chunk_bytes(shape, dtype) -> int | None:
    """The bytes of one chunk of ``shape`` (``None`` for values of no fixed size)."""
    native = dtype.to_native_dtype() if hasattr(dtype, "to_native_dtype") else np.dtype(dtype)
    if native.kind == "O" or native.itemsize == 0:
        return None
    return math.prod(int(n) for n in shape) * native.itemsize


@functools.cache
def _classes() -> dict:
    """The wrappers, made once zarr is imported (it is an optional dependency)."""
    from numcodecs.abc import Codec
    from zarr.abc.codec import BytesBytesCodec

    @dataclasses.dataclass(frozen=True)
    class BoundedBytesCodec(BytesBytesCodec):
        """A zarr v3 compressor whose decoding is bounded by the chunk it makes."""

        inner: object
        is_fixed_size = False

        def to_dict(self):
            return self.inner.to_dict()

        def evolve_from_array_spec(self, array_spec):
            return type(self)(self.inner.evolve_from_array_spec(array_spec))

        def validate(self, **kwargs):
            return self.inner.validate(**kwargs)

        def resolve_metadata(self, chunk_spec):
            return self.inner.resolve_metadata(chunk_spec)

        def compute_encoded_size(self, input_byte_length, chunk_spec):
            return self.inner.compute_encoded_size(input_byte_length, chunk_spec)

        async def _encode_single(self, chunk_bytes, chunk_spec):
            return await self.inner._encode_single(chunk_bytes, chunk_spec)

        async def _decode_single(self, chunk_bytes, chunk_spec):
            settings = self.inner.to_dict()
            nbytes = _chunk_bytes(chunk_spec.shape, chunk_spec.dtype)
            if nbytes is not None:
                made = await asyncio.to_thread(   # off zarr's loop, as its codecs decode
                    inflate, FORMATS[settings["name"]], chunk_bytes.as_numpy_array(),
                    nbytes + SLACK, exact=nbytes, config=settings.get("configuration"))
                if made is not None:
                    return chunk_spec.prototype.buffer.from_bytes(made)
            return await self.inner._decode_single(chunk_bytes, chunk_spec)

    class BoundedCompressor(Codec):
        """A zarr v2 (numcodecs) compressor whose decoding is bounded by its chunk."""

        codec_id = "pv_cubemarch.bounded"

        def __init__(self, inner, ceiling: int, exact: int | None):
            self.inner, self.ceiling, self.exact = inner, int(ceiling), exact

        def get_config(self):
            return self.inner.get_config()

        def encode(self, buf):
            return self.inner.encode(buf)

        def decode(self, buf, out=None):
            kind = FORMATS.get(self.inner.codec_id)
            made = None
            if kind is not None:
                made = inflate(kind, buf, self.ceiling, exact=self.exact,
                               config=self.inner.get_config())
            if made is None:
                return self.inner.decode(buf, out)
            if out is None:
                return made
            out_view = np.frombuffer(memoryview(out).cast("B"), np.uint8)
            out_view[:len(made)] = np.frombuffer(made, np.uint8)
            return out

        def __repr__(self):
            return f"BoundedCompressor({self.inner!r}, ceiling={self.ceiling})"

    classes = {"BoundedBytesCodec": BoundedBytesCodec, "BoundedCompressor": BoundedCompressor}
    for name, cls in classes.items():   # pickled by name: found by __getattr__ below
        cls.__module__, cls.__qualname__ = __name__, name
    return classes


def __getattr__(name: str):
    """The wrapper classes, made on first use (so pickles of bounded arrays load anywhere)."""
    if name in ("BoundedBytesCodec", "BoundedCompressor"):
        return _classes()[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
