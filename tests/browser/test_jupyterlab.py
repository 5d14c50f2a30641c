"""The live view inside JupyterLab, in a real browser (Debian's chromium driven by Playwright).

JupyterLab (from the test environment) serves a notebook whose first cell adds a volume to
a notebook plotter and calls ``plotter.show()`` under PyVista's default backend. The test
runs the cells as a user does (Shift+Enter), finds the view's iframe in the cell's output
and checks its frame is our rendering (the same plotter drawn offscreen from the kernel's
camera); it then runs ``live_view(plotter)``, moves the stop-opacity slider of the panel in
that cell's iframe with the keyboard, and checks the frame is the volume drawn at 0.5.
JupyterLab and its kernel are always stopped. Run with the browser tests:
``pytest tests/browser``.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import sys
import time
import urllib.request
from pathlib import Path

import nbformat
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

#: The notebook's cells: plotter.show() under the default backend (then the kernel's
#: camera printed), the same plotter's live view with its panel.
CELLS = [SHOW_CELL.replace("pv.set_jupyter_backend('client')\n", "")
         + "print(json.dumps([list(v) for v in plotter.camera_position]))",
         "view = pv_cubemarch.live_view(plotter)\nview"]
CODE_CELL = ".jp-NotebookPanel:not(.lm-mod-hidden) .jp-Notebook .jp-CodeCell"


@contextlib.contextmanager
def jupyterlab(root: Path):
    """JupyterLab serving ``root`` on a free port, its settings kept in ``root``; its URL."""
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    env = dict(os.environ, JUPYTER_CONFIG_DIR=str(root / ".config"),
               JUPYTERLAB_SETTINGS_DIR=str(root / ".settings"),
               JUPYTERLAB_WORKSPACES_DIR=str(root / ".workspaces"),
               VTK_WASM_DIR_OVERRIDE=str(root))
    command = [sys.executable, "-m", "jupyterlab", "--no-browser", "--ip=127.0.0.1",
               f"--port={port}", "--IdentityProvider.token=", "--ServerApp.password=",
               "--ServerApp.disable_check_xsrf=True", f"--ServerApp.root_dir={root}",
               "--allow-root"]

    def shutdown():          # the server's own shutdown stops its kernels too
        request = urllib.request.Request(url + "/api/shutdown", method="POST")
        urllib.request.urlopen(request, timeout=10).close()
    with serving(command, root / "jupyterlab.log", url + "/api/status", env, shutdown):
        yield url


def run_cell(page, index: int, timeout: float = 240.0):
    """Run code cell ``index`` with Shift+Enter; its locator once its prompt has a number."""
    cell = page.locator(CODE_CELL).nth(index)
    cell.locator(".jp-InputPrompt").click()
    page.keyboard.press("Escape")              # command mode: Shift+Enter runs the cell
    page.keyboard.press("Shift+Enter")
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        prompt = cell.locator(".jp-InputPrompt").inner_text()
        if re.search(r"\[\d+\]", prompt):
            return cell
        time.sleep(0.25)
    raise AssertionError(f"cell {index} did not finish in {timeout} s")


def view_frame(cell):
    """The trame page in the cell's output iframe, scrolled into view."""
    iframe = cell.locator(".jp-OutputArea iframe").first
    iframe.wait_for(timeout=60_000)
    iframe.scroll_into_view_if_needed()
    return iframe.element_handle().content_frame()


def test_plotter_show_and_the_panel_in_jupyterlab(tmp_path):
    book = nbformat.v4.new_notebook(metadata={"kernelspec": {
        "name": "python3", "display_name": "Python 3", "language": "python"}})
    book.cells = [nbformat.v4.new_code_cell("import json\n" + CELLS[0] if i == 0 else code)
                  for i, code in enumerate(CELLS)]
    nbformat.write(book, tmp_path / "live.ipynb")
    with jupyterlab(tmp_path) as url, sync_playwright() as driver:
        browser = launch(driver)
        try:
            page = browser.new_page(viewport={"width": 1400, "height": 1000},
                                    device_scale_factor=1)
            outside = watch_outside(page, frames_only=True)
            page.goto(f"{url}/lab/tree/live.ipynb")
            page.locator(CODE_CELL).nth(len(CELLS) - 1).wait_for(timeout=120_000)
            page.wait_for_function("() => document.body.innerText.includes('Idle')",
                                   timeout=120_000)              # the kernel is up
            shown = run_cell(page, 0)
            output = shown.locator(".jp-OutputArea").inner_text()
            camera = json.loads(re.search(r"\[\[.*\]\]", output).group(0))
            frame = view_frame(shown)
            src, first = settled_frame(frame, SHOWN_SIZE)
            assert close(first, shown_offscreen(camera)), "plotter.show() is not our view"
            assert first.std() > 5
            # the panel's stop-opacity slider to its lowest, 0.5, from the keyboard
            panel = view_frame(run_cell(page, 1))
            thumb = panel.locator(".v-input", has=panel.locator(
                "#knob-volume-stop_opacity")).locator(".v-slider-thumb[role=slider]").first
            thumb.focus()
            thumb.press("Home")
            panel.wait_for_function(
                "() => window.trame.state.get('volume__stop_opacity') <= 0.5")
            src, early = settled_frame(panel, SHOWN_SIZE)
            assert not close(early, first), "the slider did not change the frame"
            assert close(early, shown_offscreen(camera, stop_opacity=0.5))
            with contextlib.suppress(Exception):       # Lab's news question, if asked
                page.get_by_role("button", name="No", exact=True).click(timeout=2000)
                time.sleep(1.0)                          # its toast fades out
            page.locator(CODE_CELL).nth(1).scroll_into_view_if_needed()
            keep_screenshot(page, tmp_path, "jupyterlab.png")
            assert not outside, f"the view reached beyond localhost: {outside}"
        finally:
            browser.close()
