"""The live view's tuning session and app, without a browser (tests/browser drives one).

Each knob must change the drawing exactly as the same option given to the scene does; the
expected images are drawn by loading the scene with that option, not through the session.
"""

from __future__ import annotations

import asyncio
import importlib.util
import json
import os
import socket
import subprocess
import sys
import urllib.request
import warnings

import numpy as np
import PIL.Image
import pytest
import pyvista
from conftest import SCENE
from pyvista.jupyter.notebook import handle_plotter

import pv_cubemarch as cm
from pv_cubemarch.cli import main
from pv_cubemarch.views import live, notebook
from pv_cubemarch.views.app import build_app, state_name, window_mode
from pv_cubemarch.views.session import TuningSession, adoptable_actors

SIZE = (160, 120)


def scene_drawn(**options) -> np.ndarray:
    """The shipped scene with ``options`` set on its volume, drawn offscreen."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cm.SceneWarning)
        scene = cm.load_scene(SCENE)
    scene.volume_options[scene.volumes[0].name] = options
    return scene.render(size=SIZE).astype(int)


@pytest.fixture
def session(plotter_factory):
    return TuningSession(cm.load_scene(SCENE), plotter_factory(SIZE))


def test_a_knob_draws_as_the_same_option_does(session):
    # catches: a knob stored but not handed to add_volume (the frame unchanged), or the old
    # actor kept beside the new one.
    before = cm.render_image(session.plotter).astype(int)
    milliseconds = session.set("volume", "stop_opacity", 0.5)
    after = cm.render_image(session.plotter).astype(int)
    assert milliseconds > 0 and session.last_frame_ms == milliseconds
    assert np.abs(after - scene_drawn(stop_opacity=0.5)).max() <= 2
    assert np.abs(after - before).mean() > 0.3          # stop opacity 0.5 darkens the plume
    assert len([a for a in session.plotter.renderer.actors if "Smoke" in a]) == 1


def test_switching_technique_leaves_out_options_it_does_not_read(session):
    session.set("volume", "step_scale", 0.25)
    session.set("volume", "technique", "cubemap")      # step_scale is not a cube-map option
    image = cm.render_image(session.plotter).astype(int)
    assert np.abs(image - scene_drawn(technique="cubemap")).max() <= 2
    assert session.value("volume", "face_size") == 256   # the cube map's default, shown
    session.set("volume", "technique", "direct")        # and back: the step comes back
    assert np.abs(cm.render_image(session.plotter).astype(int)
                  - scene_drawn(technique="direct", step_scale=0.25)).max() <= 2


@pytest.mark.slow   # long (6-20 s): its own CI step (pytest -m slow)
def test_error_against_the_cpu_reference_grows_with_the_step(session):
    fine = session.reference_error()
    session.set("volume", "technique", "direct")
    session.set("volume", "step_scale", 2.0)
    session.set("volume", "stop_opacity", 0.6)
    coarse = session.reference_error()
    assert fine["mean_abs"] < 1.5 and coarse["mean_abs"] > fine["mean_abs"] + 0.2


def test_a_plotter_is_adopted_with_its_options(plotter_factory):
    pl = plotter_factory(SIZE)
    density = np.random.default_rng(0).random((8, 8, 8))
    cm.add_volume(pl, density, technique="direct", step_scale=0.3, name="cloud")
    labels = np.zeros((6, 6, 6), np.uint8)
    labels[1:4, 1:4, 1:4] = 2
    cm.add_voxels(pl, labels, traversal="fixed", name="blocks")
    x, y, z = np.mgrid[-1:1:10j, -1:1:10j, -1:1:10j]
    cm.add_surface(pl, x * x + y * y + z * z, isovalue=0.5, steps=80, name="ball")
    session = TuningSession.from_plotter(pl)
    assert session.kinds() == ["volume", "voxels", "surface"]
    assert session.value("volume", "step_scale") == pytest.approx(0.3)
    assert session.value("volume", "technique") == "direct"
    assert session.value("voxels", "traversal") == "fixed"
    assert session.value("surface", "steps") == 80


def test_isovalue_knob_moves_the_level(plotter_factory):
    # The field's level 0.5 moved by +0.1 is the field made at 0.6: B-splines sum to one,
    # so a constant shift of the coefficients shifts the field by it.
    pl = plotter_factory(SIZE)
    x, y, z = np.mgrid[-1:1:10j, -1:1:10j, -1:1:10j]
    samples = x * x + y * y + z * z
    cm.add_surface(pl, samples, isovalue=0.5, name="ball")
    session = TuningSession.from_plotter(pl)
    session.set("surface", "isovalue", 0.1)
    moved = pl.renderer.actors["ball"].cubemarch.model
    np.testing.assert_allclose(moved.coefficients,
                               cm.make_field(samples, 0.6).coefficients, atol=1e-12)


def test_a_surface_moved_after_a_knob_keeps_its_place_at_the_next(plotter_factory):
    # A knob re-adds the surface (add_surface copies its field); PyVista's call moves the
    # new actor; the next knob re-adds it where it was moved, not where it was first.
    # catches (found by a review, seen failing): the session's first copy re-added (the
    # surface jumped back: its transform the identity again).
    pl = plotter_factory(SIZE)
    x, y, z = np.mgrid[-1:1:10j, -1:1:10j, -1:1:10j]
    cm.add_surface(pl, x * x + y * y + z * z, isovalue=0.5, name="ball")
    session = TuningSession.from_plotter(pl)
    session.set("surface", "steps", 200)
    pl.renderer.actors["ball"].position = (0.0, 8.0, 0.0)
    cm.render_image(pl)
    session.set("surface", "steps", 100)
    session.set("surface", "isovalue", 0.1)
    moved = pl.renderer.actors["ball"].cubemarch.model.transform
    np.testing.assert_allclose(np.asarray(moved)[:3, 3], (0.0, 8.0, 0.0))


def test_the_app_binds_every_knob_of_the_scene():
    server, layout, session = build_app(SCENE, size=SIZE, name="test-views")
    try:
        for knob in session.knobs("volume"):
            assert server.state[state_name("volume", knob)] is not None
        assert server.state.frame_ms > 0
        server.controller.measure_error()
        assert server.state.error_text.startswith("error vs CPU reference: mean")
    finally:
        session.plotter.close()


def test_an_adopted_plotter_is_measured_on_its_own_background(plotter_factory):
    # catches: the reference drawn on the scene's default background (every pixel of a
    # black plotter then off by ~26/255)
    pl = plotter_factory(SIZE)
    pl.set_background("black")
    x, y, z = np.mgrid[-1:1:24j, -1:1:24j, -1:1:24j]
    cm.add_volume(pl, np.exp(-4 * (x * x + y * y + z * z)), cmap="inferno", technique="direct")
    errors = TuningSession.from_plotter(pl).reference_error()
    assert errors["mean_abs"] < 2.0


def test_a_refused_value_leaves_the_scene_as_it_was(session):
    # catches: a refused value kept in the options (every later change then failing too)
    before = cm.render_image(session.plotter).astype(int)
    with pytest.raises(ValueError, match="step_scale"):
        session.set("volume", "step_scale", -1.0)
    assert session.value("volume", "step_scale") == 0.5
    assert np.abs(cm.render_image(session.plotter).astype(int) - before).max() <= 1
    session.set("volume", "stop_opacity", 0.5)           # later changes still work
    assert session.value("volume", "stop_opacity") == 0.5


def test_an_adopted_surface_keeps_its_technique(plotter_factory):
    pl = plotter_factory(SIZE)
    x, y, z = np.mgrid[-1:1:10j, -1:1:10j, -1:1:10j]
    cm.add_surface(pl, x * x + y * y + z * z, isovalue=0.5, technique="full", name="ball")
    session = TuningSession.from_plotter(pl)
    session.set("surface", "steps", 120)
    assert pl.renderer.actors["ball"].cubemarch.cells is None       # still the full march


@pytest.mark.parametrize("opacity", [1.0, 0.5])
def test_surfaces_of_several_levels_are_drawn_as_they_are(plotter_factory, opacity):
    # the surface knobs tune one level: several levels (opaque: one surface each;
    # translucent: one pass) are not adopted, and a knob leaves them as they were
    # catches (seen failing): both adopted as their first level (a knob then drew one
    # translucent shell: 209 levels off; opaque levels crashed adoption before they had
    # options)
    pl = plotter_factory(SIZE)
    x, y, z = np.mgrid[-1:1:16j, -1:1:16j, -1:1:16j]
    cm.add_surface(pl, x * x + y * y + z * z, isosurfaces=[0.3, 0.8], name="shells",
                   opacity=opacity)
    cm.add_surface(pl, x * x + y * y + z * z, isovalue=0.5, name="ball", color="tan")
    before = cm.render_image(pl)
    session = TuningSession.from_plotter(pl)
    assert list(session.items) == ["ball"]
    session.set("surface", "steps", 500)   # the ball's own steps: nothing changes
    assert np.array_equal(cm.render_image(pl), before)


# --- plotter.show() in a notebook: PyVista's backends as pv_cubemarch wraps them ----------

def served_page(view) -> bytes:
    """The page the view's server answers with (the server runs on this loop's turns)."""
    async def fetch():
        loop = asyncio.get_running_loop()
        return await loop.run_in_executor(None, lambda: urllib.request.urlopen(
            view.url, timeout=10).read())
    return asyncio.get_event_loop().run_until_complete(fetch())


@pytest.fixture
def volume_plotter():
    pl = pyvista.Plotter(notebook=True, window_size=SIZE)
    x, y, z = np.mgrid[-1:1:24j, -1:1:24j, -1:1:24j]
    cm.add_volume(pl, np.exp(-4 * (x * x + y * y + z * z)), technique="direct")
    yield pl
    view = live._VIEWS.get(pl)
    if view is not None:
        view.close()
    pl.close()


def test_a_client_side_backend_shows_our_plotter_server_rendered(volume_plotter):
    # catches: the wrapper handing our plotter to vtk.js (no LiveView, no warning), or a
    # view whose server does not answer.
    with pytest.warns(UserWarning, match="vtk.js"):     # asked for in the call
        shown = handle_plotter(volume_plotter, backend="client")
    assert isinstance(shown, cm.LiveView) and shown.running
    assert b"trame" in served_page(shown)
    assert cm.live_view(volume_plotter) is shown        # shown again: the same server


def test_server_side_backends_show_our_plotter_without_a_warning(volume_plotter):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        shown = handle_plotter(volume_plotter, backend="trame")
    assert isinstance(shown, cm.LiveView)


#: A stand-in for trame-pyvista: entry points for the four trame names, and an import that
#: registers its own mode-bound handlers over them (as trame-pyvista's does).
FAKE_TRAME_PYVISTA = """
from pyvista import register_jupyter_backend
CALLS = []
def show(plotter, mode=None, **kwargs):
    CALLS.append(mode)
    return "fake"
def _bound(mode):
    def handler(plotter, **kwargs):
        kwargs.setdefault("mode", mode)
        return show(plotter, **kwargs)
    return handler
for _name in ("trame", "server", "client", "html"):
    register_jupyter_backend(_name, _bound(_name), override=True)
"""
SHOW_EACH_BACKEND = """
import json, sys
import numpy as np, pyvista as pv
if sys.argv[1] == "with":
    import pv_cubemarch
from pyvista.jupyter.notebook import handle_plotter
plain = pv.Plotter(notebook=True)
plain.add_mesh(pv.Sphere())
shown = [str(handle_plotter(plain, backend=name)) for name in
         (None, "client", "html", "server", "trame")]
import fake_tpv
ours = None
if sys.argv[1] == "with":
    ours = pv.Plotter(notebook=True)
    pv_cubemarch.add_volume(ours, np.random.default_rng(0).random((8, 8, 8)))
    ours = type(handle_plotter(ours)).__name__
print(json.dumps([fake_tpv.CALLS, shown, ours]))
"""


@pytest.mark.slow   # long (6-20 s): its own CI step (pytest -m slow)
def test_other_plotters_keep_trame_pyvistas_views(tmp_path):
    # catches: our registration replaced by trame-pyvista's import (our plotters then shown
    # by vtk.js), and plotters without our actors shown otherwise than without us (another
    # mode, our server, or a different auto choice). Expected: the same run without
    # importing pv_cubemarch.
    site = tmp_path / "site"
    (site / "fake_tpv-1.0.dist-info").mkdir(parents=True)
    (site / "fake_tpv.py").write_text(FAKE_TRAME_PYVISTA)
    (site / "fake_tpv-1.0.dist-info" / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: fake-tpv\nVersion: 1.0\n")
    (site / "fake_tpv-1.0.dist-info" / "entry_points.txt").write_text(
        "[pyvista.jupyter_backends]\n"
        + "".join(f"{name} = fake_tpv:show\n" for name in ("client", "html", "server", "trame")))
    script = tmp_path / "show.py"
    script.write_text(SHOW_EACH_BACKEND)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(site), os.environ.get(
        "PYTHONPATH", "")]))
    runs = {}
    for mode in ("without", "with"):
        done = subprocess.run([sys.executable, str(script), mode], capture_output=True,
                              text=True, env=env, timeout=300, cwd=tmp_path)
        assert done.returncode == 0, done.stderr[-2000:]
        runs[mode] = json.loads(done.stdout.strip().splitlines()[-1])
    calls, shown, ours = runs["with"]
    assert calls == runs["without"][0] and shown == runs["without"][1]
    assert len(calls) == 5 and ours == "LiveView"


def test_other_plotters_without_trame_pyvista_stay_static_images():
    # catches: every plotter given a server of ours once pv_cubemarch is imported
    pl = pyvista.Plotter(notebook=True, window_size=SIZE)
    pl.add_mesh(pyvista.Sphere())
    try:
        for name in (None, "client", "trame"):
            with pytest.warns(UserWarning, match="static image"):   # as PyVista warns
                assert isinstance(handle_plotter(pl, backend=name), PIL.Image.Image)
    finally:
        pl.close()


def test_static_backend_stays_an_image_of_our_rendering(volume_plotter):
    image = np.asarray(handle_plotter(volume_plotter, backend="static")).astype(int)
    assert image.shape[:2] == (SIZE[1], SIZE[0])
    expected = cm.render_image(volume_plotter).astype(int)[..., :3]
    assert np.abs(image[..., :3] - expected).max() <= 2 and expected.std() > 5


def test_the_backends_are_registered():
    names = {b.name: b.source for b in pyvista.registered_jupyter_backends()}
    for name in (*notebook.WRAPPED_BACKENDS, "cubemarch"):
        assert names[name].startswith("pv_cubemarch.views.notebook")


def test_hiding_a_voxel_material_draws_as_a_palette_without_it(plotter_factory):
    # catches: the materials knob not reaching the GPU palette (binding.set_material
    # skipped: the frame unchanged), or a hidden material not shown again. Expected: the
    # grid added with material 2 left out of a dict palette (materials left out are
    # hidden), drawn without the session.
    labels = np.zeros((6, 5, 4), np.uint8)
    labels[1:5, 1:4, 1:3] = 1
    labels[2:4, 2:4, 2:4] = 2
    labels[0, 0, 0] = 3
    palette = {1: "tomato", 2: "steelblue", 3: "gold"}
    pl = plotter_factory(SIZE)
    cm.add_voxels(pl, labels, palette=palette, name="blocks")
    pl.camera_position = "iso"
    session = TuningSession.from_plotter(pl)
    assert session.value("voxels", "materials") == [1, 2, 3]
    full = cm.render_image(pl).astype(int)
    session.set("voxels", "materials", [1, 3])
    expected_pl = plotter_factory(SIZE)
    cm.add_voxels(expected_pl, labels, palette={1: "tomato", 3: "gold"}, name="blocks")
    expected_pl.camera_position = "iso"
    assert np.abs(cm.render_image(pl).astype(int)
                  - cm.render_image(expected_pl).astype(int)).max() <= 1
    assert np.abs(cm.render_image(pl).astype(int) - full).max() > 50   # blue is gone
    session.set("voxels", "materials", [1, 2, 3])
    assert np.abs(cm.render_image(pl).astype(int) - full).max() <= 1
    with pytest.raises(ValueError, match="materials"):
        session.set("voxels", "materials", [9])


def test_unset_options_show_as_auto_and_can_be_set_back():
    # catches: an unset option shown as a made-up number, or "auto" not unsetting it
    view = cm.live_view(SCENE, size=SIZE)          # a running server: its state flushes
    state, session = view.server.state, view.session
    try:
        assert state["volume__max_samples"] == "auto"
        state["volume__technique"] = "cubemap"
        state.flush()
        state["volume__max_samples"] = 128
        state.flush()
        assert session.value("volume", "max_samples") == 128
        state["volume__max_samples"] = "auto"
        state.flush()
        assert session.value("volume", "max_samples") is None
        actor = session.plotter.renderer.actors[session.scene.volumes[0].name]
        assert actor.cubemarch.technique == "cubemap"
    finally:
        view.close()


def test_the_viewer_opens_a_window_only_where_a_display_exists(monkeypatch):
    # catches: a browser launched on a headless server, or none on a desktop
    monkeypatch.setattr(sys, "platform", "linux")
    assert window_mode("auto", {}) == "none"
    assert window_mode("auto", {"DISPLAY": ":0"}) == "browser"
    assert window_mode("browser", {}) == "browser"
    assert window_mode("none", {"DISPLAY": ":0"}) == "none"
    with pytest.raises(ValueError, match="window='tab'"):
        window_mode("tab")
    assert window_mode("auto", {"WAYLAND_DISPLAY": "wayland-0"}) == "browser"
    monkeypatch.setattr(importlib.util, "find_spec", lambda name: None)   # no pywebview
    with pytest.raises(ImportError, match="pip install pywebview"):
        window_mode("app", {"DISPLAY": ":0"})


def test_view_command_says_what_a_desktop_window_needs(capsys, monkeypatch):
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["view", "--window", "app"]) == 2
    error = capsys.readouterr().err
    assert "pywebview" in error or "display" in error


def test_closing_a_view_stops_its_server(volume_plotter):
    # catches: close() leaving the port served (a server per view never stopped)
    view = cm.live_view(volume_plotter, panel=False)
    assert b"trame" in served_page(view)
    port = view.server.port
    view.close()
    assert not view.running and "closed" in repr(view)
    with socket.socket() as sock:       # nothing listens there now (TIME_WAIT allowed)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(("127.0.0.1", port))
    assert cm.live_view(volume_plotter) is not view          # shown again: a new server


def test_a_view_displays_as_a_widget_and_as_html(volume_plotter):
    # catches: a view shown only as an ipywidget (a JupyterLab without the widget frontend
    # then shows its text form, no iframe), and a closed view displayed as if running
    view = cm.live_view(volume_plotter)
    bundle = view._repr_mimebundle_()
    assert "application/vnd.jupyter.widget-view+json" in bundle
    assert f'src="{view.url}"' in bundle["text/html"].replace("&amp;", "&")
    view.close()
    assert "text/html" not in view._repr_mimebundle_()


def test_the_panel_hides_voxel_materials(plotter_factory):
    # catches: the materials control not bound (its state missing) or its change not
    # reaching the session (the multiselect's values not typed back to materials)
    labels = np.zeros((4, 4, 4), np.uint8)
    labels[:2] = 1
    labels[2:] = 2
    pl = plotter_factory(SIZE)
    cm.add_voxels(pl, labels, name="blocks")
    view = cm.live_view(pl)
    state = view.server.state
    try:
        assert state["voxels__materials"] == [1, 2]
        assert state["voxels__mip_levels"] in ("auto", *range(13))   # adopted: as resolved
        state["voxels__materials"] = ["2"]                   # as a client may send it
        state.flush()
        assert view.session.value("voxels", "materials") == [2]
        assert not pl.renderer.actors["blocks"].cubemarch.model.palette.visible[1]
    finally:
        view.close()


def test_a_client_s_values_off_a_slider_or_past_the_labels_are_refused_in_brief(
        plotter_factory):
    # Found by a review: an isovalue shift of 1e308 (off the slider's track, which a
    # websocket client may send) was taken and emptied the surface; 200,000 unknown label
    # ids were echoed back to the page in a 1.4 MB message. catches (seen failing): the
    # range not checked (the shift taken), every unknown id listed.
    x = np.linspace(-1, 1, 16)
    field = np.sqrt(np.add.outer(np.add.outer(x**2, x**2), x**2))
    labels = np.zeros((4, 4, 4), np.uint8)
    labels[:2], labels[2:] = 1, 2
    pl = plotter_factory(SIZE)
    cm.add_surface(pl, field, isovalue=0.6, name="s")
    cm.add_voxels(pl, labels, name="v")
    view = cm.live_view(pl)
    state = view.server.state
    try:
        state["surface__isovalue"] = 1e308
        state.flush()
        assert "outside the slider's range" in state["message"], state["message"]
        assert view.session.value("surface", "isovalue") == 0.0
        state["voxels__materials"] = [str(i) for i in range(20000)]
        state.flush()
        assert "19,998 materials (0, 3, 4, 5, 6, ...)" in state["message"]
        assert len(state["message"]) < 200
        assert view.session.value("voxels", "materials") == [1, 2]
    finally:
        view.close()


def test_the_panel_shows_a_legend_of_label_ids_and_their_colours(plotter_factory):
    # catches (seen failing): the legend's state not refreshed when the labels knob hides
    # one (its entry still shown), colours read from palette rows other than the id's, and
    # ids past 2^53 sent as numbers (a browser rounds them). Expected colours: the test's
    # own hex values, given as the palette.
    ids = np.array([7, 2**40 + 3, 2**60 + 1], np.uint64)
    labels = np.zeros((6, 5, 4), np.uint64)
    labels[1:3], labels[3:5], labels[5] = ids
    colours = {int(ids[0]): "#ff0000", int(ids[1]): "#00ff80", int(ids[2]): "#102030"}
    pl = plotter_factory(SIZE)
    cm.add_voxels(pl, labels, palette=colours, name="cells")
    view = cm.live_view(pl)
    state = view.server.state
    try:
        legend = state["label_legend"]
        assert [e["id"] for e in legend] == [7, 2**40 + 3, str(2**60 + 1)]
        assert [e["color"] for e in legend] == list(colours.values())
        assert not any(e["hidden"] for e in legend)
        state["voxels__materials"] = [7, str(2**60 + 1)]
        state.flush()
        assert [e["hidden"] for e in state["label_legend"]] == [False, True, False]
    finally:
        view.close()


def test_the_technique_select_offers_auto_as_a_technique():
    # catches: "auto" read as an unset option for every knob (the volume technique 'auto'
    # then refused by the panel)
    view = cm.live_view(SCENE, size=SIZE)
    try:
        view.server.state["volume__technique"] = "auto"
        view.server.state.flush()
        assert view.session.value("volume", "technique") == "auto"
        assert view.session.actor(view.session.scene.volumes[0].name).cubemarch.technique \
            == "auto"
    finally:
        view.close()


def test_adoption_takes_each_technique_once_in_its_renderer(plotter_factory):
    # catches: an auto volume's direct half adopted as a second volume (a knob change then
    # adding a duplicate), a voxel world taken for a volume, and items of other renderers
    # left out or re-added into the active one
    pl = pyvista.Plotter(off_screen=True, window_size=SIZE, shape=(1, 2))
    try:
        x, y, z = np.mgrid[-1:1:8j, -1:1:8j, -1:1:8j]
        cm.add_volume(pl, np.exp(-(x * x + y * y + z * z)), technique="auto", name="vol")
        pl.subplot(0, 1)
        labels = np.zeros((24, 8, 8), np.uint8)
        labels[:, :4] = 1
        labels[::5, 4:] = 2
        cm.add_voxels(pl, labels, chunk_size=8, name="world")
        cm.render_image(pl)
        session = TuningSession.from_plotter(pl)
        assert {n: (i.kind, i.renderer) for n, i in session.items.items()} == {
            "vol": ("volume", 0), "world": ("voxels", 1)}
        assert session.value("volume", "technique") == "auto"
        session.set("volume", "stop_opacity", 0.9)
        session.set("voxels", "materials", [1])
        assert [name for name, _, _ in adoptable_actors(pl)] == ["vol", "world"]
        assert "vol" not in pl.renderers[1].actors and "world" not in pl.renderers[0].actors
        assert not pl.renderers[1].actors["world"].cubemarch.model.palette.visible[2]
    finally:
        pl.close()


def test_materials_over_several_grids_change_only_what_the_knob_moves(plotter_factory):
    # catches: the knob showing the first grid's materials only, and a change applying the
    # whole set to every grid (materials a grid shows the first lacks hidden by it)
    pl = plotter_factory(SIZE)
    small = np.zeros((4, 4, 4), np.uint8)
    small[:2] = 1
    large = np.zeros((4, 4, 4), np.uint8)
    large[:, :2] = 3
    large[:, 2:] = 4
    cm.add_voxels(pl, small, palette={1: "red"}, name="small")
    cm.add_voxels(pl, large, palette={3: "green", 4: "blue"}, name="large")
    session = TuningSession.from_plotter(pl)
    assert session.value("voxels", "materials") == [1, 3, 4]
    session.set("voxels", "materials", [1, 3])
    large_shown = pl.renderer.actors["large"].cubemarch.model.palette.visible
    assert large_shown[3] and not large_shown[4] and not large_shown[1]
    assert pl.renderer.actors["small"].cubemarch.model.palette.visible[1]


def test_showing_a_plotter_again_follows_its_actors(volume_plotter):
    # catches: a view kept after the plotter's actors changed (new items without knobs)
    first = cm.live_view(volume_plotter, panel=False)
    assert cm.live_view(volume_plotter) is first
    x, y, z = np.mgrid[-1:1:10j, -1:1:10j, -1:1:10j]
    cm.add_surface(volume_plotter, x * x + y * y + z * z, isovalue=0.5, name="ball")
    second = cm.live_view(volume_plotter)
    assert second is not first and not first.running
    assert second.session.kinds() == ["volume", "surface"]
    volume_plotter.close()
    with pytest.raises(ValueError, match="closed"):
        cm.live_view(volume_plotter)
    assert not second.running                          # reaped with its closed plotter


def test_adoption_of_chunk_worlds_shared_names_and_uneven_layouts():
    # catches: a per-chunk world's chunks adopted as grids of their own (each drawn twice
    # after a change), two volumes of one name in two renderers adopted as one, and
    # renderers of an uneven layout ("1|2") not made active for a re-add
    pl = pyvista.Plotter(off_screen=True, window_size=SIZE, shape="1|2")
    try:
        x, y, z = np.mgrid[-1:1:8j, -1:1:8j, -1:1:8j]
        for index in range(3):
            pl.subplot(index)
            cm.add_volume(pl, np.exp(-(x * x + y * y + z * z)), technique="direct",
                          name="volume")
        labels = np.zeros((24, 8, 8), np.uint8)
        labels[:, :4] = 1
        cm.add_voxels(pl, labels, chunk_size=8, world_traversal="per_chunk", name="world")
        cm.render_image(pl)
        session = TuningSession.from_plotter(pl)
        assert sorted(session.items) == ["volume (renderer 0)", "volume (renderer 1)",
                                         "volume (renderer 2)", "world"]
        actors = sum(len(r.actors) for r in pl.renderers)
        session.set("voxels", "traversal", "fixed")
        session.set("volume", "stop_opacity", 0.9)
        assert sum(len(r.actors) for r in pl.renderers) == actors
        assert pl.renderer is pl.renderers[2]             # the active one stays active
        assert session.holds_all_of(pl)
    finally:
        pl.close()


def test_a_refused_type_rolls_back_too(session):
    # catches: a value refused with TypeError (not ValueError) kept in the options, every
    # later change then failing the same way
    with pytest.raises(TypeError):
        session.set("volume", "lights", 3)
    assert session.value("volume", "lights") == "none"
    session.set("volume", "stop_opacity", 0.6)


def test_an_actor_replaced_under_its_name_gives_a_new_view(volume_plotter):
    # catches: a view kept after its actor was replaced (its next knob change putting the
    # old model back)
    first = cm.live_view(volume_plotter, panel=False)
    labels = np.zeros((4, 4, 4), np.uint8)
    labels[1:3] = 1
    name = next(iter(first.session.items))
    cm.add_voxels(volume_plotter, labels, name=name)
    second = cm.live_view(volume_plotter)
    assert second is not first and second.session.kinds() == ["voxels"]


def test_a_closed_view_leaves_trames_registries():
    # catches: closed servers (and the plotters their views hold) kept by trame by name
    view = cm.live_view(SCENE, size=SIZE)
    name = view.server.name
    view.close()
    assert all(name not in registry for registry in live.server_registries())
    assert len(live.server_registries()) == 2


def test_a_scenes_joint_volumes_are_one_item(plotter_factory):
    # catches: overlapping volumes (marched jointly as one actor) re-added one by one under
    # their own names beside the joint actor, which stayed: drawn twice after a change;
    # and the group recorded as 'vtk' (the scene's default) though drawn 'direct': every
    # knob then refused ("cannot march overlapping volumes jointly")
    shift = np.eye(4)
    shift[0, 3] = 8.0                                    # half a box along x: they overlap
    rng = np.random.default_rng(1)
    a = cm.make_volume(rng.random((16, 16, 16)), name="a")
    b = cm.make_volume(rng.random((16, 16, 16)), name="b", transform=shift)
    # its options name no technique: add_volumes drew the group 'direct' (vtk cannot)
    scene = cm.Scene(volumes=[a, b], volume_options={"a": {"step_scale": 0.5}})
    session = TuningSession(scene, plotter_factory(SIZE))
    assert [(i.kind, i.name) for i in session.items.values()] == [("volume", "a+b")]
    assert session.value("volume", "technique") == "direct"
    assert session.value("volume", "step_scale") == 0.5
    actors = len(session.plotter.renderer.actors)
    session.set("volume", "stop_opacity", 0.8)
    assert len(session.plotter.renderer.actors) == actors
    assert session.holds_all_of(session.plotter)


def test_blending_knob_adopts_and_switches_the_mode():
    """A volume added with ``blending='maximum'`` is adopted with it; the knob draws the
    other mode exactly as adding the volume with it does.

    catches: adoption leaving ``blending`` out (the knob reads 'composite').
    """
    from pyvista import examples

    def image_of(**options):
        pl = pyvista.Plotter(off_screen=True, window_size=(120, 90))
        pl.cubemarch.add_volume(examples.load_uniform(), **options)
        image = cm.render_image(pl)
        return pl, image

    pl, projected = image_of(blending="maximum")
    session = TuningSession(None, pl)
    assert session.value("volume", "blending") == "maximum"
    session.set("volume", "blending", "composite")
    switched = cm.render_image(pl)
    pl.close()
    fresh, composite = image_of()
    fresh.close()
    assert np.abs(switched.astype(int) - composite).max() <= 1
    assert np.abs(projected.astype(int) - composite).max() > 20


def test_channel_and_surface_opacity_knobs_draw_as_their_options_do(tmp_path,
                                                                    plotter_factory):
    # The channels knob re-mixes a channel volume loaded from a grid file; the surface's
    # opacity knob makes it translucent. Each frame against the scene drawn with the option
    # given when it is added. catches: channel_blending stored but not handed to add_volume
    # for a made channel volume (the composite frame kept).
    grid = pyvista.ImageData(dimensions=(12, 10, 8), spacing=(1.0, 1.2, 0.8))
    p = grid.points
    grid["ch"] = np.column_stack([p[:, 0] * 10.0, 100.0 - p[:, 1] * 5.0]).astype(np.float32)
    path = tmp_path / "two.vti"
    grid.save(path)
    session = TuningSession(cm.load_scene(path), plotter_factory(SIZE))
    before = cm.render_image(session.plotter).astype(int)
    session.set("volume", "channel_blending", "additive")
    after = cm.render_image(session.plotter).astype(int)
    scene = cm.load_scene(path)
    scene.volume_options[scene.volumes[0].name] = {"channel_blending": "additive"}
    assert np.abs(after - scene.render(size=SIZE).astype(int)).max() <= 2
    assert np.abs(after - before).mean() > 1.0
    pl = plotter_factory(SIZE)
    x, y, z = np.mgrid[-1:1:10j, -1:1:10j, -1:1:10j]
    cm.add_surface(pl, x * x + y * y + z * z, isovalue=0.5, name="ball")
    session = TuningSession.from_plotter(pl)
    session.set("surface", "opacity", 0.4)
    assert pl.renderer.actors["ball"].cubemarch.options.opacity == 0.4
    drawn = cm.render_image(pl).astype(int)
    expected = plotter_factory(SIZE)
    cm.add_surface(expected, x * x + y * y + z * z, isovalue=0.5, opacity=0.4, name="ball")
    expected.camera_position = pl.camera_position
    assert np.abs(drawn - cm.render_image(expected).astype(int)).max() <= 2
