"""What the browser tests share: chromium kept off the network, frames read from the page.

A frame is the remote view's ``<img>`` in ``#view-box``, read once a new one has arrived
and the stream has been quiet for :data:`QUIET` seconds (VTK re-sends a stale frame first).
"""

from __future__ import annotations

import base64
import io
import socket
import time
from pathlib import Path

import numpy as np
import pyvista
from PIL import Image

import pv_cubemarch as cm

CHROMIUM = "/usr/bin/chromium"
#: Keep chromium off the network: every name but localhost fails to resolve.
CHROMIUM_ARGS = ["--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1",
                 "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--no-pings", "--disable-domain-reliability"]
QUIET = 1.5    # seconds without a new frame before one counts (VTK re-sends a stale one)



def launch(driver):
    """Debian's chromium, headless, resolving only 127.0.0.1."""
    assert Path(CHROMIUM).exists(), "Debian's chromium is needed (tools/setup.sh installs it)"
    return driver.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)


def watch_outside(page) -> list[str]:
    """A list that collects the page's requests and websockets beyond localhost."""
    outside: list[str] = []
    local = ("http://127.0.0.1", "http://localhost", "ws://127.0.0.1", "ws://localhost",
             "blob:", "data:")
    page.on("request", lambda r: outside.append(r.url)
            if not r.url.startswith(local) else None)
    page.on("websocket", lambda socket: outside.append(socket.url)
            if not socket.url.startswith(local) else None)
    return outside


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
  return {src: img.src, png: canvas.toDataURL('image/png')};
}"""


def settled_frame(page, size, previous: str | None = None, timeout: float = 60.0):
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
