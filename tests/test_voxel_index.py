"""Voxel worlds drawn by one traversal over a chunk index (world_traversal='index'): every
pixel the CPU traversal of the whole grid's, bytes only for stored chunks."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import set_camera
from test_voxel_world import PALETTE, exact_against_one_grid, terrain_labels
from test_voxels import (
    SIZE,
    extreme_scene,
    finish_extreme_camera,
    plotter,
    random_labels,
    wrong_pixels,
)

import pv_cubemarch as cm
from pv_cubemarch.core.rendering import offscreen_plotter
from pv_cubemarch.models import voxels as voxel_models
from pv_cubemarch.models.chunk_pool import chunk_index, chunk_shift, pool_layout
from pv_cubemarch.models.voxels import make_voxels
from pv_cubemarch.models.world import VoxelWorld
from pv_cubemarch.reference.voxels import face_colors, trace_voxels
from pv_cubemarch.voxels.indexed_world import IndexedWorldBinding, why_not_indexed
from pv_cubemarch.voxels.options import VoxelOptions


def indexed(pl, labels, chunk_size=4, **options) -> IndexedWorldBinding:
    actor = cm.add_voxels(pl, labels, chunk_size=chunk_size, world_traversal="index",
                          **options)
    assert isinstance(actor.cubemarch, IndexedWorldBinding)
    return actor.cubemarch


def test_pool_slots_and_index_entries_by_hand():
    # 5 slots of an 8³ chunk with 2 levels: the slot is 8 x 8 x (8 + 4) texels when the
    # levels' slab lies along z (level 1: 4³ cells at x = 0; level 2: 2³ at x = 8 - 4 + 1
    # = 5: 7 texels along x, under 8). The most even grid of 5 or more slots: 6 = 1 x 2 x 3
    # is less even than 2 x 2 x 2 = 8 but holds fewer: fewest slots first.
    pool = pool_layout(8, 2, 5)
    assert pool.slot_shape == (8, 8, 12) and pool.capacity == 5 and sorted(pool.grid) == [
        1, 1, 5]
    gx, gy, _ = pool.grid
    for slot in range(5):   # the shader's formula, written out again
        cell = (slot % gx, (slot // gx) % gy, slot // (gx * gy))
        assert pool.slot_origin(slot) == tuple(c * n for c, n in zip(cell, (8, 8, 12),
                                                                      strict=True))
    assert pool_layout(128, 6, 10 ** 6) is None             # over one texture
    assert pool_layout(8, 2, 4, budget=4 * 8 * 8 * 12 - 1) is None   # over the byte budget
    assert chunk_shift(128) == 7 and chunk_shift(96) is None and chunk_shift(1) is None
    labels = np.zeros((8, 8, 4), np.uint8)
    labels[:4, :4, :4] = 2         # chunk (0, 0, 0): all 2
    labels[4:, :4, :4] = 3         # chunk (1, 0, 0): all 3, hidden below
    labels[5, 6, 1] = 1            # chunk (1, 1, 0): stored
    palette = cm.Palette(np.array([[0, 0, 0, 0], [1, 0, 0, 1], [0, 1, 0, 1], [0, 0, 1, 0]]))
    world = VoxelWorld.from_model(make_voxels(labels, palette=palette), chunk_size=4)
    index = chunk_index(world, {(1, 1, 0): 2}, world.drawn_labels(), pool)
    assert index.shape == (2, 2, 1, 4)
    assert index[0, 0, 0, 3] == -2 and index[1, 0, 0, 3] == 0 and index[0, 1, 0, 3] == 0
    assert tuple(index[1, 1, 0]) == (*pool.slot_origin(2), 1.0)


EXTREMES = ["inside-grid", "inside-voxel", "axis-parallel", "parallel-projection",
            "far-away", "anisotropic-mirrored", "one-voxel", "sheet", "tiny", "huge"]


@pytest.mark.parametrize("case", EXTREMES)
@pytest.mark.parametrize("mip_levels", [0, None])
def test_extremes_against_the_cpu_traversal_of_one_grid(plotter_factory, case, mip_levels):
    # Chunks of 4 cut a 12 x 10 x 8 grid into 3 x 3 x 2, the last along y cut to 2 voxels;
    # ids (mode='id', one index space for the world) must be the whole grid's.
    # catches (seen to fail): slots read at slot 0's origin (every stored chunk showed the
    # first one's voxels), the chunk level read from the pool instead of the index, the
    # chunk's entry kept from the first chunk a ray entered.
    labels = random_labels((12, 10, 8), 0.2 if mip_levels == 0 else 0.05, seed=3)
    labels[4:8, 0:4, 4:8] = 2            # a uniform chunk
    # the axis-parallel centre ray runs along chunk and voxel edges
    labels, transform, position, focal = extreme_scene(case, labels, axis_point=(8.0, 4.0))
    model = make_voxels(labels, transform=transform)
    pl = plotter(plotter_factory, (49, 49))
    cm.add_voxels(pl, model, mode="id", chunk_size=4, world_traversal="index",
                  mip_levels=mip_levels, proxy="box")
    camera = finish_extreme_camera(pl, case, set_camera(pl, position, focal=focal, angle=50.0))
    wrong, edge, hits = wrong_pixels(pl, model, camera, (49, 49))
    assert (hits.material > 0).any()
    assert wrong == 0, (case, wrong, edge)
    assert edge < 0.05 * hits.material.size, (case, edge)


def test_terrain_from_inside_and_with_ambient_occlusion_across_chunks(plotter_factory):
    # The eye standing among the hills (chunks behind it and hidden behind nearer ground),
    # then the corners' occlusion read across chunk borders: one grid's image, pixel for
    # pixel. catches (seen to fail): neighbours in another chunk read as empty (the per
    # chunk drawing: 101 pixels at chunk borders lighter than one grid's; now refused).
    labels = terrain_labels()
    pl = plotter(plotter_factory)
    indexed(pl, labels, chunk_size=16, mode="face", palette=PALETTE)
    camera = set_camera(pl, (5.0, 5.0, 14.0), focal=(24.0, 20.0, 8.0), up=(0, 0, 1),
                        angle=40.0)
    wrong, off, hits = exact_against_one_grid(pl, labels, camera)
    assert wrong == 0 and off == 0 and (hits.material > 0).mean() > 0.3
    images = []
    for chunk_size in (None, 16):
        pl = plotter(plotter_factory)
        options = {"world_traversal": "index"} if chunk_size else {}
        cm.add_voxels(pl, labels, chunk_size=chunk_size, palette=PALETTE, proxy="box",
                      ambient_occlusion=True, occlusion_strength=0.8, shading="unlit",
                      **options)
        set_camera(pl, (70.0, -30.0, 40.0), focal=(24.0, 20.0, 8.0), up=(0, 0, 1))
        images.append(cm.render_image(pl).astype(int))
    assert np.abs(images[0] - images[1]).max() <= 1 and images[0].any(axis=-1).mean() > 0.3
    with pytest.raises(ValueError, match="across chunk borders"):   # per chunk: refused
        cm.add_voxels(plotter(plotter_factory), labels, chunk_size=16, proxy="box",
                      ambient_occlusion=True, world_traversal="per_chunk")


def test_edits_upload_slot_texels_and_the_index_only_when_kinds_change(plotter_factory):
    # Chunks of 16 with 4 levels: the slot holds the labels and levels 1..3, so one voxel
    # is 1 texel of labels and 1 cell of each level: 4 bytes, the index untouched. A voxel
    # into an empty chunk makes it stored: a new slot (the pool was full: it grows by a
    # quarter and goes up whole) and the index. catches (seen to fail): slot texels not
    # uploaded (the edit not drawn), the index kept after a chunk became stored.
    labels = terrain_labels()
    pl = plotter(plotter_factory)
    world = indexed(pl, labels, chunk_size=16, mode="face", palette=PALETTE)
    camera = set_camera(pl, (70.0, -30.0, 40.0), focal=(24.0, 20.0, 8.0), up=(0, 0, 1))
    cm.render_image(pl)
    assert world.capacity == len(world.model.stored) == len(world.slots)
    pool_bytes, index_uploads = world.pool.uploaded_bytes, world.index.upload_count
    world.set_voxels((20, 20, 22), 1)
    labels[20, 20, 22] = 1
    wrong, off, _ = exact_against_one_grid(pl, labels, camera)
    assert wrong == 0 and off == 0
    assert world.pool.uploaded_bytes - pool_bytes == 4
    assert world.index.upload_count == index_uploads
    empty = [k for k in np.ndindex(3, 3, 2) if k not in world.model.stored
             and k not in world.model.uniform]
    assert empty, "the terrain has an empty chunk up high"
    key = empty[0]
    voxel = tuple(16 * k + 3 for k in key)
    capacity = world.capacity
    world.set_voxels(voxel, 2)
    labels[voxel] = 2
    wrong, off, _ = exact_against_one_grid(pl, labels, camera)
    assert wrong == 0 and off == 0
    assert key in world.slots and world.capacity >= int(np.ceil(capacity * 1.25))
    assert world.index.upload_count == index_uploads + 1
    # The same voxel emptied: the chunk is empty again and its slot free.
    world.set_voxels(voxel, 0)
    labels[voxel] = 0
    wrong, off, _ = exact_against_one_grid(pl, labels, camera)
    assert wrong == 0 and off == 0 and key not in world.slots
    # Another empty chunk filled: it takes a free slot, only its texels go up (the pool
    # keeps its size). catches (seen to fail): a new slot's texels not uploaded.
    grown, other = world.capacity, empty[-1]
    voxel = tuple(16 * k + 5 for k in other)
    pool_uploads = world.pool.upload_count
    world.set_voxels(voxel, 3)
    labels[voxel] = 3
    wrong, off, _ = exact_against_one_grid(pl, labels, camera)
    assert wrong == 0 and off == 0 and other in world.slots
    assert world.capacity == grown and world.pool.upload_count == pool_uploads


def test_hiding_a_uniform_chunk_shows_what_is_behind_it(plotter_factory):
    # A uniform chunk of 3 in front of stored chunks: hidden, it is empty to the traversal.
    # catches (seen to fail): the index not remade with the palette (the hidden chunk's
    # label drawn, or its voxels stepped one by one: still exact, 16x slower).
    labels = random_labels((32, 16, 16), 0.1, seed=7).astype(np.uint8)
    labels[:16] = 3
    pl = plotter(plotter_factory)
    world = indexed(pl, labels, chunk_size=16, mode="face", palette=PALETTE)
    assert (0, 0, 0) in world.model.uniform
    camera = set_camera(pl, (-30.0, 8.0, 8.0), focal=(16.0, 8.0, 8.0), up=(0, 0, 1))
    cm.render_image(pl)
    world.set_material(3, opacity=0.0)
    model = make_voxels(labels, palette=world.palette)
    image = cm.render_image(pl).astype(int)
    hits = trace_voxels(labels, np.eye(4), camera, SIZE, near=pl.camera.clipping_range[0],
                        visible=model.palette.visible, tie_tolerance=1e-4)
    wrong = np.any(image != face_colors(hits).astype(int), axis=-1) & ~hits.near_edge
    assert wrong.sum() == 0 and (hits.material > 0).mean() > 0.1
    assert world.index.array[0, 0, 0, 3] == 0


def test_bytes_only_for_stored_chunks(plotter_factory):
    # By hand: 2 stored chunks of 8³ with 2 levels inside (3 levels: the index is the
    # third): slots of 8 x 8 x 12 bytes, two of them; the index 16 bytes (RGBA float) per
    # chunk (4 x 4 x 1 = 16 chunks); uniform and empty chunks nothing more.
    labels = np.zeros((32, 32, 8), np.uint8)
    labels[:16, :16] = 1                 # 4 uniform chunks
    labels[20, 20, 3] = 2
    labels[30, 2, 5] = 3
    pl = plotter(plotter_factory)
    world = indexed(pl, labels, chunk_size=8, palette=PALETTE)
    assert world.options.mip_levels == 3 and world.layout.levels == 2
    assert world.pool.nbytes == 2 * 8 * 8 * 12
    assert world.index.nbytes == 16 * 16
    empty = indexed(plotter(plotter_factory), np.zeros((64, 64, 64), np.uint8))
    assert empty.pool.nbytes == 1 and empty.capacity == 0


def test_index_refuses_what_it_cannot_draw_and_none_chooses(plotter_factory):
    labels = random_labels((24, 20, 16), 0.05, seed=8).astype(np.uint8)
    for options, match in [({"chunk_size": 12}, "power of two"),
                           ({"chunk_size": 8, "distance_field": 1}, "distance field"),
                           ({"chunk_size": 8, "proxy": "bricks"}, "brick shells"),
                           ({"chunk_size": 8, "mip_levels": 4}, "mip_levels=4")]:
        with pytest.raises(ValueError, match=match):
            cm.add_voxels(plotter(plotter_factory), labels, world_traversal="index", **options)
    with pytest.raises(ValueError, match="world_traversal must be one of"):
        cm.add_voxels(plotter(plotter_factory), labels, chunk_size=8, world_traversal="one")
    chosen = cm.add_voxels(plotter(plotter_factory), labels, chunk_size=12).cubemarch
    assert not isinstance(chosen, IndexedWorldBinding)   # per chunk: 12 is no power of two
    chosen = cm.add_voxels(plotter(plotter_factory), labels, chunk_size=8).cubemarch
    assert isinstance(chosen, IndexedWorldBinding)


def test_removing_the_world_frees_its_textures(plotter_factory):
    labels = terrain_labels()
    pl = plotter(plotter_factory)
    world = indexed(pl, labels, chunk_size=16, palette=PALETTE)
    set_camera(pl, (70.0, -30.0, 40.0), focal=(24.0, 20.0, 8.0), up=(0, 0, 1))
    assert cm.render_image(pl).any() and world.pool.gl_object is not None
    pl.remove_actor(world.actor)
    pl.cubemarch.release_removed()
    assert world._released and world.pool.gl_object is None
    assert world.index.gl_object is None and pl.cubemarch.tracked == []


def test_an_edit_no_pool_holds_is_refused_and_leaves_the_world_as_it_was(plotter_factory,
                                                                          monkeypatch):
    # A budget of exactly 3 slots and 2 stored chunks: a third stored chunk still fits (the
    # pool is made again for exactly 3 when a quarter more does not fit); a fourth does not:
    # MemoryError, and the labels, slots and image stay as before; other edits go on.
    # catches (seen, review): growth refused although the chunks fit, a refused edit kept
    # in the world with stale slots (wrong pixels, then KeyError on the next edit).
    labels = np.zeros((16, 16, 8), np.uint8)
    labels[1, 1, 1] = labels[9, 1, 1] = 1
    slot_bytes = 8 * 8 * 12   # chunks of 8 with levels 1 and 2 in the slot
    monkeypatch.setattr(voxel_models, "MAX_GRID_BYTES", 3 * slot_bytes)
    pl = plotter(plotter_factory)
    world = indexed(pl, labels, chunk_size=8, mode="face", palette=PALETTE)
    camera = set_camera(pl, (30.0, -20.0, 25.0), focal=(8.0, 8.0, 4.0), up=(0, 0, 1))
    cm.render_image(pl)
    world.set_voxels((2, 9, 2), 2)
    labels[2, 9, 2] = 2
    assert world.capacity == 3 and len(world.slots) == 3
    with pytest.raises(MemoryError, match="the edit was not made"):
        world.set_voxels((10, 10, 2), 3)
    assert np.array_equal(world.model.labels_in(np.s_[0:16, 0:16, 0:8]), labels)
    wrong, off, _ = exact_against_one_grid(pl, labels, camera)
    assert wrong == 0 and off == 0
    world.set_voxels((3, 9, 3), 3)   # a stored chunk: no new slot
    labels[3, 9, 3] = 3
    wrong, off, _ = exact_against_one_grid(pl, labels, camera)
    assert wrong == 0 and off == 0


def test_worlds_the_index_cannot_hold_and_ids_beyond_24_bits():
    # catches (review): a chunk index over 2048 texels (the far chunks read as empty), two
    # errors for mode='id' pointing at each other.
    long = VoxelWorld((8 * 2049, 8, 8), 8, cm.Palette.make(None, 2))
    assert "over 2048" in why_not_indexed(long, VoxelOptions(proxy="box"))
    big = VoxelWorld((4096, 64, 72), 64, cm.Palette.make(None, 2))
    for traversal in (None, "index", "per_chunk"):
        with pytest.raises(ValueError, match="Crop the grid or use pick"):
            cm.add_voxels(offscreen_plotter((8, 8)), big, mode="id", world_traversal=traversal)
