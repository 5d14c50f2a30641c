"""What every technique's ``actor.cubemarch`` shares: the actors it draws and where.

The plotter component reads these attributes at every frame (to follow visibility, decide
multisampling and translucency, and release what left the plotter); each technique adds
its own state and ``release()``.
"""

from __future__ import annotations

import numpy as np

from ..core.rendering import needs_open_plotter
from ..core.user_warnings import warn_user
from ..models.volume import checked_transform
from .bindings import ShaderBindings
from .box import numpy_matrix, place_box
from .overlay import is_bounds_proxy, place_bounds_proxy
from .shaders import ShaderRecipe


class Placement:
    """Moving what an ``actor.cubemarch`` draws: one ``set_transform`` for every technique.

    A technique says only what follows a new placement (:meth:`place`) and, if it cannot
    move alone, why (:meth:`check_movable`).
    """

    main_renderer = None
    #: The prop standing for what it draws in the plotter, where that is not one box.
    bounds_proxy = None

    @needs_open_plotter
    def set_transform(self, transform) -> None:
        """Move what it draws: ``transform`` is its new 4x4 placement in the world.

        What it draws follows at once (passes that depend on the placement run again at the
        next frame); nothing is uploaded again.
        """
        placement = checked_transform(transform)
        self.check_movable()
        self.model.transform = placement
        self.place(placement)
        if is_bounds_proxy(self.bounds_proxy):
            place_bounds_proxy(self.bounds_proxy, self.model)
        if self.main_renderer is not None:
            self.main_renderer.ResetCameraClippingRange()

    def follow_proxy_placement(self) -> None:
        """PyVista's placement of the returned bounds proxy moves what it draws, as a mesh's.

        The proxy holds the data's own box under the ``transform`` (its ``user_matrix``), so
        its whole matrix, once ``position``, ``orientation``, ``scale`` or ``user_matrix``
        changed it, is the data's new ``transform``.
        """
        proxy = self.bounds_proxy
        matrix = numpy_matrix(proxy.GetMatrix())
        if np.allclose(matrix, np.asarray(self.model.transform, np.float64), rtol=1e-12,
                       atol=0.0):
            return
        try:
            self.set_transform(matrix)
        except ValueError as error:   # cannot move alone: put the proxy back, and say why
            place_bounds_proxy(proxy, self.model)
            warn_user(f"{self.model.name!r} was not moved: {error}")

    def check_movable(self) -> None:
        """Raise ``ValueError`` if this drawing cannot move alone (the default: it can)."""

    def place(self, transform) -> None:
        """Follow the model's new placement ``transform``: by default, the box actor."""
        place_box(self.drawn[0], self.model.world_from_index())


class DrawnBinding(Placement):
    """The drawn side of a technique's per-actor state."""

    technique = "technique"
    #: Whether the technique reads the frame's depth as a single-sampled texture (the
    #: window's multisampling is turned off on frames that draw it).
    needs_single_sample = False
    #: Whether a box draws in the plotter's renderer's translucent pass (its weighted
    #: order-independent translucency is then turned off for the frame).
    blends_in_main_renderer = False

    def __init__(self, model, bindings: ShaderBindings, recipe: ShaderRecipe | None):
        self.model = model
        self.bindings = bindings
        self.recipe = recipe
        self.actor = None          # the actor add_* returned (the plotter knows it)
        self.drawn: list = []      # actors that draw it (the actor, or overlay boxes)
        self.renderer = None       # where ``drawn`` draw
        self.main_renderer = None  # the plotter's renderer
        self.bounds_proxy = None
        self.light_map = None
        #: Calls that undo what building it added elsewhere (passes, overlay actors),
        #: run once at release after its own resources.
        self.extra_release: list = []
        self._released = False

    def recompile(self, recipe: ShaderRecipe) -> None:
        """Draw with ``recipe`` from the next frame: a feature switched in or out."""
        self.recipe = recipe
        self.bindings.install(recipe, *self.drawn)

    @property
    def name(self) -> str:
        """The model's name."""
        return self.model.name

    @property
    def shown(self) -> bool:
        """Whether the returned actor is visible (a hidden one runs no pass)."""
        return self.actor is None or bool(self.actor.GetVisibility())

    def follow_anchor(self) -> None:
        """At each frame: the drawn actors follow the visibility of the returned actor.

        Where the returned actor is the box itself, or a bounds proxy standing for several,
        PyVista's placement of it follows too (:meth:`follow_actor_placement`,
        :meth:`follow_proxy_placement`).
        """
        if self.actor is None:
            return
        shown = bool(self.actor.GetVisibility())
        for actor in self.drawn:
            if actor is not self.actor:
                actor.SetVisibility(shown)
        if self.drawn and self.actor is self.drawn[0]:
            self.follow_actor_placement()
            self.say_unfollowed_changes()
        elif self.actor is self.bounds_proxy and is_bounds_proxy(self.actor):
            self.follow_proxy_placement()
            self.say_unfollowed_changes()

    #: Where the returned actor's property (opacity, colour) is set instead, for the
    #: warning that says it is not drawn.
    look_hint = "add the data again with the opacity and colour wanted"
    #: Whether the returned actor's mapper's clipping planes cut what it draws.
    follows_mapper_planes = False

    def say_unfollowed_changes(self) -> None:
        """Once each: PyVista's calls on the returned box actor that are not drawn.

        Its property's opacity and colour, and (where not followed) its mapper's clipping
        planes: without this, they changed nothing, or cut the box, in silence.
        """
        actor = self.actor
        prop = actor.GetProperty()
        look = (prop.GetOpacity(), tuple(prop.GetColor()))
        said = self.__dict__.setdefault("_unfollowed_said", {"look": look})
        if look != said["look"] and "look said" not in said:
            said["look said"] = True
            warn_user(f"{self.name!r}: the opacity and colour set on the returned actor's "
                      f"property are not drawn; {self.look_hint}.")
        planes = actor.GetMapper().GetClippingPlanes()
        if (not self.follows_mapper_planes and planes is not None
                and planes.GetNumberOfItems() and "planes said" not in said):
            said["planes said"] = True
            warn_user(f"{self.name!r}: clipping planes added to the returned actor's mapper "
                      "are not drawn (nothing of it is cut).")

    def follow_actor_placement(self) -> None:
        """PyVista's placement of the returned box actor moves what it draws, as a mesh's.

        ``position``, ``orientation``, ``scale`` or ``user_matrix`` set on it move it as
        they move a mesh of the same data.
        The box is drawn in index space under its placement (``user_matrix`` = world from
        index); a mesh's own ``user_matrix`` places its data and its position, orientation
        and scale apply before that. So a changed actor is read as a mesh would be (its
        ``user_matrix``, if not ours, as the data's placement, else the ``transform``;
        then its position, orientation and scale), and :meth:`set_transform` places the
        box again, with position, orientation and scale put back to none.
        """
        actor = self.actor
        user = actor.GetUserMatrix()
        placed = self.model.world_from_index()
        ours = user is not None and np.array_equal(numpy_matrix(user), placed)
        moved = (tuple(actor.GetPosition()) != (0.0, 0.0, 0.0)
                 or tuple(actor.GetOrientation()) != (0.0, 0.0, 0.0)
                 or tuple(actor.GetScale()) != (1.0, 1.0, 1.0))
        if ours and not moved:
            return
        mine = numpy_matrix(user) if user is not None else np.eye(4)
        pose = np.linalg.solve(mine, numpy_matrix(actor.GetMatrix()))   # position etc.
        base = np.asarray(self.model.transform, dtype=np.float64) if ours else mine
        actor.SetPosition(0.0, 0.0, 0.0)
        actor.SetOrientation(0.0, 0.0, 0.0)
        actor.SetScale(1.0, 1.0, 1.0)
        actor.SetOrigin(0.0, 0.0, 0.0)
        try:
            self.set_transform(base @ pose)
        except ValueError as error:   # cannot move alone: put the box back, and say why
            place_box(actor, placed)
            warn_user(f"{self.name!r} was not moved: {error}")

    def release(self) -> None:
        """Free what it holds on the GPU and its observers, then ``extra_release``; once."""
        if self._released:
            return
        self._released = True
        self.release_resources()
        for release in self.extra_release:
            release()
        self.extra_release = []

    def release_resources(self) -> None:
        """Free the technique's own resources: by default its bindings' textures and hooks."""
        self.bindings.release()
