"""What every technique's ``actor.cubemarch`` shares: the actors it draws and where.

The plotter component reads these attributes at every frame (to follow visibility, decide
multisampling and translucency, and release what left the plotter); each technique adds
its own state and ``release()``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pyvista

from ..core.errors import VolumeDataError
from ..core.rendering import needs_open_plotter
from ..core.user_warnings import warn_user
from ..models.volume import checked_transform
from .bindings import ShaderBindings
from .box import GROW, cull, numpy_matrix, place_box, place_by_user_matrix
from .look import ReturnedLook
from .overlay import is_bounds_proxy, place_bounds_proxy
from .shaders import ShaderRecipe

#: Largest world coordinate drawn: past about 2e16 VTK's clipping range collapses and
#: GL's float32 camera matrices turn singular (a frame draws nothing, or stops).
MAX_WORLD_COORDINATE = 1e16


class Placement:
    """Moving what an ``actor.cubemarch`` draws: one ``set_transform`` for every technique.

    A technique says only what follows a new placement (:meth:`place`) and, if it cannot
    move alone, why (:meth:`check_movable`). The prop returned for it (its box, a bounds
    proxy or a volume's stand-in) holds the data's own frame under the ``transform`` as its
    ``user_matrix``, as a mesh of the data would: PyVista's placement calls on it then
    move the data as they move the mesh (:meth:`follow_prop_placement`).
    """

    main_renderer = None
    #: The prop standing for what it draws in the plotter, where that is not one box.
    bounds_proxy = None
    #: Whether the returned box holds the data's own frame (:meth:`use_frame_box`).
    box_in_frame = False
    #: While the data follow the returned prop's own placement, which is left as it is.
    _following_prop = False
    #: The returned prop's placement values while the data were where it placed them.
    _kept_pose = None
    #: The returned prop's modified time when it was last followed.
    _prop_seen = None

    @needs_open_plotter
    def set_transform(self, transform) -> None:
        """Move what it draws: ``transform`` is its new 4x4 placement in the world.

        What it draws follows at once (passes that depend on the placement run again at the
        next frame); nothing is uploaded again. The returned actor then reads ``transform``
        as its ``user_matrix``, with no position, orientation or scale.
        """
        placement = checked_transform(transform)
        self.check_movable()
        kept = self.model.transform
        self.model.transform = placement
        try:
            self.check_reach()
        except ValueError:
            self.model.transform = kept
            raise
        self.place(placement)
        if not self._following_prop and is_bounds_proxy(self.bounds_proxy):
            place_bounds_proxy(self.bounds_proxy, self.model, self.drawn_frame_bounds())

    def drawn_frame_bounds(self):
        """The bounds of what is drawn, in the data's own frame, where less than its grid.

        A bounds proxy spans them (``reset_camera`` frames them); None: the whole grid.
        """
        return None

    def check_reach(self) -> None:
        """Raise ``VolumeDataError`` if what it draws reaches past the coordinates drawn.

        Past :data:`MAX_WORLD_COORDINATE` from the origin nothing is drawn.
        """
        bounds = getattr(self.model, "world_bounds", None)
        reach = float(np.max(np.abs(bounds()))) if callable(bounds) else 0.0
        if reach > MAX_WORLD_COORDINATE:
            raise VolumeDataError(
                f"{self.model.name!r} would reach {reach:.3g} world units from the origin; "
                f"past about {MAX_WORLD_COORDINATE:g} VTK's clipping range and GL's float32 "
                "camera matrices break down (nothing drawn): place it nearer, or smaller "
                "(its spacing, scale or transform).")

    def check_movable(self) -> None:
        """Raise ``ValueError`` if this drawing cannot move alone (the default: it can)."""

    def place(self, transform) -> None:
        """Follow the model's new placement ``transform``: by default, the box actor.

        A returned box in the data's frame takes the ``transform`` as its ``user_matrix``
        (not while it is the one followed); the culled side follows the handedness.
        """
        box = self.drawn[0]
        if not self.box_in_frame:
            place_box(box, self.model.world_from_index())
            return
        if not self._following_prop:
            place_by_user_matrix(box, self.model.transform)
        cull(box, self.model.world_from_index(), "back")

    def follow_prop_placement(self, prop) -> None:
        """The data follow the whole placement PyVista's calls gave ``prop``, left as set.

        ``prop`` (the returned box, bounds proxy or stand-in) holds the data's own frame
        under its matrix (``user_matrix``, then position, orientation and scale), as a mesh
        of the data would; once that matrix changed, it is the data's new ``transform``.
        Calls made again with the same values then change nothing, and every value reads
        back as set. A drawing that cannot move alone puts the prop back and says why.
        """
        if prop.GetMTime() == self._prop_seen:
            return   # nothing set on it since the last look: a frame's usual case
        matrix = numpy_matrix(prop.GetMatrix())
        placed = np.asarray(getattr(self.model, "transform", np.eye(4)), np.float64)
        try:
            if np.allclose(matrix, placed, rtol=1e-12, atol=0.0):
                self._kept_pose = prop_pose(prop)   # what a refused move puts back
                return
            self._following_prop = True
            self.set_transform(matrix)
            self._kept_pose = prop_pose(prop)
        except ValueError as error:
            self._following_prop = False
            if self._kept_pose is not None:   # the values the prop read before the call
                set_prop_pose(prop, self._kept_pose)
            else:
                self.put_back_prop()
            warn_user(f"{self.model.name!r} was not moved: {error}")
        finally:
            self._following_prop = False
            self._prop_seen = prop.GetMTime()

    def put_back_prop(self) -> None:
        """Place the returned prop where the data are (after a move refused)."""
        if is_bounds_proxy(self.bounds_proxy):
            place_bounds_proxy(self.bounds_proxy, self.model, self.drawn_frame_bounds())
        elif self.box_in_frame:
            self.place(self.model.transform)


def keep_placed_by_matrix(actor) -> None:
    """Undo position, orientation, scale or origin set on a drawing's own actor.

    Such an actor is placed by its matrix alone; PyVista's ``set_scale`` scales every
    actor of the renderer, unnamed ones too, which moved the box twice (the returned
    volume's scale is followed as the data's placement).
    """
    if (actor.GetScale() != (1.0, 1.0, 1.0) or any(actor.GetPosition())
            or any(actor.GetOrientation()) or any(actor.GetOrigin())):
        actor.SetScale(1.0, 1.0, 1.0)
        actor.SetPosition(0.0, 0.0, 0.0)
        actor.SetOrientation(0.0, 0.0, 0.0)
        actor.SetOrigin(0.0, 0.0, 0.0)


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
        PyVista's placement of it follows too (:meth:`follow_prop_placement`).
        """
        if self.actor is None:
            return
        shown = bool(self.actor.GetVisibility())
        for actor in self.drawn:
            if actor is not self.actor:
                actor.SetVisibility(shown)
                keep_placed_by_matrix(actor)
        if (self.drawn and self.actor is self.drawn[0] and self.box_in_frame) or (
                self.actor is self.bounds_proxy and is_bounds_proxy(self.actor)):
            self.follow_prop_placement(self.actor)
            if self.follows_mapper_planes:
                self.follow_mapper_planes(self.actor)
            self.say_unfollowed_changes()

    #: Where the returned actor's property (opacity, colour) is set instead, for the
    #: warning that says it is not drawn.
    look_hint = "add the data again with the opacity and colour wanted"
    #: Whether the returned actor's mapper's clipping planes cut what it draws (then it
    #: has ``follow_mapper_planes(actor)``, as ``voxels.clipping.ClipPlaneSetting``).
    follows_mapper_planes = False

    def look_bindings(self) -> list:
        """The shader bindings whose uniforms the returned actor's property feeds."""
        return [self.bindings]

    def note_look(self, terms: dict) -> None:
        """Terms of the returned actor's property now drawn: the options say them too."""
        options = getattr(self, "options", None)
        if terms and dataclasses.is_dataclass(options):
            names = {f.name for f in dataclasses.fields(options)}
            kept = {k: v for k, v in terms.items() if k in names}
            if kept:
                self.options = dataclasses.replace(options, **kept)

    def say_unfollowed_changes(self) -> None:
        """Once each: PyVista's calls on the returned box actor that are not drawn.

        Its property's terms (drawn where the shaders read them, said once otherwise:
        :mod:`~pv_cubemarch.gl.look`), and (where not followed) its mapper's clipping
        planes: without this, they changed nothing, or cut the box, in silence.
        """
        actor = self.actor
        if self.__dict__.get("look") is None:   # made when added (api), else at its first frame
            self.look = ReturnedLook(self)
        self.look.follow()
        said = self.__dict__.setdefault("_unfollowed_said", {})
        planes = actor.GetMapper().GetClippingPlanes()
        if (not self.follows_mapper_planes and planes is not None
                and planes.GetNumberOfItems() and "planes said" not in said):
            said["planes said"] = True
            warn_user(f"{self.name!r}: clipping planes added to the returned actor's mapper "
                      "are not drawn (nothing of it is cut).")

    def use_frame_box(self) -> None:
        """Make the box the returned actor: its corners in the data's own frame.

        The box is drawn in index space under ``world_from_index``; returned to the user,
        it holds the data's frame instead (``grid_from_index`` applied to its corners) and
        the ``transform`` as its ``user_matrix``, as a mesh of the data would, so that
        PyVista's placement calls move and read back as on that mesh
        (:meth:`follow_prop_placement`).
        """
        box = self.drawn[0]
        corners = box.GetMapper().GetInput()
        self.box_in_frame = True
        self.set_box_polydata(corners)
        self.place(self.model.transform)

    def set_box_polydata(self, polydata) -> None:
        """Draw the box ``polydata`` (index space), in the data's frame if it is returned."""
        if self.box_in_frame:
            frame_from_index = np.linalg.solve(
                np.asarray(self.model.transform, np.float64), self.model.world_from_index())
            polydata = pyvista.wrap(polydata).copy()
            # double: a frame far from its origin (1e6) holds no float32 corner a hair out
            polydata.points = np.asarray(polydata.points, np.float64)
            grow = polydata.point_data.get(GROW)
            polydata = polydata.transform(frame_from_index, inplace=False)
            if grow is not None:   # the corners' moves outward, in the frame too
                polydata.point_data[GROW] = np.asarray(grow) @ frame_from_index[:3, :3].T
        self.drawn[0].GetMapper().SetInputData(polydata)

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


def prop_pose(prop) -> tuple:
    """A prop's placement values: user matrix (a copy), position, orientation, scale, origin."""
    user = prop.GetUserMatrix()
    return (None if user is None else numpy_matrix(user), prop.GetPosition(),
            prop.GetOrientation(), prop.GetScale(), prop.GetOrigin())


def set_prop_pose(prop, pose: tuple) -> None:
    """Give ``prop`` back the placement values :func:`prop_pose` read."""
    user, position, orientation, scale, origin = pose
    if user is None:
        prop.SetUserMatrix(None)
    else:
        place_by_user_matrix(prop, user)
    prop.SetPosition(position)
    prop.SetOrientation(orientation)
    prop.SetScale(scale)
    prop.SetOrigin(origin)
