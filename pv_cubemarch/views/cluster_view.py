"""The live view driven by a Dask cluster: a split grid's frames, shown as they composite.

The server's plotter holds no data: its camera is the one the page's mouse turns, and its
background is the last frame the cluster composited (a texture of the view's size, drawn
pixel for pixel). When the camera moves, a frame for it is asked of the cluster; while one
is being drawn, later moves only mark the view stale, and the newest camera is asked for
as soon as that frame arrives. So at most one frame is in flight, and the page always
shows the newest frame that has come back (with how long it took).
"""

from __future__ import annotations

import asyncio
import socket
import time

import numpy as np
from vtkmodules.util.numpy_support import numpy_to_vtk

from ..cluster.sort_last import SplitRenderer
from ..core import vtk_classes as vtk
from ..core.camera import Camera
from ..core.frame_errors import observe
from ..core.rendering import offscreen_plotter, render_frame
from .app import trame
from .guard import guard, warn_if_exposed, with_token

#: Seconds between looks at the frame in flight.
POLL_S = 0.05


class ClusterDisplay:
    """A plotter showing the frames a :class:`SplitRenderer` draws for its camera."""

    def __init__(self, renderer: SplitRenderer, camera: Camera):
        width, height = renderer.size
        self.renderer = renderer
        self.plotter = offscreen_plotter((width, height))
        self.plotter.disable_anti_aliasing()
        camera.apply_to(self.plotter.camera)
        self.plotter.camera_set = True
        self._image = vtk.vtkImageData()
        self._image.SetDimensions(width, height, 1)
        self._texture = vtk.vtkTexture()
        self._texture.InterpolateOff()
        self._show(np.zeros((height, width, 3), np.uint8))
        self.plotter.renderer.SetBackgroundTexture(self._texture)
        self.plotter.renderer.TexturedBackgroundOn()
        self.in_flight = None
        self.stale = False
        self.frames = 0
        self.frame_ms = 0.0
        self.asked: Camera | None = None
        observe(self.plotter.camera, vtk.vtkCommand.ModifiedEvent, self.camera_moved)
        self.ask()

    def camera(self) -> Camera:
        """The view's camera, its clipping range left to the workers (fitted to the grid)."""
        shown = Camera.from_pyvista(self.plotter.camera)
        return Camera(shown.position, shown.focal_point, shown.view_up, shown.view_angle,
                      None, shown.parallel_projection, shown.parallel_scale)

    def camera_moved(self, *_) -> None:
        """Ask for the new view now, or once the frame in flight is back."""
        if self.in_flight is None:
            self.ask()
        else:
            self.stale = True

    def ask(self) -> None:
        """Ask the cluster for a frame of the current camera."""
        camera = self.camera()
        self.stale = False
        if camera == self.asked:
            return
        self.asked = camera
        self.in_flight = (self.renderer.submit(camera), time.perf_counter())

    def poll(self) -> bool:
        """Show the frame in flight if it is back (and ask for a newer view); whether shown."""
        if self.in_flight is None or not self.in_flight[0].done():
            return False
        frame, asked = self.in_flight
        self.in_flight = None
        self._show(frame.result())
        self.frames += 1
        self.frame_ms = (time.perf_counter() - asked) * 1e3
        if self.stale:
            self.ask()
        return True

    def wait(self, timeout: float = 60.0) -> None:
        """Poll until no frame is in flight (scripts and tests)."""
        deadline = time.perf_counter() + timeout
        while self.in_flight is not None:
            if time.perf_counter() > deadline:
                raise TimeoutError(f"no frame from the cluster after {timeout:g} s")
            if not self.poll():
                time.sleep(0.01)

    def _show(self, image: np.ndarray) -> None:
        rows = numpy_to_vtk(np.ascontiguousarray(image[::-1]).reshape(-1, 3), deep=True)
        self._image.GetPointData().SetScalars(rows)
        self._image.Modified()
        self._texture.SetInputData(self._image)
        self._texture.Modified()

    def close(self) -> None:
        if self.in_flight is not None:
            self.in_flight[0].cancel()
        self.plotter.close()


def build_cluster_app(display: ClusterDisplay, name: str = "cubemarch-cluster"):
    """A trame server showing ``display``; returns ``(server, layout)``.

    The page's mouse turns the display's camera; frames from the cluster replace the view
    as they arrive, with the time each took and how many have come.
    """
    pieces = trame()
    html, vtk_widgets = pieces.html, pieces.vtk_widgets
    render_frame(display.plotter)
    server = pieces.get_server(name, client_type="vue3")
    state, ctrl = server.state, server.controller
    state.trame__title = "pv_cubemarch: cluster"
    state.cluster_text = "asking the cluster for the first frame"
    split = display.renderer.split
    width, height = display.renderer.size
    token = guard(server)
    with pieces.SinglePageWithDrawerLayout(server) as layout:
        layout.title.set_text("pv_cubemarch: a split grid drawn by a Dask cluster")
        with layout.drawer:
            html.Div(f"{len(split.partitions)} slabs on "
                     f"{len(display.renderer.client.scheduler_info()['workers'])} workers",
                     classes="ma-2")
            html.Div("{{ cluster_text }}", id="cluster-text", classes="ma-2 text-caption")
        with layout.content:
            with html.Div(id="view-box",
                          style=f"width:{width}px;height:{height}px;position:relative;"):
                view = vtk_widgets.VtkRemoteView(display.plotter.ren_win, ref="view",
                                                 interactive_ratio=1, still_quality=100)
                ctrl.view_update = view.update
    layout.cubemarch_token = token
    page = layout.iframe_builder
    layout.iframe_builder = lambda lay: {**page(lay), "src": with_token(page(lay)["src"], token)}

    async def stream():
        while True:
            if display.poll():
                state.cluster_text = (f"frame {display.frames}: {display.frame_ms:.0f} ms "
                                      "from asking to composited"
                                      + (", a newer view asked" if display.in_flight else ""))
                state.flush()
                ctrl.view_update()
            await asyncio.sleep(POLL_S)

    @ctrl.on_server_ready.add
    def start_streaming(**_):
        asyncio.get_event_loop().create_task(stream())
    return server, layout


def serve_cluster(display: ClusterDisplay, port: int = 8080, host: str = "127.0.0.1") -> None:
    """Serve the cluster-driven view on ``http://host:port/`` until stopped (Ctrl-C)."""
    server, layout = build_cluster_app(display)
    warn_if_exposed(host)
    shown = host if host not in ("0.0.0.0", "::", "") else socket.gethostname()
    url = with_token(f"http://{shown}:{port}/", layout.cubemarch_token)
    print(f"pv-cubemarch live view: {url}", flush=True)
    server.start(port=port, host=host, open_browser=False, exec_mode="main",
                 show_connection_info=False, timeout=0)
