"""A minimal OpenVDB writer for tests: zip, uncompressed, raw-chunk, double/int grids.

pyopenvdb writes only blosc + active-mask files; this writer makes the other layouts the
reader must handle (and the seeds of the fuzz corpus). Float files it writes are read back
by pyopenvdb in the tests, which checks the writer itself.
"""

import struct
import uuid
import zlib
from pathlib import Path

import numpy as np

try:
    import blosc
except ImportError:  # pragma: no cover - the test extra installs it
    blosc = None

MAGIC = 0x56444220
COMPRESS_ZIP, COMPRESS_ACTIVE_MASK, COMPRESS_BLOSC = 0x1, 0x2, 0x4
NO_MASK_OR_INACTIVE_VALS, NO_MASK_AND_MINUS_BG, NO_MASK_AND_ONE_INACTIVE_VAL = 0, 1, 2
NO_MASK_AND_ALL_VALS = 6


def string_record(s):
    b = s.encode()
    return struct.pack("<I", len(b)) + b


def value_chunk(raw, compression, force_raw=False):
    """Encode one value array the way OpenVDB's writeData does."""
    if compression & COMPRESS_BLOSC:
        packed = blosc.compress(raw, typesize=4, clevel=9, shuffle=blosc.SHUFFLE,
                                   cname="lz4")
    elif compression & COMPRESS_ZIP:
        packed = zlib.compress(raw)
    else:
        return raw
    if force_raw or len(packed) >= len(raw):
        return struct.pack("<q", -len(raw)) + raw
    return struct.pack("<q", len(packed)) + packed


def values_block(values, active, background, compression, dtype, force_raw=False):
    """Per-node metadata byte, inactive value and value chunk for one node."""
    if not compression & COMPRESS_ACTIVE_MASK:
        return bytes([NO_MASK_AND_ALL_VALS]) + value_chunk(values.astype(dtype).tobytes(),
                                                        compression, force_raw)
    inactive = np.unique(values[~active])
    head = b""
    if inactive.size == 0 or (inactive.size == 1 and inactive[0] == background):
        mode = NO_MASK_OR_INACTIVE_VALS
    elif inactive.size == 1 and inactive[0] == -background:
        mode = NO_MASK_AND_MINUS_BG
    elif inactive.size == 1:
        mode = NO_MASK_AND_ONE_INACTIVE_VAL
        head = np.array(inactive[0], dtype).tobytes()
    else:
        mode = NO_MASK_AND_ALL_VALS
    stored = values if mode == NO_MASK_AND_ALL_VALS else values[active]
    return bytes([mode]) + head + value_chunk(stored.astype(dtype).tobytes(), compression,
                                         force_raw)


def mask_bytes(bits):
    return np.packbits(bits, bitorder="little").tobytes()


def grid_body(grid):
    """Compression flags, metadata, transform, topology and buffers of one grid."""
    comp, bg, dtype = grid["compression"], grid["background"], grid["dtype"]
    name = grid["name"].encode()
    out = [struct.pack("<I", comp), struct.pack("<I", 2), string_record("class"),
           string_record("string"), struct.pack("<I", 10), b"fog volume",
           string_record("name"), string_record("string"), struct.pack("<I", len(name)), name]
    out += [string_record(grid["map"][0]), np.asarray(grid["map"][1], "<f8").tobytes()]
    out += [struct.pack("<i", 1), np.array(bg, dtype).tobytes()]
    leaves = grid["leaves"]  # {origin: (values (512,), active (512,) bool)}
    tops = sorted({tuple(np.array(o) & ~4095) for o in leaves})
    out.append(struct.pack("<II", 0, len(tops)))
    buffers = []
    for top in tops:
        out.append(struct.pack("<3i", *top))
        mids = sorted({tuple(np.array(o) & ~127) for o in leaves
                       if tuple(np.array(o) & ~4095) == top})
        out.append(internal_node(top, mids, 5, 7, grid))
        for mid in mids:
            kids = sorted(o for o in leaves if tuple(np.array(o) & ~127) == mid)
            out.append(internal_node(mid, kids, 4, 3, grid))
            for o in kids:
                values, active = leaves[o]
                out.append(mask_bytes(active))
                buffers += [mask_bytes(active),
                            values_block(values, active, bg, comp, dtype,
                                          force_raw=o[0] % 16 == 8)]
    return b"".join(out + buffers)


def internal_node(origin, children, log2, child_log2, grid):
    """Masks and (all-background, inactive) tile values of an internal node."""
    n = 1 << (3 * log2)
    child = np.zeros(n, bool)
    for c in children:
        x, y, z = ((np.array(c) - origin) >> child_log2)
        child[(x << (2 * log2)) + (y << log2) + z] = True
    values = np.full(n, grid["background"], grid["dtype"])
    return (mask_bytes(child) + mask_bytes(np.zeros(n, bool))
            + values_block(values, np.zeros(n, bool), grid["background"],
                            grid["compression"], grid["dtype"]))


def write_vdb(path, grids, has_offsets=True, version=224):
    """Write a file (version 222-224) of float/double/int grids without tiles."""
    out = bytearray(struct.pack("<qIIIB", MAGIC, version, 10, 0, int(has_offsets)))
    out += str(uuid.uuid4()).encode() + struct.pack("<I", 0) + struct.pack("<i", len(grids))
    for n, grid in enumerate(grids):
        out += (string_record(f"{grid['name']}\x1e{n}") + string_record(grid["type"])
                + string_record(""))
        body = grid_body(grid)
        start = len(out) + 24
        out += struct.pack("<3q", *((start, start, start + len(body)) if has_offsets
                                    else (0, 0, 0)))
        out += body
    Path(path).write_bytes(bytes(out))


def random_leaves(rng, dtype, background, count=12, inactive="bg"):
    leaves = {}
    for _ in range(count):
        o = tuple(int(v) * 8 for v in rng.integers(-6, 6, 3))
        active = rng.random(512) < 0.6
        values = (rng.random(512) * 100 - 50).astype(dtype)
        if inactive == "bg":
            values[~active] = background
        elif inactive == "one":
            values[~active] = 3
        elif inactive == "minus":
            values[~active] = -background
        leaves[o] = (values, active)
    return leaves
