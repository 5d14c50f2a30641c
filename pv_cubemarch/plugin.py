"""PyVista entry points: the ``plotter.cubemarch`` component and the USD readers.

Declared in ``pyproject.toml`` under ``pyvista.plotter_components`` and ``pyvista.readers``,
so PyVista imports this module lazily, on first use; nothing is monkey-patched.
"""

from __future__ import annotations

import weakref

import pyvista
from PIL import Image

from .api import add_surface, add_volume, add_voxels
from .core import vtk_classes as vtk
from .core.frame_errors import observe
from .core.rendering import check_window_size, render_frame, render_image
from .core.scalar_bar import drop_scalar_bar_mapper
from .core.user_warnings import warn_user
from .gl.draw_order import sort_far_to_near
from .gl.frame_inputs import MultisamplePolicy, release_frame_inputs
from .scene import usd  # its USD modules imported once a stage is read
from .scene.io import load_scene
from .scene.openvdb.image import read_vdb
from .volume.binding import VolumeBinding


@pyvista.register_plotter_component("cubemarch")
class CubemarchComponent:
    """``plotter.cubemarch``: pv_cubemarch's techniques on any ``pyvista.Plotter``.

    At the start of every frame it follows the scene: a volume whose actor left the
    plotter (``remove_actor``, ``clear``, another actor under its name) is released, the
    drawn actors follow the returned actor's visibility, and the window's multisampling
    and translucency settings are decided from what the frame draws.

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
        self._observers: list = []
        self._multisampling = None
        self._user_oit: dict = {}
        self._bar_mappers: list = []   # (renderer, actor, mapper, keywords): bar and actor
        self._gone: list = []          # (actor's weak reference, renderer, name): released
        self._said: set = set()        # what _say_what_is_not_drawn said (once each)
        self._props_seen = None        # the props' state when copies were last looked for
        if self._window is not None:
            self._multisampling = MultisamplePolicy(self._window)
            self._observers = [
                (self._window, observe(self._window, vtk.vtkCommand.StartEvent,
                                       self._follow_scene)),
                (self._window, observe(self._window, vtk.vtkCommand.EndEvent,
                                       self._redraw_if_missed)),
            ]
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

    def _follow_scene(self, *_) -> None:
        """Before a frame: drop removed volumes, follow the returned actors, window settings."""
        self.release_removed()
        self._say_if_added_again()
        self._say_what_is_not_drawn()
        single_sample = False
        translucent: dict = {}
        volumes: dict = {}   # renderer: the props drawing volumes in it
        for item in self._tracked:
            item.follow_anchor()
            shown = bool(item.actor.GetVisibility())
            single_sample |= shown and item.needs_single_sample
            if shown and item.blends_in_main_renderer:
                translucent[item.main_renderer] = True
            if shown and isinstance(item, VolumeBinding) and item.renderer is item.main_renderer:
                volumes.setdefault(item.renderer, []).extend(item.drawn)
        for renderer, props in volumes.items():   # the nearer composited over the farther
            sort_far_to_near(renderer, props)
        if not self._redrawing:
            self._multisampling.decide(single_sample)
        # Weighted order-independent translucency would reweight a box's single layer.
        for renderer, user in list(self._user_oit.items()):
            if renderer not in translucent:
                renderer.SetUseOIT(user)
                del self._user_oit[renderer]
        for renderer in translucent:
            self._user_oit.setdefault(renderer, bool(renderer.GetUseOIT()))
            renderer.SetUseOIT(False)
        check_window_size(self._window)   # last: said (show, screenshot), the rest done

    def release_removed(self) -> list:
        """Release every volume whose actor is no longer in its renderer; return them."""
        gone = [item for item in self._tracked
                if item.actor is None or not item.main_renderer.HasViewProp(item.actor)]
        for item in gone:
            item.release()
            self._tracked.remove(item)
            if item.actor is not None:
                self._gone = self._gone[-63:] + [
                    (weakref.ref(item.actor), item.main_renderer, item.name)]
        for held in [h for h in self._bar_mappers if not h[0].HasViewProp(h[1])]:
            self._bar_mappers.remove(held)
            drop_scalar_bar_mapper(self._plotter, held[2])
        in_use = {id(item.main_renderer) for item in self._tracked}
        for renderer in {id(item.main_renderer): item.main_renderer for item in gone}.values():
            if id(renderer) not in in_use:
                release_frame_inputs(renderer)   # the shared depth copy goes with the last
        return gone

    def _say_if_added_again(self) -> None:
        """Warn where an actor removed (what it drew released) was added again: it draws nothing."""
        for entry in list(self._gone):
            actor, renderer, name = entry
            actor = actor()
            if actor is None or renderer.HasViewProp(actor):
                self._gone.remove(entry)
            if actor is not None and renderer.HasViewProp(actor):
                warn_user(f"{name!r} was removed from the plotter, which released what it "
                          "drew, and was added again: it draws nothing. Add the data "
                          "again (add_volume, add_voxels, add_surface) instead.")

    def _say_what_is_not_drawn(self) -> None:
        """Once each: a returned actor added to another subplot, volumes under shadows.

        Both drew wrong in silence: the actor's drawing lives in its own renderer (it
        draws nothing in the other), and VTK's shadow pass casts shadows from the props'
        polygons, which for ours are boxes (volumes vanished or were drawn over the floor).
        """
        renderers = list(getattr(self._plotter, "renderers", ()))
        self._say_copies(renderers)
        for item in self._tracked:
            actor = item.actor
            for renderer in renderers:
                key = (id(actor), id(renderer))
                if (renderer is not item.main_renderer and key not in self._said
                        and renderer.HasViewProp(actor)):
                    self._said.add(key)
                    warn_user(f"{item.name!r} was added to another subplot with add_actor: "
                              "its drawing belongs to the subplot it was added to and draws "
                              "nothing there. Add the data again in that subplot (or link "
                              "the subplots' cameras with link_views).")
            shadows = getattr(getattr(item.main_renderer, "_render_passes", None),
                              "_shadow_map_pass", None)
            if shadows is not None and ("shadows", id(item)) not in self._said:
                self._said.add(("shadows", id(item)))
                volume = isinstance(item, VolumeBinding)
                what = "a volume's" if volume else "a grid's or a surface's"
                warn_user(f"{item.name!r}: VTK's shadow pass (enable_shadows()) casts shadows "
                          f"from the props' polygons, and {what} are the box it is drawn in: "
                          "it is not drawn right under it. Call plotter.disable_shadows()"
                          + ("; add_volume(lights='scene') shades a volume with its own "
                             "shadows." if volume else "."))

    def _say_copies(self, renderers) -> None:
        """Once each: a prop sharing a returned actor's mapper (a copy) draws nothing.

        Looked for only when a renderer's props or the tracked drawings change (a world
        has a prop per chunk): the frames between cost one look at each renderer's props.
        """
        state = (len(self._tracked), *((id(r), r.GetViewProps().GetMTime()) for r in renderers))
        if state == self._props_seen:
            return
        self._props_seen = state
        mappers = {}
        for item in self._tracked:
            actor = getattr(item, "actor", None)
            if actor is not None and actor.GetMapper() is not None:   # by VTK's address:
                mappers[actor.GetMapper().GetAddressAsString("vtkObject")] = item   # not id()
        for renderer in renderers:
            props = renderer.GetViewProps()
            props.InitTraversal()
            for _ in range(props.GetNumberOfItems()):
                prop = props.GetNextProp()
                mapper = prop.GetMapper() if hasattr(prop, "GetMapper") else None
                item = None if mapper is None else mappers.get(
                    mapper.GetAddressAsString("vtkObject"))
                if item is not None and prop is not item.actor and (
                        "copy", id(prop)) not in self._said:
                    self._said.add(("copy", id(prop)))
                    warn_user(f"a prop sharing the mapper of {_shown_name(item)!r} (a copy of its "
                              "actor) draws nothing: the drawing belongs to the actor it "
                              "was returned as. Add the data again to draw it elsewhere "
                              "(user_matrix= places it).")

    def add_volume(self, volume, scalars=None, **kwargs):
        """Same as :func:`pv_cubemarch.add_volume` on this plotter."""
        return add_volume(self._plotter, volume, scalars, **kwargs)

    def add_voxels(self, grid, scalars=None, **kwargs):
        """Same as :func:`pv_cubemarch.add_voxels` on this plotter."""
        return add_voxels(self._plotter, grid, scalars, **kwargs)

    def add_surface(self, field, isovalue=None, scalars=None, **kwargs):
        """Same as :func:`pv_cubemarch.add_surface` on this plotter."""
        return add_surface(self._plotter, field, isovalue, scalars, **kwargs)

    def add_scene(self, scene, camera=None, **load_options):
        """Add a :class:`~pv_cubemarch.Scene` (or a path to one) to this plotter.

        ``load_options`` (``time``, ``strict``, ``as_voxels`` ...) go to
        :func:`~pv_cubemarch.load_scene` when ``scene`` is a path.
        """
        if not hasattr(scene, "add_to"):
            scene = load_scene(scene, **load_options)
        return scene.add_to(self._plotter, camera=camera)

    def render(self) -> None:
        """Draw a frame, raising :class:`~pv_cubemarch.ShaderCompileError` on GLSL errors."""
        render_frame(self._plotter)

    def screenshot(self, filename=None):
        """Render and return the image as uint8 RGB (and save it when ``filename`` is given)."""
        image = render_image(self._plotter)
        if filename is not None:
            Image.fromarray(image).save(str(filename))
        return image

    @property
    def memory(self) -> dict[str, int]:
        """GPU bytes our techniques added, by volume name (a frame budget's targets too)."""
        return {item.name: item.nbytes + _reduced_bytes(item) for item in self._tracked}

    def remove(self, actor) -> bool:
        """Remove an actor added by pv_cubemarch and free its GPU resources now."""
        removed = bool(self._plotter.remove_actor(actor))
        self.release_removed()
        return removed

    def follow_scalar_bar(self, actor, mapper, show: bool = False, args=None) -> None:
        """Take ``mapper`` off the scalar bars when ``actor`` leaves the active renderer.

        PyVista's ``remove_actor`` takes an actor's bar (when no other actor holds it) by
        the actor's mapper; ours colour through a mapper of their own, followed here.
        ``show`` and ``args`` (the keywords the bar was added with) are kept for
        :meth:`scalar_bar_keywords`.
        """
        keywords = {"show_scalar_bar": bool(show)}
        if show and args:
            keywords["scalar_bar_args"] = dict(args)
        self._bar_mappers.append((self._plotter.renderer, actor, mapper, keywords))

    def scalar_bar_keywords(self, actor) -> dict:
        """The scalar-bar keywords ``actor`` was added with (the live view adds it so again)."""
        return next((dict(held[3]) for held in self._bar_mappers if held[1] is actor), {})

    def track(self, item) -> None:
        """Keep ``item`` (with ``bindings`` and ``release()``) until its actor leaves."""
        self.release_removed()  # an actor of the same name may just have been replaced
        self._tracked.append(item)
        actor = getattr(item, "actor", None)
        if actor is not None:   # a copy would draw nothing (its drawing is the actor's)
            actor.copy = _copy_refused(_shown_name(item))

    def untrack(self, item) -> None:
        """Release ``item`` now and stop following it (e.g. a world's replaced chunk)."""
        item.release()
        if item in self._tracked:
            self._tracked.remove(item)

    @property
    def tracked(self) -> list:
        """The volumes this plotter draws with our techniques."""
        return list(self._tracked)

    def bindings(self) -> list:
        """The shader bindings of every tracked technique."""
        return [item.bindings for item in self._tracked]

    def __plotter_close__(self) -> None:
        for item in self._tracked:
            item.release()
        for renderer in {id(i.main_renderer): i.main_renderer for i in self._tracked}.values():
            release_frame_inputs(renderer)
        self._tracked.clear()
        self._bar_mappers.clear()
        if self._multisampling is not None:
            self._multisampling.restore()
        for subject, tag in self._observers:
            subject.RemoveObserver(tag)
        self._observers = []
        self._window = None


def read_usd(path: str, **kwargs) -> pyvista.MultiBlock:
    """``pyvista.read`` handler for .usd/.usda/.usdc/.usdz: the scene's meshes and volumes."""
    return usd.load_usd(path, progress_bar=kwargs.get("progress_bar")).to_multiblock()


def read_vdb_file(path: str, **kwargs) -> pyvista.DataSet:
    """``pyvista.read`` handler for .vdb: the file's density grid (else its first)."""
    return read_vdb(path, **kwargs)


def _reduced_bytes(item) -> int:
    """Bytes of the reduced-size targets a frame budget drew ``item`` (or its levels) into."""
    parts = getattr(item, "surfaces", [item])
    return sum(part.reduced.nbytes for part in parts if getattr(part, "reduced", None))


def _shown_name(item) -> str:
    """The name the user knows ``item`` by: its actor's in the plotter, else its own."""
    return getattr(item.actor, "name", None) or getattr(item, "name", "this actor")


def _copy_refused(name: str):
    """A returned actor's ``copy``: refused by name (a copy would draw nothing)."""
    def copy(deep: bool = True):
        raise TypeError(f"{name!r} cannot be copied: its drawing belongs to the actor it was "
                        "returned as, and a copy would draw nothing. Add the data again to "
                        "draw it elsewhere (user_matrix= places it).")
    return copy

