"""zarr arrays whose compressed chunks inflate to no more than the chunk they declare.

zarr's codecs decode whatever a chunk's bytes say: a 1 KB zlib or bz2 chunk inflated to
gigabytes before zarr saw it was the wrong size, and a blosc, lz4 or zstd header claiming
2 GB had that much allocated. :func:`bounded_array` opens the same array with each
compressor wrapped (zarr v2 filters that compress too, and a shard's inner codecs). Where
the bytes a compressor must make are known (the first one after the chunk's bytes, as
zarr and numcodecs write them), it is decoded into exactly that many; elsewhere its
output is bounded by the chunk's bytes and a compressor's worst overhead: a stream
(gzip, zlib, bz2, lzma) is inflated to at most that, and a header that states its size
(blosc, lz4, zstd: every frame's) must state no more. Other codecs decode as zarr decodes
them.
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

#: A stream's members (gzip, bz2 and xz concatenate them); zarr's writers write one.
MAX_MEMBERS = 64

#: How many times the chunk's bytes a zarr v2 compressor may make when a filter that may
#: change the values' size follows it (an ``astype`` may widen float16 into float64).
FILTER_WIDENING = 8

#: v2 filters that keep the values' bytes (or add a checksum's few).
SIZE_KEEPING_FILTERS = ("shuffle", "bitround", "crc32", "crc32c", "adler32",
                        "fletcher32", "jenkins_lookup3")

#: The memory an lzma stream's decoder may take (its dictionary): xz's largest preset needs
#: 65 MiB; a header may ask for 4 GiB.
LZMA_MEMORY = 96 << 20

#: Compressor names (zarr v3's ``name``, numcodecs' ``codec_id``) and the format each writes.
FORMATS = {"gzip": "gzip", "numcodecs.gzip": "gzip", "zlib": "zlib", "numcodecs.zlib": "zlib",
           "bz2": "bz2", "numcodecs.bz2": "bz2", "lzma": "lzma", "numcodecs.lzma": "lzma",
           "zstd": "zstd", "numcodecs.zstd": "zstd", "blosc": "blosc",
           "numcodecs.blosc": "blosc", "lz4": "lz4", "numcodecs.lz4": "lz4"}

_ZSTD_MAGIC = 0xFD2FB528


def ceiling_of(nbytes: int) -> int:
    """The most a compressor inside a chain may make for a chunk of ``nbytes``.

    The bytes and the worst overhead of compressing incompressible ones (zstd's and bz2's
    about 1 %, deflate's 5 bytes a block, blosc's 16), with room to spare.
    """
    return nbytes + nbytes // 64 + (64 << 10)


def inflate(kind: str, data, *, chunk: int, exact: int | None, config: dict | None = None,
            ceiling: int | None = None) -> bytes | None:
    """``data`` of format ``kind`` inflated, or refused past what its chunk may make.

    ``chunk``: the chunk's bytes (for messages); ``exact``: the bytes this compressor must
    make, where known; else ``ceiling`` (default :func:`ceiling_of` ``chunk``) bounds them.
    Returns the bytes for a stream format and for zstd where ``exact`` is known, ``None``
    once a sized header has been checked (its codec then decodes it). ``config``: an lzma
    codec's settings.
    """
    data = memoryview(data).cast("B")
    bound = exact if exact is not None else (ceiling if ceiling is not None
                                             else ceiling_of(chunk))
    if kind in ("gzip", "zlib", "bz2", "lzma"):
        return _stream(kind, data, bound, chunk, config or {})
    if kind == "zstd":
        return _zstd(data, bound, chunk, exact)
    claimed = _claimed_size(kind, data)
    if claimed > bound:
        raise _bomb(kind, f"says it makes {claimed:,} bytes, more than the {bound:,} a "
                    f"chunk of {chunk:,} bytes may make")
    return None


def _bomb(kind: str, what: str) -> StoreReadError:
    return StoreReadError(f"a chunk compressed with {kind} {what}: refused (a compression "
                          "bomb, or metadata that lies).")


def _damaged(kind: str, what: str) -> ValueError:
    """Bytes no codec would read: said as zarr's own codecs say it, where the read is."""
    return ValueError(f"a chunk compressed with {kind} {what}")


def _stream(kind: str, data: memoryview, bound: int, chunk: int, config: dict) -> bytes:
    """A stream inflated member by member, to ``bound`` bytes, as the codec reads it."""
    pieces, total, members = [], 0, 0
    rest = bytes(data)
    while rest:
        members += 1
        if members > MAX_MEMBERS:
            raise _bomb(kind, f"holds more than {MAX_MEMBERS} streams")
        decoder = _decoder(kind, config)
        try:
            piece = decoder.decompress(rest, bound + 1 - total)
        except (zlib.error, OSError, EOFError, lzma.LZMAError) as error:
            if pieces and kind in ("bz2", "lzma"):   # bz2 and lzma ignore a tail not theirs
                break
            if isinstance(error, lzma.LZMAError) and "limit" in str(error):
                raise StoreReadError(
                    f"a chunk compressed with lzma asks for a dictionary of more than "
                    f"{LZMA_MEMORY:,} bytes (xz's largest preset needs 65 MiB): refused (a "
                    "compression bomb, or metadata that lies).") from error
            raise _damaged(kind, f"could not be decoded ({error})") from error
        total += len(piece)
        pieces.append(piece)
        if total > bound:
            raise _bomb(kind, f"inflates past {bound:,} bytes, the most a chunk of {chunk:,} "
                        "bytes may make")
        if not decoder.eof:
            raise _damaged(kind, "ends before its stream does")
        rest = decoder.unused_data
        if kind == "zlib":   # zlib reads one stream
            break
        if kind == "gzip":   # gzip skips zeros between and after its members
            rest = rest.lstrip(b"\0")
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


def _claimed_size(kind: str, data: memoryview) -> int:
    """The decoded size a blosc or lz4 header states."""
    if kind == "blosc":
        if len(data) < 16:
            raise _damaged(kind, "is shorter than its 16-byte header")
        return struct.unpack_from("<I", data, 4)[0]
    if len(data) < 4:
        raise _damaged(kind, "is shorter than its 4-byte size")
    return struct.unpack_from("<i", data, 0)[0]


def _zstd(data: memoryview, bound: int, chunk: int, exact: int | None) -> bytes | None:
    """A zstd chunk, decoded into exactly ``exact`` bytes where known.

    Whatever its frames say, then; else its frames must each state a size, together within
    ``bound``.
    """
    sizes = zstd_frame_sizes(data)
    stated = sum(s for s in sizes if s is not None)
    if stated > bound:
        raise _bomb("zstd", f"says it makes {stated:,} bytes, more than the {bound:,} a "
                    f"chunk of {chunk:,} bytes may make")
    if exact is None:
        if None in sizes:
            raise StoreReadError("a zstd chunk does not say its size, and what it must make "
                                 "is not known here: refused (a compression bomb cannot be "
                                 "told from it).")
        return None
    if None not in sizes and stated != exact:
        raise _damaged("zstd", f"says it makes {stated:,} bytes, not the {exact:,} it must")
    out = np.zeros(exact, np.uint8)
    try:
        importlib.import_module("numcodecs").Zstd().decode(bytes(data), out=out)
    except (RuntimeError, ValueError) as error:
        raise _damaged("zstd", f"did not make the {exact:,} bytes it must ({error})") \
            from error
    return out.tobytes()


def zstd_frame_sizes(data: memoryview) -> list:
    """The content size each zstd frame of ``data`` states (``None`` where left out).

    The frames' blocks are walked to find the next frame; skippable frames are passed over.
    """
    sizes, at = [], 0
    while at < len(data):
        if len(data) - at < 4:
            raise _damaged("zstd", f"ends with {len(data) - at} stray bytes")
        magic = struct.unpack_from("<I", data, at)[0]
        if magic & 0xFFFFFFF0 == 0x184D2A50:   # a skippable frame: its length, then bytes
            if len(data) - at < 8:
                raise _damaged("zstd", "ends inside a skippable frame")
            at += 8 + struct.unpack_from("<I", data, at + 4)[0]
            continue
        if magic != _ZSTD_MAGIC:
            raise _damaged("zstd", f"holds no zstd frame at byte {at}")
        size, at = _zstd_frame(data, at)
        sizes.append(size)
    if not sizes:
        raise _damaged("zstd", "holds no zstd frame")
    return sizes


def _zstd_frame(data: memoryview, at: int) -> tuple[int | None, int]:
    """One frame at ``at``: its stated content size and where the next begins."""
    if len(data) < at + 6:
        raise _damaged("zstd", "is shorter than its frame header")
    descriptor = data[at + 4]
    size_flag, single = descriptor >> 6, (descriptor >> 5) & 1
    checksum, dict_flag = (descriptor >> 2) & 1, descriptor & 3
    start = at + 5 + (0 if single else 1) + (0, 1, 2, 4)[dict_flag]
    width = (1 if single else 0, 2, 4, 8)[size_flag]
    if len(data) < start + width:
        raise _damaged("zstd", "is shorter than its frame header")
    size = None
    if width:
        size = int.from_bytes(data[start:start + width], "little") + (256 if width == 2 else 0)
    at = start + width
    while True:   # blocks: a 3-byte header, then their bytes (one for a run)
        if len(data) < at + 3:
            raise _damaged("zstd", "ends inside a frame")
        header = int.from_bytes(data[at:at + 3], "little")
        kind, length = (header >> 1) & 3, header >> 3
        if kind == 3:
            raise _damaged("zstd", "holds a block of a reserved type")
        at += 3 + (1 if kind == 1 else length)
        if header & 1:
            return size, at + 4 * checksum


def bounded_array(array):
    """``array`` (a zarr array) reopened with its compressors bounded.

    A dask array has the zarr arrays it reads (``da.from_zarr``'s) so reopened; anything
    else is returned as is.
    """
    if type(array).__module__.split(".")[0] == "dask":
        return _bounded_dask(array)
    if type(array).__module__.split(".")[0] != "zarr":
        return array
    zarr = importlib.import_module("zarr")
    if not isinstance(array, zarr.Array):   # a group: its arrays are bounded as levels
        return array
    metadata = array.metadata
    if getattr(metadata, "zarr_format", None) == 3:
        codecs = _bounded_chain(tuple(metadata.codecs))
        if codecs == tuple(metadata.codecs):
            return array
        metadata = dataclasses.replace(metadata, codecs=codecs)
    elif getattr(metadata, "zarr_format", None) == 2:
        replaced = _bounded_v2(metadata)
        if replaced is None:
            return array
        metadata = dataclasses.replace(metadata, **replaced)
    else:
        return array
    old = array.async_array
    new = type(old)(metadata=metadata, store_path=old.store_path, config=old.config)
    return zarr.Array(new)


def _bounded_dask(array):
    """A dask array whose graph reads its zarr arrays bounded.

    ``from_zarr`` keeps the array in a layer of its own, or inlines it into its reads'
    layer (``inline_array=True``).
    """
    graph = getattr(array, "dask", None)
    if not hasattr(graph, "layers") or not hasattr(array, "chunks"):
        return array
    from dask.array import Array
    from dask.blockwise import Blockwise
    from dask.highlevelgraph import HighLevelGraph, MaterializedLayer

    layers, changed = dict(graph.layers), False
    for name, layer in layers.items():
        if isinstance(layer, MaterializedLayer):
            mapping = {key: bounded_array(value) if _is_zarr_array(value) else value
                       for key, value in layer.mapping.items()}
            if any(mapping[key] is not layer.mapping[key] for key in mapping):
                layers[name], changed = MaterializedLayer(mapping, layer.annotations), True
        elif isinstance(layer, Blockwise) and any(_is_zarr_array(value)
                                                  for value, _ in layer.indices):
            layers[name], changed = _copied(layer), True
            layers[name].indices = tuple((bounded_array(value), index)
                                         if _is_zarr_array(value) else (value, index)
                                         for value, index in layer.indices)
    if not changed:
        return array
    bounded = HighLevelGraph(layers, dict(graph.dependencies))
    return Array(bounded, array.name, array.chunks, meta=array._meta)


def _is_zarr_array(value) -> bool:
    return (type(value).__module__.split(".")[0] == "zarr"
            and type(value).__name__ == "Array")


def _copied(layer):
    """A shallow copy of a dask graph layer (its attributes, not its tasks)."""
    copied = object.__new__(type(layer))
    copied.__dict__.update(layer.__dict__)
    return copied


def _name(codec) -> str | None:
    return codec.to_dict().get("name") if hasattr(codec, "to_dict") else None


def _bounded_chain(codecs: tuple) -> tuple:
    """A v3 codec chain with its compressors wrapped.

    The first after bytes of a known size (the chunk's, and any checksums') decodes into
    exactly what it must make.
    """
    wrapper = _classes()["BoundedBytesCodec"]
    out, extra = [], None   # extra: bytes past the chunk's before this codec, where known
    for codec in codecs:
        name = _name(codec)
        if isinstance(codec, wrapper):
            out.append(codec)
            extra = None
        elif name == "sharding_indexed":
            inner = _bounded_chain(tuple(codec.codecs))
            out.append(codec if inner == tuple(codec.codecs) else type(codec)(
                chunk_shape=codec.chunk_shape, codecs=inner,
                index_codecs=codec.index_codecs, index_location=codec.index_location))
            extra = None
        elif name == "bytes":
            out.append(codec)
            extra = 0
        elif name in FORMATS:
            out.append(wrapper(codec, extra))
            extra = None
        else:
            out.append(codec)
            extra = extra + 4 if name == "crc32c" and extra is not None else None
    return tuple(out)


def _bounded_v2(metadata) -> dict | None:
    """A v2 array's compressor and compressing filters wrapped, as ``replace`` fields."""
    nbytes = _chunk_bytes(metadata.chunks, metadata.dtype)
    if nbytes is None:
        return None
    compressor_class = _classes()["BoundedCompressor"]
    filters = list(metadata.filters or ())
    ids = [getattr(f, "codec_id", None) for f in filters]
    widening = 1 if all(i in FORMATS or i in SIZE_KEEPING_FILTERS for i in ids) \
        else FILTER_WIDENING
    ceiling = ceiling_of(nbytes * widening)

    def wrapped(codec, exact):
        if codec is None or isinstance(codec, compressor_class) \
                or getattr(codec, "codec_id", None) not in FORMATS:
            return codec
        return compressor_class(codec, nbytes, exact, ceiling)

    # filters[0] is decoded last, into the chunk itself; the compressor first, into the
    # chunk where no filter follows it
    new_filters = tuple(wrapped(f, nbytes if i == 0 else None) for i, f in enumerate(filters))
    compressor = wrapped(metadata.compressor, None if filters else nbytes)
    same = all(a is b for a, b in zip(new_filters, filters, strict=True))
    if compressor is metadata.compressor and same:
        return None
    return {"compressor": compressor, "filters": new_filters or metadata.filters}


def _chunk_bytes(shape, dtype) -> int | None:
    """The bytes of one chunk of ``shape`` (``None`` for values of no fixed size)."""
    native = dtype.to_native_dtype() if hasattr(dtype, "to_native_dtype") else np.dtype(dtype)
    if native.kind in "OT" or native.itemsize == 0:   # objects, numpy's variable strings
        return None
    return math.prod(int(n) for n in shape) * native.itemsize


@functools.cache
def _classes() -> dict:
    """The wrappers, made once zarr is imported (it is an optional dependency)."""
    from numcodecs.abc import Codec
    from zarr.abc.codec import BytesBytesCodec

    @dataclasses.dataclass(frozen=True)
    class BoundedBytesCodec(BytesBytesCodec):
        """A zarr v3 compressor whose decoding is bounded by the chunk it makes.

        ``extra``: the bytes past the chunk's it must make (checksums'), where known.
        """

        inner: object
        extra: int | None = None
        is_fixed_size = False

        def to_dict(self):
            return self.inner.to_dict()

        def evolve_from_array_spec(self, array_spec):
            return type(self)(self.inner.evolve_from_array_spec(array_spec), self.extra)

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
                exact = None if self.extra is None else nbytes + self.extra
                made = await asyncio.to_thread(   # off zarr's loop, as its codecs decode
                    inflate, FORMATS[settings["name"]], chunk_bytes.as_numpy_array(),
                    chunk=nbytes, exact=exact, config=settings.get("configuration"))
                if made is not None:
                    return chunk_spec.prototype.buffer.from_bytes(made)
            return await self.inner._decode_single(chunk_bytes, chunk_spec)

    class BoundedCompressor(Codec):
        """A zarr v2 (numcodecs) compressor or filter whose decoding is bounded."""

        codec_id = "pv_cubemarch.bounded"

        def __init__(self, inner, chunk: int, exact: int | None, ceiling: int):
            self.inner, self.chunk, self.exact, self.ceiling = inner, chunk, exact, ceiling

        def get_config(self):
            return self.inner.get_config()

        def encode(self, buf):
            return self.inner.encode(buf)

        def decode(self, buf, out=None):
            made = inflate(FORMATS[self.inner.codec_id], buf, chunk=self.chunk,
                           exact=self.exact, ceiling=self.ceiling,
                           config=self.inner.get_config())
            if made is None:
                return self.inner.decode(buf, out)
            if out is None:
                return made
            view = np.frombuffer(memoryview(out).cast("B"), np.uint8)
            if view.size != len(made):
                raise _damaged(self.inner.codec_id, f"made {len(made):,} bytes, not "
                               f"the {view.size:,} asked for")
            view[:] = np.frombuffer(made, np.uint8)
            return out

        def __repr__(self):
            return f"BoundedCompressor({self.inner!r}, chunk={self.chunk})"

    classes = {"BoundedBytesCodec": BoundedBytesCodec, "BoundedCompressor": BoundedCompressor}
    for name, cls in classes.items():   # pickled by name: found by __getattr__ below
        cls.__module__, cls.__qualname__ = __name__, name
    return classes


def __getattr__(name: str):
    """The wrapper classes, made on first use (so pickles of bounded arrays load anywhere)."""
    if name in ("BoundedBytesCodec", "BoundedCompressor"):
        return _classes()[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
