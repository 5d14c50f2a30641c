"""000's visible-face mask (equation 1) and adaptive LOD (section 3.3), by hand-computed cases."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pv_cubemarch.volume.cubemap.lod import (
    EDGES,
    choose_lod,
    cube_corners,
    project_corners,
    visible_face_mask,
)


def test_cube_edges_are_the_twelve_unit_edges():
    corners = cube_corners()
    assert len(EDGES) == 12 and len(set(EDGES)) == 12
    for a, b in EDGES:
        assert np.count_nonzero(corners[a] != corners[b]) == 1


@pytest.mark.parametrize("eye, mask", [
    ((0.0, 0.0, 0.0), 0b111111),   # inside: every interior face
    ((2.0, 0.0, 0.0), 0b111110),   # beyond +x: the +x face shows its back
    ((0.0, -3.0, 0.0), 0b110111),  # beyond -y
    ((2.0, 2.0, 2.0), 0b101010),   # beyond a corner: only the three far faces
    ((1.0, 0.0, 0.0), 0b111110),   # on the +x face itself: it is edge-on, not visible
    ((0.5, -1.0, 0.9), 0b110111),  # on the -y face
])
def test_visible_face_mask(eye, mask):
    assert visible_face_mask(eye) == mask


def test_at_most_five_faces_from_outside_one_slab():
    assert bin(visible_face_mask((5.0, 0.2, -0.3))).count("1") == 5


def square(edge):
    """Corners of a cube seen head-on in parallel projection: front and back coincide."""
    corners = cube_corners()
    return 100.0 + (corners[:, :2] + 1.0) * edge / 2.0


def test_lod_by_hand_capped_by_samples():
    # longest edge 200 px, k_u = 1: S_ideal = 200, N_ideal = 200/sqrt(3) = 115.47;
    # N_max = 64 caps N, so S = sqrt(3) * 64 = 110.85 and the 512 map drops to level 2 (128).
    lod = choose_lod(square(200.0), max_samples=64, finest_size=512)
    assert lod.ideal_size == pytest.approx(200.0)
    assert lod.ideal_samples == pytest.approx(200.0 / math.sqrt(3))
    assert lod.samples == 64
    assert lod.size == pytest.approx(math.sqrt(3) * 64)
    assert (lod.level, lod.level_size) == (2, 128)


def test_lod_by_hand_uncapped_with_user_factors():
    # k_u = 2 halves S_ideal to 100; k_c = 2 gives N_ideal = 115.47 -> N = 116 <= 256, and
    # S = sqrt(3) * min(115.47, 116) / 2 = 100; a 1024 map goes to level 3 (128 >= 100).
    lod = choose_lod(square(200.0), max_samples=256, finest_size=1024, upscale=2.0,
                     sample_factor=2.0)
    assert lod.ideal_size == pytest.approx(100.0)
    assert lod.samples == 116
    assert lod.size == pytest.approx(100.0)
    assert (lod.level, lod.level_size) == (3, 128)


def test_lod_never_coarser_than_one_texel_or_finer_than_level_zero():
    far = choose_lod(square(0.5), max_samples=128, finest_size=256)
    assert far.samples == 1 and far.level == 8 and far.level_size == 1
    near = choose_lod(square(5000.0), max_samples=10_000, finest_size=256)
    assert near.level == 0 and near.level_size == 256


def test_projected_corners_and_behind_the_eye():
    # unit view, perspective with f = 1 (90 degrees), cube 4 units away, scaled by 0.5
    world = np.diag([0.5, 0.5, 0.5, 1.0])
    world[2, 3] = -4.0
    near, far = 1.0, 10.0
    projection = np.array([[1, 0, 0, 0], [0, 1, 0, 0],
                           [0, 0, -(far + near) / (far - near), -2 * far * near / (far - near)],
                           [0, 0, -1, 0]], dtype=float)
    px = project_corners(world, projection, (400, 400))
    front = [k for k in range(8) if k & 4]  # z = +1 local -> 3.5 units away
    half = 200 * 0.5 / 3.5
    assert np.allclose(sorted(px[front, 0]), [200 - half] * 2 + [200 + half] * 2)
    world[2, 3] = 0.0  # the eye inside the cube: corners behind it
    assert project_corners(world, projection, (400, 400)) is None


def test_bad_arguments():
    with pytest.raises(ValueError, match="power of two"):
        choose_lod(square(10.0), max_samples=8, finest_size=300)
    with pytest.raises(ValueError, match="8 finite"):
        choose_lod(np.zeros((4, 2)), max_samples=8, finest_size=256)
