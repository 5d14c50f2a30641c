"""A live view in a notebook: the app's server started at once, shown as an iframe, stopped.

:func:`live_view` (also ``pv_cubemarch.widget``) builds the app of :mod:`.app` for a scene
or a plotter and starts its server before returning, so the cell that calls it can display
it (no ``await`` needed). One server per view, on a free localhost port, until
:meth:`LiveView.close`; showing a plotter again reuses its view.
"""

from __future__ import annotations

import asyncio
import itertools

import pyvista

from ..scene.model import Scene
from .app import INSTALL, build_app, show_session
from .session import TuningSession


def server_registries() -> tuple:
    """The registries trame keeps of servers by name (the server, the vtk view's helper).

    Imported once a view is closed (a view has imported trame by then).
    """
    try:
        from trame.app.core import AVAILABLE_SERVERS
        from trame_vtk.modules.vtk import HELPERS_PER_SERVER
    except ImportError:                 # the optional extra is not installed
        return ()
    return (AVAILABLE_SERVERS, HELPERS_PER_SERVER)

try:
    import nest_asyncio2
except ImportError:                     # the optional extra is not installed
    nest_asyncio2 = None


class LiveView:
    """A running live view: the trame server, its page and the tuning session behind it.

    Display it in a notebook cell (an iframe of the page); turn knobs from code with
    :meth:`set` (the page follows); :meth:`close` stops the server.
    """

    def __init__(self, server, layout, session: TuningSession, owns_plotter: bool):
        self.server = server
        self.layout = layout
        self.session = session
        self._owns_plotter = owns_plotter

    @property
    def url(self) -> str:
        """The page's address (``http://localhost:<port>/...``) while the server runs."""
        return self.layout.url

    @property
    def running(self) -> bool:
        """Whether the server is serving the page."""
        return self.server.running

    @property
    def ready(self):
        """An awaitable that resolves once the server listens (it already does)."""
        self._check_open()
        return self.layout.ready

    def set(self, kind: str, name: str, value) -> float:
        """Turn a knob from code (see :meth:`TuningSession.set`); the panel shows the value."""
        self._check_open()
        milliseconds = self.session.set(kind, name, value)
        show_session(self.server, self.session)
        self.server.controller.view_update()
        return milliseconds

    def show_panel(self, shown: bool = True) -> None:
        """Open (or close) the knob panel on the pages showing this view."""
        with self.server.state as state:
            state[PANEL_STATE] = bool(shown)

    def close(self) -> None:
        """Stop the server and let it go; a view made from a scene also closes its plotter."""
        if self.running:
            _run_now(self.server.stop())
        for registry in server_registries():        # trame keeps every server (and its view)
            registry.pop(self.server.name, None)
        if self._owns_plotter:
            self.session.plotter.close()
        for plotter, view in list(_VIEWS.items()):
            if view is self:
                del _VIEWS[plotter]

    def _check_open(self) -> None:
        if not self.running:
            raise RuntimeError("this live view was closed: make a new one with "
                               "pv_cubemarch.live_view(...)")
        if self.session.plotter.render_window is None:
            raise RuntimeError("the plotter of this live view was closed: make a new "
                               "plotter and show it")

    def _repr_mimebundle_(self, include=None, exclude=None) -> dict:
        """The page in an iframe: as a widget where the frontend has ipywidgets, else HTML.

        A JupyterLab without the widget frontend shows the ``text/html`` iframe instead of
        the widget's text form.
        """
        if not self.running:
            return {"text/plain": f"{self!r}: make a new one with pv_cubemarch.live_view(...)"}
        iframe = self.layout.ipywidget
        bundle = dict(iframe._repr_mimebundle_() or {})
        bundle["text/html"] = iframe.value
        return bundle

    def __repr__(self) -> str:
        state = self.url if self.running else "closed"
        return f"<LiveView {', '.join(self.session.kinds()) or 'meshes only'}: {state}>"


def live_view(scene: Scene | str | pyvista.Plotter, size: tuple[int, int] = (800, 600),
              panel: bool = True) -> LiveView:
    """The live view and knob panel of a scene or plotter, for a notebook or a browser.

    The view is rendered on the server (our shaders included), whatever PyVista's
    notebook backend is, and turns and zooms with the mouse; every knob change re-renders
    it, and the panel shows the frame's time and, on request, its error against the CPU
    reference. The server is started before this returns, on a free localhost port.

    Parameters
    ----------
    scene : Scene, str or pyvista.Plotter
        A scene, a path :func:`pv_cubemarch.load_scene` reads, or a plotter holding our
        techniques' actors (shown at its own size; showing it again reuses this view).
    size : tuple of int
        The view's size in pixels for a scene.
    panel : bool, default: True
        Open the knob panel at start (the toolbar's menu button opens and closes it; a
        plotter shown again keeps its view, and ``panel=True`` opens the panel there).

    Returns
    -------
    LiveView
        Displayed as an iframe when it ends a cell; ``view.set(kind, knob, value)`` turns
        a knob from code; ``view.close()`` stops its server.

    Examples
    --------
    >>> import pv_cubemarch
    >>> view = pv_cubemarch.live_view("datasets/smoke_scene.usda")  # doctest: +SKIP
    >>> view  # doctest: +SKIP
    >>> view.set("volume", "step_scale", 0.5)  # doctest: +SKIP

    In a script (no running event loop) the server answers only while the loop turns: use
    :func:`pv_cubemarch.views.app.serve` or ``pv-cubemarch view`` there.
    """
    for plotter, view in list(_VIEWS.items()):       # plotters closed since: their servers
        if plotter.render_window is None:
            view.close()
    if isinstance(scene, pyvista.Plotter):
        if scene.render_window is None:
            raise ValueError("the plotter was closed: make a new one to show")
        view = _VIEWS.get(scene)
        if view is not None and view.running and view.session.holds_all_of(scene):
            if panel:
                view.show_panel(True)
            return view
        if view is not None:                           # its actors changed: a new session
            view.close()
    server, layout, session = build_app(scene, size, name=f"cubemarch-{next(_COUNTER)}",
                                        show_panel=panel)
    # the iframe tall enough for the view under the app bar, and for the panel's knobs
    height = max(int(session.plotter.window_size[1]) + IFRAME_MARGIN, IFRAME_MIN_HEIGHT)
    layout.iframe_style = f"border: none; width: 100%; height: {height}px;"
    view = LiveView(server, layout, session, owns_plotter=not isinstance(scene,
                                                                          pyvista.Plotter))
    try:
        _run_now(_started(layout))
    except BaseException:                  # not started: let go of what was made for it
        view.close()
        raise
    if isinstance(scene, pyvista.Plotter):
        _VIEWS[scene] = view
    return view


#: Pixels of the page above and below the view (the app bar), and the iframe's least height.
IFRAME_MARGIN, IFRAME_MIN_HEIGHT = 96, 480
#: The trame state that opens the page's knob panel (the drawer of the "main" template).
PANEL_STATE = "main_drawer"
#: The live view of each plotter shown (so showing it again reuses the running server).
_VIEWS: dict[pyvista.Plotter, LiveView] = {}
_COUNTER = itertools.count()


async def _started(layout) -> None:
    """Start the layout's server (as a task of the running loop) and wait until it listens."""
    await layout.ready


def _run_now(coroutine) -> None:
    """Run ``coroutine`` to its end now, inside a notebook's running event loop too."""
    if nest_asyncio2 is None:
        coroutine.close()                # never awaited: no "never awaited" warning
        raise ImportError(f"showing a live view without `await` needs nest-asyncio2: "
                          f"{INSTALL}")
    try:
        loop = asyncio.get_event_loop()
    except RuntimeError:                 # a thread without a loop
        loop = asyncio.new_event_loop()
        asyncio.set_event_loop(loop)
    if loop.is_running():                # a notebook's kernel: wait inside its loop
        nest_asyncio2.apply(loop)
    loop.run_until_complete(coroutine)
