"""Grids drawn in chunks (voxel worlds): the same image and depth as one grid, bytes only
for what holds voxels."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import set_camera
from test_voxels import EDGE, SIZE, plotter, random_labels

import pv_cubemarch as cm
from pv_cubemarch.core.rendering import read_depth
from pv_cubemarch.models.voxels import make_voxels
from pv_cubemarch.models.world import VoxelWorld
from pv_cubemarch.reference.voxels import face_colors, trace_voxels

PALETTE = ["black", "red", "lime", "blue"]


def exact_against_one_grid(pl, labels, camera):
    """Wrong pixels of the face image and of the depth against one whole grid's traversal."""
    image = cm.render_image(pl).astype(int)
    depth = read_depth(pl)
    near, far = pl.camera.clipping_range
    hits = trace_voxels(labels, np.eye(4), camera, SIZE, near=near, tie_tolerance=EDGE)
    wrong = np.any(image != face_colors(hits).astype(int), axis=-1) & ~hits.near_edge
    # The hit's window depth from its view depth (perspective): expected from the CPU.
    forward = np.subtract(camera.focal_point, camera.position)
    forward /= np.linalg.norm(forward)
    z = np.where(hits.material > 0, (np.nan_to_num(hits.point) - camera.position) @ forward,
                 1.0)
    expected = np.where(hits.material > 0, (far * (z - near)) / (z * (far - near)), 1.0)
    off = (np.abs(depth - expected) > 1e-4) & ~hits.near_edge & (hits.material > 0)
    return int(wrong.sum()), int(off.sum()), hits


@pytest.mark.parametrize("proxy", ["bricks", "box"])
@pytest.mark.parametrize("eye", [(40.0, 30.0, 35.0), (-16.0, -10.0, -19.0)])
def test_chunk_seams_neither_miss_nor_double_a_voxel(plotter_factory, proxy, eye):
    # Chunks of 8 voxels cut the grid into 3 x 3 x 2 pieces: rays cross many seams, and
    # every pixel must show the face and depth of one whole grid's first voxel.
    # catches (seen to fail): chunks placed without their origin (all drawn at the corner).
    labels = random_labels((24, 20, 16), 0.03, seed=31).astype(np.uint8)
    labels[8:16, 0:8, 8:16] = 2              # a uniform chunk
    labels[16:24, 8:16, 0:8] = 0             # an empty one
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, labels, mode="face", chunk_size=8, proxy=proxy,
                          palette=PALETTE)
    camera = set_camera(pl, eye, focal=(12.0, 10.0, 8.0))
    wrong, off, hits = exact_against_one_grid(pl, labels, camera)
    assert wrong == 0 and off == 0 and (hits.material > 0).mean() > 0.1
    world = actor.cubemarch.model
    assert (1, 0, 1) in world.uniform and (2, 1, 0) not in world.stored
    assert len(actor.cubemarch.chunks) == len(world.stored) + len(world.uniform)


def test_empty_and_uniform_chunks_cost_nothing_and_one_label():
    labels = np.zeros((32, 32, 32), np.uint8)
    labels[:16, :16, :16] = 3
    labels[20, 20, 20] = 1
    world = VoxelWorld.from_model(make_voxels(labels, palette=PALETTE), chunk_size=16)
    # By hand: 8 chunks; one all 3, one with a single voxel, six empty.
    assert world.uniform == {(0, 0, 0): 3} and list(world.stored) == [(1, 1, 1)]
    assert world.nbytes == 16 ** 3 + 2
    uniform = world.chunk_model((0, 0, 0))
    assert uniform.dimensions == (1, 1, 1)
    assert np.allclose(uniform.world_bounds(), (0, 16, 0, 16, 0, 16))


def test_grids_over_the_largest_texture_are_chunked(plotter_factory):
    labels = np.zeros((2100, 4, 3), np.uint8)
    labels[::7, 1:3, 1] = 1
    labels[2050:, :, :] = 2
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, labels, mode="face", palette=PALETTE)
    assert len(actor.cubemarch.chunks) == 9   # by 256 along x: 8 full chunks and 52 voxels
    camera = set_camera(pl, (1900.0, 60.0, 40.0), focal=(2060.0, 2.0, 1.5))
    wrong, off, hits = exact_against_one_grid(pl, labels, camera)
    assert wrong == 0 and off == 0 and (hits.material > 0).any()
    with pytest.raises(ValueError, match="index within its grid"):
        cm.add_voxels(plotter(plotter_factory), labels, mode="id")


def test_removing_the_world_releases_its_chunks(plotter_factory):
    labels = random_labels((24, 20, 16), 0.05, seed=32).astype(np.uint8)
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, labels, chunk_size=8, palette=PALETTE)
    set_camera(pl, (40.0, 30.0, 35.0), focal=(12.0, 10.0, 8.0))
    assert cm.render_image(pl).any()
    chunks = actor.cubemarch.chunks
    pl.remove_actor(actor)
    pl.cubemarch.release_removed()
    assert all(c._released for c in chunks)
    assert not cm.render_image(pl).any()


def test_one_depth_pass_serves_every_chunk(plotter_factory):
    # catches: a pass (and its 8 bytes per pixel) per chunk. By default a chunked grid
    # draws without shells (box and levels: faster with many chunks, bench voxel-world).
    labels = random_labels((24, 20, 16), 0.05, seed=33).astype(np.uint8)
    pl = plotter(plotter_factory)
    plain = cm.add_voxels(pl, labels, chunk_size=8, palette=PALETTE, name="plain")
    assert all(c.options.proxy == "box" and c.shell is None for c in plain.cubemarch.chunks)
    plain.SetVisibility(False)
    actor = cm.add_voxels(pl, labels, chunk_size=8, palette=PALETTE, proxy="bricks")
    set_camera(pl, (40.0, 30.0, 35.0), focal=(12.0, 10.0, 8.0))
    cm.render_image(pl)
    world = actor.cubemarch
    shells = [c.shell for c in world.chunks if c.shell is not None]
    assert len(shells) > 4 and all(s.depth is world.depth for s in shells)
    assert world.depth.runs == 1 and world.depth.nbytes == SIZE[0] * SIZE[1] * 8
    cm.render_image(pl)
    assert world.depth.runs == 1   # nothing moved: not drawn again
