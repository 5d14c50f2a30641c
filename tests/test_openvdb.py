"""Tests of the pure-numpy OpenVDB reader against Debian's pyopenvdb (OpenVDB 10).

Reference files and arrays are made by ``make_test_grids.py`` under ``/usr/bin/python3``
(the interpreter with ``pyopenvdb``).  pyopenvdb can only write blosc + active-mask
compressed float/bool/vec3s grids, so a minimal writer below produces zip, uncompressed,
raw-chunk, double/int, TranslationMap/UnitaryMap/ScaleMap and no-offset files; float
files it writes are read back by pyopenvdb too, which checks the writer itself.
"""

import shutil
import struct
import subprocess
import time
import zlib
from pathlib import Path

import numpy as np
import pytest
import pyvista as pv
from conftest import MISSING_REFERENCE, has_pyopenvdb
from PIL import Image
from tools.vdb_writer import random_leaves, write_vdb

import pv_cubemarch as cm
import pv_cubemarch.scene.openvdb as vf
from pv_cubemarch import cli as cm_cli
from pv_cubemarch.scene.openvdb import records, tree

HERE = Path(__file__).resolve().parent
SYSTEM_PYTHON = "/usr/bin/python3"
MAKER = HERE / "tools" / "vdb_reference.py"


def _dump(path, regions=()):
    """Read a file back with pyopenvdb and return its reference arrays."""
    args = [SYSTEM_PYTHON, str(MAKER), "dump", str(path), str(path) + ".npz"]
    for lo, hi in regions:
        args += ["--region", *map(str, lo), *map(str, hi)]
    subprocess.run(args, check=True, timeout=300)
    return dict(np.load(str(path) + ".npz"))


def _ref_index(ref, name, index):
    for n in range(int(ref["count"])):
        if str(ref[f"g{n}_name"]) == name and int(ref[f"g{n}_index"]) == index:
            return n
    raise AssertionError(f"{name}[{index}] not in the reference dump")


REF_FILES = ["tiles.vdb", "root_tile.vdb", "half.vdb", "modes.vdb", "level_set.vdb",
             "negative.vdb", "multi.vdb", "affine.vdb", "bool_vec.vdb", "big_sphere.vdb",
             "big_block.vdb"]


def _compare_file(path, ref):
    infos = vf.list_grids(path)
    assert len(infos) == int(ref["count"])
    for info in infos:
        k = f"g{_ref_index(ref, info.name, info.index)}_"
        np.testing.assert_allclose(info.index_to_world, ref[k + "matrix"], rtol=1e-12,
                                   atol=1e-12)
        assert info.stored_as_half == bool(ref[k + "half"])
        if k + "values" in ref:
            grid = vf.read_grid(path, info.name, info.index)
            expected = ref[k + "values"]
            assert grid.origin_index == tuple(int(v) for v in ref[k + "bmin"])
            assert grid.values.shape == expected.shape
            assert grid.values.dtype == expected.dtype
            np.testing.assert_array_equal(grid.values, expected)
            if info.bbox_min is not None:
                assert info.bbox_min == grid.origin_index
        r = 0
        while k + f"r{r}_values" in ref:
            lo, hi = ref[k + f"r{r}_box"]
            grid = vf.read_grid(path, info.name, info.index, region=(tuple(lo), tuple(hi)))
            np.testing.assert_array_equal(grid.values, ref[k + f"r{r}_values"])
            r += 1


@pytest.mark.parametrize("fname", REF_FILES)
def test_matches_pyopenvdb(ref_dir, fname):
    path = ref_dir / fname
    _compare_file(path, dict(np.load(str(path) + ".npz")))


def test_grid_infos(ref_dir):
    infos = vf.list_grids(ref_dir / "multi.vdb")
    assert [(i.name, i.index) for i in infos] == [
        ("density", 0), ("density", 1), ("temperature", 0), ("density", 2)]
    assert infos[0].map_type == "UniformScaleTranslateMap"
    assert infos[0].compression == records.COMPRESS_BLOSC | records.COMPRESS_ACTIVE_MASK
    ls = vf.list_grids(ref_dir / "level_set.vdb")[0]
    assert ls.grid_class == "level set" and ls.value_type == "float"
    assert vf.list_grids(ref_dir / "tiles.vdb")[0].grid_class == "fog volume"
    half = vf.list_grids(ref_dir / "half.vdb")
    assert all(i.stored_as_half for i in half)
    assert [i.value_type for i in vf.list_grids(ref_dir / "bool_vec.vdb")] == ["bool", "vec3s"]
    assert vf.list_grids(ref_dir / "affine.vdb")[0].map_type == "AffineMap"
    big = vf.list_grids(ref_dir / "big_block.vdb")[0]
    assert big.voxel_count == int(np.count_nonzero(vf.read_grid(ref_dir / "big_block.vdb")
                                                    .values))


def test_all_node_modes_seen(ref_dir):
    for fname, index in (("modes.vdb", 0), ("half.vdb", 1)):
        grid = vf.read_grid(ref_dir / fname, index=index)
        assert set(grid.stats["modes"]) == set(range(7))


def test_stride_and_region(ref_dir):
    path = ref_dir / "level_set.vdb"
    full = vf.read_grid(path)
    sub = vf.read_grid(path, stride=3)
    np.testing.assert_array_equal(sub.values, full.values[::3, ::3, ::3])
    lo = np.array(full.origin_index) + 17
    part = vf.read_grid(path, region=(tuple(lo), tuple(lo + 40)), stride=2)
    np.testing.assert_array_equal(part.values, full.values[17:58:2, 17:58:2, 17:58:2])
    outside = vf.read_grid(path, region=((5000, 5000, 5000), (5001, 5002, 5003)))
    assert outside.values.shape == (2, 3, 4)
    assert (outside.values == full.background).all()


def test_a_region_of_a_bool_grid_reads_only_its_leaves(ref_dir):
    # catches: every bool leaf's values paired with the origins of the leaves in the box
    # (numpy's "shape mismatch" for any box leaving a leaf out)
    path = ref_dir / "bool_vec.vdb"
    full = vf.read_grid(path, "mask")
    lo = np.array(full.origin_index)
    part = vf.read_grid(path, "mask", region=(tuple(lo + 3), tuple(lo + (22, 45, 30))))
    np.testing.assert_array_equal(part.values, full.values[3:23, 3:46, 3:31])
    assert part.values.any() and part.stats["leaves"] > 1
    # and the box holds some leaves, not all: the fault needs both
    assert full.values[3:23, 3:46, 3:31].sum() < full.values.sum()


def test_too_large(ref_dir):
    with pytest.raises(vf.VdbFormatError, match="region=.*stride="):
        vf.read_grid(ref_dir / "root_tile.vdb")


def test_unsupported_map(ref_dir):
    info = vf.list_grids(ref_dir / "frustum.vdb")[0]
    assert info.map_type == "NonlinearFrustumMap" and info.index_to_world is None
    with pytest.raises(vf.VdbFormatError, match="NonlinearFrustumMap"):
        vf.read_grid(ref_dir / "frustum.vdb")


def test_blosc_missing(ref_dir, monkeypatch):
    monkeypatch.setattr(tree, "blosc", None)
    with pytest.raises(vf.VdbFormatError, match=r"blosc.*pip install"):
        vf.read_grid(ref_dir / "negative.vdb")


def test_bad_magic(tmp_path):
    path = tmp_path / "bad.vdb"
    path.write_bytes(b"not a vdb file at all" * 4)
    with pytest.raises(vf.VdbFormatError, match="not an OpenVDB file"):
        vf.list_grids(path)
    empty = tmp_path / "empty.vdb"
    empty.write_bytes(b"")
    with pytest.raises(vf.VdbFormatError, match="not an OpenVDB file"):
        vf.read_grid(empty)


def test_truncated(ref_dir, tmp_path):
    data = (ref_dir / "level_set.vdb").read_bytes()
    for cut in (30, 300, len(data) // 2, len(data) - 10):
        path = tmp_path / f"cut{cut}.vdb"
        path.write_bytes(data[:cut])
        with pytest.raises(vf.VdbFormatError, match="truncated|corrupt"):
            vf.read_grid(path)


def test_old_version(ref_dir, tmp_path):
    data = bytearray((ref_dir / "modes.vdb").read_bytes())
    data[8:12] = struct.pack("<I", 221)
    path = tmp_path / "old.vdb"
    path.write_bytes(bytes(data))
    with pytest.raises(vf.VdbFormatError, match="version 221"):
        vf.list_grids(path)


def test_missing_grid(ref_dir):
    with pytest.raises(vf.VdbFormatError, match="density"):
        vf.read_grid(ref_dir / "multi.vdb", "pressure")
    with pytest.raises(vf.VdbFormatError):
        vf.read_grid(ref_dir / "multi.vdb", "density", index=3)


def test_timing_one_million_voxels(ref_dir, capsys):
    for fname in ("big_sphere.vdb", "big_block.vdb"):
        path = ref_dir / fname
        vf.read_grid(path)
        best = min(_timed(vf.read_grid, path) for _ in range(3))
        active = vf.list_grids(path)[0].voxel_count
        with capsys.disabled():
            print(f"\n{fname}: {active} active voxels read in {best * 1000:.0f} ms")


def _timed(fn, *args):
    t = time.perf_counter()
    fn(*args)
    return time.perf_counter() - t


# ---------------------------------------------------------------- minimal writer


def _expected(leaves, background, dtype):
    coords = np.concatenate([np.array(o) + np.argwhere(a.reshape(8, 8, 8))
                             for o, (v, a) in leaves.items()])
    lo, hi = coords.min(axis=0), coords.max(axis=0)
    dense = np.full(hi - lo + 1, background, dtype)
    for o, (v, _a) in leaves.items():
        block = v.reshape(8, 8, 8)
        s = np.array(o) - lo
        src = tuple(slice(max(-s[a], 0), min(8, dense.shape[a] - s[a])) for a in range(3))
        dst = tuple(slice(max(s[a], 0), min(s[a] + 8, dense.shape[a])) for a in range(3))
        dense[dst] = block[src]
    return lo, dense


MAPS = {
    "translation": ("TranslationMap", [1.5, -2.0, 3.25]),
    "scale": ("ScaleMap", [0.5, 2, 3, 0.5, 2, 3, 2, 0.5, 1 / 3, 4, 0.25, 1 / 9, 1, 0.25,
                           1 / 6]),
    "unitary": ("UnitaryMap", [0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]),
    "uniform": ("UniformScaleMap", [0.5] * 6 + [2.0] * 3 + [4.0] * 3 + [1.0] * 3),
}

WRITER_CASES = [
    ("float", "<f4", 0, "translation", "bg"),
    ("float", "<f4", records.COMPRESS_ZIP, "scale", "one"),
    ("float", "<f4", records.COMPRESS_ACTIVE_MASK, "unitary", "minus"),
    ("float", "<f4", records.COMPRESS_ZIP | records.COMPRESS_ACTIVE_MASK, "uniform", "many"),
    ("float", "<f4", records.COMPRESS_BLOSC | records.COMPRESS_ACTIVE_MASK, "translation", "one"),
    ("double", "<f8", records.COMPRESS_ZIP | records.COMPRESS_ACTIVE_MASK, "uniform", "minus"),
    ("int32", "<i4", records.COMPRESS_ACTIVE_MASK, "uniform", "bg"),
    ("int64", "<i8", records.COMPRESS_ZIP, "uniform", "many"),
]


@pytest.mark.parametrize("has_offsets", [True, False])
@pytest.mark.parametrize("case", WRITER_CASES, ids=lambda c: f"{c[0]}-{c[2]}-{c[3]}")
def test_minimal_writer(tmp_path, case, has_offsets):
    _check_writer_case(tmp_path, case, has_offsets)


@pytest.mark.parametrize("version", [222, 223])
def test_older_file_versions(tmp_path, version):
    # 222 (per-node compression metadata) and 223 (before blosc, multipass I/O) share the
    # 224 layout for float/double/int grids: the same files in those versions read the same.
    for case in WRITER_CASES[:2]:
        _check_writer_case(tmp_path, case, True, version)


def _check_writer_case(tmp_path, case, has_offsets, version=224):
    vtype, dtype, comp, map_key, inactive = case
    rng = np.random.default_rng(zlib.crc32(repr(case).encode()))
    background = np.array(2, dtype)
    leaves = random_leaves(rng, dtype, background, inactive=inactive)
    grid = {"name": "g", "type": f"Tree_{vtype}_5_4_3", "dtype": dtype, "compression": comp,
            "background": background, "map": MAPS[map_key], "leaves": leaves}
    other = dict(grid, name="g", leaves=random_leaves(rng, dtype, background, count=3))
    path = tmp_path / "w.vdb"
    write_vdb(path, [other, grid], has_offsets=has_offsets, version=version)
    lo, expected = _expected(leaves, background, dtype)
    got = vf.read_grid(path, "g", 1)
    assert got.origin_index == tuple(lo)
    np.testing.assert_array_equal(got.values, expected)
    assert vf.list_grids(path)[1].compression == comp
    if vtype == "float":
        assert has_pyopenvdb(), MISSING_REFERENCE
        ref = _dump(path)  # the reference library reads our writer's file
        n = _ref_index(ref, "g", 1)
        np.testing.assert_array_equal(ref[f"g{n}_values"], expected)
        assert tuple(ref[f"g{n}_bmin"]) == tuple(lo)
        np.testing.assert_allclose(vf.list_grids(path)[1].index_to_world,
                                   ref[f"g{n}_matrix"], atol=1e-12)


def test_instance_grid(ref_dir, tmp_path):
    assert shutil.which(SYSTEM_PYTHON), MISSING_REFERENCE
    path = tmp_path / "inst.vdb"
    code = (
        "import pyopenvdb as v\n"
        "g = v.FloatGrid(); g.name = 'a'; g.fill((0, 0, 0), (20, 3, 3), 1.5)\n"
        "h = g.copy(); h.name = 'b'; h.transform = v.createLinearTransform(0.5)\n"
        f"v.write({str(path)!r}, [g, h])\n")
    subprocess.run([SYSTEM_PYTHON, "-c", code], check=True, timeout=120)
    infos = vf.list_grids(path)
    assert infos[1].instance_parent == infos[0].unique_name
    a, b = vf.read_grid(path, "a"), vf.read_grid(path, "b")
    np.testing.assert_array_equal(a.values, b.values)
    assert b.info.index_to_world[0, 0] == 0.5 and (b.values == 1.5).all()


# -- OpenVDB volumes in scenes: USD OpenVDBAsset fields, grid files, pv.read ---------------

def _reference(ref_dir, fname, name, index=0):
    """What OpenVDB reads: (dense values, index of values[0,0,0], index-to-world matrix)."""
    ref = dict(np.load(str(ref_dir / fname) + ".npz"))
    k = f"g{_ref_index(ref, name, index)}_"
    return ref[k + "values"], ref[k + "bmin"], ref[k + "matrix"]


def _vdb_stage(tmp_path, fields: dict, attrs=None, stage_name="vdb.usda"):
    """A stage whose Volume's fields are OpenVDBAssets {field: (file, fieldName, index)}."""
    from pxr import Sdf, Usd, UsdVol
    stage = Usd.Stage.CreateNew(str(tmp_path / stage_name))
    volume = UsdVol.Volume.Define(stage, "/Vol")
    for field, (file, name, index) in fields.items():
        asset = UsdVol.OpenVDBAsset.Define(stage, f"/Vol/{field}")
        asset.CreateFilePathAttr(Sdf.AssetPath(file))
        asset.CreateFieldNameAttr(name)
        if index is not None:
            asset.CreateFieldIndexAttr(index)
        volume.CreateFieldRelationship(field, asset.GetPath())
    for key, (kind, value) in (attrs or {}).items():
        volume.GetPrim().CreateAttribute(f"cubemarch:{key}", kind).Set(value)
    stage.GetRootLayer().Save()
    return tmp_path / stage_name


def test_usd_openvdb_asset_feeds_a_volume_exactly(ref_dir, tmp_path):
    # catches: fieldIndex ignored (the first "density" read), the file path not resolved
    # relative to the layer, the grid's map dropped (world bounds from index space).
    shutil.copy(ref_dir / "multi.vdb", tmp_path / "multi.vdb")
    path = _vdb_stage(tmp_path, {"density": ("./multi.vdb", "density", 1),
                                 "temperature": ("./multi.vdb", "temperature", None)})
    scene = cm.load_scene(path)
    volume = scene.volumes[0]
    values, bmin, matrix = _reference(ref_dir, "multi.vdb", "density", 1)
    np.testing.assert_array_equal(volume.values, values.astype(volume.values.dtype))
    corner = matrix @ np.append(bmin, 1.0)
    far = matrix @ np.append(bmin + np.array(values.shape) - 1, 1.0)
    bounds = volume.world_bounds()
    np.testing.assert_allclose(bounds[::2], np.minimum(corner, far)[:3], atol=1e-9)
    np.testing.assert_allclose(bounds[1::2], np.maximum(corner, far)[:3], atol=1e-9)
    listed = {s.path: s.reason for s in scene.skipped}
    assert "temperature" in listed["/Vol"] and "field:density" in listed["/Vol"]


def test_sheared_and_rotated_maps_place_the_grid(ref_dir, tmp_path):
    # The affine grid's world corners, from OpenVDB's own matrix, are the volume's corners.
    values, bmin, matrix = _reference(ref_dir, "affine.vdb", "rotated")
    volume = cm.load_scene(ref_dir / "affine.vdb").volumes[0]
    np.testing.assert_allclose(volume.world_from_index(), matrix @ _shift(bmin), atol=1e-9)
    data = pv.read(ref_dir / "affine.vdb")
    np.testing.assert_allclose(data.points[0], (matrix @ np.append(bmin, 1))[:3], atol=1e-9)
    np.testing.assert_array_equal(data.active_scalars, values.ravel(order="F"))


def _shift(bmin):
    shift = np.eye(4)
    shift[:3, 3] = bmin
    return shift


def test_level_set_as_a_surface_and_bool_as_voxels(ref_dir, tmp_path):
    shutil.copy(ref_dir / "level_set.vdb", tmp_path / "ls.vdb")
    from pxr import Sdf
    path = _vdb_stage(tmp_path, {"density": ("./ls.vdb", "surface", None)},
                      {"technique": (Sdf.ValueTypeNames.Token, "surface"),
                       "isovalue": (Sdf.ValueTypeNames.Float, 0.0)})
    surface = cm.load_scene(path).surfaces[0]
    # the sphere of radius 30 about (3, -7, 11): its box is the level set's narrow band
    center = (surface.world_bounds()[::2] + surface.world_bounds()[1::2]) / 2
    np.testing.assert_allclose(center, (3, -7, 11), atol=0.5)
    shutil.copy(ref_dir / "bool_vec.vdb", tmp_path / "bv.vdb")
    labels = cm.load_scene(_vdb_stage(tmp_path, {"labels": ("./bv.vdb", "mask", None)},
                                      stage_name="vox.usda"), as_voxels=True).voxels[0]
    values, _, _ = _reference(ref_dir, "bool_vec.vdb", "mask")   # OpenVDB's true voxels
    assert labels.dimensions == values.shape
    np.testing.assert_array_equal(labels.labels, values.astype(np.uint8))


def test_vector_grids_and_missing_files_are_reported(ref_dir, tmp_path):
    shutil.copy(ref_dir / "bool_vec.vdb", tmp_path / "bv.vdb")
    path = _vdb_stage(tmp_path, {"density": ("./bv.vdb", "velocity", None)})
    with pytest.warns(cm.SceneWarning, match="vec3s vectors"):
        scene = cm.load_scene(path)
    assert not scene.volumes
    path = _vdb_stage(tmp_path, {"density": ("./gone.vdb", "density", None)}, stage_name="g.usda")
    with pytest.warns(cm.SceneWarning, match="gone.vdb"):
        cm.load_scene(path)


def test_cli_renders_a_vdb_file(ref_dir, tmp_path):
    out = tmp_path / "fog.png"
    assert cm_cli.main(["render", str(ref_dir / "big_sphere.vdb"), "--out", str(out),
                        "--size", "96x72", "--no-progress"]) == 0
    image = np.asarray(Image.open(out))[..., :3].astype(int)
    # the fog sphere fills the middle of the default view; the corners are background
    assert np.abs(image[36, 48] - image[2, 2]).sum() > 60


def _openvdb_writes(path, code: str) -> None:
    """Run ``code`` (with ``v`` = pyopenvdb and ``path``) under the reference library."""
    assert has_pyopenvdb(), MISSING_REFERENCE
    subprocess.run([SYSTEM_PYTHON, "-c", f"import pyopenvdb as v\npath = {str(path)!r}\n"
                    + code], check=True, timeout=120)


def test_voxels_fill_their_cells_and_sheared_maps_place_volumes(tmp_path):
    # catches: a VDB's labels put on points (voxels centred half a voxel off), and a sheared
    # map (kept as field data) left out of the volume's placement.
    shear = [[0.5, 0.0, 0.0, 0.0], [0.25, 0.5, 0.0, 0.0], [0.0, 0.0, 0.5, 0.0],
             [1.0, 2.0, 3.0, 1.0]]
    _openvdb_writes(tmp_path / "s.vdb", f"""
g = v.FloatGrid(); g.name = 'density'
g.fill((2, 3, 4), (5, 6, 7), 1.0, True)
g.transform = v.createLinearTransform({shear})
v.write(path, [g])
""")
    matrix = np.array(shear).T                            # OpenVDB's row-vector convention
    volume = cm.load_scene(tmp_path / "s.vdb").volumes[0]
    corner = np.eye(4)
    corner[:3, 3] = (2, 3, 4)
    np.testing.assert_allclose(volume.world_from_index(), matrix @ corner, atol=1e-9)
    voxels = cm.load_scene(tmp_path / "s.vdb", as_voxels=True).voxels[0]
    corner[:3, 3] = (1.5, 2.5, 3.5)                        # voxel (2, 3, 4) spans ±0.5
    np.testing.assert_allclose(voxels.world_from_index(), matrix @ corner, atol=1e-9)


def test_a_surface_closes_at_the_edge_of_the_active_box(tmp_path):
    # A fog block of 1s (background 0): the level 0.5 lies between the active box and the
    # background just outside; without a margin read past the box the surface is lost.
    _openvdb_writes(tmp_path / "b.vdb", """
g = v.FloatGrid(0.0); g.name = 'density'
g.fill((0, 0, 0), (5, 5, 5), 1.0, True)
v.write(path, [g])
""")
    surface = cm.load_scene(tmp_path / "b.vdb", isovalue=0.5).surfaces[0]
    assert surface.dimensions == (8, 8, 8)                 # 6 voxels and one on each side
    image = cm.load_scene(tmp_path / "b.vdb", isovalue=0.5).render(size=(48, 36))
    assert np.abs(image[18, 24].astype(int) - image[1, 1]).sum() > 60   # the block is drawn
