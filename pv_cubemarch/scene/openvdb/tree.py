"""A grid's tree: root, internal nodes and leaves, with their compressed value arrays."""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass, field

import numpy as np

try:
    import blosc
except ImportError:  # pragma: no cover - depends on the environment
    blosc = None

from .records import (
    COMPRESS_ACTIVE_MASK,
    COMPRESS_BLOSC,
    COMPRESS_ZIP,
    INSTALL_BLOSC,
    MASK_AND_TWO_INACTIVE_VALS,
    MODES_WITH_MASK,
    MODES_WITH_VALUE,
    NO_MASK_AND_ALL_VALS,
    NO_MASK_OR_INACTIVE_VALS,
    VALUE_TYPES,
    Buf,
    Descriptor,
    Header,
    VdbFormatError,
    VdbGridInfo,
    bits,
    parse_tree_type,
)


class Codec:
    """Per-grid settings for decoding value arrays."""

    def __init__(self, info: VdbGridInfo, version: int) -> None:
        if info.value_type not in VALUE_TYPES:
            raise VdbFormatError(
                f"grid '{info.name}' has value type '{info.value_type}' "
                f"({info.tree_type}), which this reader does not support; supported: "
                f"{', '.join(VALUE_TYPES)}")
        scalar, comps, real = VALUE_TYPES[info.value_type]
        self.name = info.name
        self.is_bool = info.value_type == "bool"
        self.comps = comps
        self.full = np.dtype(scalar)
        self.half = info.stored_as_half and real
        self.stored = np.dtype("<f2") if self.half else self.full
        self.out = np.dtype(bool) if self.is_bool else self.full.newbyteorder("=")
        if self.half and self.full == np.dtype("<f4"):
            self.out = np.dtype(np.float32)
        self.item = self.full.itemsize * comps
        self.stored_item = self.stored.itemsize * comps
        self.compression = info.compression
        self.mask_compressed = bool(info.compression & COMPRESS_ACTIVE_MASK)
        self.version = version
        self.background = None
        self.modes: dict = {}

    def shape(self, n: int) -> tuple:
        """Array shape of ``n`` values."""
        return (n,) if self.comps == 1 else (n, self.comps)

    def full_values(self, raw: bytes, n: int) -> np.ndarray:
        """Decode ``n`` full-precision values (not half) into the output dtype."""
        return np.frombuffer(raw, dtype=self.full).reshape(self.shape(n)).astype(self.out)

    def negate(self, value: np.ndarray) -> np.ndarray:
        """OpenVDB's math::negative: logical not for bool, unary minus otherwise."""
        return np.logical_not(value) if self.is_bool else -value

    def chunk(self, buf: Buf, count: int, decode: bool = True) -> bytes | None:
        """Read (or skip) ``count`` stored values, decompressing them."""
        nbytes = count * self.stored_item
        if self.half and count == 0:
            return b""
        if not self.compression & (COMPRESS_ZIP | COMPRESS_BLOSC):
            return buf.take(nbytes) if decode else buf.skip(nbytes)
        size = buf.i64()
        if size <= 0:
            if -size != nbytes:
                raise VdbFormatError(
                    f"grid '{self.name}': expected a {nbytes}-byte chunk, found "
                    f"{-size} bytes at offset {buf.pos - 8}; the file is corrupt")
            return buf.take(nbytes) if decode else buf.skip(nbytes)
        if not decode:
            return buf.skip(size)
        return self._decompress(buf.take(size), nbytes)

    def _decompress(self, packed: bytes, nbytes: int) -> bytes:
        """Decompress one zip or blosc chunk."""
        if self.compression & COMPRESS_BLOSC:
            if blosc is None:
                raise VdbFormatError(
                    f"grid '{self.name}' is compressed with blosc; {INSTALL_BLOSC}")
            raw = blosc.decompress(packed)
        else:
            raw = zlib.decompress(packed)
        if len(raw) < nbytes:
            raise VdbFormatError(
                f"grid '{self.name}': a compressed chunk holds {len(raw)} bytes, expected "
                f"{nbytes}; the file is corrupt")
        return raw[:nbytes]

    def decode(self, raw: bytes, n: int) -> np.ndarray:
        """Turn stored bytes of ``n`` values into an array of the output dtype."""
        arr = np.frombuffer(raw, dtype=self.stored).reshape(self.shape(n))
        if self.is_bool:
            return arr != 0
        return arr.astype(self.out)


def _read_node_values(buf: Buf, codec: Codec, n: int, active: np.ndarray) -> np.ndarray:
    """Read the ``n`` compressed tile values of an internal node."""
    mode = buf.u8()
    codec.modes[mode] = codec.modes.get(mode, 0) + 1
    bg = codec.background
    val0 = bg if mode == NO_MASK_OR_INACTIVE_VALS else codec.negate(bg)
    val1 = bg
    if mode in MODES_WITH_VALUE:
        val0 = codec.full_values(buf.take(codec.item), 1)[0]
        if mode == MASK_AND_TWO_INACTIVE_VALS:
            val1 = codec.full_values(buf.take(codec.item), 1)[0]
    select = bits(buf.take(n // 8)) if mode in MODES_WITH_MASK else None
    stored = active if codec.mask_compressed and mode != NO_MASK_AND_ALL_VALS else None
    count = n if stored is None else int(stored.sum())
    data = codec.decode(codec.chunk(buf, count), count)
    if count == n:
        return data
    out = np.empty(codec.shape(n), dtype=codec.out)
    out[stored] = data
    off = ~stored
    if select is None:
        out[off] = val0
    else:
        sel = select[off]
        fill = np.where(sel if codec.comps == 1 else sel[:, None], val1, val0)
        out[off] = fill
    return out


@dataclass
class Tree:
    background: np.ndarray
    leaf_dim: int
    big_tiles: list = field(default_factory=list)  # (origin, dim, value, active)
    small_origins: list = field(default_factory=list)  # leaf-sized tiles
    small_values: list = field(default_factory=list)
    small_active: list = field(default_factory=list)
    leaf_origins: list = field(default_factory=list)
    leaf_masks: list = field(default_factory=list)  # raw mask bytes, per bottom node


def _node_coords(idx: np.ndarray, log2: int) -> np.ndarray:
    """Local (x, y, z) of linear offsets inside a node of side ``2**log2``."""
    dim = 1 << log2
    return np.stack([idx >> (2 * log2), (idx >> log2) & (dim - 1), idx & (dim - 1)], axis=1)


def _read_internal(buf: Buf, codec: Codec, tree: Tree, origin: np.ndarray,
                   dims: list[int]) -> None:
    """Read the topology of an internal node and, recursively, of its children."""
    log2 = dims[0]
    n = 1 << (3 * log2)
    child_log2 = sum(dims[1:])
    child_mask = bits(buf.take(n // 8))
    active = bits(buf.take(n // 8))
    values = _read_node_values(buf, codec, n, active)
    _collect_tiles(tree, codec, origin, log2, child_log2, child_mask, active, values,
                   bottom=len(dims) == 2)
    children = np.flatnonzero(child_mask)
    child_origins = origin + (_node_coords(children, log2) << child_log2)
    if len(dims) == 2:
        leaf_bytes = (1 << (3 * dims[1])) // 8
        tree.leaf_masks.append(buf.take(leaf_bytes * len(children)))
        tree.leaf_origins.append(child_origins)
        return
    for child_origin in child_origins:
        _read_internal(buf, codec, tree, child_origin, dims[1:])


def _collect_tiles(tree: Tree, codec: Codec, origin, log2, child_log2, child_mask, active,
                   values, bottom: bool) -> None:
    """Record the tiles of a node that are active or differ from the background."""
    differs = values != tree.background
    if codec.comps > 1:
        differs = differs.any(axis=1)
    keep = ~child_mask & (active | differs)
    idx = np.flatnonzero(keep)
    if not len(idx):
        return
    origins = origin + (_node_coords(idx, log2) << child_log2)
    if bottom:
        tree.small_origins.append(origins)
        tree.small_values.append(values[idx])
        tree.small_active.append(active[idx])
        return
    for o, v, a in zip(origins, values[idx], active[idx], strict=True):
        tree.big_tiles.append((o, 1 << child_log2, v, bool(a)))


def read_root(buf: Buf, codec: Codec, dims: list[int]) -> Tree:
    """Read the tree topology: root tiles, internal nodes and leaf value masks."""
    buffer_count = struct.unpack("<i", buf.take(4))[0]
    if buffer_count != 1:
        raise VdbFormatError(
            f"grid '{codec.name}' has {buffer_count} buffers per leaf (multi-buffer trees "
            "are no longer supported by OpenVDB); re-save it with a current OpenVDB")
    background = codec.full_values(buf.take(codec.item), 1)[0]
    codec.background = background
    tree = Tree(background=background, leaf_dim=1 << dims[-1])
    num_tiles, num_children = buf.unpack("<II")
    child_dim = 1 << sum(dims)
    rec = np.dtype([("o", "<i4", (3,)), ("v", codec.full, (codec.comps,)), ("a", "u1")])
    tiles = np.frombuffer(buf.take(rec.itemsize * num_tiles), dtype=rec)
    for t in tiles:
        value = t["v"].astype(codec.out)
        tree.big_tiles.append((t["o"].astype(np.int64), child_dim,
                               value[0] if codec.comps == 1 else value, bool(t["a"])))
    for _ in range(num_children):
        origin = np.array(buf.unpack("<3i"), dtype=np.int64)
        _read_internal(buf, codec, tree, origin, dims)
    return tree


def leaf_arrays(tree: Tree, codec: Codec) -> tuple[np.ndarray, np.ndarray]:
    """Concatenate leaf origins (N, 3) and value masks (N, leaf voxels)."""
    voxels = tree.leaf_dim ** 3
    if not tree.leaf_origins:
        return np.zeros((0, 3), np.int64), np.zeros((0, voxels), bool)
    origins = np.concatenate(tree.leaf_origins).astype(np.int64)
    masks = bits(b"".join(tree.leaf_masks), voxels // 8)
    return origins, masks


# --------------------------------------------------------------------- leaf buffers


def read_leaves(buf: Buf, codec: Codec, masks: np.ndarray, wanted: np.ndarray,
                 ) -> np.ndarray | None:
    """Read the leaf buffers; return values (N, voxels[, 3]) of the wanted leaves."""
    if codec.is_bool:
        return _read_bool_leaves(buf, masks)
    n, voxels = masks.shape
    mask_bytes = voxels // 8
    counts = masks.sum(axis=1)
    modes = np.full(n, NO_MASK_AND_ALL_VALS, np.int8)
    inactive_raw = {}
    select_raw = {}
    chunks = []
    for i in range(n):
        buf.skip(mask_bytes)
        mode = buf.u8()
        modes[i] = mode
        if mode in MODES_WITH_VALUE:
            nval = 2 if mode == MASK_AND_TWO_INACTIVE_VALS else 1
            inactive_raw[i] = buf.take(codec.item * nval)
        if mode in MODES_WITH_MASK:
            select_raw[i] = buf.take(mask_bytes)
        count = int(counts[i]) if codec.mask_compressed and mode != 6 else voxels
        raw = codec.chunk(buf, count, decode=bool(wanted[i]))
        if wanted[i]:
            chunks.append(raw)
    for mode, num in zip(*np.unique(modes, return_counts=True), strict=True):
        codec.modes[int(mode)] = codec.modes.get(int(mode), 0) + int(num)
    if not wanted.any():
        return None
    return _assemble_leaves(codec, masks[wanted], modes[wanted], chunks,
                            _subset(inactive_raw, wanted), _subset(select_raw, wanted))


def _subset(raw: dict, wanted: np.ndarray) -> dict:
    """Re-key a {leaf: bytes} dict to positions among the wanted leaves."""
    pos = np.cumsum(wanted) - 1
    return {int(pos[i]): v for i, v in raw.items() if wanted[i]}


def _assemble_leaves(codec: Codec, masks: np.ndarray, modes: np.ndarray, chunks: list,
                     inactive_raw: dict, select_raw: dict) -> np.ndarray:
    """Combine stored values and reconstructed inactive values of leaves, vectorised."""
    n, voxels = masks.shape
    if codec.mask_compressed:
        stored = masks | (modes == NO_MASK_AND_ALL_VALS)[:, None]
    else:
        stored = np.ones_like(masks)
    data = codec.decode(b"".join(chunks), int(stored.sum()))
    out = np.empty(codec.shape(n * voxels), dtype=codec.out).reshape(
        (n, voxels) + codec.shape(1)[1:])
    if data.shape[0] == n * voxels:
        out.reshape(data.shape)[...] = data
        return out
    out[...] = codec.background
    out[stored] = data
    odd = np.flatnonzero(modes != NO_MASK_OR_INACTIVE_VALS)
    if not len(odd):
        return out
    val0, val1 = _inactive_values(codec, modes[odd], _subset(inactive_raw, modes != 0))
    select = np.zeros((len(odd), voxels), bool)
    select_raw = _subset(select_raw, modes != 0)
    if select_raw:
        rows = np.fromiter(select_raw, dtype=np.int64, count=len(select_raw))
        select[rows] = bits(b"".join(select_raw.values()), voxels // 8)
    off = ~stored[odd]
    rows = np.nonzero(off)[0]
    sel = select[off]
    sub = out[odd]
    sub[off] = np.where(sel if codec.comps == 1 else sel[:, None], val1[rows], val0[rows])
    out[odd] = sub
    return out


def _inactive_values(codec: Codec, modes: np.ndarray, inactive_raw: dict):
    """Per-leaf inactive values (val0 where the selection bit is off, val1 where on)."""
    n = len(modes)
    bg = codec.background
    val0 = np.empty(codec.shape(n), dtype=codec.out)
    val0[...] = codec.negate(bg)
    val0[modes == NO_MASK_OR_INACTIVE_VALS] = bg
    val1 = np.empty_like(val0)
    val1[...] = bg
    for i, raw in inactive_raw.items():
        vals = codec.full_values(raw, len(raw) // codec.item)
        val0[i] = vals[0]
        if len(vals) == 2:
            val1[i] = vals[1]
    return val0, val1


def _read_bool_leaves(buf: Buf, masks: np.ndarray) -> np.ndarray:
    """Read bool leaf buffers: value mask, origin and a value bit mask per leaf."""
    n, voxels = masks.shape
    mb = voxels // 8
    rec = np.frombuffer(buf.take((2 * mb + 12) * n), np.uint8).reshape(n, 2 * mb + 12)
    return bits(rec[:, mb + 12:].tobytes(), mb)


def skip_tree(buf: Buf, desc: Descriptor, header: Header) -> None:
    """Move past a grid's topology and buffers (files without grid offsets)."""
    codec = Codec(desc.info, header.version)
    _value_type, dims = parse_tree_type(desc.info.tree_type)
    tree = read_root(buf, codec, dims)
    _origins, masks = leaf_arrays(tree, codec)
    read_leaves(buf, codec, masks, np.zeros(len(masks), bool))


# -------------------------------------------------------------------------- dense


