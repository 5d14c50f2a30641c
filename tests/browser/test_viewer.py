"""The live viewer in a real browser: Debian's chromium driven by Playwright.

`pv-cubemarch view` serves the shipped smoke scene on localhost; the test waits for the
first streamed frame and compares it with `render_image` of the same scene and camera
(the stream is JPEG: mean difference under 2/255 and 99th percentile under 12, while the
stop-opacity change below is several times that), moves the stop-opacity slider with the
keyboard and checks the frame changed as the same setting does offscreen, switches the
technique with the select (the server then says it draws a cube map), and always stops
the server. Then `plotter.show()` in a Jupyter kernel (nbclient) under the client backend:
its view must be our server's frame, turn and zoom with the mouse, and follow a knob set
from code. Run apart from the default tests: `pytest tests/browser`.
"""

from __future__ import annotations

import contextlib
import os
import re
import sys
import time
import warnings
from pathlib import Path

import nbclient
import nbformat
import numpy as np
from browsing import (
    SHOW_CELL,
    SHOWN_SIZE,
    close,
    free_port,
    keep_screenshot,
    launch,
    serving,
    settled_frame,
    shown_offscreen,
    watch_outside,
)
from playwright.sync_api import sync_playwright

import pv_cubemarch as cm
from pv_cubemarch.views.session import TuningSession

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "datasets" / "smoke_scene.usda"
SIZE = (480, 360)


@contextlib.contextmanager
def served(tmp_path, window: str = "none", **environ):
    """``pv-cubemarch view --window window`` on a free port (``environ`` added to its
    environment); yields its URL; always stops it."""
    port = free_port()
    url = f"http://127.0.0.1:{port}/"
    command = [sys.executable, "-m", "pv_cubemarch.cli", "view", str(SCENE), "--port",
               str(port), "--window", window, "--size", f"{SIZE[0]}x{SIZE[1]}"]
    env = dict(os.environ, VTK_WASM_DIR_OVERRIDE=str(tmp_path), **environ)
    with serving(command, tmp_path / "server.log", url + "index.html", env):
        # the page connects only with the server's secret, printed in the URL it serves
        printed = re.search(r"pv-cubemarch view: (http://\S+)",
                            (tmp_path / "server.log").read_text())
        assert printed and "secret=" in printed.group(1), (tmp_path / "server.log").read_text()
        yield printed.group(1)


def offscreen(**settings) -> np.ndarray:
    """The same scene and camera drawn offscreen with the volume knobs ``settings``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plotter = cm.offscreen_plotter(SIZE)
    try:
        session = TuningSession(cm.load_scene(SCENE), plotter)
        for name, value in settings.items():
            session.set("volume", name, value)
        return cm.render_image(plotter).astype(int)
    finally:
        plotter.close()


def test_viewer_streams_our_rendering_and_its_knobs_change_it(tmp_path):
    with served(tmp_path) as url, sync_playwright() as driver:
        browser = launch(driver)
        try:
            page = browser.new_page(viewport={"width": 1200, "height": 800},
                                    device_scale_factor=1)
            outside = watch_outside(page)
            page.goto(url)
            src, first = settled_frame(page, SIZE)
            assert close(first, offscreen()), "the first frame is not our rendering"
            assert first.std() > 5                   # not a blank background
            page.wait_for_function("() => window.trame && window.trame.state")
            # the stop-opacity slider to its lowest, 0.5 (rays end early: darker where
            # dense), by the keyboard on the slider's thumb, as a user would
            thumb = page.locator("#knob-volume-stop_opacity").locator(
                "xpath=ancestor::div[contains(@class,'v-slider')][1]").locator(
                ".v-slider-thumb[role=slider]").first
            thumb.focus()
            thumb.press("Home")
            page.wait_for_function(
                "() => window.trame.state.get('volume__stop_opacity') <= 0.5")
            src, early = settled_frame(page, SIZE, src)
            assert not close(early, first), "the slider did not change the frame"
            assert close(early, offscreen(stop_opacity=0.5))
            # the technique select: the cube map
            page.locator(".v-select", has=page.locator("#knob-volume-technique")).locator(
                ".v-field").first.click()
            page.locator(".v-overlay-container .v-list-item", has_text="cubemap").click()
            page.wait_for_function(
                "() => window.trame.state.get('volume__technique') === 'cubemap'")
            page.wait_for_function(   # the server's own account of what its actor draws
                "() => (window.trame.state.get('drawn') || '').includes('cubemap')")
            src, cubemap = settled_frame(page, SIZE, src)
            assert close(cubemap, offscreen(stop_opacity=0.5, technique="cubemap"))
            keep_screenshot(page, tmp_path, "viewer.png")
            assert not outside, f"the page reached beyond localhost: {outside}"
        finally:
            browser.close()


def test_plotter_show_in_a_notebook_streams_our_rendering(tmp_path):
    # catches: plotter.show() under a client-side backend drawing with vtk.js (the
    # iframe would not be our server's, or its frame the volume's box), and a view that
    # does not turn with the mouse.
    book = nbformat.v4.new_notebook()
    book.cells.append(nbformat.v4.new_code_cell(SHOW_CELL))
    book.cells.append(nbformat.v4.new_code_cell(
        "print([list(v) for v in plotter.camera_position])"))
    client = nbclient.NotebookClient(book, timeout=240, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    with client.setup_kernel(), sync_playwright() as driver:
        client.execute_cell(book.cells[0], 0)
        client.execute_cell(book.cells[1], 1)
        camera = eval(book.cells[1].outputs[0]["text"])     # noqa: S307 (our own print)
        outputs = str(book.cells[0].outputs)
        assert "vtk.js" in outputs                          # the client backend's warning
        # the text/html iframe (text/plain shows the same widget cut short, without its secret)
        url = next(u for u in re.findall(r'src="(http://localhost:\d+/[^"]*)"', outputs)
                   if "secret=" in u).replace("&amp;", "&")
        browser = launch(driver)
        try:
            page = browser.new_page(viewport={"width": 900, "height": 700})
            page.goto(url.replace("localhost", "127.0.0.1"))
            src, first = settled_frame(page, SHOWN_SIZE)
            assert close(first, shown_offscreen(camera)), "plotter.show() is not our rendering"
            assert first.std() > 5
            box = page.locator("#view-box").bounding_box()
            page.mouse.move(box["x"] + 160, box["y"] + 120)
            page.mouse.down()
            page.mouse.move(box["x"] + 260, box["y"] + 150, steps=8)
            page.mouse.up()
            page.mouse.wheel(0, -400)                         # and zoom in
            src, turned = settled_frame(page, SHOWN_SIZE, src)
            client.execute_cell(book.cells[1], 1)             # where the kernel's camera is
            moved = eval(book.cells[1].outputs[0]["text"])    # noqa: S307 (our own print)
            assert not np.allclose(moved[0], camera[0]), "the mouse did not move the camera"
            assert close(turned, shown_offscreen(moved))
            assert np.abs(turned - first).mean() > 2.0        # zoomed: a larger blob
            # a knob turned from code reaches the page shown by plotter.show(): its state,
            # the panel opened by live_view, and the frame
            book.cells.append(nbformat.v4.new_code_cell(
                "pv_cubemarch.live_view(plotter).set('volume', 'stop_opacity', 0.5)"))
            client.execute_cell(book.cells[2], 2)
            page.wait_for_function(
                "() => window.trame.state.get('volume__stop_opacity') === 0.5"
                " && window.trame.state.get('main_drawer') === true", timeout=30_000)
            src, early = settled_frame(page, SHOWN_SIZE, src)
            assert not close(early, turned), "the knob set from code did not change the frame"
        finally:
            browser.close()


def test_with_a_display_the_viewer_opens_the_browser(tmp_path):
    # catches: `pv-cubemarch view` opening nothing where a display exists (without
    # pywebview the default browser, which $BROWSER names: here a script noting the URL)
    opened = tmp_path / "opened.txt"
    browser = tmp_path / "browser.sh"
    browser.write_text(f"#!/bin/sh\necho \"$1\" >> {opened}\n")
    browser.chmod(0o755)
    with served(tmp_path, window="auto", DISPLAY=":99", BROWSER=f"{browser} %s") as url:
        deadline = time.monotonic() + 30
        while not opened.exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        assert opened.exists(), (tmp_path / "server.log").read_text()
        assert url in opened.read_text()        # with its secret: the page can connect
