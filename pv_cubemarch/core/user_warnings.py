"""Warnings attributed to the user's line, not to this package, PyVista or VTK."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import pyvista
import vtkmodules

#: Where frames are not the user's: this package, PyVista and VTK (warnings skip them).
_LIBRARIES = tuple(str(Path(module.__file__).resolve().parent)
                   for module in (pyvista, vtkmodules)) + (
    str(Path(__file__).resolve().parents[1]),)


def warn_user(message: str, category: type[Warning] = UserWarning) -> None:
    """Warn, attributed to the first caller outside this package, PyVista and VTK.

    A warning raised in a VTK observer during a frame then points at the line that drew it.
    """
    frame, level = sys._getframe(1), 2
    while frame is not None and str(Path(frame.f_code.co_filename).resolve()).startswith(
            _LIBRARIES):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, category, stacklevel=level)
