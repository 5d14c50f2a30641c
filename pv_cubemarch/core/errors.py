"""Exception types raised by pv_cubemarch, so callers can catch what they can act on."""

from __future__ import annotations


class CubemarchError(Exception):
    """Base class of every error pv_cubemarch raises on purpose."""


class OffscreenUnavailableError(CubemarchError, RuntimeError):
    """No offscreen OpenGL path (OSMesa or EGL) could be opened."""


class ShaderCompileError(CubemarchError, RuntimeError):
    """A GLSL compile or link error, with the driver's log and the snippets involved."""

    def __init__(self, message: str, log: str = "", snippets: tuple[str, ...] = ()):
        super().__init__(message)
        self.log = log
        self.snippets = snippets


class RefusedOptionsError(CubemarchError, ValueError):
    """Options that cannot be used with what is added: their names and why, apart.

    ``names``: each option as given (``'shade'``, ``"blending='maximum'"``); ``why``: the
    reason in words of no one channel, so the command line can say it with its flags.
    """

    def __init__(self, message: str, names, why: str):
        super().__init__(message)
        self.names = list(names)
        self.why = why


class SceneLoadError(CubemarchError, ValueError):
    """A scene file is missing, corrupt or uses something we cannot read."""


class VolumeDataError(CubemarchError, ValueError):
    """Volume data that cannot be rendered as given (bad dtype, NaN, non-uniform grid...)."""


class RefusedChangeError(CubemarchError, ValueError):
    """A change made after adding that is not drawn: refused, and set back where it can be.

    Raised at the next frame (inside VTK's observers): ``render_image`` raises it, and a
    frame drawn otherwise (``show``, ``render``) says it as a warning.
    """


class StoreReadError(CubemarchError, RuntimeError):
    """A level's points could not be read from its store (what was asked, and why)."""


class GpuLimitError(CubemarchError, RuntimeError):
    """GL refused what the data need (a texture past its limits): nothing would be drawn."""


class PlotterClosedError(CubemarchError, RuntimeError):
    """The plotter was closed (``plotter.close()``): it has no window to draw in any more."""


class SceneChangedError(CubemarchError, RuntimeError):
    """The scene changed in a way a volume cannot follow (e.g. its number of lights)."""


class SceneWarning(UserWarning):
    """Part of a scene was left out or drawn approximately; ``scene.skipped`` says which and why."""


class VolumeDataWarning(UserWarning):
    """Data that draws, but likely not as meant (a constant volume: nothing shows)."""
