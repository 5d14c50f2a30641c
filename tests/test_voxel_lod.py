"""Level of detail on material grids: coarse cells where voxels are smaller than a pixel.

The expected image of a level-L frame is the exact CPU traversal of an independently built
coarse grid (each cell the most frequent non-zero label of its 8 children, the smaller on a
tie, by per-cell counting here), scaled by 2^L. Under a parallel projection every pixel has
the same footprint, so the level is the same everywhere and the frame must match that
reference pixel for pixel; under perspective, up close, it must match the full grid.
"""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

import pv_cubemarch as cm
from pv_cubemarch.models.voxel_levels import occupancy_levels, representative_levels
from pv_cubemarch.reference.voxels import trace_voxels

SIZE = (96, 72)
PALETTE = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)


def coarse_labels(labels: np.ndarray, level: int) -> np.ndarray:
    """Level ``level`` of representative labels, counted cell by cell."""
    grid = labels
    for _ in range(level):
        out = np.zeros([-(-n // 2) for n in grid.shape], grid.dtype)
        for i, j, k in np.ndindex(*out.shape):
            block = grid[2 * i:2 * i + 2, 2 * j:2 * j + 2, 2 * k:2 * k + 2].ravel()
            counts = Counter(int(v) for v in block if v)
            if counts:
                top = max(counts.values())
                out[i, j, k] = min(v for v, n in counts.items() if n == top)
        grid = out
    return grid


def scene_labels(seed=3):
    rng = np.random.default_rng(seed)
    shape = (96, 64, 32)
    labels = np.where(rng.random(shape) < 0.3, rng.integers(1, 4, shape), 0).astype(np.uint8)
    labels[:, :, 20:] = 0
    return labels


def lod_plotter(plotter_factory, labels, pixel=None, palette=PALETTE, **options):
    """A frame from above one corner; parallel with a pixel ``pixel`` voxels wide if given."""
    pl = plotter_factory(SIZE)
    pl.disable_anti_aliasing()
    pl.ren_win.SetMultiSamples(0)
    pl.set_background("black")
    actor = cm.add_voxels(pl, labels, palette=palette, shading="unlit", **options)
    center = np.array(labels.shape) / 2
    pl.camera.focal_point = tuple(center)
    pl.camera.position = tuple(center + np.array([100.0, -80.0, 90.0]))
    pl.camera.up = (0, 0, 1)
    if pixel is not None:
        pl.camera.parallel_projection = True
        pl.camera.parallel_scale = pixel * SIZE[1] / 2
    pl.renderer.ResetCameraClippingRange()
    return pl, actor


def wrong_against(pl, labels, level, palette=PALETTE, visible=None):
    """(wrong pixels, covered pixels) of the frame against the level-``level`` reference."""
    image = cm.render_image(pl)[..., :3].astype(float) / 255.0
    grid = coarse_labels(labels, level)
    hits = trace_voxels(grid, np.diag([2.0 ** level] * 3 + [1.0]),
                        cm.Camera.from_pyvista(pl.camera), SIZE,
                        near=pl.camera.clipping_range[0], visible=visible, tie_tolerance=1e-3)
    wrong = (np.abs(image - palette[hits.material]).max(axis=-1) > 0.02) & ~hits.near_edge
    return int(wrong.sum()), int((hits.material > 0).sum())


def test_representative_levels_match_cell_by_cell_counting():
    # catches: the tie going to the larger label, zeros counted as a label, odd sides cut.
    labels = scene_labels()[:13, :11, :9]
    levels = representative_levels(labels, 3)
    for level, grid in enumerate(levels, start=1):
        assert np.array_equal(grid, coarse_labels(labels, level))
        assert np.array_equal(grid != 0, occupancy_levels(labels, level)[-1] != 0)


@pytest.mark.parametrize("proxy", ["box", "bricks"])
@pytest.mark.parametrize(("pixel", "bias", "level"),
                         [(2.5, 0.0, 1), (4.5, 0.0, 2), (2.5, 1.0, 2), (4.5, -1.0, 1)])
def test_parallel_frame_draws_the_chosen_level_exactly(plotter_factory, pixel, bias, level,
                                                       proxy):
    # The level is floor(log2(pixel / voxel) + bias): 2.5 voxels a pixel gives cells of 2.
    # catches (seen to fail): the coarse hit drawn with the fine voxel's label (the atlas
    # holding occupancy, not representatives: 300+ wrong), the level rounded up (ceil:
    # every row), the bias ignored (the biased rows); with proxy='bricks', rays started at
    # the brick shell, which a coarse cell reaches past (2 pixels at level 2).
    labels = scene_labels()
    pl, _ = lod_plotter(plotter_factory, labels, pixel=pixel, lod=True, lod_bias=bias,
                        proxy=proxy)
    wrong, covered = wrong_against(pl, labels, level)
    assert covered > 200
    assert wrong == 0


def test_voxels_larger_than_a_pixel_stay_exact(plotter_factory):
    # Under perspective up close every voxel spans pixels: LOD changes nothing.
    # catches (seen to fail): the pixel's footprint taken at depth 1 whatever the depth
    # (and any level chosen where a voxel is wider than a pixel).
    labels = scene_labels()
    pl, _ = lod_plotter(plotter_factory, labels, lod=True)
    pl.camera.position = (60.0, 20.0, 40.0)
    pl.renderer.ResetCameraClippingRange()
    wrong, covered = wrong_against(pl, labels, 0)
    assert covered > 1000 and wrong == 0


def test_distant_grid_goes_coarse_and_errs_little(plotter_factory):
    # Far away (about 3 voxels a pixel) the image is coarser than the exact one but close:
    # the same pixels are covered and most keep their label.
    labels = scene_labels()
    exact, _ = lod_plotter(plotter_factory, labels)
    coarse, _ = lod_plotter(plotter_factory, labels, lod=True)
    for pl in (exact, coarse):
        pl.camera.position = tuple(np.array(pl.camera.focal_point) * 1 + [500, -400, 450])
        pl.camera.view_angle = 30.0
        pl.renderer.ResetCameraClippingRange()
    a, b = (cm.render_image(pl)[..., :3].astype(int) for pl in (exact, coarse))
    changed = np.abs(a - b).max(axis=-1) > 5
    assert changed.sum() > 20          # the levels are in use
    assert (a.any(-1) != b.any(-1)).mean() < 0.05
    covered = a.any(-1).sum()
    assert changed.sum() < 0.7 * covered


def test_hidden_representative_is_looked_under(plotter_factory):
    # Each 2-cell is mostly the hidden material 2 with at most one drawn voxel of 1: the
    # coarse cell's representative is hidden, so the traversal descends and finds the 1s
    # exactly (the full grid's image with 2 hidden).
    # catches (seen to fail): a hidden representative drawn (its palette alpha ignored) or
    # stepped over as empty (the 1s under it lost).
    rng = np.random.default_rng(5)
    labels = np.full((64, 64, 16), 2, np.uint8)
    cells = rng.random((32, 32, 8)) < 0.3
    for i, j, k in zip(*np.nonzero(cells), strict=True):
        labels[2 * i + rng.integers(2), 2 * j + rng.integers(2), 2 * k + rng.integers(2)] = 1
    palette = np.array([[0, 0, 0, 0], [1, 0, 0, 1], [0, 1, 0, 0]], float)
    pl, _ = lod_plotter(plotter_factory, labels, pixel=2.1, palette=palette, lod=True,
                        proxy="box")
    image = cm.render_image(pl)[..., :3].astype(float) / 255.0
    hits = trace_voxels(labels, np.eye(4), cm.Camera.from_pyvista(pl.camera), SIZE,
                        near=pl.camera.clipping_range[0], visible=palette[:, 3] > 0,
                        tie_tolerance=1e-3)
    wrong = (np.abs(image - palette[hits.material, :3]).max(-1) > 0.02) & ~hits.near_edge
    assert (hits.material > 0).sum() > 100 and wrong.sum() == 0


def test_an_edit_updates_the_representative_levels(plotter_factory):
    # catches (seen to fail): editing writing occupancy (1) into the levels instead of the
    # representative labels: the edited block drawn red at level 1.
    labels = scene_labels()
    pl, actor = lod_plotter(plotter_factory, labels, pixel=2.5, lod=True, proxy="box")
    cm.render_image(pl)
    actor.cubemarch.fill_box((8, 8, 0), (40, 40, 24), 3)
    labels[8:40, 8:40, 0:24] = 3
    wrong, covered = wrong_against(pl, labels, 1)
    assert covered > 200 and wrong == 0


@pytest.mark.parametrize(("options", "message"), [
    ({"lod_bias": 1.0}, "lod=True"),
    ({"lod": True, "mip_levels": 0}, "mip_levels"),
    ({"lod": True, "traversal": "fixed", "mip_levels": 0}, "traversal='dda'"),
    ({"lod": True, "mode": "id"}, "mode='id'"),
    ({"lod": "yes"}, "lod must be True or False"),
    ({"lod": True, "lod_bias": 40}, "lod_bias"),
])
def test_bad_lod_options_name_the_fix(plotter_factory, options, message):
    pl = plotter_factory((32, 32))
    with pytest.raises(ValueError, match=message):
        cm.add_voxels(pl, np.ones((4, 4, 4), np.uint8), **options)
