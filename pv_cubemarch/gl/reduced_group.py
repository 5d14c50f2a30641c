"""Many actors drawn at a fraction of the viewport as one: a world's chunks, their layers.

A :class:`~.reduced_draw.ReducedDraw` whose members are the actors a callable returns at
each frame (those shown, in the renderer's drawing order), drawn one after the other into
the same targets, and shown at full size by one stand-in: the box of the bounds of
``anchor`` (a prop spanning them all), its back faces drawn, so it covers every pixel any
member draws, once, from a camera outside or inside it. Opaque members keep the nearest
fragment, the later on a tie (as the renderer draws them); translucent members (each
compositing its part of a ray in straight alpha, drawn far to near) are composited over
each other into a float target, premultiplied, which the stand-in divides back.
"""

from __future__ import annotations

from collections.abc import Callable

from ..core import vtk_classes as vtk
from .box import box_polydata
from .reduced_draw import ReducedDraw

_BLEND, _LEQUAL = 0x0BE2, 0x0203
_ONE, _SRC_ALPHA, _ONE_MINUS_SRC_ALPHA = 1, 0x0302, 0x0303


class ReducedGroup(ReducedDraw):
    """Draw the actors ``members()`` returns at 1/``factor`` of the viewport, as one.

    ``anchor``: the prop spanning every member (placed as they are), whose visibility they
    follow (none is drawn while hidden).
    """

    def __init__(self, renderer, anchor, members: Callable[[], list],
                 follows: ReducedDraw | None = None, translucent: bool = False):
        self._members, self._bounds = members, None
        if translucent:   # layers composited over each other: kept to float precision
            self.color_type = vtk.VTK_FLOAT
            self.layer_defines = {"CM_PREMULTIPLIED": True}
        super().__init__(renderer, anchor, follows, translucent)

    def members(self) -> list:
        """The members shown now, in the order the renderer draws its props."""
        if not self.actor.GetVisibility():
            return []
        shown = {id(actor): actor for actor in self._members() if actor.GetVisibility()}
        if not shown:
            return []
        props = self.renderer.GetViewProps()
        props.InitTraversal()
        ordered = [props.GetNextProp() for _ in range(props.GetNumberOfItems())]
        return [prop for prop in ordered if id(prop) in shown]

    def _follow_actor(self, members: list) -> None:
        """The stand-in is the box of the anchor's bounds, its back faces drawn.

        They cover each pixel of the box once, from outside it or inside. The anchor spans
        every member and follows their placement: one read a frame, not one per member.
        """
        bounds = tuple(self.actor.GetBounds())
        if bounds != self._bounds:
            self._bounds = bounds
            self.stand_in.GetMapper().SetInputData(box_polydata(bounds[0::2], bounds[1::2]))
            self.stand_in.GetProperty().FrontfaceCullingOn()

    def _start_blending(self, state) -> None:
        """Opaque: the nearer fragment, the later on a tie. Translucent: each over the last."""
        if self.overlay is None:
            state.vtkglDepthFunc(_LEQUAL)
            return
        state.vtkglEnable(_BLEND)   # each member ends its rays at the opaque depth
        state.vtkglBlendFuncSeparate(_SRC_ALPHA, _ONE_MINUS_SRC_ALPHA, _ONE,
                                     _ONE_MINUS_SRC_ALPHA)
