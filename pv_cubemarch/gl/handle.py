"""What every technique's ``actor.cubemarch`` shares: the actors it draws and where.

The plotter component reads these attributes at every frame (to follow visibility, decide
multisampling and translucency, and release what left the plotter); each technique adds
its own state and ``release()``.
"""

from __future__ import annotations

from ..core.rendering import needs_open_plotter
from ..models.volume import checked_transform
from .bindings import ShaderBindings
from .box import place_box
from .shaders import ShaderRecipe


class Placement:
    """Moving what an ``actor.cubemarch`` draws: one ``set_transform`` for every technique.

    A technique says only what follows a new placement (:meth:`place`) and, if it cannot
    move alone, why (:meth:`check_movable`).
    """

    main_renderer = None

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
        if self.main_renderer is not None:
            self.main_renderer.ResetCameraClippingRange()

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
        """At each frame: the drawn actors follow the visibility of the returned actor."""
        if self.actor is None:
            return
        shown = bool(self.actor.GetVisibility())
        for actor in self.drawn:
            if actor is not self.actor:
                actor.SetVisibility(shown)

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
