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
    TREE_LAYOUT,
    VALUE_TYPES,
    Buf,
    Descriptor,
    Header,
    VdbFormatError,
    VdbGridInfo,
    bits,
    corrupt,
    parse_tree_type,
)

#: Environment variable that raises the default memory budget of a read, in bytes.
BUDGET_ENV = "PV_CUBEMARCH_VDB_MAX_BYTES"


class Budget:
    """Bytes a read may allocate; exceeding it stops the read before the allocation."""

    def __init__(self, name: str, limit: int) -> None:
        self.name = name
        self.limit = int(limit)
        self.used = 0

    def spend(self, nbytes: int, what: str) -> None:
        """Account for ``nbytes`` more, or refuse with what to do instead."""
        self.used += int(nbytes)
        if self.used > self.limit:
            raise VdbFormatError(
                f"grid '{self.name}': reading it needs more than max_bytes={self.limit} "
                f"bytes ({what}); pass region=((i0, j0, k0), (i1, j1, k1)) to read a "
                f"sub-box, stride=N to subsample, or a larger max_bytes (for USD stages "
                f"and the command line, set the environment variable {BUDGET_ENV})")


def tree_layout(info: VdbGridInfo) -> list[int]:
    """The node sizes of a grid's tree, refused unless OpenVDB registers that layout."""
    _value_type, dims = parse_tree_type(info.tree_type)
    if dims != TREE_LAYOUT:
        raise VdbFormatError(
            f"grid '{info.name}': tree type {info.tree_type!r} is not a layout OpenVDB "
            f"registers (Tree_<type>_{'_'.join(map(str, TREE_LAYOUT))}); re-save the grid "
            "with a standard OpenVDB grid type")
    return dims


class Codec:
    """Per-grid settings for decoding value arrays."""

    def __init__(self, info: VdbGridInfo, version: int, budget: Budget | None = None) -> None:
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
        self.budget = budget or Budget(info.name, 2**62)

    def shape(self, n: int) -> tuple:
        """Array shape of ``n`` values."""
        return (n,) if self.comps == 1 else (n, self.comps)

    def full_values(self, raw: bytes, n: int) -> np.ndarray:
        """Decode ``n`` full-precision values (not half) into the output dtype."""
        return np.frombuffer(raw, dtype=self.full).reshape(self.shape(n)).astype(self.out)

    def negate(self, value: np.ndarray) -> np.ndarray:
        """OpenVDB's math::negative: logical not for bool, unary minus otherwise."""
        return np.logical_not(value) if self.is_bool else -value

    def chunk(self, buf: Buf, count: int, decode: bool = True,
              field: str = "values") -> bytes | None:
        """Read (or skip) ``count`` stored values, decompressing them."""
        nbytes = count * self.stored_item
        if self.half and count == 0:
            return b""
        if not self.compression & (COMPRESS_ZIP | COMPRESS_BLOSC):
            return buf.take(nbytes, field) if decode else buf.skip(nbytes, field)
        at = buf.pos
        size = buf.i64(field + " chunk size")
        if size <= 0:
            if -size != nbytes:
                raise corrupt(at, field + " chunk size",
                              f"a raw chunk of {-size} bytes where {nbytes} are stored")
            return buf.take(nbytes, field) if decode else buf.skip(nbytes, field)
        if not decode:
            return buf.skip(size, field + " chunk")
        return self._decompress(buf.take(size, field + " chunk"), nbytes, at, field)

    def _decompress(self, packed: bytes, nbytes: int, at: int, field: str) -> bytes:
        """Decompress one zip or blosc chunk into exactly ``nbytes``, never more."""
        what = field + " chunk"
        if self.compression & COMPRESS_BLOSC:
            if blosc is None:
                raise VdbFormatError(
                    f"grid '{self.name}' is compressed with blosc; {INSTALL_BLOSC}")
            packed = bytes(packed)
            try:   # the header says how much it makes: check that before decompressing
                if not blosc.cbuffer_validate(packed):
                    raise corrupt(at, what, "a blosc chunk whose header is not valid")
                made, stored, _block = blosc.get_cbuffer_sizes(packed)
                if made != nbytes or stored > len(packed):
                    raise corrupt(at, what, f"a blosc chunk that makes {made} bytes where "
                                            f"{nbytes} are stored")
                raw = blosc.decompress(packed)
            except VdbFormatError:
                raise
            except Exception as exc:  # noqa: BLE001 - blosc raises several kinds, all corrupt
                raise corrupt(at, what, f"blosc could not decompress it ({exc})") from exc
        else:
            inflate = zlib.decompressobj()
            try:
                raw = inflate.decompress(packed, max(nbytes, 1))   # 0 would mean no limit
                extra = len(raw) > nbytes or bool(inflate.decompress(inflate.unconsumed_tail, 1))
            except zlib.error as exc:
                raise corrupt(at, what, f"zlib could not decompress it ({exc})") from exc
            if extra:
                raise corrupt(at, what, f"a zip chunk that makes more than {nbytes} bytes")
        if len(raw) != nbytes:
            raise corrupt(at, what, f"a compressed chunk that makes {len(raw)} bytes where "
                                    f"{nbytes} are stored")
        return raw

    def decode(self, raw: bytes, n: int) -> np.ndarray:
        """Turn stored bytes of ``n`` values into an array of the output dtype."""
        arr = np.frombuffer(raw, dtype=self.stored).reshape(self.shape(n))
        if self.is_bool:
            return arr != 0
        return arr.astype(self.out)


def _mode(buf: Buf, field: str) -> int:
    """Read a per-node metadata byte (how inactive values are stored): 0 to 6."""
    at = buf.pos
    mode = buf.u8(field)
    if mode > NO_MASK_AND_ALL_VALS:
        raise corrupt(at, field, f"per-node metadata byte {mode} is not one of OpenVDB's "
                                 f"0-{NO_MASK_AND_ALL_VALS}")
    return mode


def _read_node_values(buf: Buf, codec: Codec, n: int, active: np.ndarray) -> np.ndarray:
    """Read the ``n`` compressed tile values of an internal node."""
    mode = _mode(buf, "node metadata byte")
    codec.modes[mode] = codec.modes.get(mode, 0) + 1
    bg = codec.background
    val0 = bg if mode == NO_MASK_OR_INACTIVE_VALS else codec.negate(bg)
    val1 = bg
    if mode in MODES_WITH_VALUE:
        val0 = codec.full_values(buf.take(codec.item, "node inactive value"), 1)[0]
        if mode == MASK_AND_TWO_INACTIVE_VALS:
            val1 = codec.full_values(buf.take(codec.item, "node inactive value"), 1)[0]
    select = bits(buf.take(n // 8, "node selection mask")) if mode in MODES_WITH_MASK else None
    stored = active if codec.mask_compressed and mode != NO_MASK_AND_ALL_VALS else None
    count = n if stored is None else int(stored.sum())
    data = codec.decode(codec.chunk(buf, count, field="node values"), count)
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
    #: tiles larger than a leaf, a group per node: (origins (n, 3), side, values, active)
    big_tiles: list = field(default_factory=list)
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
    child_mask = bits(buf.take(n // 8, "node child mask"))
    active = bits(buf.take(n // 8, "node value mask"))
    values = _read_node_values(buf, codec, n, active)
    _collect_tiles(tree, codec, origin, log2, child_log2, child_mask, active, values,
                   bottom=len(dims) == 2)
    children = np.flatnonzero(child_mask)
    child_origins = origin + (_node_coords(children, log2) << child_log2)
    if len(dims) == 2:
        leaf_bytes = (1 << (3 * dims[1])) // 8
        codec.budget.spend(9 * leaf_bytes * len(children) + 24 * len(children), "leaf masks")
        tree.leaf_masks.append(buf.take(leaf_bytes * len(children), "leaf value masks"))
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
    codec.budget.spend(len(idx) * (25 + codec.out.itemsize * codec.comps), "tiles")
    origins = origin + (_node_coords(idx, log2) << child_log2)
    if bottom:
        tree.small_origins.append(origins)
        tree.small_values.append(values[idx])
        tree.small_active.append(active[idx])
        return
    tree.big_tiles.append((origins, 1 << child_log2, values[idx], active[idx]))


def read_root(buf: Buf, codec: Codec, dims: list[int]) -> Tree:
    """Read the tree topology: root tiles, internal nodes and leaf value masks."""
    at = buf.pos
    buffer_count = struct.unpack("<i", buf.take(4, "buffer count"))[0]
    if buffer_count != 1:
        raise VdbFormatError(
            f"grid '{codec.name}' has {buffer_count} buffers per leaf at offset {at} "
            "(multi-buffer trees are no longer supported by OpenVDB); re-save it with a "
            "current OpenVDB", at, "buffer count")
    background = codec.full_values(buf.take(codec.item, "background"), 1)[0]
    codec.background = background
    tree = Tree(background=background, leaf_dim=1 << dims[-1])
    child_dim = 1 << sum(dims)
    rec = np.dtype([("o", "<i4", (3,)), ("v", codec.full, (codec.comps,)), ("a", "u1")])
    at = buf.pos
    num_tiles = buf.count("<I", rec.itemsize, "root tile count")
    num_children = buf.count("<I", 12 + 2 * (1 << 3 * dims[0]) // 8, "root child count")
    codec.budget.spend((num_tiles + num_children) * 256, "root tiles")   # with their keys
    tiles = np.frombuffer(buf.take(rec.itemsize * num_tiles, "root tiles"), dtype=rec)
    origins = tiles["o"].astype(np.int64)
    if (origins % child_dim).any():
        raise corrupt(at + 8, "root tiles", f"a root tile's origin is not a multiple of "
                                            f"{child_dim}")
    if num_tiles:
        values = tiles["v"].astype(codec.out)
        tree.big_tiles.append((origins, child_dim, values[:, 0] if codec.comps == 1
                               else values, tiles["a"] != 0))
    keys = {tuple(o) for o in origins.tolist()}
    if len(keys) < num_tiles:
        raise corrupt(at + 8, "root tiles", "two root tiles at the same origin")
    last = (-2**63,) * 3
    for _ in range(num_children):
        at = buf.pos
        origin = np.array(buf.unpack("<3i", "root child origin"), dtype=np.int64)
        if (origin % child_dim).any():   # OpenVDB would file it where no lookup finds it
            raise corrupt(at, "root child origin", f"{tuple(origin.tolist())} is not a "
                                                   f"multiple of {child_dim}")
        key = tuple(origin.tolist())
        if key in keys or key <= last:
            # OpenVDB writes its root's children in coordinate order and reads their
            # buffers in that order: any other order would pair leaves with other data
            raise corrupt(at, "root child origin", f"a root child at {key} after one at "
                                                   f"{last}, or on a tile")
        keys.add(key)
        last = key
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


def _leaf_mask(buf: Buf, mask: bytes, field: str) -> None:
    """Read a leaf's buffer copy of its value mask: it must equal the topology's copy."""
    at = buf.pos
    if buf.take(len(mask), field) != mask:
        raise corrupt(at, field, "a leaf's value mask differs from the copy stored with "
                                 "the tree's topology")


def read_leaves(buf: Buf, codec: Codec, tree: Tree, masks: np.ndarray, wanted: np.ndarray,
                ) -> np.ndarray | None:
    """Read the leaf buffers; return values (N, voxels[, 3]) of the wanted leaves."""
    n, voxels = masks.shape
    mask_bytes = voxels // 8
    raw_masks = b"".join(tree.leaf_masks)
    if codec.is_bool:
        values = _read_bool_leaves(buf, masks, raw_masks, tree)
        return values[wanted] if wanted.any() else None
    counts = masks.sum(axis=1)
    modes = np.full(n, NO_MASK_AND_ALL_VALS, np.uint8)
    inactive_raw = {}
    select_raw = {}
    chunks = []
    for i in range(n):
        _leaf_mask(buf, raw_masks[i * mask_bytes:(i + 1) * mask_bytes], "leaf value mask")
        mode = _mode(buf, "leaf metadata byte")
        modes[i] = mode
        if mode in MODES_WITH_VALUE:
            nval = 2 if mode == MASK_AND_TWO_INACTIVE_VALS else 1
            inactive_raw[i] = buf.take(codec.item * nval, "leaf inactive values")
        if mode in MODES_WITH_MASK:
            select_raw[i] = buf.take(mask_bytes, "leaf selection mask")
        count = int(counts[i]) if codec.mask_compressed and mode != 6 else voxels
        raw = codec.chunk(buf, count, decode=bool(wanted[i]), field="leaf values")
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


def _read_bool_leaves(buf: Buf, masks: np.ndarray, raw_masks: bytes, tree: Tree
                      ) -> np.ndarray:
    """Read bool leaf buffers: value mask, origin and a value bit mask per leaf.

    The buffer repeats the leaf's value mask and origin; both must equal the topology's.
    """
    n, voxels = masks.shape
    mb = voxels // 8
    at = buf.pos
    rec = np.frombuffer(buf.take((2 * mb + 12) * n, "bool leaf buffers"), np.uint8
                        ).reshape(n, 2 * mb + 12)
    topology = np.frombuffer(raw_masks, np.uint8).reshape(n, mb)
    origins = np.concatenate(tree.leaf_origins) if n else np.zeros((0, 3), np.int64)
    stored = rec[:, mb:mb + 12].copy().view("<i4").astype(np.int64)
    for bad, what in ((rec[:, :mb] != topology, "value mask"),
                      (stored != origins, "origin")):
        rows = np.flatnonzero(bad.any(axis=1))
        if len(rows):
            raise corrupt(at + int(rows[0]) * (2 * mb + 12), f"bool leaf {what}",
                          f"a leaf's {what} differs from the one stored with the topology")
    return bits(rec[:, mb + 12:].tobytes(), mb)


def skip_tree(buf: Buf, desc: Descriptor, header: Header, budget: Budget) -> None:
    """Move past a grid's topology and buffers (files without grid offsets)."""
    codec = Codec(desc.info, header.version, budget)
    tree = read_root(buf, codec, tree_layout(desc.info))
    _origins, masks = leaf_arrays(tree, codec)
    read_leaves(buf, codec, tree, masks, np.zeros(len(masks), bool))
