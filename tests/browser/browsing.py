"""What the browser tests share: chromium kept off the network, frames read from the page.

A frame is the remote view's ``<img>`` in ``#view-box``, read once a new one has arrived
and the stream has been quiet for :data:`QUIET` seconds (VTK re-sends a stale frame first).
"""

from __future__ import annotations

import base64
import contextlib
import io
import os
import signal
import socket
import subprocess
import time
import urllib.request
from pathlib import Path

import numpy as np
import pyvista
from PIL import Image

import pv_cubemarch as cm

CHROMIUM = "/usr/bin/chromium"
#: Keep chromium off the network: every name but localhost fails to resolve.
CHROMIUM_ARGS = ["--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1, EXCLUDE localhost",
                 "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--no-pings", "--disable-domain-reliability"]
QUIET = 1.5    # seconds without a new frame before one counts (VTK re-sends a stale one)



def keep_screenshot(page, tmp_path: Path, name: str) -> None:
    """Screenshot the page into ``tmp_path``, and into ``$PV_CUBEMARCH_SCREENSHOTS`` if set
    (``PV_CUBEMARCH_SCREENSHOTS=docs/images pytest tests/browser`` refreshes the guide's)."""
    shot = tmp_path / name
    page.screenshot(path=str(shot))
    if os.environ.get("PV_CUBEMARCH_SCREENSHOTS"):
        (Path(os.environ["PV_CUBEMARCH_SCREENSHOTS"]) / name).write_bytes(shot.read_bytes())


def launch(driver):
    """Debian's chromium, headless, resolving only 127.0.0.1."""
    assert Path(CHROMIUM).exists(), "Debian's chromium is needed (tools/setup.sh installs it)"
    return driver.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)


def watch_outside(page, frames_only: bool = False) -> list[str]:
    """A list that collects the page's requests and websockets beyond localhost.

    ``frames_only``: only the requests of the page's iframes (our views inside JupyterLab,
    whose own page is not ours to vouch for).
    """
    outside: list[str] = []
    local = ("http://127.0.0.1", "http://localhost", "ws://127.0.0.1", "ws://localhost",
             "blob:", "data:")

    def request(r):
        if not r.url.startswith(local) and not (frames_only and r.frame == page.main_frame):
            outside.append(r.url)
    page.on("request", request)
    page.on("websocket", lambda socket: outside.append(socket.url)
            if not socket.url.startswith(local) else None)
    return outside


@contextlib.contextmanager
def serving(command: list[str], log: Path, ready_url: str, env: dict, shutdown=None):
    """Run ``command`` (a server) until ``ready_url`` answers 200; always stop it after.

    ``shutdown``: called first to stop it gracefully (else SIGTERM to its process group);
    it is killed if it has not ended 30 s later. Its output goes to ``log``.
    """
    with open(log, "w") as out:
        process = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT, env=env,
                                   start_new_session=True)
        try:
            deadline = time.monotonic() + 120
            while True:
                assert process.poll() is None, log.read_text()[-3000:]
                assert time.monotonic() < deadline, f"{command[:3]} did not start in 120 s"
                try:
                    with urllib.request.urlopen(ready_url, timeout=1) as reply:
                        if reply.status == 200:
                            break
                except OSError:
                    pass
                time.sleep(0.2)
            yield process
        finally:
            if shutdown is not None:
                with contextlib.suppress(OSError):
                    shutdown()
                with contextlib.suppress(subprocess.TimeoutExpired):
                    process.wait(timeout=20)
            with contextlib.suppress(ProcessLookupError):   # (JupyterLab stops its kernels)
                os.killpg(process.pid, signal.SIGTERM)
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait()


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


READ_FRAME = """() => {
  const img = document.querySelector('#view-box img');
  if (!img || !img.complete || !img.naturalWidth) return null;
  const canvas = document.createElement('canvas');
  canvas.width = img.naturalWidth; canvas.height = img.naturalHeight;
  canvas.getContext('2d').drawImage(img, 0, 0);
  return {src: img.src, png: canvas.toDataURL('image/png'),
          size: [img.naturalWidth, img.naturalHeight]};
}"""


def settled_frame(page, size, previous: str | None = None, timeout: float = 60.0):
    """The view's frame once a new full-size one has arrived and the stream is quiet."""
    deadline = time.monotonic() + timeout
    last, since, seen = None, time.monotonic(), set()
    while time.monotonic() < deadline:
        frame = page.evaluate(READ_FRAME)
        seen.add(None if frame is None else (frame["src"][-12:], tuple(frame["size"])))
        if frame and frame["src"] != previous:
            if last is None or frame["src"] != last["src"]:
                last, since = frame, time.monotonic()
            elif time.monotonic() - since > QUIET:
                image = np.asarray(Image.open(io.BytesIO(base64.b64decode(
                    frame["png"].split(",", 1)[1]))).convert("RGB")).astype(int)
                if image.shape[:2] == (size[1], size[0]):
                    return frame["src"], image
        time.sleep(0.1)
    raise AssertionError(f"no settled {size} frame within {timeout} s; seen: "
                         f"{sorted(map(str, seen))[:12]}")


def close(a: np.ndarray, b: np.ndarray) -> bool:
    difference = np.abs(a - b)
    return difference.mean() < 2.0 and np.percentile(difference, 99) < 12


#: The window size of SHOW_CELL's plotter.
SHOWN_SIZE = (320, 240)
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


def shown_offscreen(camera_position, **options) -> np.ndarray:
    """What SHOW_CELL's plotter draws from ``camera_position`` (with the volume's
    ``options``), drawn offscreen in this process."""
    x, y, z = np.mgrid[-1:1:32j, -1:1:32j, -1:1:32j]
    plotter = pyvista.Plotter(off_screen=True, window_size=SHOWN_SIZE)
    try:
        cm.add_volume(plotter, np.exp(-4 * (x**2 + y**2 + z**2)), cmap="inferno",
                      technique="direct", **options)
        plotter.camera_position = camera_position
        return cm.render_image(plotter).astype(int)
    finally:
        plotter.close()
