"""Drawing frames we can trust: offscreen plotters and renders that surface shader errors."""

from __future__ import annotations

import functools
import weakref

import numpy as np
import pyvista
from vtkmodules.util.numpy_support import vtk_to_numpy

from . import vtk_classes as vtk
from .errors import PlotterClosedError, RefusedChangeError
from .frame_errors import collecting_frame_errors, raise_frame_errors
from .offscreen import configure_offscreen
from .progress import progress
from .shader_errors import watch_shader_errors


def offscreen_plotter(size: tuple[int, int] = (800, 600), **kwargs) -> pyvista.Plotter:
    """A ``pyvista.Plotter`` that renders offscreen through the configured backend."""
    configure_offscreen()
    width, height = (int(v) for v in size)
    if width < 1 or height < 1:
        raise ValueError(f"size must be two positive integers (width, height), got {size}.")
    return pyvista.Plotter(off_screen=True, window_size=(width, height), **kwargs)


def tracked_bindings(plotter) -> list:
    """The bindings the plotter's cubemarch component follows (streamed sources among them)."""
    component = plotter.__dict__.get("_cubemarch_component")
    return list(component.tracked) if component is not None else []


def _bindings_of(plotter) -> list:
    component = plotter.__dict__.get("_cubemarch_component")
    return component.bindings() if component is not None else []


def open_window(plotter: pyvista.Plotter):
    """The plotter's render window, or :class:`PlotterClosedError` once it was closed."""
    window = getattr(plotter, "ren_win", None)
    if window is None:
        raise PlotterClosedError(
            "The plotter is closed (plotter.close() freed its window); nothing can be "
            "rendered or read from it. Make a new plotter and add the volumes again.")
    return window


def check_open(renderer) -> None:
    """Raise :class:`PlotterClosedError` once the plotter ``renderer`` belongs to is closed.

    An actor outlives its plotter's ``close()``: its edits and picks would do nothing, or
    answer as if nothing were there.
    """
    try:
        plotter = getattr(renderer, "parent", None)    # PyVista's renderer: its plotter
        closed = plotter is not None and getattr(plotter, "ren_win", None) is None
    except ReferenceError:                               # the plotter itself is gone
        closed = True
    if closed:
        raise PlotterClosedError(
            "The plotter of this actor is closed (plotter.close() freed its window): its "
            "edits, values and picks went with it. Make a new plotter and add the data "
            "again.")


def needs_open_plotter(method):
    """Decorate an actor's edit or pick: :class:`PlotterClosedError` once its plotter closed."""
    @functools.wraps(method)
    def checked(self, *args, **kwargs):
        check_open(getattr(self, "main_renderer", None) or self.renderer)
        return method(self, *args, **kwargs)
    return checked


_GL_MAX_RENDERBUFFER_SIZE = 0x84E8
_GL_MAX_VIEWPORT_DIMS = 0x0D3A
#: Each window's largest side GL draws (its renderbuffer and viewport limits), once read.
_size_limits: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def check_window_size(window) -> None:
    """Raise :class:`RefusedChangeError` if ``window`` is larger than GL draws here.

    Past GL's renderbuffer or viewport limit (16384 on llvmpipe) a frame is drawn wrong
    without any error from GL or VTK (one colour, or garbage); larger still, the process
    aborts. The limit is read from the window's context (made here if not yet).
    """
    limit = _size_limits.get(window)
    if limit is None:
        if window.GetNeverRendered():
            window.Initialize()
        buffer, viewport = [0], [0, 0]
        window.GetState().vtkglGetIntegerv(_GL_MAX_RENDERBUFFER_SIZE, buffer)
        window.GetState().vtkglGetIntegerv(_GL_MAX_VIEWPORT_DIMS, viewport)
        limit = min(int(buffer[0]), *(int(v) for v in viewport))
        if limit <= 0:   # not read (no context): nothing to check against
            return
        _size_limits[window] = limit
    tiles = [max(int(v), 1) for v in window.GetTileScale()]   # a tiled screenshot's
    width, height = (int(v) // t for v, t in zip(window.GetSize(), tiles, strict=True))
    if max(width, height) > limit:
        raise RefusedChangeError(
            f"A window of {width}x{height} pixels is larger than this GL draws ({limit} "
            f"a side: GL_MAX_RENDERBUFFER_SIZE / GL_MAX_VIEWPORT_DIMS); past it the image is "
            f"drawn wrong without an error. Use a window of at most {limit} a side.")


def render_frame(plotter: pyvista.Plotter) -> None:
    """Draw one frame; raise what went wrong while it was drawn.

    :class:`ShaderCompileError` if a GLSL snippet failed; an exception raised inside one of
    our VTK observers during the frame (which VTK alone would print and swallow) is raised
    here once the frame is done; :class:`PlotterClosedError` after ``plotter.close()``.
    A frame that VTK drew without our bindings (its volume mapper rebuilds its shader
    silently) is drawn again by the ``plotter.cubemarch`` component.
    """
    window = open_window(plotter)
    check_window_size(window)
    first_render = getattr(plotter, "_on_first_render_request", None)
    if first_render is not None:   # PyVista's default camera, as show() and screenshot() set it
        first_render()
    snippets = tuple(s for b in _bindings_of(plotter) for s in b.recipe.snippet_names)
    with watch_shader_errors(snippets):
        with collecting_frame_errors() as errors:
            window.Render()
    if first_render is not None:
        plotter._rendered = True   # drawn: PyVista's screenshot() may read it
    raise_frame_errors(errors)


def render_image(plotter: pyvista.Plotter, converge: bool = False,
                 timeout: float = 60.0, progress_bar: bool | None = False) -> np.ndarray:
    """Render ``plotter`` and return its image as ``(height, width, 3)`` uint8.

    ``converge``: render again until every volume streamed by bricks has all it wants for
    this view (each frame draws what has arrived; between frames the bricks being read are
    waited for), at most ``timeout`` seconds; past it, a warning says what was missing and
    the last image is returned. ``progress_bar``: a bar of the bricks resident against
    those wanted while it converges (``None``: on a terminal only).
    """
    render_frame(plotter)
    if converge:
        _converge(plotter, float(timeout), progress_bar)
    return read_pixels(plotter)


def _converge(plotter: pyvista.Plotter, timeout: float, progress_bar: bool | None) -> None:
    """Frames until no streamed volume misses a brick (see :func:`render_image`)."""
    import time
    import warnings

    deadline = time.perf_counter() + timeout
    bar = None
    while True:
        streaming = [b for b in tracked_bindings(plotter)
                     if b.shown and not getattr(b, "converged", True)]
        if progress_bar is not False and (streaming or bar is not None):
            counts = [b.stats() for b in tracked_bindings(plotter) if hasattr(b, "stats")]
            resident = sum(c["resident"] for c in counts)
            if bar is None:
                bar = progress(desc="streaming bricks", total=1, enabled=progress_bar)
            bar.total = resident + sum(c["missing"] for c in counts)
            bar.n = resident
            bar.refresh()
        if not streaming:
            if bar is not None:
                bar.close()
            full = [b for b in tracked_bindings(plotter) if b.shown and hasattr(b, "stats")
                    and b.stats().get("over_budget")]
            if full:   # said, not drawn coarser in silence
                warnings.warn("render_image(converge=True): the GPU pool of "
                              f"{', '.join(repr(b.name) for b in full)} holds too few "
                              "bricks for this view, so coarser levels are drawn where it "
                              "had no room; give it more bytes (gpu_bytes=, --gpu-bytes) or a "
                              "larger lod_bias.", stacklevel=3)
            return
        left = deadline - time.perf_counter()
        if left <= 0:
            if bar is not None:
                bar.close()
            warnings.warn(f"render_image(converge=True): not converged after {timeout:g} s "
                          f"({'; '.join(str(b.stats()) for b in streaming)}); the image "
                          "shows coarser levels where bricks are missing.", stacklevel=3)
            return
        streaming[0].wait_for_bricks(min(left, 0.5))
        render_frame(plotter)


def _grab(plotter: pyvista.Plotter, depth: bool) -> np.ndarray:
    window = open_window(plotter)
    grab = vtk.vtkWindowToImageFilter()
    grab.SetInput(window)
    if depth:
        grab.SetInputBufferTypeToZBuffer()
    else:
        grab.SetInputBufferTypeToRGB()
    grab.ReadFrontBufferOff()
    grab.ShouldRerenderOff()
    grab.Update()
    image = grab.GetOutput()
    width, height, _ = image.GetDimensions()
    values = vtk_to_numpy(image.GetPointData().GetScalars()).reshape(height, width, -1)
    return np.ascontiguousarray(values[::-1])


def read_pixels(plotter: pyvista.Plotter) -> np.ndarray:
    """The last drawn frame as ``(height, width, 3)`` uint8, rows top to bottom, no redraw."""
    return _grab(plotter, depth=False)[..., :3]


def read_depth(plotter: pyvista.Plotter) -> np.ndarray:
    """The last frame's depth buffer, ``(height, width)`` in [0, 1], rows top to bottom."""
    return _grab(plotter, depth=True)[..., 0]
