"""A deterministic corpus of hostile ``.vdb`` files, and the workers that read it.

The corpus is made from small seed files: every field the reader reads (found by tracing
the reader's cursor over the seed) is mutated to extreme and nearby values, seeds are
cut short, and a few bombs are crafted by hand. Each case is then read in a worker
process under a memory cap and a time limit, by pv_cubemarch (``worker-ours``, in the
project's venv) and by libopenvdb (``worker-ref``, under the system python with
pyopenvdb), so that a crash, a hang or a memory bomb costs one case, not the run::

    python vdb_fuzz.py worker-ours LIST OUTDIR MAX_BYTES SECONDS
    /usr/bin/python3 vdb_fuzz.py worker-ref LIST OUTDIR MAX_BYTES SECONDS

``LIST`` holds one ``index path`` per line; each worker appends one JSON line per case to
``OUTDIR/results.jsonl`` (status ``ok``, ``refused`` (our VdbFormatError or an OpenVDB
exception), ``other`` (any other exception), ``hang``) and, for ``ok``, the values read to
``OUTDIR/<index>.npz``.
"""

import hashlib
import json
import os
import re
import resource
import signal
import struct
import subprocess
import sys
import time
import zlib
from pathlib import Path

import numpy as np

# ------------------------------------------------------------------------- corpus

#: Replacement values of one-byte fields, and of 4- and 8-byte words (besides old +- 1).
BYTE_VALUES = (0, 1, 6, 7, 0x7F, 0x80, 0xFF)


def _word_values(old: int, size: int, rng) -> list[int]:
    """Extreme and nearby values of a little-endian word of ``size`` bytes."""
    top = 1 << (8 * size)
    values = {0, top - 1, top >> 1, (top >> 1) - 1, (old + 1) % top, (old - 1) % top,
              old ^ (1 << int(rng.integers(8 * size))), (old << 20) % top}
    values.discard(old)
    return sorted(values)


def field_map(data: bytes) -> list[tuple[int, int, str]]:
    """Where each field the reader reads lies in ``data``: (offset, size, field)."""
    from pv_cubemarch.scene.openvdb import reader, records, tree

    trace: list = []
    buf = records.Buf(data, trace=trace)
    header, descs = reader._read_descriptors(buf)
    for desc in descs:
        try:
            reader._read_selected(buf, header, desc, reader._tree_source(descs, desc),
                                  None, 1, tree.Budget(desc.info.name, 2**30))
        except records.VdbFormatError:
            pass   # an unsupported grid (a frustum map): its fields are still traced
    return sorted({t for t in trace if t[1] > 0})


def _mutations(data: bytes, fields, rng, per_seed: int):
    """Mutants of ``data``: each picked field set to extreme / nearby values."""
    by_name: dict = {}
    for off, size, name in fields:
        by_name.setdefault((name, size), []).append(off)
    out = []
    for (name, size), offsets in sorted(by_name.items()):
        picks = sorted({offsets[0], offsets[-1], offsets[int(rng.integers(len(offsets)))]})
        for off in picks:
            for label, new in _field_mutants(data, off, size, rng):
                out.append((f"{name}@{off}:{label}", new))
    order = rng.permutation(len(out))
    return [out[i] for i in order[:per_seed]]


def _field_mutants(data: bytes, off: int, size: int, rng):
    """A few mutated copies of ``data`` with the field at ``off`` changed."""
    old = data[off:off + size]
    if size == 1:
        values = [v for v in BYTE_VALUES if v != old[0]]
        return [(f"={v}", data[:off] + bytes([v]) + data[off + 1:])
                for v in rng.choice(values, 3, replace=False)]
    if size in (4, 8, 12, 24):
        word = 8 if size in (8, 24) else 4
        out = []
        for w in range(0, size, word):
            at = off + w
            value = int.from_bytes(data[at:at + word], "little")
            values = _word_values(value, word, rng)
            for pick in rng.choice(len(values), 2, replace=False):
                raw = values[pick].to_bytes(word, "little")
                out.append((f"+{w}={values[pick]}", data[:at] + raw + data[at + word:]))
        return out
    flip = bytearray(data)
    bit = int(rng.integers(size * 8))
    flip[off + bit // 8] ^= 1 << (bit % 8)
    ones = bytearray(data)
    run = min(size, 16)
    start = off + int(rng.integers(size - run + 1))
    ones[start:start + run] = b"\xff" * run
    return [(f"bit{bit}", bytes(flip)), (f"ff@{start - off}", bytes(ones))]


def _masks_disagree(data: bytes, fields):
    """The first leaf's topology mask all on, its buffer copy as it was.

    libopenvdb takes a leaf's active voxels from the buffer's copy; where values are stored
    whole (no active-mask compression) both copies leave the stream readable.
    """
    topology = next(((off, size) for off, size, name in fields
                     if name == "leaf value masks"), None)
    if topology is None:
        return []
    off = topology[0]
    return [("leaf masks disagree", data[:off] + b"\xff" * 64 + data[off + 64:])]


def _truncations(data: bytes, rng, count: int = 6):
    cuts = sorted({8, 30, len(data) - 1, *rng.integers(40, len(data) - 1, count - 3)})
    return [(f"cut{c}", data[:c]) for c in cuts]


def corpus(seeds: dict, per_seed: int = 70, seed: int = 25) -> list[tuple[str, bytes]]:
    """Every case: mutants and truncations of each seed, then the crafted bombs.

    ``seeds`` maps a name to the bytes of a valid file. Identical mutants appear once.
    """
    rng = np.random.default_rng(seed)
    cases, seen = [], set()
    for name, data in sorted(seeds.items()):
        fields = field_map(data)
        for label, raw in (_mutations(data, fields, rng, per_seed) + _truncations(data, rng)
                           + _masks_disagree(data, fields)):
            digest = hashlib.sha1(raw).digest()
            if digest not in seen:
                seen.add(digest)
                cases.append((f"{name}/{label}", raw))
    cases += crafted()
    return cases


# ---------------------------------------------------------------------- crafted

def _s(text: str) -> bytes:
    raw = text.encode()
    return struct.pack("<I", len(raw)) + raw


def _file(grids: list[tuple[str, str, bytes]], count: int | None = None,
          end=None) -> bytes:
    """A version-224 file with grid offsets: (name, tree type, grid body) per grid."""
    out = bytearray(struct.pack("<qIIIB", 0x56444220, 224, 10, 0, 1))
    out += b"8515f31e-92a0-44b2-9dcb-556b7a7740a4" + struct.pack("<I", 0)
    out += struct.pack("<i", len(grids) if count is None else count)
    for name, tree_type, body in grids:
        out += _s(name) + _s(tree_type) + _s("")
        start = len(out) + 24
        stop = start + len(body) if end is None else end(start)
        out += struct.pack("<3q", start, start, stop) + body
    return bytes(out)


def _grid_head(compression: int = 0) -> bytes:
    """Compression flags, no metadata, a unit scale map."""
    scale = [1.0] * 3 + [0.5] * 3 + [1.0] * 3 + [1.0] * 3 + [1.0] * 3
    return (struct.pack("<II", compression, 0) + _s("ScaleMap")
            + struct.pack("<15d", *scale))


def _root(background: bytes, tiles: list[tuple], children: bytes = b"", nchildren=0,
          value_fmt: str = "<f") -> bytes:
    """Root: buffer count, background, tiles (origin, value, active) and children."""
    out = struct.pack("<i", 1) + background + struct.pack("<II", len(tiles), nchildren)
    for origin, value, active in tiles:
        out += struct.pack("<3i", *origin) + struct.pack(value_fmt, *np.atleast_1d(value))
        out += bytes([active])
    return out + children


def _leaf_file(mode: int = 0, chunk: bytes | None = None, compression: int = 1,
               tree_type: str = "Tree_float_5_4_3") -> bytes:
    """A grid with one full leaf at the origin: its mode byte and value chunk as given."""
    def node(log2: int, child: bool) -> bytes:
        n = 1 << (3 * log2)
        mask = np.zeros(n, bool)
        mask[0] = child
        values = struct.pack("<q", -4 * n) + b"\0" * (4 * n)    # a raw chunk
        return (np.packbits(mask, bitorder="little").tobytes() + b"\0" * (n // 8)
                + bytes([0]) + (values if compression else b"\0" * (4 * n)))
    leaf_mask = b"\xff" * 64
    values = chunk if chunk is not None else struct.pack("<q", -2048) + b"\0" * 2048
    children = (struct.pack("<3i", 0, 0, 0) + node(5, True) + node(4, True) + leaf_mask
                + leaf_mask + bytes([mode]) + values)
    body = _grid_head(compression) + _root(struct.pack("<f", 0), [], children, 1)
    return _file([("density", tree_type, body)])


def crafted() -> list[tuple[str, bytes]]:
    """Files built to bomb, hang or confuse a reader (what each aims at is its name)."""
    out = []
    zeros = zlib.compress(b"\0" * (64 << 20), 9)       # 64 MiB from ~64 KB
    out.append(("crafted/zip_bomb_leaf", _leaf_file(chunk=struct.pack("<q", len(zeros))
                                                    + zeros)))
    out.append(("crafted/zip_garbage", _leaf_file(chunk=struct.pack("<q", 64)
                                                  + b"\x78\x9c" + b"\xab" * 62)))
    fake_blosc = bytes([2, 1, 1, 4]) + struct.pack("<III", 1 << 30, 1 << 16, 64) + b"\0" * 48
    out.append(("crafted/blosc_claims_1GiB", _leaf_file(
        chunk=struct.pack("<q", len(fake_blosc)) + fake_blosc, compression=4)))
    out.append(("crafted/mode_200", _leaf_file(mode=200)))
    out.append(("crafted/mode_7", _leaf_file(mode=7)))
    out.append(("crafted/tree_0_0_3", _leaf_file(tree_type="Tree_float_0_0_3")))
    out.append(("crafted/tree_deep", _leaf_file(tree_type="Tree_float" + "_3" * 1101)))
    out.append(("crafted/tree_4_3", _leaf_file(tree_type="Tree_float_4_3")))
    far = [((0, 0, 0), 1.0, 1), ((1 << 30, 1 << 30, 1 << 30), 2.0, 1)]
    out.append(("crafted/two_far_tiles", _file([("density", "Tree_float_5_4_3",
                                                 _grid_head() + _root(b"\0" * 4, far))])))
    vec = [((0, 0, 0), (1.0, 2.0, 3.0), 1), ((4096 * 4, 0, 0), (1.0, 1.0, 1.0), 1)]
    out.append(("crafted/vec3d_tiles", _file([("v", "Tree_vec3d_5_4_3", _grid_head() + _root(
        b"\0" * 24, vec, value_fmt="<3d"))])))
    out.append(("crafted/unaligned_root_tile", _file([("density", "Tree_float_5_4_3",
                                                       _grid_head() + _root(
                                                           b"\0" * 4, [((5, 0, 0), 1.0, 1)]))])))
    twice = [((0, 0, 0), 1.0, 1), ((0, 0, 0), 2.0, 1)]
    out.append(("crafted/duplicate_root_tiles", _file([("density", "Tree_float_5_4_3",
                                                        _grid_head() + _root(b"\0" * 4, twice))])))
    body = _grid_head() + _root(b"\0" * 4, [((0, 0, 0), 1.0, 1)])
    out.append(("crafted/grid_count_2^31-1_end_points_back", _file(
        [("density", "Tree_float_5_4_3", body)], count=2**31 - 1, end=lambda start: start)))
    out.append(("crafted/end_offset_before_descriptor", _file(
        [("density", "Tree_float_5_4_3", body)], end=lambda start: 10)))
    out.append(("crafted/negative_grid_offset", _file(
        [("density", "Tree_float_5_4_3", body)], end=lambda start: -8)))
    huge_children = _grid_head() + struct.pack("<i", 1) + b"\0" * 4 + struct.pack(
        "<II", 0, 2**32 - 1)
    out.append(("crafted/root_children_2^32-1", _file([("density", "Tree_float_5_4_3",
                                                        huge_children)])))
    meta = struct.pack("<II", 0, 2**31) + _s("x")
    out.append(("crafted/metadata_count_2^31", _file([("density", "Tree_float_5_4_3",
                                                       meta)])))
    out.append(("crafted/tile_bomb", _tile_bomb(64)))
    return out


def _tile_bomb(nodes: int) -> bytes:
    """``nodes`` top-level internal nodes whose 32768 tiles are all active (zip values)."""
    n = 1 << 15
    values = zlib.compress(struct.pack("<f", 1.0) * n, 9)
    node = (b"\0" * (n // 8) + b"\xff" * (n // 8) + bytes([6])
            + struct.pack("<q", len(values)) + values)
    children = b"".join(struct.pack("<3i", 4096 * k, 0, 0) + node for k in range(nodes))
    body = _grid_head(1) + _root(b"\0" * 4, [], children, nodes)
    return _file([("density", "Tree_float_5_4_3", body)])


# ---------------------------------------------------------------------- workers


class _HangError(BaseException):
    """Raised by the alarm; not an Exception, so no ``except Exception`` in a reader hides it."""


def _on_alarm(*_args):
    raise _HangError


def _cap_memory(extra: int) -> None:
    """Cap the address space at what is mapped now plus ``extra`` bytes."""
    with open("/proc/self/status") as status:
        size = next(int(line.split()[1]) * 1024 for line in status
                    if line.startswith("VmSize:"))
    resource.setrlimit(resource.RLIMIT_AS, (size + extra, size + extra))


def _read_ours(path: str, max_bytes: int) -> dict:
    import pv_cubemarch.scene.openvdb as vf

    out = {}
    for k, info in enumerate(vf.list_grids(path)):
        grid = vf.read_grid(path, info.name, info.index, max_bytes=max_bytes)
        # a coarser copy and a part read as the whole read's slices (their own code paths)
        if grid.values.size:
            lo, shape = np.array(grid.origin_index), np.array(grid.values.shape[:3])
            coarse = vf.read_grid(path, info.name, info.index, stride=2, max_bytes=max_bytes)
            part = vf.read_grid(path, info.name, info.index, max_bytes=max_bytes,
                                region=(tuple(lo + shape // 4), tuple(lo + shape // 2)))
            a, b = shape // 4, shape // 2 + 1
            for got, want in ((coarse.values, grid.values[::2, ::2, ::2]),
                              (part.values, grid.values[a[0]:b[0], a[1]:b[1], a[2]:b[2]])):
                if got.shape != want.shape or not np.array_equal(
                        got, want, equal_nan=got.dtype.kind == "f"):
                    raise AssertionError("a stride or region read differs from the whole")
        out[f"g{k}_name"] = np.array(info.name)
        out[f"g{k}_index"] = np.array(info.index)
        out[f"g{k}_values"] = grid.values
        out[f"g{k}_bmin"] = np.array(grid.origin_index)
    return out


def _read_ref(path: str, max_bytes: int) -> dict:
    sys.path.insert(0, str(Path(__file__).parent))
    import vdb_reference

    out_path = path + ".ref.npz"
    vdb_reference.dump(path, out_path)
    return dict(np.load(out_path))


def serve(kind: str, list_file: str, out_dir: str, max_bytes: int, seconds: int) -> None:
    """Read every case of ``list_file``, appending one JSON line per case."""
    import tracemalloc

    refused: tuple = ()
    if kind == "ours":
        import pv_cubemarch.scene.openvdb as vf
        refused = (vf.VdbFormatError,)
        read = _read_ours
    else:
        import pyopenvdb  # noqa: F401 - its exceptions are RuntimeError/ValueError/...
        refused = (RuntimeError, ValueError, KeyError, IndexError, TypeError, OSError,
                   MemoryError, OverflowError)
        read = _read_ref
    _cap_memory(3 << 30)
    signal.signal(signal.SIGALRM, _on_alarm)
    tracemalloc.start()
    results = Path(out_dir) / "results.jsonl"
    for line in Path(list_file).read_text().splitlines():
        index, path = line.split(" ", 1)
        with open(Path(out_dir) / "started", "w") as mark:
            mark.write(index)
        tracemalloc.reset_peak()
        start = time.perf_counter()
        entry = {"i": int(index)}
        signal.alarm(seconds)
        try:
            arrays = read(path, max_bytes)
            np.savez(Path(out_dir) / f"{index}.npz", **arrays)
            entry["status"] = "ok"
        except _HangError:
            entry["status"] = "hang"
        except refused as exc:
            entry.update(status="refused", error=f"{type(exc).__name__}: {exc}"[:300])
        except BaseException as exc:  # noqa: BLE001 - what the suite is there to catch
            entry.update(status="other", error=f"{type(exc).__name__}: {exc}"[:300])
        finally:
            signal.alarm(0)
        entry["seconds"] = round(time.perf_counter() - start, 4)
        entry["peak"] = tracemalloc.get_traced_memory()[1]
        with open(results, "a") as out:
            out.write(json.dumps(entry) + "\n")


def run_workers(python: str, kind: str, cases: list[Path], out_dir: Path, max_bytes: int,
                seconds: int) -> dict:
    """Run a worker over ``cases``; after a crash or a case past ``seconds``, go on after it.

    Returns ``{index: entry}`` (the worker's JSON line, or status ``crash``/``hang``).
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    results, started = out_dir / "results.jsonl", out_dir / "started"
    done: dict = {}
    todo = list(range(len(cases)))
    while todo:
        listing = out_dir / "list.txt"
        listing.write_text("".join(f"{i} {cases[i]}\n" for i in todo))
        started.unlink(missing_ok=True)
        # libopenvdb reads leaf buffers lazily unless told not to: a lazy read's failure is
        # only logged, so the reference would "read" files it never decoded
        env = dict(os.environ, OMP_NUM_THREADS="1", OPENVDB_DISABLE_DELAYED_LOAD="1")
        proc = subprocess.Popen([python, __file__, f"worker-{kind}", str(listing),
                                 str(out_dir), str(max_bytes), str(seconds)], env=env,
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        code = _watch(proc, started, seconds)
        if results.exists():
            for line in results.read_text().splitlines():
                entry = json.loads(line)
                done[entry["i"]] = entry
        todo = [i for i in todo if i not in done]
        current = int(started.read_text()) if started.exists() else None
        if todo and current in todo:
            done[current] = {"i": current, "status": "hang" if code == "hang" else "crash",
                             "error": f"worker exit {code}"}
            todo.remove(current)
        elif todo:
            raise RuntimeError(f"the {kind} worker stopped before case {todo[0]} (exit "
                               f"{code}): {proc.stderr.read()[-2000:]!r}")
    return done


def _watch(proc: subprocess.Popen, started: Path, seconds: int):
    """Wait for the worker; kill it when one case has run past ``seconds`` (+ a margin)."""
    last, since = None, time.monotonic()
    while proc.poll() is None:
        time.sleep(0.05)
        mark = started.stat().st_mtime_ns if started.exists() else None
        if mark != last:
            last, since = mark, time.monotonic()
        elif time.monotonic() - since > (seconds + 2 if mark else 120):   # or its imports
            proc.kill()
            proc.wait()
            return "hang"
    return proc.returncode


_UUID = re.compile(rb"[0-9a-fA-F]{8}-[0-9a-fA-F]{4}-[0-9a-fA-F]{4}-[0-9a-fA-F]{4}-"
                   rb"[0-9a-fA-F]{12}")


def compare(ours: dict, ref: dict, raw: bytes) -> str | None:
    """Why the arrays we read from ``raw`` differ from libopenvdb's, or None if they agree.

    libopenvdb gives no grid at all for a file whose UUID it cannot parse (we do not read
    the UUID): that is its refusal, not a difference.
    """
    grids = {(str(ours[k]), int(ours[k.replace("name", "index")])): k[:-5]
             for k in ours if k.endswith("_name")}
    count = int(ref["count"])
    if count == 0 and not _UUID.fullmatch(raw[21:57]):
        return None
    if len(grids) != count:
        return f"{len(grids)} grids, libopenvdb {count}"
    keys = [(str(ref[f"g{n}_name"]), int(ref[f"g{n}_index"])) for n in range(count)]
    # libopenvdb names a grid by its "name" metadata, we by its descriptor's; both list
    # grids by descriptor name, so grids whose names differ pair up in that order
    spare = iter(sorted(set(grids) - set(keys)))
    for n, key in enumerate(keys):
        k = grids[key] if key in grids else grids[next(spare)]
        if f"g{n}_values" not in ref:
            continue
        expected, got = ref[f"g{n}_values"], ours[k + "_values"]
        if tuple(ours[k + "_bmin"]) != tuple(ref[f"g{n}_bmin"]):
            return f"grid {key}: box starts at {tuple(ours[k + '_bmin'])}, libopenvdb " \
                   f"{tuple(ref[f'g{n}_bmin'])}"
        if got.shape != expected.shape or not np.array_equal(
                got.astype(expected.dtype), expected, equal_nan=expected.dtype.kind == "f"):
            return f"grid {key}: values differ"
    return None


if __name__ == "__main__":
    command, *args = sys.argv[1:]
    serve(command.split("-", 1)[1], args[0], args[1], int(args[2]), int(args[3]))
