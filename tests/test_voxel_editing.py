"""Editing drawn material grids: the next frame equals the CPU traversal of the edited labels,
and only the touched region goes to the GPU (bytes counted by hand)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import set_camera
from test_voxels import plotter, random_labels, wrong_pixels

import pv_cubemarch as cm

EYE, FOCAL = (40.0, 30.0, 35.0), (12.0, 10.0, 8.0)


def edited_grid(plotter_factory, **options):
    labels = random_labels((24, 20, 16), 0.03, seed=21).astype(np.uint8)
    labels[21:, 17:, 13:] = 0   # the corner nearest the camera starts empty
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, labels, mode="id", **options)
    camera = set_camera(pl, EYE, focal=FOCAL)
    assert wrong_pixels(pl, actor.cubemarch.model, camera)[0] == 0   # uploaded once
    return pl, actor, camera


@pytest.mark.parametrize("options", [{"mip_levels": 3, "distance_field": 2},
                                     {"mip_levels": 0, "proxy": "box"}],
                         ids=["mip3-df2-bricks", "plain-box"])
def test_single_voxel_edits_upload_only_their_texels(plotter_factory, options):
    # catches (seen to fail): region uploads sent through a window system whose context
    # is not current (nothing arrived: the new voxel missing).
    pl, actor, camera = edited_grid(plotter_factory, **options)
    binding = actor.cubemarch
    labels_before = binding.labels.uploaded_bytes
    field_before = [t.uploaded_bytes for t in binding.skipping]
    binding.set_voxels((23, 19, 15), 2)      # a new voxel, in front of the others
    wrong, _, hits = wrong_pixels(pl, binding.model, camera)
    assert wrong == 0 and (hits.index == (23, 19, 15)).all(axis=-1).sum() > 3
    binding.set_voxels((23, 19, 15), 0)      # carved again: what was behind it shows
    wrong, _, hits = wrong_pixels(pl, binding.model, camera)
    assert wrong == 0 and not (hits.index == (23, 19, 15)).all(axis=-1).any()
    # By hand: per edit one texel of labels and one cell per occupancy level, and the
    # distance field's (2r + 1)^3 texels around the voxel, cut by the grid (r = 2 at the
    # corner voxel: x 21..23, y 17..19, z 13..15, 3^3).
    levels = options["mip_levels"]
    assert binding.labels.uploaded_bytes - labels_before == 2 * (1 + levels)
    if options.get("distance_field"):
        assert binding.skipping[0].uploaded_bytes - field_before[0] == 2 * 3 ** 3


def test_brushes_and_whole_replacement(plotter_factory):
    # catches (seen to fail): regions uploaded with the driver's row length left from a
    # whole upload (sub-uploads landing nowhere), occupancy cells above an edit left empty
    # (the brushed voxels skipped), the brick shell not rebuilt.
    pl, actor, camera = edited_grid(plotter_factory, mip_levels=3)
    binding = actor.cubemarch
    before = binding.labels.uploaded_bytes
    binding.fill_sphere((8.0, 8.0, 8.0), 4.0, 3)
    binding.fill_box((14, 2, 0), (22, 6, 16), 1)
    binding.fill_box((16, 3, 0), (20, 5, 16), 0)   # a tunnel through the block
    x, y, z = np.mgrid[0:24, 0:20, 0:16] + 0.5
    inside = (x - 8) ** 2 + (y - 8) ** 2 + (z - 8) ** 2 <= 16
    assert (binding.model.labels[inside] == 3).all()
    assert (binding.model.labels[14:16, 2:6, :] == 1).all()
    assert not binding.model.labels[16:20, 3:5, :].any()
    assert wrong_pixels(pl, binding.model, camera)[0] == 0
    partial = binding.labels.uploaded_bytes - before
    assert 0 < partial < binding.labels.nbytes   # regions, not the whole atlas
    replacement = random_labels((24, 20, 16), 0.05, seed=22)
    before = binding.labels.uploaded_bytes
    binding.set_values(replacement)
    wrong, _, hits = wrong_pixels(pl, binding.model, camera)
    assert wrong == 0 and np.array_equal(binding.model.labels, replacement)
    assert binding.labels.uploaded_bytes - before == binding.labels.nbytes   # whole


def test_edits_beyond_the_filled_box_are_drawn(plotter_factory):
    # The box actor and the brick shell cover only the filled voxels: an edit outside them
    # must grow both. catches (seen to fail): the shell not rebuilt after an edit.
    labels = np.zeros((24, 20, 16), np.uint8)
    labels[10:13, 8:11, 6:9] = 1
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, labels, mode="id", palette=["black", "tan", "steelblue"])
    camera = set_camera(pl, EYE, focal=FOCAL)
    assert wrong_pixels(pl, actor.cubemarch.model, camera)[0] == 0
    actor.cubemarch.set_voxels(np.s_[16:21, 13:17, 11:15], 2)   # outside the filled box
    # the clipping range stays as it was, as after an edit of a PyVista mesh: reset here,
    # as PyVista's user does (or any mouse interaction does)
    pl.renderer.ResetCameraClippingRange()
    wrong, _, hits = wrong_pixels(pl, actor.cubemarch.model, camera)
    assert wrong == 0 and (hits.material == 2).sum() > 10
    mask = np.zeros(labels.shape, bool)
    mask[10:13, 8:11, 6:9] = True
    actor.cubemarch.set_voxels(mask, 0)
    wrong, _, hits = wrong_pixels(pl, actor.cubemarch.model, camera)
    assert wrong == 0 and set(np.unique(hits.material)) == {0, 2}


def test_bad_edits_are_refused(plotter_factory):
    pl, actor, _ = edited_grid(plotter_factory)
    binding = actor.cubemarch
    with pytest.raises(ValueError, match="no colour"):
        binding.set_voxels((1, 1, 1), 9)
    with pytest.raises(ValueError, match="0..255"):
        binding.set_voxels((1, 1, 1), 300)
    with pytest.raises(ValueError, match="whole number"):
        binding.set_voxels((1, 1, 1), 1.5)
    with pytest.raises(IndexError, match="outside"):
        binding.set_voxels((30, 1, 1), 1)
    with pytest.raises(ValueError, match="mask"):
        binding.set_voxels(np.zeros((3, 3, 3), bool), 1)
    with pytest.raises(ValueError, match="shape"):
        binding.set_values(np.zeros((4, 4, 4), int))
    with pytest.raises(cm.VolumeDataError, match="palette"):
        binding.set_values(np.full((24, 20, 16), 7))


def test_the_shell_grows_by_the_bricks_an_edit_fills(plotter_factory):
    # A voxel in an empty brick adds that brick's 6 faces (no rebuild); emptying it keeps
    # them (a ray starting early changes no hit); the image stays exact throughout.
    pl, actor, camera = edited_grid(plotter_factory)
    shell = actor.cubemarch.shell
    quads = len(shell.quads)
    assert not shell.occupied[23 >> shell.level, 19 >> shell.level, 15 >> shell.level]
    actor.cubemarch.set_voxels((23, 19, 15), 1)
    assert len(shell.quads) == quads + 6
    assert wrong_pixels(pl, actor.cubemarch.model, camera)[0] == 0
    actor.cubemarch.set_voxels((23, 19, 15), 0)
    assert len(shell.quads) == quads + 6
    assert wrong_pixels(pl, actor.cubemarch.model, camera)[0] == 0
    actor.cubemarch.set_voxels((22, 19, 15), 2)   # the same brick: filled again, no faces
    assert len(shell.quads) == quads + 6
    assert wrong_pixels(pl, actor.cubemarch.model, camera)[0] == 0


def test_automaton_steps_upload_their_changed_box(plotter_factory):
    # Each step's changed box goes up through set_block; every frame equals the CPU
    # traversal of the automaton's state, and only that box's texels travel.
    from pv_cubemarch.models.automaton import VoxelAutomaton

    automaton = VoxelAutomaton((24, 20, 16), rule="445", seed=4, start_size=0.5)
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, automaton.state, mode="id", palette=["black"] + ["tan"] * 4)
    camera = set_camera(pl, EYE, focal=FOCAL)
    assert wrong_pixels(pl, actor.cubemarch.model, camera)[0] == 0
    for _ in range(3):
        box = automaton.step()
        before = actor.cubemarch.labels.uploaded_bytes
        actor.cubemarch.set_block(box, automaton.state[box])
        wrong, _, hits = wrong_pixels(pl, actor.cubemarch.model, camera)
        assert wrong == 0 and (hits.material > 0).any()
        assert np.array_equal(actor.cubemarch.model.labels, automaton.state)
        sent = actor.cubemarch.labels.uploaded_bytes - before
        assert sent >= np.prod([s.stop - s.start for s in box])   # the box, and its levels
        assert sent < actor.cubemarch.labels.nbytes
    with pytest.raises(ValueError, match="set_block"):
        actor.cubemarch.set_block(np.s_[0:2, 0:2, 0:2], np.zeros((3, 3, 3), int))


def test_edit_corners_and_types_are_checked(plotter_factory):
    # catches (seen to fail): a lower corner below 0 read as Python's index from the end
    # (nothing, or the far side, filled); labels above the grid's type stored wrapped
    # (uint8: 256 stored as 0, the voxel gone).
    pl, actor, camera = edited_grid(plotter_factory)
    binding = actor.cubemarch
    binding.model.labels[...] = 0
    binding.set_values(binding.model.labels)
    binding.fill_box((-3, 0, 0), (4, 2, 2), 1)
    assert (binding.model.labels[0:4, 0:2, 0:2] == 1).all() and binding.model.labels.sum() == 16
    binding.fill_box((20, 18, 14), (40, 40, 40), 2)      # clipped at the far corner
    assert (binding.model.labels[20:, 18:, 14:] == 2).all()
    assert wrong_pixels(pl, binding.model, camera)[0] == 0
    wide = cm.add_voxels(plotter(plotter_factory), np.zeros((4, 4, 4), np.uint8),
                         palette=["black"] + ["tan"] * 299)
    with pytest.raises(cm.VolumeDataError, match="0..255"):
        wide.cubemarch.set_block(np.s_[0:1, 0:1, 0:1], np.full((1, 1, 1), 256))


def test_grids_that_need_another_atlas_layout_or_none(plotter_factory):
    # A tall grid: the levels cannot sit past the labels along z (1400 + 700 > 2048), so
    # they go along another axis; the image stays exact. A grid over the largest texture
    # is drawn in chunks instead of drawing nothing.
    # catches (seen to fail): the slab always along z (the tall grid refused; before the
    # layout was checked, drawn blank: no texture made).
    from pv_cubemarch.models.voxel_levels import atlas_layout

    assert atlas_layout((16, 16, 1400), 2)[0] != 2
    assert atlas_layout((1400, 1400, 1400), 1) is None
    labels = np.zeros((8, 6, 1400), np.uint8)
    labels[2:5, 1:4, 600:700] = 1
    labels[6, 5, 1300] = 2
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, labels, mode="id", mip_levels=2, proxy="box")
    camera = set_camera(pl, (30.0, 20.0, 1000.0), focal=(4.0, 3.0, 700.0))
    wrong, _, hits = wrong_pixels(pl, actor.cubemarch.model, camera)
    assert wrong == 0 and (hits.material > 0).any()
    # Over the largest texture: chunked, not refused (nothing filled: no chunk at all).
    world = cm.add_voxels(plotter(plotter_factory), np.zeros((2049, 1, 1), np.uint8)).cubemarch
    assert world.slots == {} and world.model.stored == {} and world.model.uniform == {}


def test_an_id_the_grid_was_not_added_with_is_refused_saying_how_to_add_it(plotter_factory):
    # Labels 1 and 2 coloured by cmap over clim=(0, 10): painting id 7 is refused, saying
    # to add the grid with every id it will hold (found by a review: the message sent a
    # cmap user to palette=). catches (seen failing): the old message.
    labels = np.zeros((8, 8, 8), np.uint8)
    labels[:4], labels[4:] = 1, 2
    actor = cm.add_voxels(plotter(plotter_factory), labels, cmap="viridis", clim=(0, 10))
    with pytest.raises(ValueError, match="tables hold the ids 0..2.*with cmap=, a grid whose"):
        actor.cubemarch.set_voxels(np.s_[:2], 7)
