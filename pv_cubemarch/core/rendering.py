"""Drawing frames we can trust: offscreen plotters and renders that surface shader errors."""

from __future__ import annotations

import numpy as np
import pyvista
import vtk
from vtkmodules.util.numpy_support import vtk_to_numpy

from .offscreen import configure_offscreen
from .shader_errors import watch_shader_errors


def offscreen_plotter(size: tuple[int, int] = (800, 600), **kwargs) -> pyvista.Plotter:
    """A ``pyvista.Plotter`` that renders offscreen through the configured backend."""
    configure_offscreen()
    width, height = (int(v) for v in size)
    if width < 1 or height < 1:
        raise ValueError(f"size must be two positive integers (width, height), got {size}.")
    return pyvista.Plotter(off_screen=True, window_size=(width, height), **kwargs)


def _bindings_of(plotter) -> list:
    component = plotter.__dict__.get("_cubemarch_component")
    return component.bindings() if component is not None else []


def render_frame(plotter: pyvista.Plotter) -> None:
    """Draw one frame and raise :class:`ShaderCompileError` if a GLSL snippet failed.

    A frame that VTK drew without our bindings (its volume mapper rebuilds its shader
    silently) is drawn again by the ``plotter.cubemarch`` component.
    """
    snippets = tuple(s for b in _bindings_of(plotter) for s in b.recipe.snippet_names)
    with watch_shader_errors(snippets):
        plotter.ren_win.Render()


def render_image(plotter: pyvista.Plotter) -> np.ndarray:
    """Render ``plotter`` and return its image as ``(height, width, 3)`` uint8."""
    render_frame(plotter)
    return read_pixels(plotter)


def _grab(plotter: pyvista.Plotter, depth: bool) -> np.ndarray:
    grab = vtk.vtkWindowToImageFilter()
    grab.SetInput(plotter.ren_win)
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
