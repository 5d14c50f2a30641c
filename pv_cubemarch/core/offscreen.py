"""Choose the offscreen OpenGL window (OSMesa by default, EGL as the alternative) and report it.

The VTK wheel selects its window class at run time from ``VTK_DEFAULT_OPENGL_WINDOW``.
With no display we set it before any window exists, so VTK never tries X (and never
prints the "bad X server connection" warning). ``PV_CUBEMARCH_GL`` chooses:
``osmesa`` (default), ``egl`` or ``auto`` (OSMesa if its library loads, else EGL).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
from functools import cache

from .errors import OffscreenUnavailableError

BACKEND_ENV = "PV_CUBEMARCH_GL"
WINDOW_CLASSES = {"osmesa": "vtkOSOpenGLRenderWindow", "egl": "vtkEGLRenderWindow"}
_LIBRARIES = {
    "osmesa": ("OSMesa", "libOSMesa.so.8", "libOSMesa.so"),
    "egl": ("EGL", "libEGL.so.1", "libEGL.so"),
}
_INSTALL_HINT = (
    "Install Mesa's offscreen libraries, e.g. on Debian/Ubuntu "
    "`apt-get install libosmesa6` (OSMesa) or `apt-get install libegl1 libegl-mesa0` (EGL), "
    f"or set {BACKEND_ENV}=egl|osmesa to pick the one you have."
)


def has_display() -> bool:
    """Whether an X11 or Wayland display is available to open on-screen windows."""
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


@cache
def library_available(backend: str) -> bool:
    """Whether the shared library behind ``backend`` ('osmesa' or 'egl') can be loaded."""
    for name in _LIBRARIES[backend]:
        path = ctypes.util.find_library(name) if "." not in name else name
        if not path:
            continue
        try:
            ctypes.CDLL(path)
        except OSError:
            continue
        return True
    return False


def requested_backend() -> str:
    """The backend the user asked for through ``PV_CUBEMARCH_GL`` (default ``osmesa``)."""
    value = os.environ.get(BACKEND_ENV, "osmesa").strip().lower() or "osmesa"
    if value not in ("osmesa", "egl", "auto"):
        raise OffscreenUnavailableError(
            f"{BACKEND_ENV}={value!r} is not a known offscreen backend; "
            "use 'osmesa', 'egl' or 'auto'."
        )
    return value


def choose_backend() -> str:
    """Resolve the requested backend to one whose library loads, or raise with install advice."""
    wanted = requested_backend()
    order = {"osmesa": ["osmesa", "egl"], "egl": ["egl", "osmesa"],
             "auto": ["osmesa", "egl"]}[wanted]
    for backend in order:
        if library_available(backend):
            return backend
    raise OffscreenUnavailableError(
        f"No offscreen OpenGL library could be loaded (tried {', '.join(order)}). {_INSTALL_HINT}"
    )


def configure_offscreen() -> str | None:
    """Select the offscreen window class when there is no display; return the backend used.

    A ``VTK_DEFAULT_OPENGL_WINDOW`` set by the user is respected. Returns ``None`` when a
    display exists and nothing was changed.
    """
    if os.environ.get("VTK_DEFAULT_OPENGL_WINDOW"):
        for name, cls in WINDOW_CLASSES.items():
            if cls == os.environ["VTK_DEFAULT_OPENGL_WINDOW"]:
                return name
        return None
    if has_display() and BACKEND_ENV not in os.environ:
        return None
    backend = choose_backend()
    os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = WINDOW_CLASSES[backend]
    import pyvista

    pyvista.OFF_SCREEN = True
    return backend


def gl_info() -> dict[str, str]:
    """Open a tiny offscreen window and report the window class and GL strings really used.

    Returns
    -------
    dict
        ``window_class``, ``vendor``, ``renderer``, ``version`` and ``backend``.

    Examples
    --------
    >>> import pv_cubemarch
    >>> pv_cubemarch.gl_info()["window_class"]  # doctest: +SKIP
    'vtkOSOpenGLRenderWindow'
    """
    import pyvista

    backend = configure_offscreen()
    plotter = pyvista.Plotter(off_screen=True, window_size=(8, 8))
    try:
        window = plotter.ren_win
        window.Render()
        if not window.IsCurrent():
            window.MakeCurrent()
        report = window.ReportCapabilities() or ""
        info = {"window_class": window.GetClassName(), "backend": backend or "display"}
        keys = {"vendor": "OpenGL vendor string:", "renderer": "OpenGL renderer string:",
                "version": "OpenGL version string:"}
        for key, prefix in keys.items():
            info[key] = next((line.split(":", 1)[1].strip() for line in report.splitlines()
                              if line.startswith(prefix)), "unknown")
        return info
    except Exception as exc:  # pragma: no cover - depends on the machine's GL stack
        raise OffscreenUnavailableError(f"Could not open an offscreen GL context: {exc}. "
                                        f"{_INSTALL_HINT}") from exc
    finally:
        plotter.close()
