"""An opaque box actor drawn at a fraction of the viewport, shown at full size.

While its :attr:`ReducedDraw.factor` is above 1 (a frame budget coarsening a moving view),
the actor is drawn alone, at the renderer's start, into colour and depth targets of
1/factor the renderer's size, its fragments seeing that size as their viewport
(:func:`~pv_cubemarch.gl.box.drawing_at`); the actor sits the frame out, and a stand-in
with its geometry and placement draws the targets back at full size, nearest texel, with
their depth, so the scene's meshes occlude it and are occluded as by the actor itself. The
pixels marched fall as ``factor**2``.

A translucent actor (one VTK draws in its translucent pass) that draws each pixel once in
straight alpha and stops at the frame's opaque depth (a grid's translucent labels, a
translucent surface, a directly marched volume) is drawn so, into a colour target alone
(nothing is depth-tested), after the scene's opaque props instead: at the start of the
scene overlay (:mod:`~pv_cubemarch.gl.overlay`), reading the opaque depth copied there,
its stand-in compositing the target over the frame in the overlay (after the main
renderer's other translucent props, while the view moves).

Under eye-dome lighting (PyVista's ``enable_eye_dome_lighting``), which shades each pixel
from its neighbours' depths, the actor is drawn at full size: a reduced frame's blocks of
one depth would shade their edges (measured: 15 % of 2x2 blocks off), and a translucent
one drawn from the overlay would miss the shading. Said once.
"""

from __future__ import annotations

from vtkmodules.vtkRenderingOpenGL2 import vtkOpenGLFramebufferObject, vtkTextureObject

from ..core import vtk_classes as vtk
from ..core.frame_errors import observe
from ..core.user_warnings import warn_user
from .bindings import ShaderBindings, TextureUnitLedger
from .box import drawing_at, drawn_viewport, fragment_viewport, render_pass_of
from .face_depth import start_nearest_draw
from .overlay import renderer_overlay
from .shaders import box_recipe


class _Target:
    """One of the draw's targets, as :class:`ShaderBindings` binds textures (not owned)."""

    kind = "2d"
    nbytes = 0

    def __init__(self, draw: ReducedDraw, index: int):
        self.draw, self.index = draw, index

    def ensure(self, window) -> vtkTextureObject:
        return self.draw.targets[self.index]

    def release(self) -> None:
        """Nothing: the draw frees its targets."""


class ReducedDraw:
    """Draw ``actor`` (in ``renderer``) at 1/``factor`` of the viewport when asked.

    The returned actor's visibility is the user's: the actor sits out only the frames drawn
    reduced (hidden between the renderer's start and the window's end), and the stand-in
    is shown only then, so bounds and picks between frames are the actor's; a selection
    render (picking) draws the actor itself.
    """

    #: The colour target's texel type (RGBA8: one layer's straight colour).
    color_type = vtk.VTK_UNSIGNED_CHAR

    def __init__(self, renderer, actor, follows: ReducedDraw | None = None,
                 translucent: bool | None = None):
        self.renderer, self.actor = renderer, actor
        # an actor VTK draws in its translucent pass is drawn after the opaque props
        if translucent is None:
            translucent = bool(actor.GetForceTranslucent())
        overlay = renderer_overlay(renderer) if translucent else None
        self.overlay, self.follows = overlay, follows
        self._factor = 1
        self.runs = 0
        self.targets: list[vtkTextureObject] = []
        self._fbo = None
        self._allocated = (0, 0)
        self._size = (1, 1)
        self._hidden: list = []   # the members sitting this frame out
        self._said_shading = False
        mapper = vtk.vtkPolyDataMapper()   # its own events: the bindings' UpdateShaderEvent
        mapper.SetInputData(actor.GetMapper().GetInput())
        self.stand_in = vtk.vtkActor()
        self.stand_in.SetMapper(mapper)
        self.stand_in.GetProperty().LightingOff()
        self.stand_in.GetMapper().ScalarVisibilityOff()
        self.stand_in.SetPickable(False)
        self.stand_in.SetVisibility(False)
        shown_by = renderer if overlay is None else overlay.renderer
        self.bindings = ShaderBindings(self.stand_in.GetMapper(), shown_by)
        self.bindings.add_texture("cm_reducedColor", _Target(self, 0))
        self.bindings.set_uniform("cm_viewport", lambda: fragment_viewport(renderer))
        self.bindings.set_uniform("cm_reducedSize", lambda: tuple(float(v) for v in self._size))
        window = renderer.GetRenderWindow()
        # after the other start observers (the actor's bindings count the frame first)
        self._tags = [(renderer, observe(renderer, vtk.vtkCommand.StartEvent, self._on_start,
                                         -5.0)),
                      (window, observe(window, vtk.vtkCommand.EndEvent, self._on_end, 5.0))]
        if overlay is None:
            self.stand_in.ForceOpaqueOn()
            self.bindings.add_texture("cm_reducedDepth", _Target(self, 1))
            self.bindings.install(box_recipe(("reduced_declarations",), "reduced_fragment"),
                                  self.stand_in)
        else:   # composited over the frame from the overlay, drawn at its start
            self.stand_in.ForceTranslucentOn()
            self.bindings.install(box_recipe(("reduced_declarations",),
                                             "reduced_layer_fragment",
                                             defines=self.layer_defines), self.stand_in)
            overlay.add_user(self.stand_in)
            self._tags.append((overlay.renderer, observe(
                overlay.renderer, vtk.vtkCommand.StartEvent, self._draw_translucent, 0.5)))
        shown_by.AddActor(self.stand_in)

    #: The translucent stand-in's defines (its target holds one layer's straight colour).
    layer_defines: dict | None = None

    def members(self) -> list:
        """The actors drawn reduced this frame, in drawing order: the actor, if shown."""
        return [self.actor] if self.actor.GetVisibility() else []

    @property
    def factor(self) -> int:
        """The fraction of the viewport drawn across (that of the draw it follows, if any)."""
        return self.follows.factor if self.follows is not None else self._factor

    @factor.setter
    def factor(self, value: int) -> None:
        self._factor = int(value)

    @property
    def nbytes(self) -> int:
        """GPU bytes of the targets allocated now (colour; float32 depth where opaque)."""
        texel = 16 if self.color_type == vtk.VTK_FLOAT else 4
        texel += 4 if self.overlay is None else 0
        return texel * self._allocated[0] * self._allocated[1]

    def _on_start(self, *_) -> None:
        # a selection render (picking) draws the actor itself, the one that can be picked
        members = self.members() if self.factor > 1 else []
        reduced = bool(members) and self.renderer.GetSelector() is None
        if reduced and render_pass_of(self.renderer, "vtkEDLShading") is not None:
            reduced = False
            if not self._said_shading and self.follows is None:   # said by the one followed
                self._said_shading = True
                warn_user("Eye-dome lighting shades each pixel from its neighbours' depths: "
                          "moving frames are drawn at full size, not reduced, under the "
                          "frame budget (turn it off with disable_eye_dome_lighting() to "
                          "move faster).")
        if not reduced:
            return
        self._follow_actor(members)
        self.stand_in.SetVisibility(True)
        width, height = drawn_viewport(self.renderer)[2:]
        self._size = (max(1, -(-width // self.factor)), max(1, -(-height // self.factor)))
        if self.overlay is None:
            self._draw(members, "RenderOpaqueGeometry")
        for actor in members:   # back at the window's end
            actor.SetVisibility(False)
        self._hidden = members

    def _draw_translucent(self, *_) -> None:
        """At the overlay's start (every opaque prop drawn): the actor, reduced.

        It reads the scene's opaque depth (its own binding copies it then).
        """
        if self._hidden and self.overlay is not None:
            for actor in self._hidden:
                actor.SetVisibility(True)
            try:
                self._draw(self._hidden, "RenderTranslucentPolygonalGeometry")
            finally:
                for actor in self._hidden:
                    actor.SetVisibility(False)

    def _on_end(self, *_) -> None:
        """The frame is over: the actor is shown again, the stand-in hidden (bounds, picks)."""
        self.stand_in.SetVisibility(False)
        for actor in self._hidden:
            actor.SetVisibility(True)
        self._hidden = []

    def _follow_actor(self, members: list) -> None:
        """The stand-in takes the actor's geometry, placement (pose too) and culled faces now."""
        geometry = self.actor.GetMapper().GetInput()
        if self.stand_in.GetMapper().GetInput() is not geometry:
            self.stand_in.GetMapper().SetInputData(geometry)
        if self.stand_in.GetUserMatrix() is not self.actor.GetUserMatrix():
            self.stand_in.SetUserMatrix(self.actor.GetUserMatrix())
        # and the pose PyVista's calls gave a returned box (set only where it changed)
        self.stand_in.SetPosition(self.actor.GetPosition())
        self.stand_in.SetOrientation(self.actor.GetOrientation())
        self.stand_in.SetScale(self.actor.GetScale())
        self.stand_in.SetOrigin(self.actor.GetOrigin())
        ours, theirs = self.stand_in.GetProperty(), self.actor.GetProperty()
        if (ours.GetFrontfaceCulling(), ours.GetBackfaceCulling()) != (
                theirs.GetFrontfaceCulling(), theirs.GetBackfaceCulling()):
            ours.SetFrontfaceCulling(theirs.GetFrontfaceCulling())
            ours.SetBackfaceCulling(theirs.GetBackfaceCulling())

    def _create(self, window, size: tuple[int, int]) -> None:
        self._release_targets()
        color = vtkTextureObject()
        color.SetContext(window)
        color.Allocate2D(size[0], size[1], 4, self.color_type)
        self.targets = [color]
        if self.overlay is None:   # the stand-in writes the depth; a translucent one none
            depth = vtkTextureObject()
            depth.SetContext(window)
            depth.AllocateDepth(size[0], size[1], vtkTextureObject.Float32)
            self.targets.append(depth)
        for texture in self.targets:
            texture.SetMinificationFilter(vtkTextureObject.Nearest)
            texture.SetMagnificationFilter(vtkTextureObject.Nearest)
        self._fbo = vtkOpenGLFramebufferObject()
        self._fbo.SetContext(window)
        self._allocated, self._window = size, window

    def _start_blending(self, state) -> None:
        """After the targets are cleared and bound: how the members' fragments combine.

        One actor draws each pixel once: blending off (as cleared); where opaque, the nearest
        fragment kept.
        """

    def _draw(self, members: list, method: str) -> None:
        """Each member's ``method(renderer)`` into the targets, cleared.

        The colour is cleared to nothing, the depth (where drawn opaque) to far.
        """
        window = self.renderer.GetRenderWindow()
        TextureUnitLedger.release_window(window)
        size = self._size
        if self._fbo is None or size != self._allocated:
            self._create(window, size)
        state = window.GetState()
        state.Push()
        state.PushFramebufferBindings()
        try:
            depth = self.targets[1] if len(self.targets) > 1 else None
            start_nearest_draw(state, self._fbo, self.targets[0], depth, size,
                               (0.0, 0.0, 0.0, 0.0))
            self._start_blending(state)
            with drawing_at((0, 0, *size)):
                for actor in members:
                    getattr(actor, method)(self.renderer)
        finally:
            state.PopFramebufferBindings()
            state.Pop()
        TextureUnitLedger.release_window(window)
        self.runs += 1

    def _release_targets(self) -> None:
        window = getattr(self, "_window", None)
        for texture in self.targets:
            if window is not None:
                texture.ReleaseGraphicsResources(window)
        if self._fbo is not None and window is not None:
            self._fbo.ReleaseGraphicsResources(window)
        self.targets, self._fbo, self._allocated = [], None, (0, 0)

    def release(self) -> None:
        """Stop following frames, give the actor back, free the targets and the stand-in."""
        for subject, tag in self._tags:
            subject.RemoveObserver(tag)
        self._tags = []
        self._on_end()
        self.bindings.release()
        if self.overlay is None:
            self.renderer.RemoveActor(self.stand_in)
        else:
            self.overlay.remove_actor(self.stand_in)
            self.overlay.release_user(self.stand_in)
        self._release_targets()
