"""``add_voxels(..., quality=)``: every target is met by the exact traversal, whose error
against the CPU reference is measured and reported (and reported as missed when the
drawing and the reference differ); refusals; the CLI, USD and live-view channels.

Labels are uint16 ids in the thousands on an anisotropic grid far from the origin. The
oracle is the CPU voxel reference, which imports nothing of the renderer, traced over the
whole frame at the camera, near plane, background and lights the plotter really has.
"""

from __future__ import annotations

import numpy as np
import pytest
import pyvista
from conftest import headlit_plotter, stored_settings

import pv_cubemarch
from pv_cubemarch.core.camera import Camera
from pv_cubemarch.core.rendering import offscreen_plotter, read_pixels, render_frame
from pv_cubemarch.image_metrics import compare_images
from pv_cubemarch.models.lights import VolumeLight
from pv_cubemarch.quality import parse_quality
from pv_cubemarch.reference.voxel_layers import render_voxel_layers
from pv_cubemarch.reference.voxels import render_voxels

SIZE = (240, 180)
PLANE = [(-95.0, 30.0, 12.0, 1.0, 0.3, -0.2)]   # a point inside the grid, the normal kept


@pytest.fixture(autouse=True)
def _own_cache(quality_cache):
    """Every test calibrates afresh, in a cache folder of its own."""


@pytest.fixture(scope="module")
def cells():
    rng = np.random.default_rng(11)
    shape = (28, 20, 14)
    ids = np.where(rng.random(shape) < 0.3, rng.choice([1200, 7000, 40000], shape),
                   0).astype(np.uint16)
    grid = pyvista.ImageData(dimensions=np.add(shape, 1), spacing=(0.6, 0.8, 1.1),
                             origin=(-100.0, 25.0, 5.0))
    grid.cell_data["cell_id"] = ids.ravel(order="F")
    return grid


def _whole_frame_psnr(plotter, actor, **look) -> float:
    render_frame(plotter)
    model = actor.cubemarch.model
    lights = [VolumeLight.from_pyvista(light, plotter.camera)
              for light in plotter.renderer.GetLights()]
    expected = render_voxels(model.labels, model.world_from_index(), model.palette.rgba,
                             Camera.from_pyvista(plotter.camera), SIZE,
                             background=plotter.background_color.float_rgb,
                             near=plotter.camera.clipping_range[0], lights=lights, **look)
    return compare_images(read_pixels(plotter), expected).psnr


def _first_frame_unwarned(size, grid, **keywords):
    """A plotter of ``size`` without MSAA, ``grid`` added, its first frame drawn; a warning
    then (the view differing from the one calibrated) fails the test."""
    import warnings
    plotter = offscreen_plotter(size)
    plotter.ren_win.SetMultiSamples(0)
    actor = pv_cubemarch.add_voxels(plotter, grid, **keywords)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        render_frame(plotter)
    return plotter, actor


def _by_hand(plotter, actor, ids, spacing, origin, **look) -> np.ndarray:
    """The reference of the test's own labels, placed by hand (spacing, origin), at the
    plotter's camera, near plane and background."""
    world_from_index = np.diag([*spacing, 1.0])
    world_from_index[:3, 3] = origin
    return render_voxels(ids, world_from_index, actor.cubemarch.palette.rgba,
                         Camera.from_pyvista(plotter.camera), tuple(plotter.window_size),
                         background=plotter.background_color.float_rgb,
                         near=plotter.camera.clipping_range[0], **look)


def _assert_met_as_measured(plotter, actor, expected, within_db):
    """The first frame meets 'exact' against ``expected``, as the report says (within
    ``within_db``, or both above 60 dB); the plotter is closed."""
    measured = compare_images(read_pixels(plotter), expected).psnr
    choice = actor.cubemarch.quality
    plotter.close()
    assert choice.met and measured >= 45.0, (choice, measured)
    assert abs(measured - choice.psnr) < within_db or min(measured, choice.psnr) > 60.0, (
        choice, measured)


@pytest.mark.parametrize("quality", ["exact", 40.0])
def test_every_target_gets_the_dda_with_its_error_measured(cells, quality):
    # the probe's estimate and the whole frame both see the reference drawn, clip planes,
    # edges and lights included
    # catches (seen failing): the clip planes left out of the reference's look (the
    # estimate 14 dB: the cut-away voxels traced)
    plotter = headlit_plotter(SIZE)
    actor = pv_cubemarch.add_voxels(plotter, cells, quality=quality, show_edges=True,
                                    clip_planes=PLANE)
    choice = actor.cubemarch.quality
    assert choice.setting == {"traversal": "dda"} and choice.met
    assert choice.psnr >= 45.0, choice
    assert choice.traced > 1000 and choice.size == SIZE   # the window's own frame
    edge = pyvista.Color(pyvista.global_theme.edge_color).float_rgb
    measured = _whole_frame_psnr(plotter, actor, show_edges=True, edge_color=edge,
                                 line_width=1.1, shading="blinn",
                                 clip_planes=[((-95.0, 30.0, 12.0), (1.0, 0.3, -0.2))])
    assert measured >= 45.0
    plotter.close()


@pytest.mark.parametrize("quality", [40, "exact"])
def test_a_drawing_that_differs_from_the_reference_is_reported_as_missed(cells, quality,
                                                                          monkeypatch):
    # the report is a measurement, not a promise: a reference traced without the probe's
    # light (as a driver drawing wrong would differ) misses the target, with a warning,
    # 'exact' too
    # catches (seen failing): met set for any target; 'exact' met by promise (found by a
    # review: 15.7 dB reported as met)
    from pv_cubemarch.quality.voxels import VoxelCalibration
    monkeypatch.setattr(VoxelCalibration, "probe_lights", lambda self: [])
    plotter = offscreen_plotter(SIZE)
    with pytest.warns(UserWarning, match="no 'voxels' setting reaches"):
        actor = pv_cubemarch.add_voxels(plotter, cells, quality=quality)
    choice = actor.cubemarch.quality
    assert not choice.met and choice.psnr < 40.0
    plotter.close()


@pytest.mark.parametrize("size", [(201, 150), (161, 120)])
def test_the_report_is_the_window_s_own_and_its_first_frame_is_the_one_calibrated(
        cells, size):
    # odd window widths draw a few edge pixels apart from the reference: the report must
    # say the window's frame, and the first frame must not warn of another view
    # catches (seen failing, found by a review): a probe frame scaled to 160x120 (a view
    # other than the window's: 45.1 dB drawn where inf was reported, and a warning at the
    # first frame); the probe framed on the grid without the drawn box's margin (every
    # first frame warned that the view had changed)
    plotter, actor = _first_frame_unwarned(size, cells, quality=35, shading="unlit")
    model = actor.cubemarch.model
    expected = render_voxels(model.labels, model.world_from_index(), model.palette.rgba,
                             Camera.from_pyvista(plotter.camera), size,
                             background=plotter.background_color.float_rgb,
                             near=plotter.camera.clipping_range[0])
    measured = compare_images(read_pixels(plotter), expected).psnr
    choice = actor.cubemarch.quality
    assert abs(measured - choice.psnr) < 0.5 or min(measured, choice.psnr) > 60.0, (
        choice, measured)
    plotter.close()


@pytest.mark.parametrize("keywords", [
    {"chunk_size": 8},                                  # one traversal over the chunk index
    {"chunk_size": 8, "world_traversal": "per_chunk"},  # a box per chunk
    {"chunk_size": 6, "show_edges": True},              # per chunk: not a power of two
])
def test_a_world_s_drawing_is_measured_against_its_labels_traced_whole(cells, keywords):
    # The report and the first frame, against the reference of the test's own labels and
    # placement (by hand: spacing and origin), traced over the whole frame; the camera is
    # the one PyVista frames the world's actor with (none set).
    # catches (seen failing): the probe framed on a grid's margined box where a world drawn
    # per chunk stands as its bounds (the first frame warned of another view); the
    # reference given the world's labels mirrored (13.0 dB reported)
    plotter, actor = _first_frame_unwarned(SIZE, cells, quality="exact", shading="unlit",
                                           **keywords)
    ids = cells.cell_data["cell_id"].reshape(np.subtract(cells.dimensions, 1), order="F")
    expected = _by_hand(plotter, actor, ids, (0.6, 0.8, 1.1), (-100.0, 25.0, 5.0),
                        show_edges=bool(keywords.get("show_edges")), line_width=1.1,
                        edge_color=pyvista.Color(pyvista.global_theme.edge_color).float_rgb)
    _assert_met_as_measured(plotter, actor, expected, 0.5)


#: Two of the cells' three labels translucent (their faces composited), one opaque.
TRANSLUCENT = {1200: ("tomato", 0.4), 7000: "steelblue", 40000: ("gold", 0.6)}


@pytest.mark.parametrize("keywords", [
    {},
    {"chunk_size": 8},                                  # one traversal over the chunk index
    {"chunk_size": 8, "world_traversal": "per_chunk"},  # a box per chunk, layers per chunk
    {"clip_planes": PLANE},
])
@pytest.mark.slow   # long: its own CI step (pytest -m slow)
def test_translucent_labels_are_measured_against_the_layered_reference(cells, keywords):
    # The report and the first frame, lit by a headlight, against the layered reference
    # (every translucent face a ray crosses composited in depth order, no code shared with
    # the shaders) of the test's own labels and placement (by hand), the whole frame.
    # Measured: 65 dB. catches (seen failing): the opaque reference used for translucent
    # labels (27.2 dB reported, missed); the clip planes left out of the layered
    # reference's look (17.6 dB); translucent labels refused.
    plotter = headlit_plotter(SIZE)
    actor = pv_cubemarch.add_voxels(plotter, cells, quality="exact", palette=TRANSLUCENT,
                                    **keywords)
    render_frame(plotter)
    ids = cells.cell_data["cell_id"].reshape(np.subtract(cells.dimensions, 1), order="F")
    world_from_index = np.diag([0.6, 0.8, 1.1, 1.0])
    world_from_index[:3, 3] = (-100.0, 25.0, 5.0)
    lights = [VolumeLight.from_pyvista(light, plotter.camera)
              for light in plotter.renderer.GetLights()]
    planes = [((-95.0, 30.0, 12.0), (1.0, 0.3, -0.2))] if "clip_planes" in keywords else None
    expected = render_voxel_layers(ids, world_from_index, actor.cubemarch.palette.rgba,
                                   Camera.from_pyvista(plotter.camera), SIZE,
                                   background=plotter.background_color.float_rgb,
                                   near=plotter.camera.clipping_range[0], lights=lights,
                                   shading="blinn", clip_planes=planes)
    opaque = render_voxels(ids, world_from_index, actor.cubemarch.palette.rgba,
                           Camera.from_pyvista(plotter.camera), SIZE,
                           background=plotter.background_color.float_rgb,
                           near=plotter.camera.clipping_range[0], lights=lights,
                           shading="blinn", clip_planes=planes)
    assert compare_images(opaque, expected).psnr < 30.0   # the layers show
    _assert_met_as_measured(plotter, actor, expected, 1.0)


def test_a_world_s_report_follows_its_edits(cells):
    # recalibrate() after an edit measures the world as it is now (its labels read again)
    # catches (seen failing, found by a review): the labels read once at add_voxels (the
    # edited world reported at 16.9 dB, out of reach, while drawn exactly)
    plotter = offscreen_plotter(SIZE)
    plotter.ren_win.SetMultiSamples(0)
    plotter.camera_position = [(-130.0, 0.0, 40.0), cells.center, (0, 0, 1)]
    actor = pv_cubemarch.add_voxels(plotter, cells, quality="exact", shading="unlit",
                                    chunk_size=8)
    actor.cubemarch.fill_box((0, 0, 0), (28, 20, 7), 7000)   # the lower half one id
    plotter.camera.Azimuth(25.0)   # another view: no cached choice to fall back on
    choice = actor.cubemarch.recalibrate()
    render_frame(plotter)
    ids = cells.cell_data["cell_id"].reshape((28, 20, 14), order="F").copy()
    ids[:, :, :7] = 7000
    expected = _by_hand(plotter, actor, ids, (0.6, 0.8, 1.1), (-100.0, 25.0, 5.0))
    measured = compare_images(read_pixels(plotter), expected).psnr
    assert choice.met and measured >= 45.0, (choice, measured)
    plotter.close()


def test_a_small_grid_in_a_large_box_is_measured_from_its_first_frame_s_view():
    # 12 filled voxels of a 120x100x60 grid: its actor is the box of the filled voxels,
    # which PyVista frames; the report is that first frame's, and it does not warn
    # catches (seen failing, found by a review): the probe framed on the whole grid (the
    # first frame warned that the view had changed)
    ids = np.zeros((120, 100, 60), np.uint16)
    ids[60:63, 40:42, 30:32] = 40000
    grid = pyvista.ImageData(dimensions=(121, 101, 61), spacing=(0.3, 0.2, 0.5),
                             origin=(-5000.0, 300.0, -20.0))
    grid.cell_data["ids"] = ids.ravel(order="F")
    plotter, actor = _first_frame_unwarned(SIZE, grid, quality=40, shading="unlit")
    expected = _by_hand(plotter, actor, ids, (0.3, 0.2, 0.5), (-5000.0, 300.0, -20.0))
    assert np.any(expected != expected[0, 0], axis=-1).mean() > 0.05   # framed on it
    measured = compare_images(read_pixels(plotter), expected).psnr
    choice = actor.cubemarch.quality
    assert choice.met and (abs(measured - choice.psnr) < 0.5 or min(measured,
                                                                    choice.psnr) > 60.0)
    plotter.close()


def test_an_exact_measurement_is_served_from_the_cache():
    # a choice measured at infinite PSNR (drawn equal to the reference), written to the
    # cache file and read back from it (not from memory)
    # catches (seen failing, found by a review): an infinite PSNR read back as a bad
    # entry (every identical add calibrated again)
    from pv_cubemarch.quality import cache
    from pv_cubemarch.quality.calibration import QualityChoice
    from pv_cubemarch.quality.ladders import Rung
    from pv_cubemarch.quality.probe import stored_choice
    setting = {"traversal": "dda"}
    choice = QualityChoice(parse_quality("exact", exact=True), setting, float("inf"), True,
                           [{"setting": setting, "psnr": float("inf"), "cost": 1.0}], 0.1,
                           (240, 180), 100)
    cache.store("exact-key", choice.as_dict())
    cache._MEMORY.clear()
    read = stored_choice(cache.lookup("exact-key"), [[Rung(setting, 1.0)]],
                         parse_quality("exact", exact=True), (240, 180))
    assert read is not None and read.cached and read.psnr == float("inf") and read.met
    assert stored_choice({**choice.as_dict(), "psnr": float("-inf")}, [[Rung(setting, 1.0)]],
                         parse_quality("exact", exact=True), (240, 180)) is None


def test_a_world_too_large_to_trace_whole_is_refused_before_drawing(cells, monkeypatch):
    # catches (seen failing): the cap on the world's filled box not checked
    from pv_cubemarch.quality import voxels
    monkeypatch.setattr(voxels, "WORLD_REFERENCE_VOXELS", 1000)
    plotter = offscreen_plotter((80, 60))
    with pytest.raises(ValueError, match="over 1,000"):
        pv_cubemarch.add_voxels(plotter, cells, quality=40, chunk_size=8)
    assert not plotter.renderer.actors
    plotter.close()


@pytest.mark.parametrize("keywords, words", [
    ({"traversal": "fixed"}, "leave traversal, step_scale and lod out"),
    ({"lod": True}, "leave traversal, step_scale and lod out"),
    ({"mode": "id"}, "draws none"),
    ({"opacity": 0.5, "show_edges": True}, "draws no show_edges"),
    ({"chunk_size": 8, "opacity": 0.5, "ambient_occlusion": True}, "no ambient_occlusion"),
    ({"chunk_size": 8, "mode": "face"}, "draws none"),
    ({"quality": "perfect"}, "not a target"),
])
def test_what_voxel_quality_cannot_take_is_refused_by_name(cells, keywords, words):
    plotter = offscreen_plotter((80, 60))
    with pytest.raises(ValueError, match=words):
        pv_cubemarch.add_voxels(plotter, cells, **{"quality": "exact", **keywords})
    assert not plotter.renderer.actors
    plotter.close()


@pytest.mark.parametrize("budget", [-1, 0, float("inf"), True, "fast"])
@pytest.mark.parametrize("world", [{}, {"chunk_size": 8, "world_traversal": "per_chunk"}])
def test_a_voxel_budget_that_is_no_time_is_refused(cells, budget, world):
    # catches (seen failing): the check left out for a world (its chunks drawn per chunk
    # accept a budget: tests/test_voxel_world.py)
    plotter = offscreen_plotter((80, 60))
    with pytest.raises(ValueError, match="positive number of milliseconds"):
        pv_cubemarch.add_voxels(plotter, cells, frame_budget_ms=budget, **world)
    assert not plotter.renderer.actors
    plotter.close()


def test_the_cli_and_usd_ask_voxels_for_quality(cells, tmp_path, capsys):
    # catches (seen failing): --quality taken as no voxel option (refused with
    # --technique voxels); the USD attribute checked as a technique's option (the stage
    # refused)
    from conftest import write_voxel_stage

    from pv_cubemarch.cli import main
    path = tmp_path / "cells.vti"
    cells.save(path)
    out = tmp_path / "q.png"
    assert main(["render", str(path), "--technique", "voxels", "--quality", "exact",
                 "--size", "96x72", "--no-progress", "-o", str(out)]) == 0
    assert "does not apply" not in capsys.readouterr().err
    assert stored_settings() == [{"traversal": "dda"}]
    # a world, and its frame budget (catches (seen failing): --chunk-size with --quality
    # refused as a grid drawn in chunks)
    assert main(["render", str(path), "--technique", "voxels", "--quality", "40",
                 "--chunk-size", "8", "--frame-budget-ms", "30", "--size", "96x72",
                 "--no-progress", "-o", str(out)]) == 0
    assert stored_settings() == [{"traversal": "dda"}] * 2
    stage = write_voxel_stage(tmp_path, np.asarray(cells.cell_data["cell_id"]).reshape(
        (28, 20, 14), order="F"), attrs={"cubemarch:quality": ("String", "exact")})
    scene = pv_cubemarch.load_scene(stage, strict=True)
    (options,) = scene.voxel_options.values()
    assert options["quality"] == "exact"
    plotter = offscreen_plotter((96, 72))
    actors = scene.add_to(plotter)
    (actor,) = actors.values()
    assert actor.cubemarch.quality.met
    plotter.close()


def test_the_live_view_asks_voxels_for_quality(cells):
    from pv_cubemarch.views.app import quality_text
    from pv_cubemarch.views.session import TuningSession
    plotter = offscreen_plotter((96, 72))
    pv_cubemarch.add_voxels(plotter, cells, traversal="fixed", step_scale=0.25)
    session = TuningSession.from_plotter(plotter)
    assert "quality" in [knob.name for knob in session.knobs("voxels")]
    # catches (seen failing): the session's fixed traversal handed on with the quality
    session.set("voxels", "quality", "exact")
    assert "quality exact: traversal=dda" in quality_text(session)
    plotter.close()


def test_every_channel_gives_voxels_a_frame_budget(cells, tmp_path, capsys):
    # the CLI flag, the USD attribute and the live view's select reach add_voxels
    # catches (seen failing): the option left out of what add_voxels reads itself
    # (CALL_ONLY: the CLI refused the flag for voxels, exit 2)
    from conftest import write_voxel_stage

    from pv_cubemarch.cli import main
    from pv_cubemarch.views.session import TuningSession
    path = tmp_path / "cells.vti"
    cells.save(path)
    assert main(["render", str(path), "--technique", "voxels", "--frame-budget-ms", "30",
                 "--size", "96x72", "--no-progress", "-o", str(tmp_path / "b.png")]) == 0
    assert "does not apply" not in capsys.readouterr().err
    stage = write_voxel_stage(tmp_path, np.asarray(cells.cell_data["cell_id"]).reshape(
        (28, 20, 14), order="F"), attrs={"cubemarch:frameBudgetMs": ("Double", 30.0)})
    scene = pv_cubemarch.load_scene(stage, strict=True)
    plotter = offscreen_plotter((96, 72))
    (actor,) = scene.add_to(plotter).values()
    assert actor.cubemarch.frame_budget.budget_ms == 30.0
    plotter.close()
    plotter = offscreen_plotter((96, 72))
    pv_cubemarch.add_voxels(plotter, cells)
    session = TuningSession.from_plotter(plotter)
    assert "frame_budget_ms" in [knob.name for knob in session.knobs("voxels")]
    session.set("voxels", "frame_budget_ms", 33)
    assert session.actor(next(iter(session.items))).cubemarch.frame_budget.budget_ms == 33.0
    plotter.close()
