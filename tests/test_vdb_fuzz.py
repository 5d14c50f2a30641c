"""The OpenVDB reader against a deterministic corpus of hostile files, beside libopenvdb.

The corpus (``tests/tools/vdb_fuzz.py``): every field the reader reads in eight small seed
files (the shipped smoke grid, files OpenVDB itself wrote, files of the test writer in zip,
uncompressed and no-offset layouts; pyopenvdb cannot read its double grid) set to extreme
and nearby values, each seed cut short at several places, and crafted bombs (a zip bomb, a
blosc header claiming a gibibyte, a grid count of 2^31-1 whose end offset points back, far
tiles, deep or unregistered tree layouts, a tile bomb). Each case is read by our reader in a
worker under a memory cap and a time limit, and by libopenvdb (pyopenvdb) in another.

Held: no case hangs, crashes or raises anything but ``VdbFormatError``; no case traces
more than the read's byte budget plus a small constant; and wherever both read a file,
the values and boxes are libopenvdb's.
"""

from __future__ import annotations

import collections
import json
import struct
import sys

import numpy as np
import pytest
from conftest import ROOT, SYSTEM_PYTHON, has_pyopenvdb
from tools.vdb_writer import random_leaves, write_vdb

import pv_cubemarch as cm
import pv_cubemarch.scene.openvdb as vf
from tools import vdb_fuzz

#: About 40 s: CI runs it in the long tests' own step (pytest -m slow), beside the default run.
pytestmark = pytest.mark.slow

#: The byte budget each case is read with, and what the worker may trace beyond it.
BUDGET = 32 << 20
SLACK = 24 << 20
#: Seconds a case may take (the slowest take a few hundred milliseconds).
CASE_SECONDS = 10


VALUE_TYPES = {"<f4": "float", "<f8": "double", "<i4": "int32"}


def _writer_seed(tmp_path, name, dtype, compression, has_offsets):
    rng = np.random.default_rng(len(name))
    background = np.array(2, dtype)
    grid = {"name": "density", "type": f"Tree_{VALUE_TYPES[dtype]}_5_4_3",
            "dtype": dtype, "compression": compression, "background": background,
            "map": ("UniformScaleMap", [0.5] * 6 + [2.0] * 3 + [4.0] * 3 + [1.0] * 3),
            "leaves": random_leaves(rng, dtype, background, count=4, inactive="one")}
    path = tmp_path / name
    write_vdb(path, [grid], has_offsets=has_offsets)
    return path.read_bytes()


@pytest.fixture(scope="module")
def fuzz_results(ref_dir, tmp_path_factory):
    assert has_pyopenvdb()
    tmp = tmp_path_factory.mktemp("fuzz")
    seeds = {"mixed_smoke": (ROOT / "datasets" / "mixed_smoke.vdb").read_bytes()}
    for name in ("modes", "affine", "tiles", "bool_vec"):
        seeds[name] = (ref_dir / f"{name}.vdb").read_bytes()
    seeds["zip_float"] = _writer_seed(tmp, "zip_float.vdb", "<f4", 1, True)
    seeds["raw_float_no_offsets"] = _writer_seed(tmp, "raw_float.vdb", "<f4", 0, False)
    seeds["zip_mask_double"] = _writer_seed(tmp, "zip_double.vdb", "<f8", 3, True)
    cases = vdb_fuzz.corpus(seeds)
    paths = []
    for i, (_label, raw) in enumerate(cases):
        paths.append(tmp / f"case{i}.vdb")
        paths[-1].write_bytes(raw)
    ours = vdb_fuzz.run_workers(sys.executable, "ours", paths, tmp / "ours", BUDGET,
                                CASE_SECONDS)
    # libopenvdb reads only what we read: the comparison needs both, and libopenvdb itself
    # takes seconds (or hangs) on many of the files we refuse
    read = [i for i in range(len(cases)) if ours[i]["status"] == "ok"]
    theirs = vdb_fuzz.run_workers(SYSTEM_PYTHON, "ref", [paths[i] for i in read], tmp / "ref",
                                  BUDGET, CASE_SECONDS)
    ref = {i: dict(theirs[k], i=i) for k, i in enumerate(read)}
    return cases, ours, ref, tmp, read


def test_no_hang_no_crash_no_foreign_exception(fuzz_results):
    # catches: any unchecked field (OverflowError, struct.error, AxisError, RecursionError,
    # zlib/blosc errors, MemoryError) and the back-pointing grid count's endless loop
    cases, ours, _ref, _tmp, _read = fuzz_results
    bad = [(cases[i][0], e["status"], e.get("error")) for i, e in ours.items()
           if e["status"] not in ("ok", "refused")]
    assert not bad, bad[:10]
    refused = [e for e in ours.values() if e["status"] == "refused"]
    assert all("VdbFormatError" in e["error"] for e in refused)


def test_memory_stays_within_the_budget(fuzz_results):
    # catches: unbounded decompression (the zip bomb traced 64 MiB), the tile bomb's
    # python tuples, a dense box or a leaf array allocated before the budget is asked
    cases, ours, _ref, _tmp, _read = fuzz_results
    over = [(cases[i][0], e["peak"]) for i, e in ours.items()
            if e.get("peak", 0) > BUDGET + SLACK]
    assert not over, over[:10]


def test_where_both_read_a_file_we_read_what_libopenvdb_reads(fuzz_results):
    # catches: a leaf's value mask taken from the topology where libopenvdb uses the
    # buffer's, unaligned root children placed where libopenvdb does not put them
    cases, _ours, ref, tmp, read = fuzz_results
    differ, both = [], 0
    for k, i in enumerate(read):
        if ref[i]["status"] == "ok":
            both += 1
            why = vdb_fuzz.compare(dict(np.load(tmp / "ours" / f"{i}.npz")),
                                   dict(np.load(tmp / "ref" / f"{k}.npz")), cases[i][1])
            if why:
                differ.append((cases[i][0], why))
    assert not differ, differ[:10]
    assert both >= len(cases) // 5        # a corpus most of which is refused tests little


def test_leaf_masks_that_disagree_are_refused(fuzz_results):
    # catches: the buffer's copy of a leaf's value mask left unchecked (libopenvdb reading a
    # file takes the topology's copy and skips the other; a stream reader takes the other)
    cases, ours, _ref, _tmp, _read = fuzz_results
    disagree = [i for i, (label, _raw) in enumerate(cases) if label.endswith("masks disagree")]
    assert len(disagree) >= 6
    for i in disagree:
        assert ours[i]["status"] == "refused", cases[i][0]
        assert "value mask differs" in ours[i]["error"], ours[i]["error"]


def test_the_counts(fuzz_results, capsys):
    """Print the corpus's outcomes (the documentation's table) and write them as JSON."""
    cases, ours, ref, tmp, _read = fuzz_results
    table = collections.Counter(e["status"] for e in ours.values())
    theirs = collections.Counter(e["status"] for e in ref.values())
    summary = {"cases": len(cases), "crafted": sum(c[0].startswith("crafted/") for c in cases),
               "ours": dict(sorted(table.items())),
               "libopenvdb_where_we_read": dict(sorted(theirs.items())),
               "slowest_s": max(e.get("seconds", 0) for e in ours.values()),
               "peak_traced_bytes": max(e.get("peak", 0) for e in ours.values())}
    (tmp / "summary.json").write_text(json.dumps(summary, indent=1))
    with capsys.disabled():
        print("\nOpenVDB fuzz corpus:", json.dumps(summary))
    assert summary["cases"] > 300


def _vec_tiles(tmp_path):
    raw = dict(vdb_fuzz.crafted())["crafted/vec3d_tiles"]
    path = tmp_path / "vec.vdb"
    path.write_bytes(raw)
    return path


def test_a_vector_grid_is_refused_before_its_voxels_are_read(tmp_path):
    # catches: the 9 KB vec3d file that allocated 6 GiB before its type was refused
    with pytest.raises(vf.VdbFormatError, match="vec3d vectors"):
        cm.read_vdb(_vec_tiles(tmp_path))


def test_the_budget_names_itself_and_how_to_raise_it(tmp_path, monkeypatch):
    path = tmp_path / "far.vdb"
    path.write_bytes(dict(vdb_fuzz.crafted())["crafted/two_far_tiles"])
    with pytest.raises(vf.VdbFormatError, match=r"max_bytes=.*region=.*stride=.*"
                                                r"PV_CUBEMARCH_VDB_MAX_BYTES"):
        vf.read_grid(path)
    monkeypatch.setenv("PV_CUBEMARCH_VDB_MAX_BYTES", "1000")
    with pytest.raises(vf.VdbFormatError, match="max_bytes=1000 "):
        vf.read_grid(path, region=((0, 0, 0), (99, 99, 99)))
    grid = vf.read_grid(path, region=((0, 0, 0), (9, 9, 9)), max_bytes=10**6)
    assert (grid.values == 1.0).all()       # the first tile, by hand: value 1.0 at the origin


def test_a_broken_file_in_a_stage_is_one_warning_and_the_rest_renders(tmp_path):
    # catches: one bad .vdb making the whole load_scene raise
    from pxr import Sdf, Usd, UsdVol
    good = (ROOT / "datasets" / "mixed_smoke.vdb").read_bytes()
    (tmp_path / "good.vdb").write_bytes(good)
    broken = bytearray(good)
    broken[-40:] = b"\xff" * 40                       # its last leaf's bytes
    (tmp_path / "broken.vdb").write_bytes(bytes(broken[:len(good) // 2]))
    stage = Usd.Stage.CreateNew(str(tmp_path / "two.usda"))
    for name, file in (("Good", "good.vdb"), ("Broken", "broken.vdb")):
        volume = UsdVol.Volume.Define(stage, f"/{name}")
        asset = UsdVol.OpenVDBAsset.Define(stage, f"/{name}/density")
        asset.CreateFilePathAttr(Sdf.AssetPath(f"./{file}"))
        asset.CreateFieldNameAttr("density")
        volume.CreateFieldRelationship("density", asset.GetPath())
    stage.GetRootLayer().Save()
    with pytest.warns(cm.SceneWarning, match=r"/Broken.*broken\.vdb.*(truncated|corrupt)"):
        scene = cm.load_scene(tmp_path / "two.usda")
    assert len(scene.volumes) == 1
    assert [s.path for s in scene.skipped if s.problem] == ["/Broken"]


def test_buf_refuses_negative_and_outside_offsets():
    # catches: Buf reading from the end for a negative position (slices wrap in python)
    buf = vf.records.Buf(struct.pack("<q", 5) * 4)
    with pytest.raises(vf.VdbFormatError, match="offset -8 lies outside"):
        buf.seek(-8, "grid offset")
    with pytest.raises(vf.VdbFormatError, match="offset 40 lies outside"):
        buf.seek(40, "grid offset")
    buf.seek(24, "grid offset")
    with pytest.raises(vf.VdbFormatError, match=r"needed 9 bytes at offset 24 \(x\)"):
        buf.take(9, "x")
