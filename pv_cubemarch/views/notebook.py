"""``plotter.show()`` in a notebook: our techniques' plotters shown by the server-rendered view.

PyVista's client-side notebook backends (``'client'``, ``'html'`` and the client half of
``'trame'``) draw with vtk.js, which cannot run our GLSL: a volume would show as its proxy
box. Importing pv_cubemarch (with the ``jupyter`` extra) registers wrappers of PyVista's
trame backends (:func:`pyvista.register_jupyter_backend`): a plotter that holds one of our
actors is shown by :func:`~.live.live_view` (panel closed), warning when a client-side
backend was set; any other plotter goes to the handler registered before ours
(trame-pyvista's, when installed), or without one to PyVista's static image, as before.
``'static'`` (a server-rendered image: correct) and ``'none'`` are left alone.
The backend ``'cubemarch'`` shows any plotter by the live view.
"""

from __future__ import annotations

import warnings

import pyvista
from pyvista.jupyter.notebook import show_static_image

from .app import has_trame
from .live import LiveView, live_view

#: PyVista's backends that our wrappers take over for plotters holding our actors.
WRAPPED_BACKENDS = ("trame", "server", "client", "html")
#: Of those, the ones that render in the browser (vtk.js), which cannot draw our GLSL.
CLIENT_SIDE_BACKENDS = ("client", "html")


def holds_our_actors(plotter: pyvista.Plotter) -> bool:
    """Whether any renderer of ``plotter`` holds a volume, voxel grid or surface of ours."""
    return any(getattr(actor, "cubemarch", None) is not None
               for renderer in plotter.renderers for actor in renderer.actors.values())


def show_server_rendered(plotter: pyvista.Plotter, screenshot=None, panel: bool = False,
                         **ignored) -> LiveView:
    """PyVista's notebook backend ``'cubemarch'``: the live view of ``plotter``.

    ``screenshot`` (a path) also saves the first frame, as PyVista's backends do; ``panel``
    opens the knob panel. Other keywords (``jupyter_kwargs`` meant for trame-pyvista) are
    ignored with a warning naming them.
    """
    if ignored:
        warnings.warn(f"pv_cubemarch's server-rendered view ignores jupyter_kwargs "
                      f"{sorted(ignored)}", stacklevel=3)
    if screenshot:
        plotter.screenshot(screenshot)
    return live_view(plotter, panel=panel)


def _wrapped(name: str, original):
    """The handler registered under PyVista's backend ``name`` (``original``: the one before)."""
    def handler(plotter, screenshot=None, **kwargs):
        if not holds_our_actors(plotter):
            if original is None:                 # PyVista's own fallback, as before us
                warnings.warn(f"no notebook backend {name!r} is installed for plotters "
                              "without pv_cubemarch's actors: showing a static image "
                              "(pip install 'pyvista[jupyter]' for PyVista's interactive "
                              "views)", stacklevel=3)
                return show_static_image(plotter, screenshot)
            return original(plotter, screenshot=screenshot, **kwargs)   # as before us
        if name in CLIENT_SIDE_BACKENDS:         # asked for: the auto choice is 'trame'
            warnings.warn(
                f"jupyter backend {name!r} renders in the browser (vtk.js), which cannot run "
                "pv_cubemarch's shaders (a volume would show as its box): showing the "
                "server-rendered view instead. Set pyvista.set_jupyter_backend('trame') or "
                "'cubemarch' to silence this.", stacklevel=3)
        kwargs.pop("mode", None)            # trame-pyvista's; ours is always server-side
        try:
            return show_server_rendered(plotter, screenshot=screenshot, **kwargs)
        except (ImportError, OSError, ValueError, RuntimeError) as error:
            warnings.warn(f"pv_cubemarch's live view could not start ({error}): showing a "
                          "static image of the server's rendering instead", stacklevel=3)
            return show_static_image(plotter, screenshot)
    handler.__qualname__ = f"wrapped_{name}_backend"
    return handler


def register_notebook_backends() -> bool:
    """Register the wrapped backends and ``'cubemarch'``; ``False`` without trame.

    The handlers already registered under those names (trame-pyvista's: discovered first,
    which imports it, so that it cannot replace ours later) are kept to show the plotters
    that hold none of our actors. Without trame (the ``jupyter`` extra) nothing is
    registered: PyVista's own fallbacks (a static image) stay, and they draw our
    techniques correctly.
    """
    if not has_trame():
        return False
    before = {b.name: b.handler for b in pyvista.registered_jupyter_backends()}
    for name in WRAPPED_BACKENDS:
        original = before.get(name)
        if getattr(original, "__module__", None) == __name__:
            continue                                 # registered already (a reload)
        pyvista.register_jupyter_backend(name, _wrapped(name, original), override=True)
    pyvista.register_jupyter_backend("cubemarch", show_server_rendered, override=True)
    return True
