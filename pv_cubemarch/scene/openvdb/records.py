"""The file's records: header, metadata, transforms and grid descriptors, and their types."""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

import numpy as np

MAGIC = 0x56444220
MIN_VERSION = 222  # NODE_MASK_COMPRESSION: per-node metadata byte, per-grid compression
MAX_VERSION = 224  # MULTIPASS_IO (only changes point data grids)

COMPRESS_ZIP = 0x1
COMPRESS_ACTIVE_MASK = 0x2
COMPRESS_BLOSC = 0x4

# Per-node metadata byte of compressed value arrays.
NO_MASK_OR_INACTIVE_VALS = 0  # inactive values are all +background
NO_MASK_AND_MINUS_BG = 1  # inactive values are all -background
NO_MASK_AND_ONE_INACTIVE_VAL = 2  # inactive values are all one stored value
MASK_AND_NO_INACTIVE_VALS = 3  # selection mask picks -background (off) / +background (on)
MASK_AND_ONE_INACTIVE_VAL = 4  # selection mask picks stored value (off) / background (on)
MASK_AND_TWO_INACTIVE_VALS = 5  # selection mask picks between two stored values
NO_MASK_AND_ALL_VALS = 6  # every value is stored

MODES_WITH_VALUE = (NO_MASK_AND_ONE_INACTIVE_VAL, MASK_AND_ONE_INACTIVE_VAL,
                     MASK_AND_TWO_INACTIVE_VALS)
MODES_WITH_MASK = (MASK_AND_NO_INACTIVE_VALS, MASK_AND_ONE_INACTIVE_VAL,
                    MASK_AND_TWO_INACTIVE_VALS)

HALF_SUFFIX = "_HalfFloat"
NAME_SEPARATOR = "\x1e"

# value type name -> (numpy scalar type, number of components, is floating point)
VALUE_TYPES = {
    "float": ("<f4", 1, True),
    "double": ("<f8", 1, True),
    "int32": ("<i4", 1, False),
    "int64": ("<i8", 1, False),
    "bool": ("u1", 1, False),
    "vec3s": ("<f4", 3, True),
    "vec3d": ("<f8", 3, True),
    "vec3i": ("<i4", 3, False),
}

_META_FORMATS = {
    "bool": "<?", "int32": "<i", "int64": "<q", "float": "<f", "double": "<d",
    "vec2i": "<2i", "vec2s": "<2f", "vec2d": "<2d",
    "vec3i": "<3i", "vec3s": "<3f", "vec3d": "<3d",
    "vec4i": "<4i", "vec4s": "<4f", "vec4d": "<4d",
    "mat4s": "<16f", "mat4d": "<16d",
}

# map name -> number of doubles stored for it
MAP_SIZES = {
    "UniformScaleMap": 15, "ScaleMap": 15,
    "UniformScaleTranslateMap": 18, "ScaleTranslateMap": 18,
    "TranslationMap": 3, "AffineMap": 16, "UnitaryMap": 16,
}

INSTALL_BLOSC = (
    "install the optional extra: pip install 'pv_cubemarch[openvdb]' (the blosc package)"
)


class VdbFormatError(ValueError):
    """A ``.vdb`` file could not be read; the message says why and what to do.

    ``offset`` and ``field`` say where in the file and what was being read, when the
    cause is the file's bytes (``None`` otherwise).
    """

    def __init__(self, message: str, offset: int | None = None,
                 field: str | None = None) -> None:
        super().__init__(message)
        self.offset = offset
        self.field = field


def corrupt(offset: int, field: str, problem: str) -> VdbFormatError:
    """The error for damaged bytes: where they are, what they should have been."""
    return VdbFormatError(
        f"corrupt OpenVDB file at offset {offset} ({field}): {problem}; the file is "
        "damaged or not written by OpenVDB: re-export or re-download it", offset, field)


@dataclass
class VdbGridInfo:
    """Description of one grid of a ``.vdb`` file, read without decoding voxel data.

    Attributes
    ----------
    name : str
        Grid name (without the file's uniqueness suffix).
    index : int
        Position among the grids of the file that share this name.
    unique_name : str
        Name as stored in the file (``name``, a 0x1E character and a number for
        duplicates).
    value_type : str
        OpenVDB value type name, e.g. ``'float'``, ``'double'``, ``'vec3s'``, ``'bool'``.
    tree_type : str
        Full tree type name, e.g. ``'Tree_float_5_4_3'``.
    stored_as_half : bool
        Floating-point values are stored as 16-bit halves.
    compression : int
        Compression flags: ZIP = 1, ACTIVE_MASK = 2, BLOSC = 4.
    grid_class : str
        ``'level set'``, ``'fog volume'``, ``'staggered'`` or ``'unknown'``.
    metadata : dict
        Grid metadata of known types (unknown types are skipped).
    map_type : str
        Name of the transform's map, e.g. ``'UniformScaleMap'``.
    index_to_world : numpy.ndarray or None
        4x4 matrix acting on column vectors: the centre of voxel ``ijk`` lies at
        ``index_to_world @ [i, j, k, 1]``; None for unsupported (non-linear) maps.
    bbox_min, bbox_max : tuple of int or None
        Inclusive active-voxel bounding box in index space, if stored in metadata.
    voxel_count : int or None
        Active voxel count, if stored in metadata.
    instance_parent : str
        Unique name of the grid whose tree this grid shares ('' if none).
    file_version : int
        File format version of the file.
    """

    name: str
    index: int
    unique_name: str
    value_type: str
    tree_type: str
    stored_as_half: bool
    compression: int
    grid_class: str
    metadata: dict
    map_type: str
    index_to_world: np.ndarray | None
    bbox_min: tuple[int, int, int] | None
    bbox_max: tuple[int, int, int] | None
    voxel_count: int | None
    instance_parent: str = ""
    file_version: int = 0


@dataclass
class VdbGrid:
    """A grid decoded into a dense numpy array.

    Attributes
    ----------
    info : VdbGridInfo
        Description of the grid.
    values : numpy.ndarray
        Dense values indexed ``[i, j, k]`` (x, y, z); a trailing axis of 3 for vector
        grids. ``values[a, b, c]`` is voxel ``origin_index + stride * (a, b, c)``.
    origin_index : tuple of int
        Index coordinates of ``values[0, 0, 0]``.
    stride : int
        Step between neighbouring samples, in voxels.
    background : object
        Background value of the tree (numpy scalar or array).
    """

    info: VdbGridInfo
    values: np.ndarray
    origin_index: tuple[int, int, int]
    stride: int
    background: object
    stats: dict = field(default_factory=dict, repr=False)


# ----------------------------------------------------------------------------- bytes


class Buf:
    """Cursor over the bytes of a file (an mmap or bytes object) that never leaves it.

    Every read names the field it reads, so that a failure says where and what; with
    ``trace`` (a list) each read is recorded as ``(offset, size, field)``.
    """

    def __init__(self, data, pos: int = 0, trace: list | None = None) -> None:
        self.data = data
        self.pos = pos
        self.size = len(data)
        self.trace = trace

    @property
    def left(self) -> int:
        """Bytes between the cursor and the end of the file."""
        return self.size - self.pos

    def seek(self, pos: int, field: str, lowest: int = 0) -> None:
        """Move to ``pos``, which must lie in ``[lowest, size]`` (offsets only go forward)."""
        if not lowest <= pos <= self.size:
            raise corrupt(self.pos, field, f"offset {pos} lies outside [{lowest}, "
                                           f"{self.size}] (the file has {self.size} bytes)")
        self.pos = pos

    def take(self, n: int, field: str = "data") -> bytes:
        """Return the next ``n`` bytes."""
        if n < 0 or n > self.size - self.pos:
            raise VdbFormatError(
                f"file is truncated or corrupt: needed {n} bytes at offset {self.pos} "
                f"({field}) but the file has {self.size} bytes; re-export or re-download "
                "the file", self.pos, field)
        if self.trace is not None:
            self.trace.append((self.pos, n, field))
        out = self.data[self.pos:self.pos + n]
        self.pos += n
        return out

    def skip(self, n: int, field: str = "data") -> None:
        """Advance by ``n`` bytes."""
        if n < 0 or n > self.size - self.pos:
            self.take(n, field)
        if self.trace is not None:
            self.trace.append((self.pos, n, field))
        self.pos += n

    def unpack(self, fmt: str, field: str = "data") -> tuple:
        """Unpack a struct format at the cursor."""
        return struct.unpack(fmt, self.take(struct.calcsize(fmt), field))

    def u8(self, field: str = "byte") -> int:
        """Read one unsigned byte."""
        return self.take(1, field)[0]

    def u32(self, field: str = "uint32") -> int:
        """Read an unsigned 32-bit integer."""
        return self.unpack("<I", field)[0]

    def i64(self, field: str = "int64") -> int:
        """Read a signed 64-bit integer."""
        return self.unpack("<q", field)[0]

    def count(self, fmt: str, least: int, field: str) -> int:
        """Read a count of items that take at least ``least`` bytes each; bound it."""
        at = self.pos
        n = self.unpack(fmt, field)[0]
        if n < 0 or n * least > self.left:
            raise corrupt(at, field, f"{n} items of at least {least} bytes each cannot "
                                     f"fit in the {self.left} bytes left")
        return n

    def string(self, field: str = "string") -> str:
        """Read a string stored as uint32 length then bytes."""
        n = self.count("<I", 1, field + " length")
        return self.take(n, field).decode("utf-8", "replace")


def bits(raw: bytes, width: int = 0) -> np.ndarray:
    """Unpack OpenVDB node masks (uint64 words, little-endian) into bool arrays.

    With ``width`` (bytes per mask) the result has one row per mask.
    """
    arr = np.frombuffer(raw, dtype=np.uint8)
    if width:
        arr = arr.reshape(-1, width)
    return np.unpackbits(arr, axis=-1, bitorder="little").view(bool)


# -------------------------------------------------------------------------- header


@dataclass
class Header:
    version: int
    library: tuple[int, int]
    has_offsets: bool
    uuid: str
    metadata: dict
    grids_pos: int


def read_header(buf: Buf) -> Header:
    """Read the file header and file-level metadata."""
    if buf.size < 8 or struct.unpack_from("<q", buf.data, 0)[0] != MAGIC:
        raise VdbFormatError(
            "not an OpenVDB file: the first 8 bytes are not the VDB magic number "
            "0x56444220; pass a .vdb file written by OpenVDB")
    buf.pos = 8
    version = buf.u32("file version")
    if version < MIN_VERSION:
        raise VdbFormatError(
            f"VDB file format version {version} is older than {MIN_VERSION} (OpenVDB < 2.0); "
            f"only versions {MIN_VERSION}-{MAX_VERSION} are supported: re-save the file "
            "with a current OpenVDB (e.g. `vdb_print`/`vdb_tool`, Houdini or Blender)")
    if version > MAX_VERSION:
        raise VdbFormatError(
            f"VDB file format version {version} is newer than this reader knows "
            f"({MIN_VERSION}-{MAX_VERSION}); re-save the file with OpenVDB 10-12 "
            "or update pv_cubemarch")
    library = buf.unpack("<II", "library version")
    has_offsets = buf.u8("has-grid-offsets flag") != 0
    uuid = buf.take(36, "uuid").decode("ascii", "replace")
    metadata = _read_metadata(buf)
    return Header(version, library, has_offsets, uuid, metadata, buf.pos)


def _read_metadata(buf: Buf) -> dict:
    """Read a metadata map; entries of unknown type are skipped by their size."""
    out = {}
    for _ in range(buf.count("<I", 12, "metadata count")):
        name = buf.string("metadata name")
        type_name = buf.string("metadata type")
        payload = buf.take(buf.count("<I", 1, "metadata size"), f"metadata {name!r}")
        value = _decode_meta(type_name, payload)
        if value is not None:
            out[name] = value
    return out


def _decode_meta(type_name: str, payload: bytes):
    """Decode one metadata value, or None for unknown types."""
    if type_name == "string":
        return payload.decode("utf-8", "replace")
    fmt = _META_FORMATS.get(type_name)
    if fmt is None or struct.calcsize(fmt) != len(payload):
        return None
    value = struct.unpack(fmt, payload)
    return value[0] if len(value) == 1 else value


def _read_transform(buf: Buf) -> tuple[str, np.ndarray | None]:
    """Read a transform; return its map name and 4x4 index-to-world matrix."""
    map_type = buf.string("transform map type")
    count = MAP_SIZES.get(map_type)
    if count is None:
        return map_type, None
    at = buf.pos
    d = np.array(buf.unpack(f"<{count}d", f"{map_type} values"), dtype=np.float64)
    matrix = _map_matrix(map_type, d)
    if not np.isfinite(matrix).all() or abs(np.linalg.det(matrix[:3, :3])) < 1e-300:
        raise corrupt(at, f"{map_type} values", "the index-to-world map is not finite or "
                                                "not invertible (a zero or NaN scale)")
    return map_type, matrix


def _map_matrix(map_type: str, d: np.ndarray) -> np.ndarray:
    """Build the column-vector index-to-world matrix of a linear map."""
    m = np.eye(4)
    if map_type in ("AffineMap", "UnitaryMap"):
        return d.reshape(4, 4).T.copy()  # stored row-major for row vectors
    if map_type == "TranslationMap":
        m[:3, 3] = d[:3]
    elif map_type in ("UniformScaleMap", "ScaleMap"):
        m[[0, 1, 2], [0, 1, 2]] = d[:3]
    else:  # (Uniform)ScaleTranslateMap: translation then scale
        m[:3, 3] = d[:3]
        m[[0, 1, 2], [0, 1, 2]] = d[3:6]
    return m


# --------------------------------------------------------------------- descriptors


@dataclass
class Descriptor:
    info: VdbGridInfo
    grid_pos: int  # offset of the compression flags
    tree_pos: int  # offset of the topology
    end_pos: int


#: Node sizes (log2 of their side, root's children first) of the trees OpenVDB registers.
TREE_LAYOUT = [5, 4, 3]


def parse_tree_type(tree_type: str) -> tuple[str, list[int]]:
    """Split 'Tree_float_5_4_3' into ('float', [5, 4, 3])."""
    parts = tree_type.split("_")
    dims = []
    while parts and parts[-1].isdigit():
        dims.insert(0, int(parts.pop()))
    if parts and parts[0] == "Tree":
        parts = parts[1:]
    return "_".join(parts), dims


def read_descriptor(buf: Buf, header: Header, seen: dict) -> Descriptor:
    """Read one grid descriptor and the grid's header (compression, metadata, transform)."""
    unique = buf.string("grid name")
    tree_type = buf.string("tree type")
    half = tree_type.endswith(HALF_SUFFIX)
    if half:
        tree_type = tree_type[: -len(HALF_SUFFIX)]
    parent = buf.string("instance parent")
    at = buf.pos
    # the block offset (of the leaf buffers) is not used: OpenVDB reads them in sequence
    grid_pos, _block_pos, end_pos = buf.unpack("<3q", "grid offsets")
    if header.has_offsets:
        if not buf.pos <= grid_pos <= end_pos <= buf.size:
            raise corrupt(at, "grid offsets", f"grid {grid_pos} and end {end_pos} must "
                          f"follow the descriptor ({buf.pos}) in that order and lie inside "
                          f"the file ({buf.size} bytes)")
        buf.seek(grid_pos, "grid offset", buf.pos)
    else:
        grid_pos = buf.pos
    compression = buf.u32("compression flags")
    at = buf.pos
    metadata = _read_metadata(buf)
    real = tree_type.split("_")[1:2] in (["float"], ["double"], ["vec3s"], ["vec3d"])
    if real and bool(metadata.get("is_saved_as_half_float", False)) != half:
        # OpenVDB decodes values as this metadata says (absent: full precision); the tree
        # type's suffix saying otherwise is a damaged file, read two ways
        raise corrupt(at, "grid metadata", "is_saved_as_half_float disagrees with the tree "
                                           f"type {tree_type + (HALF_SUFFIX if half else '')!r}")
    map_type, matrix = _read_transform(buf)
    name = unique.split(NAME_SEPARATOR)[0]
    index = seen.get(name, 0)
    seen[name] = index + 1
    value_type, _dims = parse_tree_type(tree_type)
    info = VdbGridInfo(
        name=name, index=index, unique_name=unique, value_type=value_type,
        tree_type=tree_type, stored_as_half=half, compression=compression,
        grid_class=str(metadata.get("class", "unknown")), metadata=metadata,
        map_type=map_type, index_to_world=matrix,
        bbox_min=_meta_ijk(metadata, "file_bbox_min"),
        bbox_max=_meta_ijk(metadata, "file_bbox_max"),
        voxel_count=metadata.get("file_voxel_count"),
        instance_parent=parent, file_version=header.version)
    if not header.has_offsets and matrix is None:
        raise VdbFormatError(
            f"grid '{name}' uses a {map_type} transform, which this reader does not "
            "support; resample the grid to a linear transform in OpenVDB first")
    return Descriptor(info, grid_pos, buf.pos, end_pos)


def _meta_ijk(metadata: dict, key: str) -> tuple[int, int, int] | None:
    """Return an ijk triple stored in metadata, or None."""
    lo, hi = metadata.get("file_bbox_min"), metadata.get("file_bbox_max")
    ok = isinstance(lo, tuple) and isinstance(hi, tuple) and len(lo) == len(hi) == 3
    if not ok or any(a > b for a, b in zip(lo, hi, strict=True)):
        return None  # absent, or the empty box OpenVDB stores for empty grids
    return tuple(int(v) for v in metadata[key])


