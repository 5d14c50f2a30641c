"""Grids of a file: listed from their descriptors, or read into dense arrays."""

from __future__ import annotations

import mmap

import numpy as np

from ...core.budgets import budget_from_env
from .records import (
    MAP_SIZES,
    Buf,
    Descriptor,
    Header,
    VdbFormatError,
    VdbGrid,
    VdbGridInfo,
    read_descriptor,
    read_header,
)
from .tree import (
    BUDGET_ENV,
    Budget,
    Codec,
    Tree,
    leaf_arrays,
    read_leaves,
    read_root,
    skip_tree,
    tree_layout,
)

#: Smallest grid descriptor and grid header: three strings, three offsets, the
#: compression flags, an empty metadata map and a map name.
_SMALLEST_GRID = 3 * 4 + 3 * 8 + 4 + 4 + 4


def default_max_bytes() -> int:
    """The memory budget of a read: ``PV_CUBEMARCH_VDB_MAX_BYTES`` or 1 GiB."""
    return budget_from_env(BUDGET_ENV, 2**30, VdbFormatError)


def _read_descriptors(buf: Buf, max_bytes: int | None = None
                      ) -> tuple[Header, list[Descriptor]]:
    """Read the header and every grid descriptor of a file."""
    header = read_header(buf)
    count = buf.count("<i", _SMALLEST_GRID, "grid count")
    seen: dict = {}
    out = []
    for _ in range(count):
        desc = read_descriptor(buf, header, seen)
        out.append(desc)
        if header.has_offsets:
            buf.seek(desc.end_pos, "grid end offset", desc.tree_pos)
        elif not desc.info.instance_parent:
            limit = default_max_bytes() if max_bytes is None else max_bytes
            skip_tree(buf, desc, header, Budget(desc.info.name, limit))
            desc.end_pos = buf.pos
    return header, out


class _OpenFile:
    """Context manager giving a Buf over a memory-mapped file."""

    def __init__(self, path) -> None:
        self.path = path
        self.file = None
        self.map = None

    def __enter__(self) -> Buf:
        self.file = open(self.path, "rb")  # noqa: SIM115 - closed in __exit__
        try:
            self.map = mmap.mmap(self.file.fileno(), 0, access=mmap.ACCESS_READ)
        except ValueError:  # empty file
            return Buf(b"")
        return Buf(self.map)

    def __exit__(self, *exc) -> None:
        if self.map is not None:
            self.map.close()
        self.file.close()


def list_grids(path) -> list[VdbGridInfo]:
    """List the grids of a ``.vdb`` file without decoding their voxels.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.vdb`` file.

    Returns
    -------
    list of VdbGridInfo
        One entry per grid, in file order.
    """
    with _OpenFile(path) as buf:
        _header, descs = _read_descriptors(buf)
    return [d.info for d in descs]


# ---------------------------------------------------------------------- tree parse


def _active_bbox(tree: Tree, origins: np.ndarray, masks: np.ndarray):
    """Inclusive (min, max) index box of active voxels and tiles, or None if empty."""
    lows, highs = [], []
    dim = tree.leaf_dim
    has = masks.any(axis=1)
    if has.any():
        m = masks[has].reshape(-1, dim, dim, dim)
        o = origins[has]
        for axis in range(3):
            other = tuple(a for a in (1, 2, 3) if a != axis + 1)
            occ = m.any(axis=other)
            lo = occ.argmax(axis=1)
            hi = dim - 1 - occ[:, ::-1].argmax(axis=1)
            lows.append((o[:, axis] + lo).min())
            highs.append((o[:, axis] + hi).max())
        lows, highs = [np.array(lows)], [np.array(highs)]
    for origins_, size, _values, active in tree.big_tiles:
        if active.any():
            lows.append(origins_[active].min(axis=0))
            highs.append(origins_[active].max(axis=0) + size - 1)
    if tree.small_origins:
        so = np.concatenate(tree.small_origins)[np.concatenate(tree.small_active)]
        if len(so):
            lows.append(so.min(axis=0))
            highs.append(so.max(axis=0) + dim - 1)
    if not lows:
        return None
    return np.min(lows, axis=0).astype(np.int64), np.max(highs, axis=0).astype(np.int64)


def _axis_targets(start: np.ndarray, dim: int, lo: int, count: int, stride: int):
    """Per-block target indices along one axis and whether each lands in the box."""
    rel = start[:, None] + np.arange(dim) - lo
    ok = (rel >= 0) & (rel % stride == 0)
    tgt = rel // stride
    ok &= tgt < count
    return tgt, ok


def _scatter_blocks(flat: np.ndarray, shape: tuple, lo: np.ndarray, stride: int,
                    origins: np.ndarray, values: np.ndarray, dim: int) -> None:
    """Write cubes of side ``dim`` (values (N, dim**3, ...)) into the dense array."""
    if not len(origins):
        return
    if stride == 1 and not (lo % dim).any() and not any(n % dim for n in shape):
        _scatter_aligned(flat, shape, lo, origins, values, dim)
        return
    tx, okx = _axis_targets(origins[:, 0], dim, lo[0], shape[0], stride)
    ty, oky = _axis_targets(origins[:, 1], dim, lo[1], shape[1], stride)
    tz, okz = _axis_targets(origins[:, 2], dim, lo[2], shape[2], stride)
    idx = ((tx[:, :, None, None] * shape[1] + ty[:, None, :, None]) * shape[2]
           + tz[:, None, None, :]).reshape(len(origins), -1)
    valid = (okx[:, :, None, None] & oky[:, None, :, None] & okz[:, None, None, :])
    valid = valid.reshape(len(origins), -1)
    if valid.all():
        flat[idx] = values
    else:
        flat[idx[valid]] = np.broadcast_to(values, valid.shape + values.shape[2:])[valid]


def _scatter_aligned(flat: np.ndarray, shape: tuple, lo: np.ndarray, origins: np.ndarray,
                     values: np.ndarray, dim: int) -> None:
    """Write cubes into a dense array whose box is aligned to the cube grid."""
    rel = (origins - lo) // dim
    inside = ((rel >= 0) & (rel < np.array(shape) // dim)).all(axis=1)
    if not inside.all():
        rel, values = rel[inside], values[inside]
    nb = [n // dim for n in shape]
    blocks = flat.reshape([nb[0], dim, nb[1], dim, nb[2], dim] + list(flat.shape[1:]))
    side = (1, 1, 1) if values.shape[1] == 1 else (dim, dim, dim)
    cubes = values.reshape((len(values),) + side + values.shape[2:])
    blocks[rel[:, 0], :, rel[:, 1], :, rel[:, 2], :] = cubes


def _tile_slice(o: int, size: int, lo: int, count: int, stride: int) -> slice | None:
    """Slice of dense indices covered by [o, o + size) along one axis, or None."""
    first = max(o - lo, 0)
    first = -(-first // stride)
    last = min((o + size - 1 - lo) // stride, count - 1)
    return slice(first, last + 1) if last >= first else None


def _paint_big_tiles(dense: np.ndarray, tree: Tree, lo: np.ndarray, stride: int) -> None:
    """Fill the dense array with tiles larger than a leaf (only those that reach it)."""
    hi = lo + (np.array(dense.shape[:3]) - 1) * stride
    for origins, size, values, _active in tree.big_tiles:
        near = np.flatnonzero(((origins + size - 1 >= lo) & (origins <= hi)).all(axis=1))
        for t in near:
            sl = tuple(_tile_slice(int(origins[t, a]), size, int(lo[a]), dense.shape[a],
                                   stride) for a in range(3))
            if None not in sl:
                dense[sl] = values[t]


def _spend_dense(codec: Codec, shape: tuple, padded: tuple, leaves: int) -> None:
    """Account for the dense box (and its padded copy) and the wanted leaves' values."""
    item = codec.out.itemsize * codec.comps
    nbytes = int(np.prod(np.array(padded, dtype=object))) * item
    if tuple(padded) != tuple(shape):
        nbytes += int(np.prod(np.array(shape, dtype=object))) * item
    codec.budget.spend(nbytes, f"a dense box of shape {tuple(shape)}")
    codec.budget.spend(3 * leaves * codec.item * 512, f"the values of {leaves} leaves")


# ------------------------------------------------------------------------- public


def _select(descs: list[Descriptor], name: str | None, index: int) -> Descriptor:
    """Pick a grid by name and index among grids of that name."""
    pool = descs if name is None else [d for d in descs if d.info.name == name]
    if not pool or not -len(pool) <= index < len(pool):
        names = ", ".join(repr(d.info.name) for d in descs) or "no grids"
        what = "grids" if name is None else f"grids named {name!r}"
        raise VdbFormatError(
            f"grid index {index} is out of range: the file holds {len(pool)} {what} "
            f"(all grids: {names}); pick one of them")
    return pool[index]


def _tree_source(descs: list[Descriptor], desc: Descriptor) -> Descriptor:
    """The descriptor whose stored tree a grid uses (itself, or its instance parent)."""
    parent = desc.info.instance_parent
    if not parent:
        return desc
    for d in descs:
        if d.info.unique_name == parent:
            return d
    raise VdbFormatError(
        f"grid '{desc.info.name}' is an instance of '{parent}', which is not in the file")


def _box(region, bbox, stride: int):
    """Resolve the inclusive index box to read and the dense shape."""
    if region is not None:
        lo = np.array(region[0], dtype=np.int64)
        hi = np.array(region[1], dtype=np.int64)
        if lo.shape != (3,) or hi.shape != (3,) or (hi < lo).any():
            raise VdbFormatError(
                f"region must be ((i0, j0, k0), (i1, j1, k1)) with i1 >= i0 etc.; got {region}")
    elif bbox is None:
        return np.zeros(3, np.int64), (0, 0, 0)
    else:
        lo, hi = bbox
    return lo, tuple(int(v) for v in (hi - lo) // stride + 1)


def _leaf_wanted(origins: np.ndarray, dim: int, lo: np.ndarray, shape: tuple,
                 stride: int) -> np.ndarray:
    """Which leaves overlap the box being read."""
    hi = lo + (np.array(shape) - 1) * stride
    return ((origins + dim - 1 >= lo) & (origins <= hi)).all(axis=1)


def read_grid(path, name: str | None = None, index: int = 0,
              region=None, stride: int = 1, max_bytes: int | None = None) -> VdbGrid:
    """Read one grid of a ``.vdb`` file into a dense numpy array.

    Every byte of the file is checked before it is trusted: a damaged or hostile file
    raises :class:`VdbFormatError` (naming the offset and the field), never another
    error, and a read never allocates more than ``max_bytes``.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.vdb`` file.
    name : str, optional
        Grid name; None selects among all grids of the file (the first by default).
    index : int, default 0
        Which of the grids named ``name`` (or of all grids, if ``name`` is None).
    region : tuple, optional
        Inclusive index box ``((i0, j0, k0), (i1, j1, k1))``; default: the active
        voxel bounding box of the tree (active tiles included).
    stride : int, default 1
        Keep every ``stride``-th voxel along each axis, starting at the box minimum.
    max_bytes : int, optional
        The memory budget of the read (the tree, the leaves read and the dense array);
        by default the environment variable ``PV_CUBEMARCH_VDB_MAX_BYTES``, else 1 GiB.

    Returns
    -------
    VdbGrid
        The grid, with values equal to OpenVDB's ``tree.getValue`` at each voxel.

    Raises
    ------
    VdbFormatError
        If the file is malformed, uses an unsupported feature, or the read needs more
        than ``max_bytes``.
    """
    if int(stride) < 1:
        raise VdbFormatError(f"stride must be a positive integer, got {stride}")
    stride = int(stride)
    limit = default_max_bytes() if max_bytes is None else int(max_bytes)
    with _OpenFile(path) as buf:
        header, descs = _read_descriptors(buf, limit)
        desc = _select(descs, name, index)
        return _read_selected(buf, header, desc, _tree_source(descs, desc), region, stride,
                              Budget(desc.info.name, limit))


def _read_selected(buf: Buf, header: Header, desc: Descriptor, source: Descriptor,
                   region, stride: int, budget: Budget) -> VdbGrid:
    """Decode the tree of ``source`` for the grid described by ``desc``."""
    info = desc.info
    if info.index_to_world is None:
        raise VdbFormatError(
            f"grid '{info.name}' uses a {info.map_type} transform; only linear maps "
            f"({', '.join(MAP_SIZES)}) are supported: resample the grid to a linear "
            "transform in OpenVDB first")
    codec = Codec(source.info, header.version, budget)
    dims = tree_layout(source.info)
    buf.seek(source.tree_pos, "grid topology")
    tree = read_root(buf, codec, dims)
    origins, masks = leaf_arrays(tree, codec)
    lo, shape = _box(region, _active_bbox(tree, origins, masks), stride)
    plo, pshape = _padded(lo, shape, stride, tree.leaf_dim)
    wanted = _leaf_wanted(origins, tree.leaf_dim, lo, shape, stride)
    _spend_dense(codec, shape, pshape, int(wanted.sum()))
    leaf_values = read_leaves(buf, codec, tree, masks, wanted)
    dense = _dense(tree, codec, lo, shape, stride, plo, pshape, origins[wanted],
                   leaf_values)
    return VdbGrid(info=info, values=dense, origin_index=tuple(int(v) for v in lo),
                   stride=stride, background=tree.background,
                   stats={"modes": dict(codec.modes), "leaves": len(origins)})


def _padded(lo: np.ndarray, shape: tuple, stride: int, dim: int) -> tuple:
    """The box grown to whole leaves (stride 1 only: leaves then scatter as blocks)."""
    if stride != 1 or not all(shape):
        return lo, shape
    plo = lo // dim * dim
    return plo, tuple(int(v) for v in -(-(lo + np.array(shape) - plo) // dim) * dim)


def _dense(tree: Tree, codec: Codec, lo: np.ndarray, shape: tuple, stride: int,
           plo: np.ndarray, pshape: tuple, leaf_origins: np.ndarray,
           leaf_values: np.ndarray | None) -> np.ndarray:
    """Allocate the (padded) dense array, fill it and cut it to the box."""
    dense = np.empty(pshape + codec.shape(1)[1:], dtype=codec.out)
    dense[...] = tree.background
    _fill_dense(dense, tree, plo, stride, leaf_origins, leaf_values)
    if pshape == shape:
        return dense
    off = lo - plo
    return np.ascontiguousarray(
        dense[off[0]:off[0] + shape[0], off[1]:off[1] + shape[1], off[2]:off[2] + shape[2]])


def _fill_dense(dense: np.ndarray, tree: Tree, lo: np.ndarray, stride: int,
                leaf_origins: np.ndarray, leaf_values: np.ndarray | None) -> None:
    """Paint tiles, then leaves, into the dense array."""
    if not dense.size:
        return
    _paint_big_tiles(dense, tree, lo, stride)
    flat = dense.reshape((-1,) + dense.shape[3:])
    shape = dense.shape[:3]
    if tree.small_origins:
        origins = np.concatenate(tree.small_origins)
        near = _leaf_wanted(origins, tree.leaf_dim, lo, shape, stride)   # tiles in the box
        values = np.concatenate(tree.small_values)[near]
        _scatter_blocks(flat, shape, lo, stride, origins[near],
                        values.reshape((len(values), 1) + values.shape[1:]), tree.leaf_dim)
    if leaf_values is not None:
        _scatter_blocks(flat, shape, lo, stride, leaf_origins, leaf_values, tree.leaf_dim)

