"""The trame app: the plotter rendered on the server (our GLSL included) and a knob panel.

Built from a :class:`~pv_cubemarch.views.session.TuningSession`: one panel section per kind
of technique in the scene, a control per knob (bound to trame state ``<kind>__<option>``),
the last frame's time, and a button that measures the error against the CPU reference.
trame, trame-vtk and trame-vuetify are the optional ``jupyter`` extra; without them
:func:`build_app` says what to install.
"""

from __future__ import annotations

import asyncio
import functools
import importlib
import importlib.util
import os
import socket
import subprocess
import sys
import tempfile
import types
import webbrowser

import pyvista

from ..core.rendering import offscreen_plotter
from ..scene.io import load_scene
from ..scene.model import Scene
from .guard import guard, warn_if_exposed, with_token
from .knobs import AUTO, Knob
from .session import TuningSession

INSTALL = "install the optional extra: pip install 'pv_cubemarch[jupyter]' (trame, trame-vtk, " \
    "trame-vuetify, nest-asyncio2)"

#: The trame modules the pages use (the ``jupyter`` extra).
TRAME_MODULES = ("trame.app", "trame.ui.vuetify3", "trame.widgets.html",
                 "trame.widgets.vuetify3", "trame.widgets.vtk")


@functools.cache
def has_trame() -> bool:
    """Whether the live view's trame modules are installed (found, not imported)."""
    try:
        return all(importlib.util.find_spec(name) is not None for name in TRAME_MODULES)
    except (ImportError, ValueError):   # a parent package that fails to import
        return False


def trame():
    """The trame pieces the pages use, imported when a page is made.

    ``import pv_cubemarch`` does not pay their 0.15 s. An ImportError says how to install
    them where they are missing.
    """
    if not has_trame():
        raise ImportError(f"pv_cubemarch's live view needs trame: {INSTALL}.")
    modules = [importlib.import_module(name) for name in TRAME_MODULES]
    return types.SimpleNamespace(
        get_server=modules[0].get_server, SinglePageWithDrawerLayout=(
            modules[1].SinglePageWithDrawerLayout), html=modules[2], vuetify3=modules[3],
        vtk_widgets=modules[4])


def state_name(kind: str, knob: Knob) -> str:
    """The trame state variable of a knob."""
    return f"{kind}__{knob.name}"


def build_app(scene: Scene | str | pyvista.Plotter, size: tuple[int, int] = (800, 600),
              name: str = "cubemarch", show_panel: bool = True):
    """The trame server, its layout and the tuning session for ``scene``.

    Parameters
    ----------
    scene : Scene, str or pyvista.Plotter
        A scene, a path :func:`pv_cubemarch.load_scene` reads, or a plotter holding our
        techniques' actors (drawn as it is, at its own size).
    size : tuple of int
        The view's size in pixels (the server renders at this size).
    name : str
        The trame server's name (one server per name and process).
    show_panel : bool
        Open the knob panel at start (the toolbar's menu button toggles it).

    Returns
    -------
    tuple
        ``(server, layout, session)``; only a page holding ``layout.cubemarch_token``
        (in its URL, as ``layout.url`` and the iframe give it) may connect.
    """
    get_server = trame().get_server
    # trame-vtklocal (pulled in by some trame installs) downloads WebAssembly when it
    # starts; an empty local folder keeps it offline.
    if "VTK_WASM_DIR_OVERRIDE" not in os.environ:
        os.environ["VTK_WASM_DIR_OVERRIDE"] = tempfile.mkdtemp(prefix="cubemarch_wasm")
    if isinstance(scene, pyvista.Plotter):
        plotter = scene
        size = tuple(plotter.window_size)
        session = TuningSession.from_plotter(plotter)
    else:
        scene = load_scene(scene) if not isinstance(scene, Scene) else scene
        plotter = offscreen_plotter(size)
        session = TuningSession(scene, plotter)
    session.draw()                      # context and shaders before any client connects
    server = get_server(name, client_type="vue3")
    state, ctrl = server.state, server.controller
    state.trame__title = "pv_cubemarch"
    state.frame_ms = round(session.last_frame_ms or 0.0, 1)
    state.error_text = "error: not measured"
    state.message = ""
    state.drawn = _drawn(session)
    state.label_legend = session.legend()
    state.streaming = streaming_text(plotter)
    state.quality_text = quality_text(session)
    for kind in session.kinds():
        for knob in session.knobs(kind):
            _bind(server, session, kind, knob)
    token = guard(server)
    layout = _layout(server, session, plotter, size, show_panel)
    layout.cubemarch_token = token
    page = layout.iframe_builder
    layout.iframe_builder = lambda lay: {**page(lay), "src": with_token(page(lay)["src"], token)}

    @ctrl.on_server_ready.add
    def start_refining(**_):
        asyncio.get_event_loop().create_task(refine_while_streaming(server, session))

    @ctrl.set("measure_error")
    def measure_error():
        try:
            errors = session.reference_error()
        except ValueError as exc:
            state.error_text = f"error: {exc}"
            return
        state.error_text = (f"error vs CPU reference: mean {errors['mean_abs']:.2f}/255, "
                            f"PSNR {errors['psnr']:.1f} dB, SSIM {errors['ssim']:.4f}")
    return server, layout, session


#: Seconds between the live view's redraws while streamed bricks arrive.
REFINE_S = 0.2


def streaming_text(plotter: pyvista.Plotter) -> str:
    """What each source streamed by bricks holds and misses now ('' when none streams)."""
    parts = []
    for binding in plotter.cubemarch.tracked:
        if not hasattr(binding, "converged") or not hasattr(binding, "stats"):
            continue
        stats = binding.stats()
        parts.append(f"{binding.name}: {stats['resident']} of {stats['slots']} slots, "
                     f"{stats['missing']} bricks missing, {stats['reading']} reading, "
                     f"{stats['bytes_read'] / 2**20:.1f} MB read"
                     + (", over budget: coarser where the pool has no room"
                        if stats["over_budget"] else "")
                     + (f", {stats['failed']} unreadable" if stats.get("failed") else ""))
    return "; ".join(parts)


def refine_step(server, session: TuningSession) -> bool:
    """Redraw the page's image while streamed bricks arrive; True while some are missing.

    The streaming line follows each redraw (resident, missing, reading bricks, bytes read),
    and the quality line and the frame time the last frame (a drag's frames are drawn by
    the view itself).
    """
    plotter = session.plotter
    streaming = any(getattr(b, "shown", True) and not b.converged
                    for b in plotter.cubemarch.tracked if hasattr(b, "converged"))
    if streaming:
        server.controller.view_update()
    text = streaming_text(plotter)
    if text != server.state.streaming:
        with server.state as state:
            state.streaming = text
    quality = quality_text(session)   # a drag's frames: their time, setting and estimate
    frame = round(session.window_frame_ms or session.last_frame_ms or 0.0, 1)
    if quality != server.state.quality_text or frame != server.state.frame_ms:
        with server.state as state:
            state.quality_text = quality
            state.frame_ms = frame
    return streaming


async def refine_while_streaming(server, session: TuningSession) -> None:
    """Every :data:`REFINE_S`: :func:`refine_step` (a frame never waits for a read).

    Also how the panel follows a drag's frames under ``frame_budget_ms``.
    """
    while True:
        await asyncio.sleep(REFINE_S)
        try:
            refine_step(server, session)
        except Exception as error:   # said on the page; the next step tries again
            with server.state as state:
                state.message = f"streaming: {error}"


def _bind(server, session: TuningSession, kind: str, knob: Knob) -> None:
    """Set the knob's state from the session and redraw when it changes."""
    state, ctrl = server.state, server.controller
    variable = state_name(kind, knob)
    state[variable] = _shown(knob, session.value(kind, knob.name))

    @state.change(variable)
    def changed(**current):
        message = ""
        try:
            new = _typed(knob, current[variable])
            if new == session.value(kind, knob.name):
                return                  # the control's start, or set back by show_session
            _check_range(knob, new)
            session.set(kind, knob.name, new)
        except Exception as exc:    # refused (any error): the scene and the knob as they were
            message = str(exc)
        show_session(server, session)   # every knob as now (a technique switch moves some)
        state.message = message
        ctrl.view_update()


def show_session(server, session: TuningSession) -> None:
    """Push the session's knob values, frame time and drawn techniques to the page.

    After a change from the page or from code: written inside the state's context, so they
    are sent at once (within a change handler, with its flush); the knobs' change handlers
    find the session already there.
    """
    with server.state as state:
        for kind in session.kinds():
            for knob in session.knobs(kind):
                state[state_name(kind, knob)] = _shown(knob, session.value(kind, knob.name))
        state.frame_ms = round(session.last_frame_ms or 0.0, 1)
        state.drawn = _drawn(session)
        state.label_legend = session.legend()
        state.error_text = "error: not measured"
        state.quality_text = quality_text(session)


def quality_text(session: TuningSession) -> str:
    """What ``quality=`` chose and what ``frame_budget_ms`` drew last, per item."""
    parts = []
    for name in session.items:
        binding = session.actor(name).cubemarch
        choice = getattr(binding, "quality", None)
        budget = getattr(binding, "frame_budget", None)
        if choice is not None:
            parts.append(f"{name}: quality {choice.target.name}: {choice.setting_text}, "
                         f"{choice.psnr:.1f} dB estimated")
        if budget is not None and budget.frames:
            last = budget.frames[-1]
            estimate = budget.estimated_psnr
            parts.append(f"{name}: {'moving' if last.moving else 'still'} frame "
                         f"{last.ms:.0f} ms (budget {budget.budget_ms:g}) at "
                         f"{budget.describe(last.value)}" + (
                             "" if estimate is None else f", {estimate:.1f} dB estimated"))
    return "; ".join(parts)


def _drawn(session: TuningSession) -> str:
    """What each item is drawn with now, as its actor says."""
    return ", ".join(f"{name}: {getattr(session.actor(name).cubemarch, 'technique', '?')}"
                     for name in session.items)


def _shown(knob: Knob, value):
    """An option's value as its control shows it (an unset optional one as "auto")."""
    if value is None and knob.optional:
        return AUTO
    return value


def _check_range(knob: Knob, value) -> None:
    """Refuse a slider's value off its track (a client may send any number)."""
    if knob.control == "slider" and not knob.low <= value <= knob.high:
        raise ValueError(f"{knob.label} = {value:g} is outside the slider's range "
                         f"[{knob.low:g}, {knob.high:g}]: refused.")


def _typed(knob: Knob, value):
    """A control's value as the option's type (an optional knob's "auto": unset)."""
    if knob.optional and value == AUTO:
        return None
    if knob.control == "switch":
        return value.lower() == "true" if isinstance(value, str) else bool(value)
    if knob.control == "multiselect":
        return sorted((next((c for c in knob.choices if str(c) == str(v)), v) for v in value),
                      key=lambda c: int(c))   # label ids; past 2^53 as strings
    if knob.control == "slider":
        return float(value) if isinstance(knob.step, float) and knob.step % 1 else \
            int(round(float(value)))
    choice = next((c for c in knob.choices if str(c) == str(value)), value)
    return choice


def _layout(server, session: TuningSession, plotter: pyvista.Plotter, size, show_panel: bool):
    """The page: a drawer of knobs by kind and the server-rendered view."""
    pieces = trame()
    html, vuetify3, vtk_widgets = pieces.html, pieces.vuetify3, pieces.vtk_widgets
    with pieces.SinglePageWithDrawerLayout(server, show_drawer=show_panel) as layout:
        layout.title.set_text("pv_cubemarch")
        with layout.drawer:
            for kind in session.kinds():
                html.Div(kind, classes="text-subtitle-2 ma-2")
                for knob in session.knobs(kind):
                    _control(kind, knob)
                if kind == "voxels":
                    _legend()
            html.Div("frame: {{ frame_ms }} ms", id="frame-time", classes="ma-2")
            html.Div("drawn with {{ drawn }}", id="drawn", classes="ma-2 text-caption")
            vuetify3.VBtn("measure error", id="measure-error", click=server.controller
                          .measure_error, classes="ma-2", size="small")
            html.Div("{{ error_text }}", id="error-text", classes="ma-2 text-caption")
            html.Div("{{ quality_text }}", id="quality-text", classes="ma-2 text-caption")
            html.Div("{{ streaming }}", id="streaming", classes="ma-2 text-caption",
                     v_show="streaming")
            html.Div("{{ message }}", id="message", classes="ma-2 text-caption text-error")
        with layout.content:
            with html.Div(id="view-box", style=f"width:{size[0]}px;height:{size[1]}px;"
                                               "position:relative;"):
                view = vtk_widgets.VtkRemoteView(plotter.ren_win, ref="view",
                                                 interactive_ratio=1, still_quality=100)
                server.controller.view_update = view.update
    return layout


def _legend() -> None:
    """The label ids listed, each with a swatch of its colour (faint when hidden)."""
    html = trame().html
    with html.Div(id="label-legend", classes="mx-2 mb-2 text-caption",
                  style="max-height: 12em; overflow-y: auto;"):
        with html.Div(v_for="entry in label_legend", key=("entry.id",),
                      classes="label-legend-entry d-flex align-center"):
            html.Span(classes="label-swatch", style=(
                "{background: entry.color, opacity: entry.hidden ? 0.2 : 1, width: '12px', "
                "height: '12px', display: 'inline-block', marginRight: '6px', "
                "border: '1px solid #888'}",))
            html.Span("{{ entry.id }}{{ entry.hidden ? ' (hidden)' : '' }}")


def _control(kind: str, knob: Knob) -> None:
    """One vuetify control bound to the knob's state (greyed out where not read)."""
    variable = state_name(kind, knob)
    common = dict(v_model=(variable,), label=knob.label, id=f"knob-{kind}-{knob.name}",
                  density="compact", classes="mx-2", hide_details=True)
    if knob.techniques:
        common["disabled"] = (f"!{list(knob.techniques)!r}.includes({kind}__technique)",)
    vuetify3 = trame().vuetify3
    if knob.control in ("select", "multiselect"):
        vuetify3.VSelect(items=(repr(list(knob.choices)),), multiple=knob.control ==
                         "multiselect", chips=knob.control == "multiselect", **common)
    elif knob.control == "switch":
        vuetify3.VSwitch(**common)
    else:
        vuetify3.VSlider(min=knob.low, max=knob.high, step=knob.step, thumb_label=True,
                         **common)


def serve(scene: Scene | str, port: int = 8080, host: str = "127.0.0.1",
          size: tuple[int, int] = (800, 600), window: str = "auto") -> None:
    """Serve the live view of ``scene`` on ``http://host:port/`` until stopped (Ctrl-C).

    ``window`` (see :func:`window_mode`): where a display exists the app also opens in a
    desktop window (``'app'``, pywebview) or the default browser (``'browser'``).
    """
    mode = window_mode(window)
    server, layout, _ = build_app(scene, size)
    warn_if_exposed(host)
    shown = host if host not in ("0.0.0.0", "::", "") else socket.gethostname()
    url = with_token(f"http://{shown}:{port}/", layout.cubemarch_token)
    print(f"pv-cubemarch view: {url}", flush=True)
    if mode == "browser":
        server.controller.on_server_ready.add(lambda **_: webbrowser.open(url))
    elif mode == "app":
        server.controller.on_server_ready.add(lambda **_: _open_window(server, url))
    server.start(port=port, host=host, open_browser=False, exec_mode="main",
                 show_connection_info=False, timeout=0)


def _open_window(server, url: str) -> None:
    """Open the page in a desktop window of its own process; stop the server when it closes.

    trame's own desktop mode opens its page without the secret, so it is not used.
    """
    window = subprocess.Popen([sys.executable, "-m", "pv_cubemarch.views.window", url])

    async def stop_when_closed():
        while window.poll() is None:
            await asyncio.sleep(0.5)
        await server.stop()

    asyncio.get_event_loop().create_task(stop_when_closed())


#: What ``pv-cubemarch view --window`` accepts.
WINDOW_MODES = ("auto", "app", "browser", "none")


def window_mode(window: str = "auto", environ: dict | None = None) -> str:
    """Where the served app opens: ``'app'``, ``'browser'`` or ``'none'`` (serve only).

    ``'auto'``: with a display (``DISPLAY`` or ``WAYLAND_DISPLAY``, or macOS/Windows) the
    default browser, a window every desktop can open; without one, nowhere. ``'app'``
    (a pywebview window) without pywebview or without a display is an error saying why.
    """
    if window not in WINDOW_MODES:
        raise ValueError(f"window={window!r}: use one of {', '.join(WINDOW_MODES)}")
    environ = os.environ if environ is None else environ
    display = sys.platform in ("darwin", "win32") or bool(
        environ.get("DISPLAY") or environ.get("WAYLAND_DISPLAY"))
    if window == "app":
        if importlib.util.find_spec("webview") is None:
            raise ImportError("window='app' opens the view in a desktop window with "
                              "pywebview: pip install pywebview (or use window='browser')")
        if not display:
            raise ValueError("window='app' needs a display (DISPLAY or WAYLAND_DISPLAY is not "
                             "set); serve with window='none' and open the printed URL")
        return "app"
    if window == "auto":
        return "browser" if display else "none"
    return window
