"""Procedural material grids and 3D cellular automata (002), against hand derivations."""

from __future__ import annotations

import numpy as np
import pytest

from pv_cubemarch.models.automaton import AutomatonRule, VoxelAutomaton, count_neighbours
from pv_cubemarch.models.procedural import (
    box,
    capsule,
    fbm2,
    noise2,
    octahedron,
    sphere,
    terrain,
    torus,
)


def centres(shape):
    return np.stack(np.meshgrid(*(np.arange(n) + 0.5 for n in shape), indexing="ij"), -1)


def test_shapes_fill_the_voxels_whose_centre_is_inside():
    # By hand: a box of half size 3 around 8 holds the centres 5.5..10.5 (6 per axis); the
    # others against their textbook inequality at every voxel centre.
    assert box((8, 8, 8), (3, 3, 3)).voxels((16, 16, 16)).sum() == 6 ** 3
    p = centres((20, 18, 16))
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    cases = [
        (sphere((10, 9, 8), 6.2), (x - 10) ** 2 + (y - 9) ** 2 + (z - 8) ** 2 <= 6.2 ** 2),
        (torus((10, 9, 8), 6, 2), (np.hypot(x - 10, y - 9) - 6) ** 2 + (z - 8) ** 2 <= 4),
        (octahedron((10, 9, 8), 7), np.abs(x - 10) + np.abs(y - 9) + np.abs(z - 8) <= 7),
    ]
    for shape, inside in cases:
        assert np.array_equal(shape.voxels((20, 18, 16)) == 1, inside)
    # A capsule along x: within 3 of the segment y = 9, z = 8, 4 <= x <= 15.
    along = np.clip(x, 4, 15)
    inside = (x - along) ** 2 + (y - 9) ** 2 + (z - 8) ** 2 <= 9
    assert np.array_equal(capsule((4, 9, 8), (15, 9, 8), 3).voxels((20, 18, 16)) == 1, inside)


def test_combinations_are_set_operations():
    a, b = sphere((8, 8, 8), 5), box((11, 8, 8), (3, 4, 4))
    dims = (16, 16, 16)
    va, vb = a.voxels(dims) > 0, b.voxels(dims) > 0
    assert np.array_equal((a | b).voxels(dims) > 0, va | vb)
    assert np.array_equal((a & b).voxels(dims) > 0, va & vb)
    assert np.array_equal((a - b).voxels(dims) > 0, va & ~vb)
    painted = a.voxels(dims, material=2)
    b.voxels(dims, material=3, into=painted)
    assert set(np.unique(painted)) == {0, 2, 3} and (painted == 3).sum() == vb.sum()
    with pytest.raises(ValueError, match="dimensions"):
        a.voxels((4, 4))


def test_noise_and_fbm_follow_the_listing():
    x, y = np.meshgrid(np.linspace(0, 7, 40), np.linspace(0, 5, 30), indexing="ij")
    for kind in ("perlin", "value"):
        n = noise2(x, y, kind, seed=3)
        assert np.abs(n).max() <= 1.0 + 1e-9 and n.std() > 0.05
        assert np.array_equal(n, noise2(x, y, kind, seed=3))        # deterministic
        assert not np.allclose(n, noise2(x, y, kind, seed=4))
    # Perlin noise is 0 on the lattice (gradients dotted with a zero offset).
    assert np.allclose(noise2(np.arange(5.0), np.arange(5.0)[::-1]), 0.0)
    # The seed's Listing 2 by hand for two octaves: G = 2^-H. catches (seen to fail): the
    # gain halved once more per octave.
    for hurst in (0.0, 0.5, 1.0):
        expected = noise2(x, y, "perlin", 7) + 2.0 ** -hurst * noise2(2 * x, 2 * y, "perlin", 8)
        assert np.allclose(fbm2(x, y, octaves=2, hurst=hurst, seed=7), expected)
    with pytest.raises(ValueError, match="hurst"):
        fbm2(x, y, hurst=1.5)


def test_terrain_is_layered_and_deterministic():
    labels = terrain((48, 40, 32), seed=5)
    assert np.array_equal(labels, terrain((48, 40, 32), seed=5))
    assert not np.array_equal(labels, terrain((48, 40, 32), seed=6))
    # Every column, bottom up: bedrock (3), dirt (2), grass (1), then air, never mixed.
    order = {3: 0, 2: 1, 1: 2, 0: 3}
    ranks = np.vectorize(order.get)(labels)
    assert (np.diff(ranks, axis=2) >= 0).all()
    assert set(np.unique(labels)) == {0, 1, 2, 3}


def test_rules_parse_and_refuse():
    rule = AutomatonRule.parse("4-6,9/4/5/M")
    assert (rule.survival, rule.birth, rule.states, rule.neighbourhood) == (
        frozenset({4, 5, 6, 9}), frozenset({4}), 5, "moore")
    assert AutomatonRule.parse("pyroclastic") == AutomatonRule.parse("4-7/6-8/10/M")
    assert AutomatonRule.parse("clouds").states == 2
    assert AutomatonRule.parse("0-6/1,3/2/VN").neighbourhood == "von_neumann"
    for bad in ("4/4/5", "4/4/1/M", "4/30/5/M", "4/4/5/X", "4/7/5/VN", "a/4/5/M"):
        with pytest.raises(ValueError):
            AutomatonRule.parse(bad)


def test_neighbour_counts_by_hand():
    one = np.zeros((5, 5, 5), np.uint8)
    one[2, 2, 2] = 1
    moore = count_neighbours(one, "moore")
    assert moore[1:4, 1:4, 1:4].sum() == 26 and moore[2, 2, 2] == 0 and moore.sum() == 26
    vn = count_neighbours(one, "von_neumann")
    assert vn.sum() == 6 and vn[1, 2, 2] == vn[2, 2, 3] == 1 and vn[1, 1, 2] == 0
    corner = np.zeros((4, 4, 4), np.uint8)
    corner[0, 0, 0] = 1
    assert count_neighbours(corner, "moore").sum() == 7                 # dead outside
    wrapped = count_neighbours(corner, "moore", wrap=True)
    assert wrapped.sum() == 26 and wrapped[3, 3, 3] == 1                # around the edges


def test_automaton_steps_by_hand():
    # Rule 0/1/3/VN on 3^3 from the centre alone (state 2 = alive), derived by hand:
    # step 1: the centre (0 alive neighbours) survives, its 6 face neighbours (1 each) are
    # born; step 2: all 7 now have 6 or 1 alive neighbours, not 0: they start dying
    # (state 1), and no dead cell has exactly 1 alive face neighbour; step 3: all dead.
    automaton = VoxelAutomaton((3, 3, 3), rule="0/1/3/VN")
    automaton.state[...] = 0
    automaton.state[1, 1, 1] = 2
    faces = [(0, 1, 1), (2, 1, 1), (1, 0, 1), (1, 2, 1), (1, 1, 0), (1, 1, 2)]
    assert automaton.step() == (slice(0, 3), slice(0, 3), slice(0, 3))
    expected = np.zeros((3, 3, 3), np.uint8)
    expected[1, 1, 1] = 2
    for f in faces:
        expected[f] = 2
    assert np.array_equal(automaton.state, expected)
    automaton.step()
    assert np.array_equal(automaton.state, expected // 2)
    automaton.step()
    assert not automaton.state.any() and automaton.step() is None


def test_automaton_is_seeded_and_colours_its_cells():
    a = VoxelAutomaton((24, 24, 24), rule="445", seed=3)
    b = VoxelAutomaton((24, 24, 24), rule="445", seed=3)
    for _ in range(4):
        a.step()
        b.step()
    assert np.array_equal(a.state, b.state) and a.state.any()
    filled = a.state > 0
    for color_by in ("state", "density", "distance", "position"):
        labels = a.labels(color_by)
        assert np.array_equal(labels > 0, filled), color_by
    assert a.labels("state").max() <= 4 and a.labels("density").max() <= 27
    with pytest.raises(ValueError, match="color_by"):
        a.labels("heat")


def test_dying_cells_neither_count_nor_are_born_again():
    # Rule 0/1/3/VN on a row of 5 cells from cell 0 alive, by hand (2 alive, 1 dying):
    # [2,0,0,0,0] -> [2,2,0,0,0] -> [1,1,2,0,0] -> [0,0,2,2,0]: at the last step cell 2
    # survives because its dying neighbour does not count, and cell 1 is not born again.
    # catches (seen to fail): dying cells counted as alive (cell 2 would start dying).
    automaton = VoxelAutomaton((5, 1, 1), rule="0/1/3/VN")
    automaton.state[...] = 0
    automaton.state[0, 0, 0] = 2
    rows = []
    for _ in range(3):
        automaton.step()
        rows.append(automaton.state[:, 0, 0].tolist())
    assert rows == [[2, 2, 0, 0, 0], [1, 1, 2, 0, 0], [0, 0, 2, 2, 0]]


def test_terrain_region_is_the_same_box_of_the_whole_terrain():
    # catches: the region's columns sampled from 0 (each chunk the same terrain).
    whole = terrain((40, 36, 24), feature_size=9.0, seed=4)
    box = (slice(8, 24), slice(16, 36), slice(4, 20))
    assert np.array_equal(terrain((40, 36, 24), feature_size=9.0, seed=4, region=box),
                          whole[box])
