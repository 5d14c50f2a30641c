"""Grids drawn in chunks (voxel worlds): the same image and depth as one grid, bytes only
for what holds voxels."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import pyvista as pv
import vtk
from conftest import rotated_mirrored_placement, set_camera
from test_voxels import EDGE, SIZE, plotter, random_labels

import pv_cubemarch as cm
from pv_cubemarch.core.rendering import offscreen_plotter, read_depth
from pv_cubemarch.gl import textures
from pv_cubemarch.models import voxels as voxel_models
from pv_cubemarch.models.procedural import terrain
from pv_cubemarch.models.voxels import make_voxels
from pv_cubemarch.models.world import VoxelWorld
from pv_cubemarch.quality.interaction import KNOBS
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


@pytest.mark.parametrize(("proxy", "traversal"), [("bricks", "per_chunk"), ("box", "per_chunk"),
                                                  ("box", "index")])
@pytest.mark.parametrize("eye", [(40.0, 30.0, 35.0), (-16.0, -10.0, -19.0)])
def test_chunk_seams_neither_miss_nor_double_a_voxel(plotter_factory, proxy, traversal, eye):
    # Chunks of 8 voxels cut the grid into 3 x 3 x 2 pieces: rays cross many seams, and
    # every pixel must show the face and depth of one whole grid's first voxel.
    # catches (seen to fail): chunks placed without their origin (all drawn at the corner).
    labels = random_labels((24, 20, 16), 0.03, seed=31).astype(np.uint8)
    labels[8:16, 0:8, 8:16] = 2              # a uniform chunk
    labels[16:24, 8:16, 0:8] = 0             # an empty one
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, labels, mode="face", chunk_size=8, proxy=proxy,
                          palette=PALETTE, world_traversal=traversal)
    camera = set_camera(pl, eye, focal=(12.0, 10.0, 8.0))
    wrong, off, hits = exact_against_one_grid(pl, labels, camera)
    assert wrong == 0 and off == 0 and (hits.material > 0).mean() > 0.1
    world = actor.cubemarch.model
    assert (1, 0, 1) in world.uniform and (2, 1, 0) not in world.stored
    if traversal == "index":   # a slot per stored chunk, none for the others
        assert sorted(actor.cubemarch.slots) == sorted(world.stored)
    else:
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
    world = actor.cubemarch.model   # by 128 along x: 16 full chunks and 52 voxels
    assert len(world.stored) + len(world.uniform) == 17
    camera = set_camera(pl, (1900.0, 60.0, 40.0), focal=(2060.0, 2.0, 1.5))
    wrong, off, hits = exact_against_one_grid(pl, labels, camera)
    assert wrong == 0 and off == 0 and (hits.material > 0).any()
    with pytest.raises(ValueError, match="index within its grid"):
        cm.add_voxels(plotter(plotter_factory), labels, mode="id", world_traversal="per_chunk")


@pytest.mark.parametrize("traversal", ["index", "per_chunk"])
def test_a_world_takes_its_name_and_replaces_no_other_actor(plotter_factory, traversal):
    # catches (found by review, seen failing): a world drawn per chunk added under its
    # model's name whatever name= said, replacing (and releasing) a grid of that name
    labels = random_labels((16, 12, 8), 0.3, seed=5).astype(np.uint8)
    pl = plotter(plotter_factory)
    grid = cm.add_voxels(pl, labels, palette=PALETTE)
    world = cm.add_voxels(pl, labels, palette=PALETTE, chunk_size=4,
                          world_traversal=traversal)
    named = cm.add_voxels(pl, labels, palette=PALETTE, chunk_size=4,
                          world_traversal=traversal, name="segmentation")
    assert pl.actors["voxels"] is grid and not grid.cubemarch._released
    assert world in pl.actors.values() and pl.actors["segmentation"] is named


def test_world_traversal_on_a_grid_drawn_whole_is_said(plotter_factory):
    # catches (seen failing): world_traversal silently ignored on a grid drawn whole
    import warnings

    labels = random_labels((16, 12, 8), 0.3, seed=5).astype(np.uint8)
    pl = plotter(plotter_factory)
    with pytest.warns(UserWarning, match=r"world_traversal='per_chunk' is for grids drawn "
                      r"in chunks.*\(16, 12, 8\).*chunk_size="):
        cm.add_voxels(pl, labels, palette=PALETTE, world_traversal="per_chunk")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cm.add_voxels(pl, labels, palette=PALETTE, world_traversal="per_chunk", chunk_size=4)


def test_removing_the_world_releases_its_chunks(plotter_factory):
    labels = random_labels((24, 20, 16), 0.05, seed=32).astype(np.uint8)
    labels[:16, :16, :8] = 2   # solid bricks: the occluders' pass runs
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, labels, chunk_size=8, palette=PALETTE,
                          world_traversal="per_chunk")
    set_camera(pl, (40.0, 30.0, 35.0), focal=(12.0, 10.0, 8.0))
    assert cm.render_image(pl).any()
    chunks = list(actor.cubemarch.chunks.values())
    occluders = actor.cubemarch.occluders
    assert occluders.faces > 0 and occluders.depth.runs == 1
    pl.remove_actor(actor)
    pl.cubemarch.release_removed()
    assert all(c._released for c in chunks)
    assert occluders.faces == 0 and pl.cubemarch.tracked == []
    assert not cm.render_image(pl).any()


def test_one_depth_pass_serves_every_chunk(plotter_factory):
    # catches: a pass (and its 8 bytes per pixel) per chunk. By default a chunked grid
    # draws without shells (box and levels: faster with many chunks, bench voxel-world).
    labels = random_labels((24, 20, 16), 0.05, seed=33).astype(np.uint8)
    pl = plotter(plotter_factory)
    plain = cm.add_voxels(pl, labels, chunk_size=8, palette=PALETTE, name="plain",
                          world_traversal="per_chunk")
    assert all(c.options.proxy == "box" and c.shell is None
               for c in plain.cubemarch.chunks.values())
    plain.SetVisibility(False)
    actor = cm.add_voxels(pl, labels, chunk_size=8, palette=PALETTE, proxy="bricks")
    set_camera(pl, (40.0, 30.0, 35.0), focal=(12.0, 10.0, 8.0))
    cm.render_image(pl)
    world = actor.cubemarch
    shells = [c.shell for c in world.chunks.values() if c.shell is not None]
    assert len(shells) > 4 and all(s.depth is world.depth for s in shells)
    assert world.depth.runs == 1 and world.depth.nbytes == SIZE[0] * SIZE[1] * 8
    cm.render_image(pl)
    assert world.depth.runs == 1   # nothing moved: not drawn again


def terrain_labels(seed=40):
    """A 48 x 40 x 24 ground: solid below a rough surface (whole solid bricks of 8), three
    materials in layers, a few floating voxels."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.arange(48), np.arange(40), indexing="ij")
    height = (10 + 5 * np.sin(x / 6.0) * np.cos(y / 5.0) + rng.integers(0, 2, x.shape))
    z = np.arange(24)
    labels = np.where(z[None, None, :] < height[..., None], 2, 0).astype(np.uint8)
    labels[z[None, None, :] < height[..., None] - 4] = 3
    labels[:, :, 0] = 1
    labels[rng.integers(0, 48, 30), rng.integers(0, 40, 30), rng.integers(16, 24, 30)] = 1
    return labels


#: Both ways of drawing a world: one traversal over the chunk index, a box per chunk.
BOTH = pytest.mark.parametrize("traversal", ["index", "per_chunk"])


def world_plotter(plotter_factory, labels, traversal="per_chunk", **options):
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, labels, mode="face", palette=PALETTE, chunk_size=16,
                          world_traversal=traversal, **options)
    return pl, actor


@pytest.mark.parametrize(("eye", "up"), [((70.0, -30.0, 30.0), (0, 0, 1)),
                                         ((5.0, 5.0, 14.0), (0, 0, 1)),
                                         ((24.0, 20.0, 80.0), (0, 1, 0))])
def test_solid_faces_end_rays_without_cutting_a_hit(plotter_factory, eye, up):
    # The eye over the ground, standing on it among the hills, and straight above: the
    # occluders (solid bricks' faces) end every chunk's rays; the image and depth stay
    # those of one grid. catches (seen to fail): the faces standing outside their bricks
    # (margin +1/64: rays cut just before hits on solid faces), solid bricks taken from
    # occupancy only (a brick with an empty voxel stopped the rays that pass through it).
    labels = terrain_labels()
    labels[8:16, 8:16, 0:8][3, 3, 3] = 0   # a hole in an otherwise solid brick
    pl, actor = world_plotter(plotter_factory, labels)
    camera = set_camera(pl, eye, focal=(24.0, 20.0, 8.0), up=up, angle=40.0)
    wrong, off, hits = exact_against_one_grid(pl, labels, camera)
    assert actor.cubemarch.occluders.faces > 0 and actor.cubemarch.occluders.active
    assert (hits.material > 0).mean() > 0.15 and wrong == 0 and off == 0


@BOTH
def test_world_edits_show_next_frame_across_chunks(plotter_factory, traversal):
    # One voxel in a stored chunk, a sphere across seams into empty and uniform chunks, a
    # box emptying a uniform chunk in part, a mask: each frame equals one grid's traversal
    # of the edited labels. catches (seen to fail): an edit of an empty or uniform chunk
    # given no new actor (drawn as before), the occluders kept after a solid brick was
    # carved (rays ended at the carved hole's old faces).
    labels = terrain_labels()
    labels[32:48, 0:16, 0:16] = 3          # a uniform chunk
    pl, actor = world_plotter(plotter_factory, labels, traversal)
    world = actor.cubemarch
    assert (2, 0, 0) in world.model.uniform
    camera = set_camera(pl, (70.0, -30.0, 40.0), focal=(24.0, 20.0, 8.0), up=(0, 0, 1))
    cm.render_image(pl)
    edits = [
        lambda w: w.set_voxels((20, 20, 22), 1),
        lambda w: w.fill_sphere((30.0, 14.0, 18.0), 7.0, 1),
        lambda w: w.fill_box((34, 2, 6), (46, 12, 24), 0),
        lambda w: w.set_voxels(np.pad(np.ones((4, 4, 4), bool), ((2, 42), (30, 6), (18, 2))),
                               2),
    ]
    mirror = [
        lambda a: a.__setitem__((20, 20, 22), 1),
        lambda a: a.__setitem__(np.sum((np.indices(a.shape).T + 0.5 - (30, 14, 18)) ** 2,
                                       axis=-1).T <= 49, 1),
        lambda a: a.__setitem__(np.s_[34:46, 2:12, 6:24], 0),
        lambda a: a.__setitem__(np.s_[2:6, 30:34, 18:22], 2),
    ]
    for edit, same in zip(edits, mirror, strict=True):
        edit(world)
        same(labels)
        wrong, off, hits = exact_against_one_grid(pl, labels, camera)
        assert wrong == 0 and off == 0
    assert (2, 0, 0) in world.model.stored and (2, 0, 0) not in world.model.uniform


@BOTH
def test_world_pick_matches_the_cpu_traversal_of_the_whole_grid(plotter_factory, traversal):
    # catches (seen to fail): chunks tried far to near (a hidden voxel picked), a uniform
    # chunk's index taken as its one stretched voxel's.
    labels = terrain_labels()
    labels[32:48, 0:16, 0:16] = 3
    pl, actor = world_plotter(plotter_factory, labels, traversal)
    camera = set_camera(pl, (70.0, -30.0, 40.0), focal=(24.0, 20.0, 8.0), up=(0, 0, 1))
    cm.render_image(pl)
    hits = trace_voxels(labels, np.eye(4), camera, SIZE, near=pl.camera.clipping_range[0])
    picked = 0
    for y in range(0, SIZE[1], 5):
        for x in range(0, SIZE[0], 5):
            got = actor.cubemarch.pick(x, y)
            if hits.material[y, x] == 0 or hits.near_edge[y, x]:
                continue
            assert got is not None and got.index == tuple(hits.index[y, x])
            assert got.material == hits.material[y, x] and got.face == hits.face[y, x]
            picked += 1
    assert picked > 50


@BOTH
def test_world_palette_changes_reach_every_chunk_and_the_occluders(plotter_factory, traversal):
    # Hiding the top layer (2) shows the layer under it: the solid bricks of 2 no longer
    # end rays. catches (seen to fail): occluders not rebuilt (rays ended at hidden ground).
    labels = terrain_labels()
    pl, actor = world_plotter(plotter_factory, labels, traversal)
    camera = set_camera(pl, (70.0, -30.0, 40.0), focal=(24.0, 20.0, 8.0), up=(0, 0, 1))
    cm.render_image(pl)
    actor.cubemarch.set_material(2, opacity=0.0)
    image = cm.render_image(pl).astype(int)
    visible = np.array([False, True, False, True])
    hits = trace_voxels(labels, np.eye(4), camera, SIZE, near=pl.camera.clipping_range[0],
                        visible=visible, tie_tolerance=EDGE)
    wrong = np.any(image != face_colors(hits).astype(int), axis=-1) & ~hits.near_edge
    assert (hits.material == 3).sum() > 100 and wrong.sum() == 0


@BOTH
def test_chunks_placed_by_hand_draw_as_the_split_grid(plotter_factory, traversal):
    labels = terrain_labels()
    split = VoxelWorld.from_model(make_voxels(labels, palette=PALETTE), chunk_size=16)
    chunks = {key: split.chunk_labels(key) for key in (*split.stored, *split.uniform)}
    world = VoxelWorld.from_chunks(chunks, 16, palette=PALETTE, dimensions=labels.shape)
    assert world.uniform == split.uniform and set(world.stored) == set(split.stored)
    pl = plotter(plotter_factory)
    cm.add_voxels(pl, world, mode="face", world_traversal=traversal)
    camera = set_camera(pl, (70.0, -30.0, 40.0), focal=(24.0, 20.0, 8.0), up=(0, 0, 1))
    wrong, off, _ = exact_against_one_grid(pl, labels, camera)
    assert wrong == 0 and off == 0
    with pytest.raises(ValueError, match="must have the shape"):
        VoxelWorld.from_chunks({(0, 0, 0): np.ones((4, 4, 4))}, 8, dimensions=(16, 16, 16))
    with pytest.raises(ValueError, match="three whole numbers"):
        VoxelWorld.from_chunks({(0, -1, 0): np.ones((8, 8, 8))}, 8)


def test_grids_over_the_byte_budget_are_chunked(plotter_factory, monkeypatch):
    # 2048 x 2048 x 512 uint8 fits the largest texture edge but not llvmpipe's memory for
    # one texture (seen: a blank image, GL_OUT_OF_MEMORY unreported): chunked by bytes too.
    # catches: chunking on the edge alone (this grid drawn as one texture).
    assert not voxel_models.fits_one_texture((2048, 2048, 512), np.uint8)
    assert voxel_models.fits_one_texture((2048, 64, 64), np.uint8)
    assert not voxel_models.fits_one_texture((2049, 1, 1), np.uint8)
    monkeypatch.setattr(voxel_models, "MAX_GRID_BYTES", 16 ** 3 - 1)
    labels = terrain_labels()[:16, :16, :16]
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, labels, mode="face", palette=PALETTE)
    assert isinstance(actor.cubemarch.model, VoxelWorld)
    camera = set_camera(pl, (40.0, -20.0, 30.0), focal=(8.0, 8.0, 8.0), up=(0, 0, 1))
    wrong, off, _ = exact_against_one_grid(pl, labels, camera)
    assert wrong == 0 and off == 0


def test_an_upload_the_driver_refused_is_an_error(plotter_factory, monkeypatch):
    # VTK reports success when the driver runs out of memory; the GL error flag says so.
    # catches: the flag not read after the upload (a grid drawn blank, in silence).
    calls = []

    def flags():
        calls.append(1)
        return [] if len(calls) % 2 else [0x0505]   # before the upload: none; after: OOM

    monkeypatch.setattr(textures, "pending_gl_errors", flags)
    pl = plotter(plotter_factory)
    cm.add_voxels(pl, terrain_labels(), palette=PALETTE)
    with pytest.raises(MemoryError, match="chunk_size=128"):
        cm.render_image(pl)


@pytest.mark.parametrize("eye", [(-30.0, 20.0, 12.0), (-6.0, 30.0, 20.0), (-2.0, 3.0, 3.0)])
def test_chunks_hidden_behind_solid_ground_are_not_drawn(plotter_factory, eye):
    # A solid wall (x < 16, all drawn) in front of chunks of scattered voxels: the chunks
    # behind it are left out of the frame (their every pixel ends at the wall first), the
    # frame is still the whole grid's. The last eye is close to the wall: its rectangle
    # covers pixels the wall misses at the edges. catches (seen to fail): a block's
    # rectangle read for its nearest occluder instead of its farthest (in the pyramid and
    # the exact reading: chunks beside the wall's silhouette left out, wrong pixels), the
    # chunks never left out (hidden_chunks == 0).
    labels = random_labels((48, 40, 24), 0.2, seed=44).astype(np.uint8)
    labels[:16] = 3
    pl, actor = world_plotter(plotter_factory, labels)
    camera = set_camera(pl, eye, focal=(24.0, 20.0, 12.0), up=(0, 0, 1), angle=40.0)
    wrong, off, hits = exact_against_one_grid(pl, labels, camera)
    world = actor.cubemarch
    behind = sum(1 for key in world.chunks if key[0] > 0)
    assert wrong == 0 and off == 0 and (hits.material > 0).mean() > 0.3
    assert world.hidden_chunks > 0
    if eye[0] < -10:   # far enough that the wall hides everything behind it
        assert world.hidden_chunks >= behind


@pytest.mark.parametrize("parallel", [False, True])
def test_chunks_are_drawn_far_to_near(plotter_factory, parallel):
    # Hits in adjacent chunks may lie closer than the depth buffer resolves; the depth test
    # passes equal depths, so the nearer chunk must be drawn last (seen: 10 pixels of the
    # bench's 100-chunk terrain showing the farther chunk's face). catches: the chunks left
    # in the order they were made (nearest first from this eye).
    labels = terrain_labels()
    pl, actor = world_plotter(plotter_factory, labels)
    pl.camera.parallel_projection = parallel
    camera = set_camera(pl, (-60.0, -50.0, 40.0), focal=(24.0, 20.0, 8.0), up=(0, 0, 1))
    cm.render_image(pl)
    world = actor.cubemarch
    where = {id(c.drawn[0]): key for key, c in world.chunks.items()}
    order = [where[id(p)] for p in pl.renderer.GetViewProps() if id(p) in where]
    centers = (np.array(order, float) + 0.5) * 16
    offsets = centers - np.asarray(camera.position)
    forward = np.subtract(camera.focal_point, camera.position)
    distance = offsets @ (forward / np.linalg.norm(forward)) if parallel else np.linalg.norm(
        offsets, axis=1)
    assert len(order) == len(world.chunks) > 4
    assert np.all(np.diff(distance) <= 1e-9)


def test_world_filled_chunk_by_chunk_equals_the_split_grid():
    dims = (40, 36, 24)
    whole = terrain(dims, feature_size=9.0, seed=4)
    split = VoxelWorld.from_model(make_voxels(whole, palette=PALETTE), chunk_size=16)
    asked = []

    def fill(box):
        asked.append(box)
        return terrain(dims, feature_size=9.0, seed=4, region=box)

    world = VoxelWorld.from_function(dims, 16, fill, palette=PALETTE)
    assert len(asked) == 3 * 3 * 2 and world.uniform == split.uniform
    assert all(np.array_equal(world.stored[k], split.stored[k]) for k in split.stored)
    assert set(world.stored) == set(split.stored)
    with pytest.raises(ValueError, match="that box's shape"):
        VoxelWorld.from_function(dims, 16, lambda box: np.ones((2, 2, 2), np.uint8))


@BOTH
def test_labels_above_255_stay_whole_in_worlds(plotter_factory, traversal):
    # catches (seen, review): chunks filed as uint8 while none was stored yet (300 -> 44),
    # a 401-entry palette overflowing the uint8 visibility lookup, the pool's texture
    # object reused after its labels widened to uint16 (it kept GL_R8: 1079 pixels wrong).
    mixed = np.zeros((8, 8, 8), np.uint16)
    mixed[2:5, 2:5, 2:5] = 300
    mixed[0, 0, 0] = 2
    world = VoxelWorld.from_chunks({(0, 0, 0): mixed, (1, 0, 0): np.full((8, 8, 8), 300)}, 8,
                                   palette="turbo")
    assert world.label_type == "uint16" and world.uniform == {(1, 0, 0): 300}
    assert set(np.unique(world.stored[(0, 0, 0)])) == {0, 2, 300}
    labels = terrain_labels()[:32, :32, :16]
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, labels, mode="face", palette="turbo", chunk_size=16,
                          world_traversal=traversal)
    palette = np.tile([[1.0, 0.0, 0.0, 1.0]], (401, 1))
    big = plotter(plotter_factory)
    cm.add_voxels(big, labels, palette=palette, chunk_size=16)   # builds: no overflow
    camera = set_camera(pl, (50.0, -20.0, 30.0), focal=(16.0, 16.0, 4.0), up=(0, 0, 1))
    assert cm.render_image(pl).any()   # uploaded as uint8 first
    actor.cubemarch.model.palette = cm.Palette(np.tile([[1.0, 0.0, 0.0, 1.0]], (301, 1)))
    actor.cubemarch.fill_box((0, 0, 0), (20, 20, 4), 300)   # widens every chunk to uint16
    labels = labels.astype(np.uint16)
    labels[:20, :20, :4] = 300
    assert actor.cubemarch.model.label_type == "uint16"
    wrong, off, _ = exact_against_one_grid(pl, labels, camera)
    assert wrong == 0 and off == 0


@BOTH
def test_world_pick_with_tiny_rotated_voxels(traversal):
    # catches (seen, review): the nudge into a uniform chunk's voxel in index units per
    # world unit (55 of 498 picks wrong at a spacing of 1e-5).
    labels = terrain_labels()
    labels[32:48, 0:16, 0:16] = 3
    placement = rotated_mirrored_placement() @ np.diag([1e-5, 1e-5, 1e-5, 1.0])
    pl = offscreen_plotter(SIZE)
    actor = cm.add_voxels(pl, labels, mode="face", palette=PALETTE, chunk_size=16,
                          transform=placement, world_traversal=traversal)
    eye = (placement @ [70.0, -30.0, 40.0, 1.0])[:3]
    focal = (placement @ [24.0, 20.0, 8.0, 1.0])[:3]
    camera = set_camera(pl, tuple(eye), focal=tuple(focal), up=tuple(placement[:3, 2]))
    cm.render_image(pl)
    hits = trace_voxels(labels, placement, camera, SIZE, near=pl.camera.clipping_range[0])
    picked = 0
    for y in range(0, SIZE[1], 4):
        for x in range(0, SIZE[0], 4):
            if hits.material[y, x] == 0 or hits.near_edge[y, x]:
                continue
            assert actor.cubemarch.pick(x, y).index == tuple(hits.index[y, x])
            picked += 1
    assert picked > 50


@BOTH
def test_world_keeps_chunks_as_small_as_their_labels(plotter_factory, traversal):
    # catches: from_function holding every non-empty chunk as an array (uniform ones too),
    # a stored chunk left stored once an edit made it one label.
    world = VoxelWorld.from_function((32, 32, 16), 16, lambda box: np.ones(
        [s.stop - s.start for s in box], np.uint8), palette=PALETTE)
    assert world.stored == {} and len(world.uniform) == 4
    labels = terrain_labels()
    pl, actor = world_plotter(plotter_factory, labels, traversal)
    key = next(iter(actor.cubemarch.model.stored))
    box = tuple(slice(k * 16, min((k + 1) * 16, n)) for k, n in zip(key, labels.shape,
                                                                   strict=True))
    actor.cubemarch.set_voxels(box, 2)
    labels[box] = 2
    assert key in actor.cubemarch.model.uniform and key not in actor.cubemarch.model.stored
    camera = set_camera(pl, (70.0, -30.0, 40.0), focal=(24.0, 20.0, 8.0), up=(0, 0, 1))
    wrong, off, _ = exact_against_one_grid(pl, labels, camera)
    assert wrong == 0 and off == 0


def test_a_failed_world_build_leaves_nothing(plotter_factory):
    # catches (seen, review): the anchor, the passes and the ordering observer left behind.
    labels = np.zeros((2100, 4, 3), np.uint8)
    labels[::7, 1, 1] = 1
    pl = plotter(plotter_factory)
    observers = pl.renderer.HasObserver(vtk.vtkCommand.StartEvent)
    with pytest.raises(ValueError, match="chunk"):
        cm.add_voxels(pl, labels, chunk_size=4096)
    assert "voxels" not in pl.actors and pl.cubemarch.tracked == []
    assert pl.renderer.HasObserver(vtk.vtkCommand.StartEvent) == observers


@BOTH
def test_level_of_detail_in_chunks_matches_one_grid(plotter_factory, traversal):
    # Coarse cells reach past their voxels; chunk boxes cut at the voxels cut them off.
    # Cells of 4 voxels here (levels up to the chunk's own size agree with one grid's).
    # catches (seen, review): 54 pixels missing at lod_bias=2 before the boxes were grown
    # to whole coarse cells.
    labels = terrain_labels()
    images = []
    for chunk in (None, 16):
        pl = plotter(plotter_factory)
        cm.add_voxels(pl, labels, palette=PALETTE, shading="unlit", lod=True, lod_bias=2,
                      proxy="box", chunk_size=chunk,
                      world_traversal=traversal if chunk else None)
        pl.camera.parallel_projection = True
        pl.camera.parallel_scale = 1.2 * SIZE[1] / 2   # 1.2 voxels a pixel: level 0 + 2
        set_camera(pl, (70.0, -30.0, 40.0), focal=(24.0, 20.0, 8.0), up=(0, 0, 1))
        images.append(cm.render_image(pl).astype(int))
    assert (np.abs(images[0] - images[1]).max(axis=-1) > 2).sum() == 0
    assert images[0].any(axis=-1).mean() > 0.2


@pytest.mark.parametrize(("eye", "up"), [((70.0, -30.0, 30.0), (0, 0, 1)),
                                         ((5.0, 5.0, 14.0), (0, 0, 1))])
def test_a_world_drawn_per_chunk_under_a_frame_budget_draws_its_chunks_reduced(
        plotter_factory, eye, up):
    # A moving frame at 1/2 draws every chunk into one half-size target: each 2x2 block is
    # the CPU traversal of the whole grid at half the size (the eye over the terrain, and
    # among its hills, the near plane cutting chunks); the still frame after it is whole.
    # catches (seen failing): the budget refused for a world drawn per chunk; the chunks'
    # rays ended at the occluders' depth read at the reduced fragment's texel (202 of
    # 3072 blocks showing a farther chunk or nothing); the chunks left at full size.
    labels = terrain_labels()
    size = (128, 96)
    pl = plotter(plotter_factory, size)
    actor = cm.add_voxels(pl, labels, mode="face", palette=PALETTE, chunk_size=16,
                          world_traversal="per_chunk", frame_budget_ms=1000.0)
    camera = set_camera(pl, eye, focal=(24.0, 20.0, 8.0), up=up, angle=40.0)
    still = cm.render_image(pl).astype(int)
    assert actor.cubemarch.occluders.active
    KNOBS["pixels"].write(actor.cubemarch, 2.0)
    reduced = cm.render_image(pl).astype(int)
    assert actor.cubemarch.reduced.runs > 0 and actor.cubemarch.reduced.nbytes == 8 * 64 * 48
    near = pl.camera.clipping_range[0]
    hits = trace_voxels(labels, np.eye(4), camera, (64, 48), near=near, tie_tolerance=EDGE)
    # each 2x2 block one pixel's, but where the world box's outline cuts it (the stand-in
    # drawing the targets back is that box: pixels outside show what is behind)
    blocks = reduced.reshape(48, 2, 64, 2, 3)
    whole = np.all(blocks == blocks[:, :1, :, :1], axis=(1, 3, 4))
    assert whole.mean() > 0.97, whole.mean()
    wrong = np.any(blocks[:, 0, :, 0] != face_colors(hits).astype(int), axis=-1)
    assert (hits.material > 0).mean() > 0.3
    wrong &= whole & ~hits.near_edge
    assert not wrong.any(), wrong.sum()
    KNOBS["pixels"].write(actor.cubemarch, 1.0)
    assert np.array_equal(cm.render_image(pl).astype(int), still)


def test_a_world_drawn_per_chunk_and_moved_is_drawn_reduced_where_it_now_stands(
        plotter_factory):
    # set_transform between reduced frames: the frame at 1/2 is the CPU traversal of the
    # placed grid at half the size, and the world's actor reports its new bounds.
    # catches (seen failing): the world's bounds prop left where the first placement put it
    # (its bounds those of that placement; the stand-in, its box, then cut the frame: 1090
    # of 3072 blocks wrong; found by a review)
    labels = terrain_labels()
    pl = plotter(plotter_factory, (128, 96))
    actor = cm.add_voxels(pl, labels, mode="face", palette=PALETTE, chunk_size=16,
                          world_traversal="per_chunk", frame_budget_ms=1000.0)
    set_camera(pl, (-60.0, -50.0, 40.0), focal=(0.0, 10.0, 8.0), up=(0, 0, 1))
    cm.render_image(pl)
    KNOBS["pixels"].write(actor.cubemarch, 2.0)
    cm.render_image(pl)
    placement = rotated_mirrored_placement()
    placement[:3, 3] = (10.0, -5.0, 3.0)
    actor.cubemarch.set_transform(placement)
    corners = np.array([[x, y, z, 1.0] for x in (0, 48) for y in (0, 40) for z in (0, 24)])
    placed = (corners @ placement.T)[:, :3]
    assert np.allclose(actor.GetBounds(), np.ravel([placed.min(0), placed.max(0)], "F"))
    camera = set_camera(pl, (-60.0, -50.0, 40.0), focal=(0.0, 10.0, 8.0), up=(0, 0, 1))
    reduced = cm.render_image(pl).astype(int)
    hits = trace_voxels(labels, placement, camera, (64, 48),
                        near=pl.camera.clipping_range[0], tie_tolerance=EDGE)
    blocks = reduced.reshape(48, 2, 64, 2, 3)
    whole = np.all(blocks == blocks[:, :1, :, :1], axis=(1, 3, 4))
    wrong = np.any(blocks[:, 0, :, 0] != face_colors(hits).astype(int), axis=-1)
    assert (hits.material > 0).mean() > 0.2 and whole.mean() > 0.97
    wrong &= whole & ~hits.near_edge
    assert not wrong.any(), wrong.sum()


@pytest.mark.parametrize("keywords", [{}, {"chunk_size": 16, "world_traversal": "per_chunk"}])
def test_lights_placed_once_a_frame_follow_the_camera(plotter_factory, keywords):
    # The scene's lights are placed in view space once per frame for every shader that
    # takes them (a world's chunks share them): after the camera moves, the frame is the
    # one a new plotter draws from there, lit by PyVista's light kit.
    # catches (seen failing): the lights kept from the first frame's view
    labels = terrain_labels()
    frames = []
    for moved in (True, False):
        pl = plotter(plotter_factory, (96, 72))
        cm.add_voxels(pl, labels, palette=PALETTE, shading="blinn", **keywords)
        if moved:
            set_camera(pl, (70.0, -30.0, 30.0), focal=(24.0, 20.0, 8.0), up=(0, 0, 1))
            cm.render_image(pl)
        set_camera(pl, (-30.0, 60.0, 40.0), focal=(24.0, 20.0, 8.0), up=(0, 0, 1))
        frames.append(cm.render_image(pl).astype(int))
    assert (frames[1].max(axis=-1) > 60).mean() > 0.2
    assert np.array_equal(frames[0], frames[1])


def test_subplots_sharing_a_program_each_draw_their_own_view():
    # The chunks of a world share one shader program, and a value they all set alike (the
    # projection, the lights) is set on it once per frame of each renderer
    # (gl/bindings.py ProgramUniforms). Two subplots drawing the same world from two views
    # share that program: each half is the CPU traversal of the whole grid from its view.
    # catches (seen failing): a uniform skipped by its name alone, whatever its value (the
    # right half drawn with the left's matrices: 1124 of 3072 pixels wrong); the values
    # held across frames (after the left camera moves: 1015). Not caught: the renderer
    # left out of the key (each renderer's matrices are arrays of its own, never the same).
    labels = random_labels((24, 20, 16), 0.03, seed=31).astype(np.uint8)
    pl = pv.Plotter(off_screen=True, window_size=(2 * SIZE[0], SIZE[1]), shape=(1, 2),
                    border=False)
    pl.disable_anti_aliasing()
    pl.ren_win.SetMultiSamples(0)
    eyes = [(40.0, 30.0, 35.0), (-16.0, -10.0, -19.0)]
    for column, eye in enumerate(eyes):
        pl.subplot(0, column)
        pl.set_background("black")
        cm.add_voxels(pl, labels, mode="face", chunk_size=8, palette=PALETTE,
                      world_traversal="per_chunk")
        set_camera(pl, eye, focal=(12.0, 10.0, 8.0))
    for turn in (0.0, 25.0):   # a frame, then the left camera moved
        pl.subplot(0, 0)
        pl.camera.azimuth = turn
        pl.renderer.ResetCameraClippingRange()
        image = cm.render_image(pl).astype(int)
        for column in (0, 1):
            renderer = pl.renderers[column]
            camera = cm.Camera.from_pyvista(renderer.camera)
            hits = trace_voxels(labels, np.eye(4), camera, SIZE,
                                near=renderer.camera.clipping_range[0], tie_tolerance=EDGE)
            half = image[:, column * SIZE[0]:(column + 1) * SIZE[0]]
            wrong = np.any(half != face_colors(hits).astype(int), axis=-1) & ~hits.near_edge
            assert (hits.material > 0).mean() > 0.1
            assert wrong.sum() == 0, (turn, column, int(wrong.sum()))
    pl.close()


@pytest.mark.parametrize("add", ["voxels", "world", "surface", "volume"])
def test_an_actor_removed_and_added_again_is_said_to_draw_nothing(add):
    # remove_actor releases what the actor drew (textures, passes): PyVista's add_actor of
    # it afterwards draws nothing, which is said (found by a review: it was silent).
    # catches (seen failing): no warning.
    labels = random_labels((24, 20, 16), 0.03, seed=31).astype(np.uint8)
    plotter = offscreen_plotter((64, 48))
    if add in ("voxels", "world"):
        actor = cm.add_voxels(plotter, labels, palette=PALETTE,
                              **({"chunk_size": 8} if add == "world" else {}))
    elif add == "surface":
        grid = pv.ImageData(dimensions=(12, 12, 12))
        grid["r"] = np.linalg.norm(grid.points - grid.center, axis=1)
        actor = plotter.cubemarch.add_surface(grid, isovalue=4.0, scalars="r")
    else:
        grid = pv.ImageData(dimensions=(12, 12, 12))
        grid["d"] = np.linalg.norm(grid.points - grid.center, axis=1)
        actor = cm.add_volume(plotter, grid, scalars="d", technique="direct")
    cm.render_image(plotter)
    plotter.remove_actor(actor)
    cm.render_image(plotter)
    with pytest.warns(UserWarning, match="was removed from the plotter.*draws nothing"):
        plotter.add_actor(actor)   # PyVista draws a frame there
        cm.render_image(plotter)
    plotter.close()


@pytest.mark.parametrize("rectilinear", [False, True], ids=["image", "rectilinear"])
@pytest.mark.parametrize("add", ["voxels", "surface", "volume"])
def test_a_dataset_modified_after_adding_is_said_to_be_drawn_as_it_was(add, rectilinear):
    # PyVista draws a dataset as it is at each frame; ours draws the copy uploaded when it
    # was added: editing the dataset in place afterwards is said, once, with the call that
    # draws new values (found by a review: it was silent). A frame without edits says
    # nothing; a uniform RectilinearGrid (drawn through an ImageData of it) is watched
    # itself. catches (seen failing): no warning; the ImageData made of the
    # RectilinearGrid watched instead of it (a fresh review found it silent).
    plotter = offscreen_plotter((64, 48))
    grid = pv.ImageData(dimensions=(12, 12, 12))
    grid["v"] = np.linalg.norm(grid.points - grid.center, axis=1)
    if add == "voxels":
        labels = pv.ImageData(dimensions=(13, 13, 13))
        labels.cell_data["m"] = (np.arange(12 ** 3) % 3).astype(np.uint8)
        grid = labels
    if rectilinear:
        grid = grid.cast_to_rectilinear_grid()
    if add == "voxels":
        cm.add_voxels(plotter, grid, palette=PALETTE)
    elif add == "surface":
        plotter.cubemarch.add_surface(grid, isovalue=4.0, scalars="v")
    else:
        cm.add_volume(plotter, grid, scalars="v", technique="direct")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cm.render_image(plotter)
    with pytest.warns(UserWarning, match="modified after it was added.*as it was"):
        grid.active_scalars[:] = 0   # PyVista's arrays mark their dataset modified
    plotter.close()
