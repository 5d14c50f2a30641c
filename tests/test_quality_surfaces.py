"""``add_surface(..., quality=, frame_budget_ms=)``: the chosen steps meet their target
against the CPU reference over the whole frame and are the fewest that do; 'exact' draws
the exact root; refusals; the budget's steps; the CLI, USD and live-view channels.

Samples in millimetres around an isovalue of 250 (not 0), on a non-cubic, anisotropic
grid far from the origin, with sheets thinner than a cell in places. The oracle is the
CPU reference traced over the whole frame at the camera, near plane, background and
light the plotter really has; it imports nothing of the renderer.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import pyvista
from conftest import headlit_plotter, stored_settings
from scipy.spatial.transform import Rotation

import pv_cubemarch
from pv_cubemarch.core.camera import Camera
from pv_cubemarch.core.rendering import read_pixels, render_frame
from pv_cubemarch.image_metrics import compare_images
from pv_cubemarch.models.lights import VolumeLight
from pv_cubemarch.quality.calibration import MARGIN_DB
from pv_cubemarch.reference.surfaces import render_surface

SIZE = (200, 150)
ISOVALUE = 250.0


@pytest.fixture(autouse=True)
def _own_cache(quality_cache):
    """Every test calibrates afresh, in a cache folder of its own."""


@pytest.fixture(scope="module")
def sheets():
    shape = (40, 32, 24)
    i, j, k = np.meshgrid(*(np.linspace(-1.0, 1.0, n) for n in shape), indexing="ij")
    millimetres = ISOVALUE + 1000.0 * (0.04 - np.abs(0.6 * np.sin(5 * i + 2 * j) - k)
                                        + 0.03 * np.cos(7 * j))
    grid = pyvista.ImageData(dimensions=shape, spacing=(0.5, 0.7, 0.9),
                             origin=(-300.0, 40.0, 1000.0))
    grid.point_data["mm"] = millimetres.ravel(order="F")
    return grid


def _whole_frame_psnr(plotter, actor) -> float:
    """The drawn frame against the reference traced over every pixel."""
    render_frame(plotter)
    lights = [VolumeLight.from_pyvista(light, plotter.camera)
              for light in plotter.renderer.GetLights()]
    expected = render_surface(
        actor.cubemarch.model, Camera.from_pyvista(plotter.camera), SIZE,
        color=pyvista.Color("tan").float_rgb, background=plotter.background_color.float_rgb,
        near=plotter.camera.clipping_range[0], lights=lights, shading="blinn")
    return compare_images(read_pixels(plotter), expected).psnr


def _drawn(sheets, **keywords):
    plotter = headlit_plotter(SIZE)
    actor = pv_cubemarch.add_surface(plotter, sheets, isovalue=ISOVALUE, color="tan",
                                     **keywords)
    return plotter, actor


@pytest.mark.parametrize("target", [30.0, 40.0])
@pytest.mark.slow   # long: its own CI step (pytest -m slow)
def test_the_chosen_steps_meet_the_target_and_half_of_them_do_not(sheets, target):
    # catches (seen failing): the reference traced unlit against the lit probe (no rung
    # met 30 dB: 22 dB); the probe framed on the domain without the drawn box's margin
    # (another camera than the first frame's: the estimate 3.1 dB off the frame drawn);
    # a sample of 4096 pixels (a thin sheet's few wrong pixels seen by chance: 1.3 dB off)
    plotter, actor = _drawn(sheets, quality=target)
    choice = actor.cubemarch.quality
    steps = choice.setting["steps"]
    assert choice.met and actor.cubemarch.options.steps == steps
    measured = _whole_frame_psnr(plotter, actor)
    assert measured >= target, (choice, measured)
    assert abs(measured - choice.psnr) < 1.0, (choice, measured)
    plotter.close()
    # the fewest: the rung below (half the steps) misses the target and the margin the
    # calibration aims past it over the whole frame (measured at 30 dB: 200 steps 30.3 dB)
    plotter, actor = _drawn(sheets, steps=steps // 2)
    assert _whole_frame_psnr(plotter, actor) < target + MARGIN_DB
    plotter.close()


@pytest.mark.parametrize("rotated", [False, True])
@pytest.mark.parametrize("keywords", [{}, {"traversal": "cell_boxes"}, {"technique": "full"}])
def test_a_fresh_plotter_s_first_frame_is_the_view_calibrated_for(sheets, keywords, rotated):
    # The calibration predicts the camera PyVista frames the returned actor with (the
    # theme's isometric view of its bounds): the first frame draws that view, so it does
    # not warn that the view has changed. Rotated: a ball on a grid of a turned
    # direction_matrix under a turning user_matrix (the actor's bounds are the box of its
    # corners' box in the data's frame). catches (seen failing; found by reviews): the
    # drawn box predicted 1 % of the grid larger than the actor's exact corners and past
    # the points' hull (unrotated, each way of drawing); the cell boxes' box predicted, not
    # their corners' (rotated, cell_boxes).
    grid, more = sheets, {"isovalue": ISOVALUE}
    if rotated:
        grid = pyvista.ImageData(dimensions=(10, 9, 8), spacing=(1.0, 1.2, 0.9),
                                 origin=(2.0, -3.0, 7.0))
        turn = Rotation.from_euler("xyz", [30, 20, 50], degrees=True).as_matrix()
        grid.direction_matrix = turn
        grid.point_data["f"] = np.linalg.norm(grid.points - (3.0, 0.0, 9.0), axis=1)
        placed = np.eye(4)
        placed[:3, :3] = Rotation.from_euler("z", 35, degrees=True).as_matrix()
        placed[:3, 3] = (1.0, 2.0, 3.0)
        more = {"isovalue": 4.0, "user_matrix": placed}
    plotter = pyvista.Plotter(off_screen=True, window_size=SIZE)
    actor = pv_cubemarch.add_surface(plotter, grid, quality=30, **keywords, **more)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        pv_cubemarch.render_image(plotter)
    assert not [w for w in said if "calibrated for the view" in str(w.message)]
    assert actor.cubemarch.quality.met
    plotter.close()


def test_exact_draws_each_cell_s_first_root(sheets):
    # catches (seen failing): the choice not applied (root='march' drawn); 'exact'
    # reported as out of reach (no estimate is infinite)
    plotter, actor = _drawn(sheets, quality="exact")
    choice = actor.cubemarch.quality
    assert choice.setting == {"root": "exact"} and choice.met
    assert actor.cubemarch.options.root == "exact"
    assert _whole_frame_psnr(plotter, actor) > 60.0
    assert "root=exact" in str(choice)
    plotter.close()


@pytest.mark.parametrize("keywords, words", [
    ({"quality": 40, "steps": 100}, "chooses steps itself"),
    ({"quality": "exact", "root": "march"}, "chooses root itself"),
    ({"quality": "exact", "opacity": 0.5}, "give it a PSNR target"),
    ({"quality": 40, "shading": "normals"}, "no shading='normals'"),
    ({"quality": "exact", "technique": "full"}, "technique='active'"),
    ({"quality": "superb"}, "not a target"),
    ({"quality": 75}, "out of range"),
    ({"frame_budget_ms": 30, "root": "exact"}, "has none"),
    ({"frame_budget_ms": 30, "quality": " Exact"}, "has none"),
    ({"frame_budget_ms": 0}, "positive"),
])
def test_what_surface_calibration_cannot_measure_is_refused_by_name(sheets, keywords, words):
    plotter = headlit_plotter(SIZE)
    keywords = {"color": "tan", **keywords}
    with pytest.raises(ValueError, match=words):
        pv_cubemarch.add_surface(plotter, sheets, isovalue=ISOVALUE, **keywords)
    assert not plotter.renderer.actors
    plotter.close()


#: Several levels of the sheets' field (millimetres) and how the test colours them by hand.
LEVELS = (200.0, 250.0, 300.0)


def _viridis(fractions) -> np.ndarray:
    """Viridis at ``fractions`` of its range, as a 256-entry table gives it (by hand).

    VTK's tables hold bytes, each colour truncated: matplotlib's floats unrounded are up to
    a level off, which lit curvature colours turn into a 60.7 dB floor.
    """
    import matplotlib

    entries = np.floor(np.asarray(fractions, float) * 255.0 + 0.5) / 255.0
    return np.floor(np.asarray(matplotlib.colormaps["viridis"](entries))[:, :3] * 255.0) / 255.0


def _whole_frame_psnr_of(plotter, field, **look) -> float:
    """The drawn frame against the reference of ``field`` (its zero) with ``look``."""
    render_frame(plotter)
    lights = [VolumeLight.from_pyvista(light, plotter.camera)
              for light in plotter.renderer.GetLights()]
    expected = render_surface(field, Camera.from_pyvista(plotter.camera), SIZE,
                              background=plotter.background_color.float_rgb,
                              near=plotter.camera.clipping_range[0], lights=lights,
                              shading="blinn", **look)
    return compare_images(read_pixels(plotter), expected).psnr


# long (2-5 s a case): their own CI step (-m slow)
@pytest.mark.parametrize("case", ["levels", "levels exact", "translucent levels",
                                  "translucent", "curvature", "cut, lit terms"])
@pytest.mark.slow   # long: its own CI step (pytest -m slow)
def test_levels_translucency_and_colour_maps_meet_their_target(sheets, case):
    # Levels coloured by viridis over their own range (by hand: its first, middle and last
    # entries), translucent ones composited, a colour map over a given clim: the frame
    # drawn against the reference traced over every pixel with those colours.
    # catches (seen failing): the probe drawing the levels without their colours (no rung
    # met: 9.5 dB, every level white); the reference given the model's zero only (9.4 dB);
    # "cut, lit terms": the calibration's reference without the clip planes or diffuse
    # (found by a review: 13.7 dB reported, the fallback to root='exact', not met)
    plotter = headlit_plotter(SIZE)
    colours = _viridis([0.0, 0.5, 1.0])
    target, keywords, look = 40.0, {}, {}
    field_of = LEVELS[0]
    if "levels" in case:
        keywords = {"isosurfaces": list(LEVELS)}
        look = {"levels": [v - LEVELS[0] for v in LEVELS], "level_colors": colours}
    else:
        keywords, field_of = {"isovalue": ISOVALUE, "color": "tan"}, ISOVALUE
        look = {"color": pyvista.Color("tan").float_rgb}
    if "translucent" in case:
        keywords["opacity"] = look["opacity"] = 0.5
    if case == "levels exact":
        target = "exact"
    if case == "cut, lit terms":
        centre = np.asarray(sheets.center)
        plane = (*centre, -1.0, -0.3, 0.2)
        keywords.update(clip_planes=plane, ambient=0.4, diffuse=0.5)
        look.update(clip_planes=[(plane[:3], plane[3:])], ambient=0.4, diffuse=0.5)
    if case == "curvature":
        clim = (-0.05, 0.05)
        keywords.update(color_by="curvature", clim=clim)
        look.update(color_by="curvature", clim=clim,
                    lookup_table=_viridis(np.arange(256) / 255.0))
    actor = pv_cubemarch.add_surface(plotter, sheets, quality=target, **keywords)
    choice = actor.cubemarch.quality
    assert choice.met, choice
    field = pv_cubemarch.models.field_sources.make_field(sheets, field_of)
    measured = _whole_frame_psnr_of(plotter, field, **look)
    floor = 60.0 if target == "exact" else target
    assert measured >= floor, (choice, measured)
    if target != "exact":
        assert abs(measured - choice.psnr) < 1.5, (choice, measured)
    plotter.close()


def test_a_budget_moves_every_level_s_steps_and_pixels(sheets):
    # several opaque levels: the knob's value reaches each level, drawn reduced by each
    # catches (seen failing): the steps set on the first level only ([400, 100, 100])
    plotter = headlit_plotter(SIZE)
    actor = pv_cubemarch.add_surface(plotter, sheets, isosurfaces=list(LEVELS), steps=100,
                                     frame_budget_ms=30.0)
    budget = actor.cubemarch.frame_budget
    budget.knob.write(actor.cubemarch, 25.0)   # 100 steps at 1/2 size
    assert [level.options.steps for level in actor.cubemarch.levels] == [100] * 3
    assert [level.reduced.factor for level in actor.cubemarch.levels] == [2] * 3
    budget.knob.write(actor.cubemarch, 400.0)
    assert [level.options.steps for level in actor.cubemarch.levels] == [400] * 3
    assert [level.reduced.factor for level in actor.cubemarch.levels] == [1] * 3
    plotter.close()


def test_moving_frames_march_fewer_steps_and_a_still_view_draws_all_of_them(sheets):
    # frame times from a scripted clock (ms = steps / 10): a 30 ms budget fits 240 steps,
    # so moving frames draw 200 (the ladder's next below), and the still one 800 again,
    # pixel for pixel what those steps draw when asked for
    # catches (seen failing): the steps' uniform not written (moving frames drew 800),
    # the cost read as falling with the steps (frames over budget took more)
    from pv_cubemarch.quality.interaction import attach_frame_budget
    plotter, actor = _drawn(sheets, steps=800)
    state = {"t": 0.0, "calls": 0}

    def clock():
        state["calls"] += 1
        if state["calls"] % 2 == 0:
            state["t"] += budget.value / 10.0 / 1e3
        return state["t"]
    budget = attach_frame_budget(actor.cubemarch, "active", plotter.ren_win, 30.0,
                                 clock=clock)
    render_frame(plotter)
    still = read_pixels(plotter)
    plotter.ren_win.SetDesiredUpdateRate(15.0)
    for _ in range(4):
        plotter.camera.Azimuth(0.0)
        render_frame(plotter)
    moving = [f for f in budget.frames if f.moving]
    assert moving[-1].value == 200.0 and all(f.ms <= 30.0 for f in moving[1:])
    coarse = read_pixels(plotter)
    plotter.ren_win.SetDesiredUpdateRate(0.0001)
    render_frame(plotter)
    assert budget.frames[-1].value == 800.0
    assert np.array_equal(read_pixels(plotter), still)
    plotter.close()
    other, _ = _drawn(sheets, steps=200)
    render_frame(other)
    assert np.array_equal(read_pixels(other), coarse)
    assert not np.array_equal(coarse, still)
    other.close()


def test_add_surface_takes_a_budget_with_the_quality_s_estimates(sheets):
    plotter, actor = _drawn(sheets, quality=40, frame_budget_ms=25)
    budget, choice = actor.cubemarch.frame_budget, actor.cubemarch.quality
    assert budget.still == choice.setting["steps"]
    assert budget.estimated_psnr == choice.psnr
    plotter.close()


@pytest.mark.slow   # long: its own CI step (pytest -m slow)
def test_recalibrating_gives_the_budget_this_view_s_estimates(sheets):
    # catches (seen failing, found by a review): recalibrate() moving the still steps but
    # leaving the budget the old view's estimates (the live view's moving-frame PSNR)
    plotter, actor = _drawn(sheets, quality=40, frame_budget_ms=25)
    render_frame(plotter)
    plotter.camera.Zoom(2.5)
    choice = actor.cubemarch.recalibrate()
    budget = actor.cubemarch.frame_budget
    assert budget.errors == {float(m["setting"]["steps"]): m["psnr"]
                             for m in choice.measured}
    assert budget.still == choice.setting["steps"]
    plotter.close()


def test_the_cli_flag_reaches_a_surface_and_draws_its_choice(sheets, tmp_path, capsys):
    # --quality is a volume's and a surface's flag: it reaches add_surface, and the image
    # is what the chosen steps draw
    # catches (seen failing): the flag kept from the surfaces' options (drawn at the
    # default steps, nothing calibrated)
    from PIL import Image

    from pv_cubemarch.cli import main
    path = tmp_path / "sheets.vti"
    sheets.save(path)
    common = ["render", str(path), "--isovalue", str(ISOVALUE), "--size", "120x90",
              "--no-progress"]
    out = tmp_path / "q.png"
    assert main([*common, "--quality", "35", "-o", str(out)]) == 0
    (setting,) = stored_settings()
    again = tmp_path / "s.png"
    assert main([*common, "--steps", str(setting["steps"]), "-o", str(again)]) == 0
    assert np.array_equal(np.asarray(Image.open(out)), np.asarray(Image.open(again)))
    capsys.readouterr()


def test_the_live_view_asks_a_surface_for_quality_and_a_step_by_hand_drops_it(sheets):
    # catches (seen failing): the session's own steps handed to add_surface with the
    # quality (refused: "chooses steps, root itself")
    from pv_cubemarch.views.app import quality_text
    from pv_cubemarch.views.session import TuningSession
    plotter, _ = _drawn(sheets, steps=100)
    session = TuningSession.from_plotter(plotter)
    names = [knob.name for knob in session.knobs("surface")]
    assert "quality" in names and "frame_budget_ms" in names
    session.set("surface", "quality", "exact")
    assert "quality exact: root=exact" in quality_text(session)
    session.set("surface", "steps", 300)
    assert session.actor(next(iter(session.items))).cubemarch.quality is None
    assert session.value("surface", "steps") == 300
    plotter.close()


def test_a_usd_attribute_asks_a_surface_for_quality_from_the_scene_camera(tmp_path, seen):
    # catches (seen failing): the surface prim's options checked with quality among them
    # (the stage refused as "quality is not an option of technique='active'"); the
    # scene's camera applied after the surfaces were added (calibrated on another view)
    from conftest import write_voxel_stage

    p = np.indices((16, 16, 16)).reshape(3, -1).T.astype(float)
    ball = (5.0 - np.linalg.norm(p - 7.5, axis=1)).reshape(16, 16, 16)
    path = write_voxel_stage(tmp_path, ball, technique="surface", attrs={
        "cubemarch:isovalue": ("Float", 0.0), "cubemarch:quality": ("String", "balanced")},
        eye=(20.0, 14.0, 19.0), target=(8.0, 6.0, 7.5), stage_name="q.usda")
    scene = pv_cubemarch.load_scene(path, strict=True)
    (name,) = scene.surface_options
    assert scene.surface_options[name]["quality"] == "balanced"
    assert scene.render(size=(80, 60)).std() > 3
    (camera,) = seen
    assert np.allclose(camera.position, scene.camera.position)
    (setting,) = stored_settings()
    assert set(setting) == {"steps"}


def test_the_ladder_tops_with_the_exact_root_and_a_choice_switches_the_root(sheets):
    # the exact root tops 'active''s ladder (it costs what 1600-3200 steps cost and
    # misses nothing), not with a frame budget (which needs steps to move); a choice
    # applied to a drawn surface switches the root finder in or out, drawing what those
    # settings draw when asked for
    # catches (seen failing): the root finder left as built when another is applied (the
    # image stayed the march's)
    from pv_cubemarch.quality.surfaces import SurfaceCalibration, surface_tracks
    from pv_cubemarch.quality.targets import parse_quality
    from pv_cubemarch.surfaces.options import SurfaceOptions
    (ladder,) = surface_tracks(SurfaceOptions(), (40, 32, 24), parse_quality(40))
    assert ladder[-1].setting == {"root": "exact"}
    assert [r.setting["steps"] for r in ladder[:-1]] == [25, 50, 100, 200, 400, 800, 1600]
    (marched,) = surface_tracks(SurfaceOptions(), (40, 32, 24), parse_quality(40),
                                exact_rung=False)
    assert all("steps" in r.setting for r in marched) and marched[-1].setting["steps"] > 1600
    plotter, actor = _drawn(sheets, steps=200)
    calibration = SurfaceCalibration(actor.cubemarch.model, "active", None, {}, None, None)
    for setting in ({"root": "exact"}, {"steps": 800}):
        calibration.apply(actor.cubemarch, setting)
        render_frame(plotter)
        other, _ = _drawn(sheets, **setting)
        render_frame(other)
        assert np.array_equal(read_pixels(plotter), read_pixels(other)), setting
        other.close()
    plotter.close()
