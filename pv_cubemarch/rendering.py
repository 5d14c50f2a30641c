"""Drawing frames we can trust: offscreen plotters and renders that surface shader errors."""

from __future__ import annotations

import numpy as np
import pyvista

from .offscreen import configure_offscreen
from .shaders import raise_for_shader_errors


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
    """Draw one frame, again if VTK rebuilt a shader without our bindings, and check errors.

    VTK's volume mapper does not announce a frame on which it (re)builds its shader, so
    our textures are missing on that one frame; we then draw it once more.
    """
    import vtk
    from vtkmodules.util.misc import calldata_type

    messages: list[str] = []

    @calldata_type(vtk.VTK_STRING)
    def collect(_caller, _event, text):
        messages.append(str(text))

    output = vtk.vtkOutputWindow.GetInstance()
    tag = output.AddObserver(vtk.vtkCommand.ErrorEvent, collect)
    try:
        plotter.ren_win.Render()
        if any(b.missed_last_frame for b in _bindings_of(plotter)):
            plotter.ren_win.Render()
    finally:
        output.RemoveObserver(tag)
    snippets = tuple(s for b in _bindings_of(plotter) for s in b.recipe.snippet_names)
    raise_for_shader_errors(messages, snippets)


def render_image(plotter: pyvista.Plotter) -> np.ndarray:
    """Render ``plotter`` and return its image as ``(height, width, 3)`` uint8."""
    render_frame(plotter)
    return read_pixels(plotter)


def read_pixels(plotter: pyvista.Plotter) -> np.ndarray:
    """The last drawn frame as ``(height, width, 3)`` uint8, rows top to bottom, no redraw."""
    import vtk
    from vtkmodules.util.numpy_support import vtk_to_numpy

    grab = vtk.vtkWindowToImageFilter()
    grab.SetInput(plotter.ren_win)
    grab.SetInputBufferTypeToRGB()
    grab.ReadFrontBufferOff()
    grab.ShouldRerenderOff()
    grab.Update()
    image = grab.GetOutput()
    width, height, _ = image.GetDimensions()
    pixels = vtk_to_numpy(image.GetPointData().GetScalars()).reshape(height, width, -1)
    return np.ascontiguousarray(pixels[::-1, :, :3])
