"""The live viewer in a real browser: Debian's chromium driven by Playwright.

`pv-cubemarch view` serves the shipped smoke scene on localhost; the test waits for the
first streamed frame and compares it with `render_image` of the same scene and camera
(the stream is JPEG: mean difference under 2/255 and 99th percentile under 12, while the
stop-opacity change below is several times that), moves the stop-opacity slider with the
keyboard and checks the frame changed as the same setting does offscreen, switches the
technique with the select (the server then says it draws a cube map), and always stops
the server. Run apart from the default tests: `pytest tests/browser`.
"""

from __future__ import annotations

import base64
import contextlib
import io
import os
import re
import signal
import socket
import subprocess
import sys
import time
import urllib.request
import warnings
from pathlib import Path

import nbclient
import nbformat
import numpy as np
import pyvista
from PIL import Image
from playwright.sync_api import sync_playwright

import pv_cubemarch as cm
from pv_cubemarch.views.session import TuningSession

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "datasets" / "smoke_scene.usda"
SIZE = (480, 360)
CHROMIUM = "/usr/bin/chromium"
#: Keep chromium off the network: every name but localhost fails to resolve.
CHROMIUM_ARGS = ["--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1",
                 "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--no-pings", "--disable-domain-reliability"]
QUIET = 1.5    # seconds without a new frame before one counts (VTK re-sends a stale one)

def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


@contextlib.contextmanager
def served(tmp_path):
    """``pv-cubemarch view`` on a free port; yields its URL; always stops it."""
    port = free_port()
    url = f"http://127.0.0.1:{port}/"
    log = open(tmp_path / "server.log", "w")  # noqa: SIM115 (closed below)
    process = subprocess.Popen(
        [sys.executable, "-m", "pv_cubemarch.cli", "view", str(SCENE), "--port", str(port),
         "--size", f"{SIZE[0]}x{SIZE[1]}"], stdout=log, stderr=subprocess.STDOUT,
        start_new_session=True, env=dict(os.environ, VTK_WASM_DIR_OVERRIDE=str(tmp_path)))
    try:
        deadline = time.monotonic() + 120
        while True:
            assert process.poll() is None, (tmp_path / "server.log").read_text()
            assert time.monotonic() < deadline, "the viewer did not start in 120 s"
            try:
                with urllib.request.urlopen(url + "index.html", timeout=1) as reply:
                    if reply.status == 200:
                        break
            except OSError:
                time.sleep(0.2)
        yield url
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGTERM)
        try:
            process.wait(timeout=15)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
        log.close()


READ_FRAME = """() => {
  const img = document.querySelector('#view-box img');
  if (!img || !img.complete || !img.naturalWidth) return null;
  const canvas = document.createElement('canvas');
  canvas.width = img.naturalWidth; canvas.height = img.naturalHeight;
  canvas.getContext('2d').drawImage(img, 0, 0);
  return {src: img.src, png: canvas.toDataURL('image/png')};
}"""


def settled_frame(page, previous: str | None = None, timeout: float = 60.0, size=SIZE):
    """The view's frame once a new full-size one has arrived and the stream is quiet."""
    deadline = time.monotonic() + timeout
    last, since = None, time.monotonic()
    while time.monotonic() < deadline:
        frame = page.evaluate(READ_FRAME)
        if frame and frame["src"] != previous:
            if last is None or frame["src"] != last["src"]:
                last, since = frame, time.monotonic()
            elif time.monotonic() - since > QUIET:
                image = np.asarray(Image.open(io.BytesIO(base64.b64decode(
                    frame["png"].split(",", 1)[1]))).convert("RGB")).astype(int)
                if image.shape[:2] == (size[1], size[0]):
                    return frame["src"], image
        time.sleep(0.1)
    raise AssertionError(f"no settled {size} frame within {timeout} s")


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


def close(a: np.ndarray, b: np.ndarray) -> bool:
    difference = np.abs(a - b)
    return difference.mean() < 2.0 and np.percentile(difference, 99) < 12


def test_viewer_streams_our_rendering_and_its_knobs_change_it(tmp_path):
    assert Path(CHROMIUM).exists(), "Debian's chromium is needed (tools/setup.sh installs it)"
    with served(tmp_path) as url, sync_playwright() as driver:
        browser = driver.chromium.launch(executable_path=CHROMIUM, headless=True,
                                         args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 1200, "height": 800},
                                    device_scale_factor=1)
            outside = []
            page.on("request", lambda r: outside.append(r.url)
                    if not r.url.startswith(("http://127.0.0.1", "ws://127.0.0.1", "blob:",
                                             "data:")) else None)
            page.on("websocket", lambda socket: outside.append(socket.url)
                    if not socket.url.startswith("ws://127.0.0.1") else None)
            page.goto(url)
            src, first = settled_frame(page)
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
            src, early = settled_frame(page, src)
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
            src, cubemap = settled_frame(page, src)
            assert close(cubemap, offscreen(stop_opacity=0.5, technique="cubemap"))
            shot = tmp_path / "viewer.png"
            page.screenshot(path=str(shot))
            if os.environ.get("PV_CUBEMARCH_SCREENSHOT"):
                Path(os.environ["PV_CUBEMARCH_SCREENSHOT"]).write_bytes(shot.read_bytes())
            assert not outside, f"the page reached beyond localhost: {outside}"
        finally:
            browser.close()


#: A notebook cell: a client-side backend set, a volume added, plotter.show().
SHOW_CELL = """
import numpy as np
import pyvista as pv
import pv_cubemarch
pv.set_jupyter_backend('client')
x, y, z = np.mgrid[-1:1:32j, -1:1:32j, -1:1:32j]
plotter = pv.Plotter(notebook=True, window_size=(320, 240))
pv_cubemarch.add_volume(plotter, np.exp(-4 * (x**2 + y**2 + z**2)), cmap='inferno',
                        technique='direct')
plotter.show()
"""


def shown_offscreen(camera_position) -> np.ndarray:
    """What SHOW_CELL's plotter draws from ``camera_position``, drawn in this process."""
    x, y, z = np.mgrid[-1:1:32j, -1:1:32j, -1:1:32j]
    plotter = pyvista.Plotter(off_screen=True, window_size=(320, 240))
    try:
        cm.add_volume(plotter, np.exp(-4 * (x**2 + y**2 + z**2)), cmap="inferno",
                      technique="direct")
        plotter.camera_position = camera_position
        return cm.render_image(plotter).astype(int)
    finally:
        plotter.close()


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
        url = re.search(r'src="(http://localhost:\d+/[^"]*)"', outputs).group(1)
        browser = driver.chromium.launch(executable_path=CHROMIUM, headless=True,
                                         args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 900, "height": 700})
            page.goto(url.replace("localhost", "127.0.0.1"))
            src, first = settled_frame(page, size=(320, 240))
            assert close(first, shown_offscreen(camera)), "plotter.show() is not our rendering"
            assert first.std() > 5
            box = page.locator("#view-box").bounding_box()
            page.mouse.move(box["x"] + 160, box["y"] + 120)
            page.mouse.down()
            page.mouse.move(box["x"] + 260, box["y"] + 150, steps=8)
            page.mouse.up()
            page.mouse.wheel(0, -400)                         # and zoom in
            src, turned = settled_frame(page, src, size=(320, 240))
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
            src, early = settled_frame(page, src, size=(320, 240))
            assert not close(early, turned), "the knob set from code did not change the frame"
        finally:
            browser.close()
