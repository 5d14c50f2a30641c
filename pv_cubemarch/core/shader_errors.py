"""GLSL compile and link errors reported by VTK, turned into :class:`ShaderCompileError`.

VTK prints shader errors through its output window and goes on; these helpers watch that
window while a shader is built or a frame drawn, and name the snippets the errors point at.
"""

from __future__ import annotations

import contextlib
import re

from . import vtk_classes as vtk
from .errors import GpuLimitError, ShaderCompileError
from .frame_errors import observe

#: The comment line that opens each snippet in an assembled shader.
MARKER = "// pv_cubemarch snippet: "


def _snippet_at_error(log: str, snippets: tuple[str, ...]) -> tuple[str, ...]:
    """Snippets whose lines the driver's errors point at, found through our markers."""
    source_lines = {}
    for match in re.finditer(r"^\s*(\d+):\s?(.*)$", log, re.MULTILINE):
        source_lines[int(match.group(1))] = match.group(2)
    hits = []
    for match in re.finditer(r"\d+:(\d+)\(\d+\): error", log):
        line = int(match.group(1))
        for number in range(line, 0, -1):
            text = source_lines.get(number, "")
            if MARKER in text:
                hits.append(text.split(MARKER, 1)[1].strip())
                break
    found = tuple(dict.fromkeys(hits))
    return found or snippets


@contextlib.contextmanager
def watch_shader_errors(snippets: tuple[str, ...] = ()):
    """Turn GLSL compile/link errors reported by VTK inside the block into an exception."""
    window = vtk.vtkOutputWindow.GetInstance()
    messages: list[str] = []

    def collect(_caller, _event, text):
        messages.append(str(text))

    tag = observe(window, vtk.vtkCommand.ErrorEvent, collect, calldata=vtk.VTK_STRING)
    try:
        yield messages
    finally:
        window.RemoveObserver(tag)
    raise_for_shader_errors(messages, snippets)
    raise_for_texture_errors(messages)


def raise_for_texture_errors(messages: list[str]) -> None:
    """Raise where VTK's own upload refused a texture (its volume mapper then draws nothing)."""
    refused = next((m for m in messages if "Invalid texture dimensions" in m), None)
    if refused is None:
        return
    shape = re.search(r"Invalid texture dimensions \[([^\]]*)\]", refused)
    raise GpuLimitError(
        f"VTK's volume mapper could not make a 3D texture of "
        f"{'[' + shape.group(1) + ']' if shape else 'this volume'} points: it is past this "
        "GL's GL_MAX_3D_TEXTURE_SIZE (pv-cubemarch info --gl), and the volume would draw "
        "nothing; pass a coarser copy (values[::2, ::2, ::2], or grid.extract_subset(extent, "
        "rate=(2, 2, 2))) or a part of it")


def raise_for_shader_errors(messages: list[str], snippets: tuple[str, ...]) -> None:
    """Raise :class:`ShaderCompileError` if ``messages`` hold a shader compile or link error."""
    shader_lines = [m for m in messages if re.search(
        r"shader|link|compile", m, re.IGNORECASE)]
    if not shader_lines:
        return
    log = "\n".join(shader_lines)
    culprits = _snippet_at_error(log, snippets)
    driver = re.search(r"\d+:\d+\(\d+\): error:.*", log)
    first_error = driver.group(0) if driver else next(
        (line for line in log.splitlines() if "error" in line.lower()), "")
    hint = ""
    if "vertexVC" in first_error and "shadowAttenuation" in log:
        hint = (" VTK's shadow pass (PyVista's enable_shadows()) casts shadows from the "
                "props' polygons and builds its shader from theirs; pv_cubemarch's voxels and "
                "surfaces are drawn inside boxes whose polygons are not what they draw, and "
                "their shader takes no part in it (nor does an add_mesh(..., "
                "lighting=False)'s); call plotter.disable_shadows() to draw this scene.")
    raise ShaderCompileError(
        f"GLSL compile/link failed in snippet(s) {', '.join(culprits) or '(unknown)'}: "
        f"{first_error.strip()[:300]}.{hint}", log=log, snippets=culprits)
