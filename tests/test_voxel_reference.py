"""The voxel CPU reference (grid traversal) against a brute-force slab test of every voxel.

The brute force derives the answer independently: each pixel's ray is intersected with the
box of every filled voxel (``ray_box_interval``) and the nearest entry wins. Index and
material must match exactly except on pixels the traversal flags ``near_edge`` (rays
passing within ``tie_tolerance`` of a voxel edge, where the nearest voxel is ambiguous);
depth to 1e-9 relative. Seen to fail (each on its own): stepping the axis with the
*largest* next crossing, starting at ``floor`` of the origin instead of the clamped start
point, ignoring ``near``, dividing by an exactly-zero direction component, breaking ties
toward z, starting on a boundary in the voxel behind, swapping the face's +/- bit, treating
label 0 as filled and not flagging start points near a face. (The float64 traversal is
exact enough 1e7 away even without subtracting a reference point first, so
``test_far_from_the_origin`` only fails for a grossly imprecise transform, e.g. float32.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from pv_cubemarch.core.camera import Camera
from pv_cubemarch.reference.rays import ray_box_interval
from pv_cubemarch.reference.voxels import VoxelHits, id_colors, render_voxels, trace_voxels

SIZE = (48, 40)
#: Largest share of pixels a test accepts as flagged ``near_edge`` (ambiguous).
MAX_NEAR_EDGE = 0.03


@dataclass
class Brute:
    index: np.ndarray
    material: np.ndarray
    face: np.ndarray
    depth: np.ndarray


def brute_force(labels, world_from_index, camera, size, near=None, visible=None,
                chunk=256) -> Brute:
    """Nearest entry over the boxes of all filled voxels, pixel by pixel (ties: any)."""
    labels = np.asarray(labels)
    width, height = size
    origins, directions = camera.rays(size)
    o_w, d_w = origins.reshape(-1, 3), directions.reshape(-1, 3)
    linear, shift = world_from_index[:3, :3], world_from_index[:3, 3]
    o = np.linalg.solve(linear, (o_w - shift).T).T
    d = np.linalg.solve(linear, d_w.T).T
    t0, t1 = ray_box_interval(o, d, np.zeros(3), np.array(labels.shape, dtype=float))
    start = np.maximum(t0, 0.0)
    if near is not None:
        start = np.maximum(start, near / (d_w @ camera.basis()[2]))
    from_entry = t0 >= start
    table = np.ones(labels.max() + 1, bool) if visible is None else np.array(visible, bool)
    table[0] = False
    voxels = np.argwhere(table[labels]).astype(float)
    n = o.shape[0]
    depth = np.full(n, np.inf)
    best = np.zeros(n, dtype=np.int64)
    best_tn = np.full(n, np.inf)
    for a in range(0, n, chunk):
        b = slice(a, a + chunk)
        tn, tf = ray_box_interval(o[b, None], d[b, None], voxels[None], voxels[None] + 1.0)
        ok = (tn <= tf) & (tf >= start[b, None]) & (start[b] <= t1[b])[:, None]
        entry = np.where(ok, np.maximum(tn, start[b, None]), np.inf)
        if voxels.shape[0]:
            best[b] = entry.argmin(axis=1)
            rows = np.arange(best[b].size)
            depth[b] = entry[rows, best[b]]
            best_tn[b] = tn[rows, best[b]]
    hit = np.isfinite(depth)
    index = np.full((n, 3), -1, dtype=np.int64)
    index[hit] = voxels[best[hit]].astype(np.int64)
    material = np.zeros(n, dtype=np.int64)
    material[hit] = labels[tuple(index[hit].T)]
    # entry face: the axis whose slab the ray enters last (the one bounding tn)
    lower = index[hit].astype(float)
    with np.errstate(divide="ignore", invalid="ignore"):
        ta, tb = (lower - o[hit]) / d[hit], (lower + 1 - o[hit]) / d[hit]
    per_axis = np.where(d[hit] == 0, -np.inf, np.minimum(ta, tb))
    axis = per_axis.argmax(axis=1)
    face = np.full(n, -1, dtype=np.int64)
    inside = ~from_entry[hit] & (best_tn[hit] <= start[hit])
    face[hit] = np.where(inside, -1, 2 * axis + (d[hit][np.arange(axis.size), axis] > 0))
    shape2 = (height, width)
    return Brute(index.reshape(*shape2, 3), material.reshape(shape2), face.reshape(shape2),
                 depth.reshape(shape2))


def check(labels, world_from_index, camera, size=SIZE, near=None, visible=None,
          min_hits=0.05, max_near_edge=MAX_NEAR_EDGE) -> VoxelHits:
    hits = trace_voxels(labels, world_from_index, camera, size, near=near, visible=visible)
    ref = brute_force(labels, world_from_index, camera, size, near=near, visible=visible)
    ok = ~hits.near_edge
    assert hits.near_edge.mean() <= max_near_edge, hits.near_edge.sum()
    assert (hits.material > 0).mean() >= min_hits   # the scene is really seen
    np.testing.assert_array_equal(hits.index[ok], ref.index[ok])
    np.testing.assert_array_equal(hits.material[ok], ref.material[ok])
    np.testing.assert_array_equal(hits.face[ok], ref.face[ok])
    a, b = hits.depth[ok], ref.depth[ok]
    assert ((np.isinf(a) == np.isinf(b)) & (np.isinf(a) | np.isclose(a, b, rtol=1e-9,
                                                                      atol=0))).all()
    # the result is self-consistent on every pixel, flagged or not
    miss = hits.material == 0
    assert (hits.index[miss] == -1).all() and (hits.face[miss] == -1).all()
    assert np.isinf(hits.depth[miss]).all() and np.isfinite(hits.depth[~miss]).all()
    assert (hits.material[~miss] == np.asarray(labels)[tuple(hits.index[~miss].T)]).all()
    return hits


def random_labels(shape=(8, 6, 5), fill=0.2, seed=0, materials=3):
    rng = np.random.default_rng(seed)
    return np.where(rng.random(shape) < fill, rng.integers(1, materials + 1, shape), 0)


def centred(shape, spacing=0.25, origin=None):
    """``world_from_index`` with ``spacing`` per axis, centred on ``origin`` (default 0)."""
    matrix = np.eye(4)
    matrix[:3, :3] = np.diag(np.broadcast_to(np.asarray(spacing, dtype=float), 3))
    centre = np.zeros(3) if origin is None else np.asarray(origin, dtype=float)
    matrix[:3, 3] = centre - matrix[:3, :3] @ (0.5 * np.array(shape, dtype=float))
    return matrix


@pytest.mark.parametrize("position", [(3.0, 2.2, 4.1), (-2.5, 3.3, -1.7), (0.4, -4.0, 0.9)])
def test_perspective(position):
    labels = random_labels()
    check(labels, centred(labels.shape), Camera(position, (0.05, -0.03, 0.02)))


@pytest.mark.parametrize("position", [(3.0, 2.2, 4.1), (-1.0, -3.0, 2.0)])
def test_parallel_projection(position):
    labels = random_labels(seed=1)
    camera = Camera(position, (0.0, 0.0, 0.0), parallel_projection=True, parallel_scale=1.3)
    check(labels, centred(labels.shape), camera)


@pytest.mark.parametrize("parallel", [False, True])
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_rays_parallel_to_an_axis(axis, parallel):
    """Looking down an axis: the centre ray (odd pixel count) is exactly axis-aligned."""
    labels = random_labels(seed=2, fill=0.3)
    focal = np.array([0.113, -0.071, 0.052])
    position = focal.copy()
    position[axis] += 4.0
    camera = Camera(tuple(position), tuple(focal), view_up=(0.0, 0.0, 1.0) if axis != 2
                    else (0.0, 1.0, 0.0), parallel_projection=parallel, parallel_scale=0.83)
    size = (47, 39)
    _, directions = camera.rays(size)
    centre = directions[19, 23]
    assert (np.delete(centre, axis) == 0).all()   # exactly parallel: zero components
    if parallel:
        assert (np.delete(directions, axis, axis=-1) == 0).all()
    hits = check(labels, centred(labels.shape), camera, size=size)
    assert not hits.near_edge[19, 23]


@pytest.mark.parametrize("parallel", [False, True])
def test_rays_parallel_to_a_face_diagonal(parallel):
    labels = random_labels(seed=3, fill=0.25)
    focal = np.array([0.125, -0.0625, 0.078125])   # exact binary fractions: d_x == d_y
    camera = Camera((focal[0] - 3.0, focal[1] - 3.0, focal[2]), tuple(focal),
                    view_up=(0.0, 0.0, 1.0), parallel_projection=parallel, parallel_scale=0.9)
    size = (47, 39)
    _, directions = camera.rays(size)
    centre = directions[19, 23]
    assert centre[0] == centre[1] and centre[2] == 0
    check(labels, centred(labels.shape), camera, size=size)


def test_tie_steps_x_before_y_before_z():
    """A ray through a voxel corner visits the in-between voxels in the order x, y, z."""
    identity = np.eye(4)
    for direction, filled_voxels, expected, face in [
        ((1.0, 1.0, 0.0), [(1, 0, 0), (0, 1, 0)], (1, 0, 0), 1),
        ((1.0, 1.0, 0.0), [(0, 1, 0), (1, 1, 0)], (1, 1, 0), 3),  # never (0, 1, 0)
        ((1.0, 1.0, 1.0), [(0, 1, 0), (0, 0, 1), (1, 1, 0)], (1, 1, 0), 3),  # x, y, then z
        ((-1.0, 1.0, 1.0), [(1, 0, 1), (0, 1, 1)], (0, 1, 1), 5),   # -x, y, then z
    ]:
        labels = np.zeros((2, 2, 2), dtype=np.int64)
        start = np.array([1.5 if direction[0] < 0 else 0.5, 0.5, 0.5])
        for voxel in filled_voxels:
            labels[voxel] = 7
        camera = Camera(tuple(start), tuple(start + np.array(direction)),
                        view_up=(0.3, -0.2, 0.9) if direction[2] == 0 else (0.0, 1.0, 0.2))
        d = camera.rays((1, 1))[1][0, 0]
        assert len(set(np.abs(d[np.array(direction) != 0]))) == 1   # exact tie
        hits = trace_voxels(labels, identity, camera, (1, 1))
        assert tuple(hits.index[0, 0]) == expected, (direction, hits.index[0, 0])
        assert hits.face[0, 0] == face and hits.near_edge[0, 0]
        assert hits.depth[0, 0] == pytest.approx(0.5 / abs(d[0]), rel=1e-15)


def test_camera_inside_the_grid():
    labels = random_labels(seed=4, fill=0.15)
    camera = Camera((0.13, 0.07, -0.21), (1.0, 0.6, 0.3), view_angle=70)
    check(labels, centred(labels.shape), camera, min_hits=0.3)


def test_camera_inside_a_filled_voxel():
    labels = random_labels(seed=5)
    matrix = centred(labels.shape)
    position = np.array([0.13, 0.07, -0.21])
    voxel = tuple(np.floor(np.linalg.solve(matrix[:3, :3], position - matrix[:3, 3]))
                  .astype(int))
    labels[voxel] = 2
    camera = Camera(tuple(position), (1.0, 0.6, 0.3), view_angle=70)
    hits = check(labels, matrix, camera, min_hits=1.0)
    assert (hits.face == -1).all() and (hits.depth == 0).all()
    assert (hits.index == voxel).all() and (hits.material == 2).all()


@pytest.mark.parametrize("position", [(1.5, 1.1, 2.0), (-0.9, -0.6, 0.5), (0.05, 0.02, 0.0)])
def test_only_the_drawn_voxels_box_is_traversed(position):
    # Voxels drawn only inside (2..5, 1..4, 1..3) of a 9x7x6 grid, one visible material far
    # outside it hidden: the traversal of that box alone (indices put back) equals the
    # brute force over the whole grid, from outside the grid, inside the grid but outside
    # the box, and inside the box.
    # catches (seen to fail): the sub-box's indices not shifted back; its placement not
    # shifted by the box's low corner.
    labels = np.zeros((9, 7, 6), np.int64)
    labels[2:6, 1:5, 1:4] = random_labels((4, 4, 3), fill=0.4, seed=21)
    labels[8, 6, 5] = 3
    visible = np.array([False, True, True, False])
    camera = Camera(position, (0.1, 0.05, -0.02), view_angle=70)
    check(labels, centred(labels.shape), camera, visible=visible, min_hits=0.02,
          near=0.01)


def test_near_plane_cutting_the_grid():
    labels = random_labels(seed=6, fill=0.3)
    camera = Camera((2.0, 1.5, 2.4), (0.0, 0.0, 0.0), view_angle=40)
    near = 3.4   # the grid's centre is 3.47 away
    hits = check(labels, centred(labels.shape), camera, near=near)
    # a full grid cut by the near plane: every ray starting inside hits where it starts
    full = np.ones((8, 6, 5), dtype=np.int64)
    hits = check(full, centred(full.shape), camera, near=near)
    origins, directions = camera.rays(SIZE)
    start = near / (directions @ camera.basis()[2])
    inside = (hits.face == -1) & (hits.material > 0)
    assert inside.mean() > 0.1
    np.testing.assert_array_equal(hits.depth[inside], start[inside])
    # and without near, they hit the grid's surface, farther from the eye than nothing
    assert (trace_voxels(full, centred(full.shape), camera, SIZE).depth[inside]
            < start[inside]).all()


@pytest.mark.parametrize("shape", [(1, 1, 1), (1, 7, 5), (6, 1, 4), (9, 3, 6), (2, 11, 1)])
def test_grid_shapes(shape):
    labels = random_labels(shape, fill=0.35, seed=7)
    if labels.max() == 0:
        labels[(0,) * 3] = 1
    camera = Camera((2.1, 1.7, 2.9), (0.0, 0.02, -0.01), view_angle=35)
    check(labels, centred(shape, spacing=1.2 / max(shape)), camera, min_hits=0.01)


@pytest.mark.parametrize("linear", [
    np.diag([-0.5, 2.0, 1.0]) * 0.2,                     # mirrored, anisotropic
    np.diag([0.1, 0.3, -0.15]),
    np.array([[0.2, 0.05, 0.0], [-0.04, 0.18, 0.07], [0.03, 0.0, -0.22]]),  # sheared
])
def test_anisotropic_and_mirrored(linear):
    labels = random_labels(seed=8)
    matrix = np.eye(4)
    matrix[:3, :3] = linear
    matrix[:3, 3] = -linear @ (0.5 * np.array(labels.shape, dtype=float))
    check(labels, matrix, Camera((3.0, 2.2, 4.1), (0.05, -0.03, 0.02)))


@pytest.mark.parametrize("offset", [1e6, 1e7])
def test_far_from_the_origin(offset):
    labels = random_labels(seed=9)
    centre = np.array([offset, -0.7 * offset, 0.3 * offset])
    camera = Camera(tuple(centre + [3.0, 2.2, 4.1]), tuple(centre + [0.05, -0.03, 0.02]))
    matrix = centred(labels.shape, origin=centre)
    hits = check(labels, matrix, camera)
    # the same picture as at the origin
    near_origin = trace_voxels(labels, centred(labels.shape),
                               Camera((3.0, 2.2, 4.1), (0.05, -0.03, 0.02)), SIZE)
    ok = ~hits.near_edge & ~near_origin.near_edge
    assert ok.mean() > 0.95
    np.testing.assert_array_equal(hits.index[ok], near_origin.index[ok])


def test_hidden_materials():
    labels = random_labels(seed=10, fill=0.5, materials=3)
    visible = np.array([False, True, False, True])
    hits = check(labels, centred(labels.shape), Camera((3.0, 2.2, 4.1), (0.0, 0.0, 0.0)),
                 visible=visible)
    assert set(np.unique(hits.material)) <= {0, 1, 3}


def test_small_perturbations_change_only_flagged_pixels():
    """A float32-sized change of the camera moves the answer only where near_edge is set."""
    labels = random_labels(seed=11, fill=0.3)
    matrix = centred(labels.shape)
    base = Camera((2.9, 2.1, 4.0), (0.0, 0.0, 0.0))
    moved = Camera((2.9 + 3e-7, 2.1 - 2e-7, 4.0 + 1e-7), (0.0, 0.0, 0.0))
    a = trace_voxels(labels, matrix, base, (96, 80))
    b = trace_voxels(labels, matrix, moved, (96, 80))
    differ = (a.index != b.index).any(axis=-1) | (a.face != b.face)
    assert not (differ & ~a.near_edge & ~b.near_edge).any()


def test_crop_is_a_window_of_the_full_image():
    labels = random_labels(seed=12)
    camera = Camera((3.0, 2.2, 4.1), (0.0, 0.0, 0.0))
    full = trace_voxels(labels, centred(labels.shape), camera, SIZE)
    part = trace_voxels(labels, centred(labels.shape), camera, SIZE, crop=(5, 7, 20, 11))
    np.testing.assert_array_equal(part.index, full.index[7:18, 5:25])
    np.testing.assert_array_equal(part.depth, full.depth[7:18, 5:25])
    with pytest.raises(ValueError, match="does not fit"):
        trace_voxels(labels, centred(labels.shape), camera, SIZE, crop=(40, 0, 20, 10))


def test_id_colors_round_trip():
    labels = random_labels(seed=13)
    hits = trace_voxels(labels, centred(labels.shape), Camera((3.0, 2.2, 4.1), (0, 0, 0)),
                        SIZE)
    colors = id_colors(hits, labels.shape)
    assert colors.dtype == np.uint8 and colors.shape == (*SIZE[::-1], 3)
    colors = colors.astype(np.int64)
    v = colors[..., 0] + (colors[..., 1] << 8) + (colors[..., 2] << 16)
    hit = hits.material > 0
    assert (v[~hit] == 0).all() and (v[hit] > 0).all()
    nx, ny, _ = labels.shape
    flat = v[hit] - 1
    decoded = np.stack([flat % nx, (flat // nx) % ny, flat // (nx * ny)], axis=-1)
    np.testing.assert_array_equal(decoded, hits.index[hit])
    # ids above 8 bits use the other channels
    big = VoxelHits(np.array([[[299, 200, 100]]]), np.ones((1, 1), np.int64),
                    np.zeros((1, 1), np.int64), np.zeros((1, 1)), np.zeros((1, 1), bool))
    value = 299 + 300 * (200 + 250 * 100) + 1
    assert id_colors(big, (300, 250, 200))[0, 0].tolist() == [
        value & 255, (value >> 8) & 255, (value >> 16) & 255]
    with pytest.raises(ValueError, match="24 bits"):
        id_colors(big, (300, 300, 300))


def test_render_voxels_palette_and_hidden_material():
    labels = random_labels(seed=14, fill=0.5, materials=3)
    camera = Camera((3.0, 2.2, 4.1), (0.0, 0.0, 0.0))
    palette = np.array([[0.5, 0.5, 0.5, 1.0], [1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 0.0],
                        [0.0, 0.0, 1.0, 1.0]])
    background = (0.1, 0.2, 0.3)
    image = render_voxels(labels, centred(labels.shape), palette, camera, SIZE, background)
    hits = trace_voxels(labels, centred(labels.shape), camera, SIZE,
                        visible=np.array([False, True, False, True]))
    expected = np.where((hits.material > 0)[..., None], palette[hits.material, :3],
                        np.array(background))
    np.testing.assert_array_equal(image, expected)
    assert image.shape == (*SIZE[::-1], 3)
    colours = {tuple(c) for c in image.reshape(-1, 3)}
    assert colours == {(1.0, 0.0, 0.0), (0.0, 0.0, 1.0), background}


def test_empty_and_all_hidden_grids_miss_everywhere():
    camera = Camera((3.0, 2.2, 4.1), (0.0, 0.0, 0.0))
    for labels, visible in [(np.zeros((4, 3, 2), int), None),
                            (np.full((4, 3, 2), 2), [True, True, False])]:
        hits = trace_voxels(labels, centred(labels.shape), camera, SIZE, visible=visible)
        assert (hits.material == 0).all() and np.isinf(hits.depth).all()
        assert (hits.index == -1).all() and (hits.face == -1).all()


def test_bad_input():
    camera = Camera((3.0, 2.2, 4.1), (0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="grid"):
        trace_voxels(np.ones((3, 3)), np.eye(4), camera, (4, 4))
    with pytest.raises(ValueError, match=">= 0"):
        trace_voxels(-np.ones((2, 2, 2), int), np.eye(4), camera, (4, 4))
    with pytest.raises(ValueError, match="integers"):
        trace_voxels(np.ones((2, 2, 2)), np.eye(4), camera, (4, 4))
    with pytest.raises(ValueError, match="visible"):
        trace_voxels(np.full((2, 2, 2), 3), np.eye(4), camera, (4, 4), visible=[False, True])
    with pytest.raises(ValueError, match="singular"):
        trace_voxels(np.ones((2, 2, 2), int), np.diag([1.0, 0.0, 1.0, 1.0]), camera, (4, 4))


@pytest.mark.parametrize("parallel", [False, True])
def test_rays_in_a_face_plane_are_flagged(parallel):
    """Rays lying exactly in the plane between two voxel columns are ambiguous: flagged.

    The camera looks down -z from x = 0, the plane between columns i = 3 and 4: the brute
    force picks either column, the traversal column 4.
    """
    labels = random_labels(seed=15, fill=0.4)
    camera = Camera((0.0, 0.0371, 4.0), (0.0, 0.0371, 0.0), parallel_projection=parallel,
                    parallel_scale=0.9)
    size = (47, 39)
    hits = check(labels, centred(labels.shape), camera, size=size, max_near_edge=0.05)
    column = hits.near_edge[:, 23]
    assert column[hits.material[:, 23] > 0].all() and column.sum() >= 10
    ref = brute_force(labels, centred(labels.shape), camera, size)
    assert (ref.index[:, 23, 0] == 3).any()   # the ambiguity is real in this scene
    assert (hits.index[:, 23, 0] != 3).all()


def test_start_on_a_boundary_takes_the_voxel_ahead():
    """A ray starting exactly on a voxel face takes the voxel it moves into, not the one behind."""
    labels = np.array([1, 0, 2]).reshape(3, 1, 1)
    camera = Camera((2.0, 0.5, 0.5), (1.0, 0.5, 0.5))   # looking -x from the face x = 2
    hits = trace_voxels(labels, np.eye(4), camera, (1, 1))
    assert tuple(hits.index[0, 0]) == (0, 0, 0) and hits.material[0, 0] == 1
    assert hits.face[0, 0] == 0 and hits.depth[0, 0] == 1.0 and hits.near_edge[0, 0]
    with pytest.raises(ValueError, match="palette has 2 rows"):
        render_voxels(np.full((2, 2, 2), 3), np.eye(4), np.ones((2, 4)), camera, (4, 4))
