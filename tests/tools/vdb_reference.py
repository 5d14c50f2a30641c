"""Write OpenVDB test files with Debian's pyopenvdb and dump reference arrays.

Run with the system python that has ``pyopenvdb`` (OpenVDB 10)::

    /usr/bin/python3 make_test_grids.py write OUTDIR
    /usr/bin/python3 make_test_grids.py dump FILE.vdb OUT.npz [--region i0 j0 k0 i1 j1 k1]...

``write`` creates a set of ``.vdb`` files in OUTDIR and, for each, ``<file>.npz`` made by
reading the file back with pyopenvdb (``dump``).  For every grid ``n`` of a file the
``.npz`` holds ``g{n}_name``, ``g{n}_type``, ``g{n}_values`` (copyToArray over the
grid's evalActiveVoxelBoundingBox), ``g{n}_bmin``, ``g{n}_matrix`` (4x4 index-to-world,
column vectors) and, per requested region ``r``, ``g{n}_r{r}_values``.
"""

import json
import math
import os
import sys

import numpy as np
import pyopenvdb as vdb

MAX_REF_VOXELS = 2**25

# Regions (inclusive index boxes) dumped in addition to the active bounding box.
REGIONS = {
    "tiles.vdb": [((-10, -10, -10), (140, 260, 20)), ((4090, 0, 0), (4100, 3, 3))],
    "root_tile.vdb": [((4090, -3, 5), (4100, 9, 12)), ((-5, -5, -5), (3, 3, 3))],
}


def index_to_world(transform):
    """4x4 column-vector matrix of a linear transform, from mapped basis points."""
    o = np.array(transform.indexToWorld((0, 0, 0)))
    m = np.eye(4)
    m[:3, 3] = o
    for a in range(3):
        e = [0, 0, 0]
        e[a] = 1
        m[:3, a] = np.array(transform.indexToWorld(tuple(e))) - o
    return m


def dense(grid, lo, hi):
    """Copy the grid's values over the inclusive box [lo, hi]."""
    shape = tuple(int(b - a + 1) for a, b in zip(lo, hi, strict=True))
    kind = grid.valueTypeName
    if kind == "bool":
        arr = np.zeros(shape, dtype=bool)
    elif kind == "vec3s":
        arr = np.zeros(shape + (3,), dtype=np.float32)
    else:
        arr = np.zeros(shape, dtype=np.float32)
    grid.copyToArray(arr, ijk=tuple(int(v) for v in lo))
    return arr


def dump(path, out, regions=()):
    """Read every grid of ``path`` back with pyopenvdb and save reference arrays."""
    grids, _meta = vdb.readAll(path)
    ref = {"count": np.array(len(grids))}
    seen = {}
    for n, g in enumerate(grids):
        key = f"g{n}_"
        ref[key + "name"] = np.array(g.name)
        # readAll orders grids by name (a std::multimap), keeping file order within a name
        ref[key + "index"] = np.array(seen.get(g.name, 0))
        seen[g.name] = seen.get(g.name, 0) + 1
        ref[key + "type"] = np.array(g.valueTypeName)
        ref[key + "background"] = np.array(g.background)
        ref[key + "half"] = np.array(bool(g.saveFloatAsHalf))
        ref[key + "matrix"] = index_to_world(g.transform)
        ref[key + "active"] = np.array(g.activeVoxelCount())
        lo, hi = g.evalActiveVoxelBoundingBox()
        ref[key + "bmin"] = np.array(lo)
        ref[key + "bmax"] = np.array(hi)
        voxels = np.prod([max(b - a + 1, 0) for a, b in zip(lo, hi, strict=True)])
        if g.activeVoxelCount() and voxels <= MAX_REF_VOXELS:
            ref[key + "values"] = dense(g, lo, hi)
        for r, (rlo, rhi) in enumerate(regions):
            ref[key + f"r{r}_values"] = dense(g, rlo, rhi)
            ref[key + f"r{r}_box"] = np.array([rlo, rhi])
    np.savez_compressed(out, **ref)


def tiles_grid():
    """Float fog volume with active/inactive tiles at every level, root tile included."""
    g = vdb.FloatGrid(0.0)
    g.name = "density"
    g.gridClass = vdb.GridClass.FOG_VOLUME
    g.fill((0, 0, 0), (127, 127, 127), 0.5, True)  # active 128^3 tile (32^3 node)
    g.fill((0, 128, 0), (127, 255, 127), 0.3, False)  # inactive 128^3 tile
    g.fill((128, 0, 0), (135, 7, 7), 0.25, False)  # inactive 8^3 tile (16^3 node)
    g.fill((128, 8, 0), (135, 15, 7), 0.75, True)  # active 8^3 tile
    g.fill((4096, 0, 0), (8191, 4095, 4095), 2.0, False)  # inactive root tile
    acc = g.getAccessor()
    rng = np.random.default_rng(1)
    for ijk in rng.integers(-9, 140, size=(300, 3)):
        acc.setValueOn(tuple(int(v) for v in ijk), float(rng.random()))
    acc.setValueOff((130, 20, 3), 0.125)
    return g


def root_tile_grid():
    """Float grid with an active root tile (4096^3 voxels) and a few voxels nearby."""
    g = vdb.FloatGrid(-1.0)
    g.name = "root_tile"
    g.fill((0, 0, 0), (4095, 4095, 4095), 3.0, True)
    acc = g.getAccessor()
    acc.setValueOn((-2, -2, -2), 4.0)
    acc.setValueOn((4097, 5, 9), 5.0)
    return g


def random_block(name, origin, shape, seed, half=False):
    """Float grid from a dense random block (zeros become inactive background)."""
    rng = np.random.default_rng(seed)
    arr = rng.random(shape).astype(np.float32)
    arr[arr < 0.2] = 0.0
    g = vdb.FloatGrid()
    g.name = name
    g.copyFromArray(arr, ijk=origin, tolerance=0.0)
    g.saveFloatAsHalf = half
    return g


def modes_grid(half=False):
    """Float grid whose leaves use all seven per-node inactive-value encodings."""
    g = vdb.FloatGrid(1.0)
    g.name = "modes_half" if half else "modes"
    g.saveFloatAsHalf = half
    acc = g.getAccessor()
    # inactive value pattern per leaf, as a function of the voxel offset n
    patterns = [
        lambda n: 1.0,  # 0: all background
        lambda n: -1.0,  # 1: all -background
        lambda n: 5.0,  # 2: one other value
        lambda n: -1.0 if n % 3 else 1.0,  # 3: -bg / +bg
        lambda n: 7.0 if n % 3 else 1.0,  # 4: bg / one other
        lambda n: 7.0 if n % 3 else 9.0,  # 5: two other values
        lambda n: float(n % 4) + 0.5,  # 6: many values
    ]
    for leaf, pattern in enumerate(patterns):
        for n in range(512):
            ijk = (8 * leaf + (n >> 6), -8 + ((n >> 3) & 7), n & 7)
            if n % 7 == 0:
                acc.setValueOn(ijk, 0.1 * n + 0.3333)
            else:
                acc.setValueOff(ijk, pattern(n))
    return g


def level_set():
    """Level set sphere (inactive +-background values, interior -background tiles)."""
    g = vdb.createLevelSetSphere(radius=30.0, center=(3.0, -7.0, 11.0), voxelSize=0.5,
                                 halfWidth=3.0)
    g.name = "surface"
    return g


def bool_grid():
    """Bool grid with voxels, an active tile and inactive true values."""
    g = vdb.BoolGrid(False)
    g.name = "mask"
    g.fill((0, 0, 0), (7, 7, 15), True, True)
    acc = g.getAccessor()
    for i in range(-20, 20, 3):
        acc.setValueOn((i, 2 * i, -i), True)
        acc.setValueOn((i, 2 * i + 1, -i), False)
        acc.setValueOff((i + 1, 2 * i, -i), True)
    return g


def vec_grid():
    """Vec3s grid with voxel values and a tile."""
    g = vdb.Vec3SGrid((0.0, 0.0, 0.0))
    g.name = "velocity"
    g.fill((16, 16, 16), (23, 23, 23), (1.0, -2.0, 3.0), True)
    acc = g.getAccessor()
    rng = np.random.default_rng(5)
    for ijk in rng.integers(-30, 30, size=(200, 3)):
        acc.setValueOn(tuple(int(v) for v in ijk), tuple(float(v) for v in rng.random(3)))
    return g


def fog_sphere(radius=62):
    """Fog volume sphere of about 4/3 pi radius^3 active voxels."""
    r = np.arange(-radius, radius + 1, dtype=np.float32)
    d = np.sqrt(r[:, None, None] ** 2 + r[None, :, None] ** 2 + r[None, None, :] ** 2)
    arr = np.clip(1.0 - d / (radius + 0.5), 0.0, None).astype(np.float32)
    g = vdb.FloatGrid()
    g.name = "density"
    g.gridClass = vdb.GridClass.FOG_VOLUME
    g.copyFromArray(arr, ijk=(-radius, -radius, -radius), tolerance=0.0)
    return g


def affine(g):
    """Give a grid a rotation + non-uniform scale + translation transform."""
    c, s = math.cos(0.3), math.sin(0.3)
    g.transform = vdb.createLinearTransform(
        [[2 * c, 2 * s, 0, 0], [-1.5 * s, 1.5 * c, 0, 0], [0, 0, 0.75, 0], [4, -5, 6, 1]])
    return g


def frustum_grid():
    """Small grid with a NonlinearFrustumMap transform (unsupported by the reader)."""
    g = random_block("frustum", (0, 0, 0), (4, 4, 4), 10)
    g.transform = vdb.createFrustumTransform((0, 0, 0), (9, 9, 9), 0.5, 10.0)
    return g


def scaled(g, voxel, translate=None):
    """Give a grid a uniform scale (and optional translation) transform."""
    t = vdb.createLinearTransform(voxel)
    if translate is not None:
        t.translate(translate)
    g.transform = t
    return g


def files():
    """Map of file name -> list of grids."""
    multi = [
        scaled(random_block("density", (-40, -3, 7), (20, 30, 10), 2), 0.25, (1, 2, 3)),
        random_block("density", (5, 5, 5), (9, 17, 33), 3),
        scaled(random_block("temperature", (100, -200, 0), (12, 12, 12), 4), 2.0),
        random_block("density", (0, 0, 0), (3, 3, 3), 5),
    ]
    return {
        "tiles.vdb": [tiles_grid()],
        "root_tile.vdb": [root_tile_grid()],
        "half.vdb": [random_block("half", (-3, 4, -5), (40, 30, 20), 6, half=True),
                     modes_grid(half=True)],
        "modes.vdb": [modes_grid()],
        "level_set.vdb": [level_set()],
        "negative.vdb": [scaled(random_block("neg", (-1000, -37, -5), (33, 18, 41), 7), 0.1)],
        "multi.vdb": multi,
        "affine.vdb": [affine(random_block("rotated", (2, 3, 4), (10, 11, 12), 8))],
        "bool_vec.vdb": [bool_grid(), vec_grid()],
        "big_sphere.vdb": [fog_sphere()],
        "big_block.vdb": [random_block("block", (0, 0, 0), (100, 100, 100), 9)],
        "frustum.vdb": [frustum_grid()],
    }


def write_all(outdir):
    """Write every test file and its reference dump."""
    os.makedirs(outdir, exist_ok=True)
    manifest = {}
    for name, grids in files().items():
        path = os.path.join(outdir, name)
        vdb.write(path, grids)
        dump(path, path + ".npz", REGIONS.get(name, ()))
        manifest[name] = [g.name for g in grids]
    with open(os.path.join(outdir, "manifest.json"), "w") as f:
        json.dump(manifest, f, indent=1)


def main(argv):
    """Command line entry point."""
    if len(argv) >= 2 and argv[0] == "write":
        write_all(argv[1])
    elif len(argv) >= 3 and argv[0] == "dump":
        regions = []
        rest = argv[3:]
        while rest and rest[0] == "--region":
            v = [int(x) for x in rest[1:7]]
            regions.append((tuple(v[:3]), tuple(v[3:])))
            rest = rest[7:]
        dump(argv[1], argv[2], regions)
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main(sys.argv[1:])
