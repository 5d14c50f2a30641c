"""Errors raised inside our VTK observers reach whoever asked for the frame.

VTK calls a Python observer from C++; an exception raised there is printed by VTK's
wrapper and swallowed, and the frame goes on as if nothing happened. Every observer
pv_cubemarch installs goes through :func:`observe`, which records the exception in the
collector of the frame being drawn (:func:`collecting_frame_errors`, opened by
:func:`pv_cubemarch.render_frame` around ``ren_win.Render()``); the frame finishes, then
the first recorded error is raised to the caller. Outside such a frame (``pl.show()``,
``pl.render()``, ``pl.screenshot()``) a :class:`RefusedChangeError`, what refuses a user's
change, is a warning attributed to the user's line (VTK would print a traceback from
inside its observer, which no ``warnings`` filter or ``try`` catches); any other
exception goes to VTK as before, which prints it with its traceback.
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Callable

from vtkmodules.util.misc import calldata_type

from .errors import RefusedChangeError
from .user_warnings import warn_user

#: Collectors of the frames being drawn, innermost last (a frame may render another).
_collectors: list[list[Exception]] = []


def guarded(callback: Callable, calldata: int | None = None) -> Callable:
    """``callback`` as a VTK observer whose exceptions go to the current frame's collector.

    ``calldata`` is the VTK type of the event's call data (e.g. ``vtk.VTK_OBJECT``), as
    :func:`vtkmodules.util.misc.calldata_type` takes it.
    """

    @functools.wraps(callback)
    def observer(*args):
        try:
            return callback(*args)
        except Exception as exc:
            if not _collectors:
                if isinstance(exc, RefusedChangeError):   # said on the user's line
                    warn_user(str(exc))
                    return None
                raise  # no frame collects: VTK prints it, as it always did
            _collectors[-1].append(exc)
            return None

    if calldata is not None:
        observer = calldata_type(calldata)(observer)
    return observer


def observe(subject, event: int, callback: Callable, priority: float | None = None,
            calldata: int | None = None) -> int:
    """``subject.AddObserver(event, callback[, priority])`` with :func:`guarded`; the tag."""
    wrapped = guarded(callback, calldata)
    if priority is None:
        return subject.AddObserver(event, wrapped)
    return subject.AddObserver(event, wrapped, float(priority))


@contextlib.contextmanager
def collecting_frame_errors():
    """Collect the exceptions our observers raise inside the block; yields their list."""
    errors: list[Exception] = []
    _collectors.append(errors)
    try:
        yield errors
    finally:
        if _collectors and _collectors[-1] is errors:
            _collectors.pop()
        else:   # not innermost (should not happen): remove this very list, not an equal one
            _collectors[:] = [c for c in _collectors if c is not errors]


def raise_frame_errors(errors: list[Exception]) -> None:
    """Raise the first collected error (the others are named in a note)."""
    if not errors:
        return
    first = errors[0]
    if hasattr(first, "add_note"):
        first.add_note("Raised inside a VTK observer while the frame was drawn.")
        for other in errors[1:]:
            first.add_note(f"Also raised in the same frame: {type(other).__name__}: {other}")
    raise first
