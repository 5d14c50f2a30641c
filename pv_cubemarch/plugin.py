"""PyVista entry points: the ``plotter.cubemarch`` component and the USD readers.

Declared in ``pyproject.toml`` under ``pyvista.plotter_components`` and ``pyvista.readers``,
so PyVista imports this module lazily, on first use; nothing is monkey-patched.
"""

from __future__ import annotations

import weakref

import pyvista


@pyvista.register_plotter_component("cubemarch")
class CubemarchComponent:
    """``plotter.cubemarch``: pv_cubemarch's techniques on any ``pyvista.Plotter``.

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> pl = pv.Plotter(off_screen=True)
    >>> actor = pl.cubemarch.add_volume(np.random.rand(16, 16, 16))
    >>> image = pl.cubemarch.screenshot()  # doctest: +SKIP
    """

    def __init__(self, plotter):
        self._plotter = weakref.proxy(plotter)
        self._tracked: list = []
        self._redrawing = False
        self._window = plotter.ren_win
        self._window_tag = None
        if self._window is not None:
            import vtk

            self._window_tag = self._window.AddObserver(vtk.vtkCommand.EndEvent,
                                                        self._redraw_if_missed)
        plotter.__dict__["_cubemarch_component"] = self

    def _redraw_if_missed(self, window, _event) -> None:
        """Draw again, once, a frame on which VTK rebuilt a shader without our bindings.

        VTK's volume mapper skips ``UpdateShaderEvent`` on such a frame, so every path that
        renders (``show``, ``screenshot``, our own) gets a second, complete frame.
        """
        if self._redrawing or not any(b.missed_last_frame for b in self.bindings()):
            return
        self._redrawing = True
        try:
            window.Render()
        finally:
            self._redrawing = False

    def add_volume(self, volume, scalars=None, **kwargs):
        """Same as :func:`pv_cubemarch.add_volume` on this plotter."""
        from .emission_absorption import add_volume

        return add_volume(self._plotter, volume, scalars, **kwargs)

    def add_scene(self, scene, camera=None):
        """Add a :class:`~pv_cubemarch.Scene` (or a path to one) to this plotter."""
        from .scene_io import load_scene

        if not hasattr(scene, "add_to"):
            scene = load_scene(scene)
        return scene.add_to(self._plotter, camera=camera)

    def render(self) -> None:
        """Draw a frame, raising :class:`~pv_cubemarch.ShaderCompileError` on GLSL errors."""
        from .rendering import render_frame

        render_frame(self._plotter)

    def screenshot(self, filename=None):
        """Render and return the image as uint8 RGB (and save it when ``filename`` is given)."""
        from .rendering import render_image

        image = render_image(self._plotter)
        if filename is not None:
            from PIL import Image

            Image.fromarray(image).save(str(filename))
        return image

    @property
    def memory(self) -> dict[str, int]:
        """GPU bytes our techniques added, by actor name."""
        return {item.name: item.nbytes for item in self._tracked}

    def remove(self, actor) -> bool:
        """Remove an actor added by pv_cubemarch and free its GPU resources now."""
        for item in list(self._tracked):
            if getattr(item, "actor", None) is actor:
                item.release()
                self._tracked.remove(item)
                return bool(self._plotter.remove_actor(actor))
        return bool(self._plotter.remove_actor(actor))

    def track(self, item) -> None:
        """Keep ``item`` (with ``bindings`` and ``release()``) until the plotter closes."""
        self._tracked.append(item)

    def bindings(self) -> list:
        """The shader bindings of every tracked technique."""
        return [item.bindings for item in self._tracked]

    def __plotter_close__(self) -> None:
        for item in self._tracked:
            item.release()
        self._tracked.clear()
        if self._window is not None and self._window_tag is not None:
            self._window.RemoveObserver(self._window_tag)
        self._window = None


def read_usd(path: str, **kwargs) -> pyvista.MultiBlock:
    """``pyvista.read`` handler for .usd/.usda/.usdc/.usdz: the scene's meshes and volumes."""
    from .usd_import import load_usd

    return load_usd(path, progress_bar=kwargs.get("progress_bar")).to_multiblock()
