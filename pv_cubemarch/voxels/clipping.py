"""Clip planes of a label grid: the shaders' switch and the index-space planes they read."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..core.rendering import needs_open_plotter
from ..gl.bindings import FloatArray, ShaderBindings
from ..volume.clipping import texture_planes


def clip_count(options) -> int | None:
    """The ``CM_CLIP_PLANES`` define: how many planes cut the grid, or off."""
    return len(options.world_planes) or None


def bind_clip_planes(bindings: ShaderBindings, model, planes) -> None:
    """The clip planes in the grid's index space, at each draw (the grid may move).

    ``planes``: a callable giving the world ``(origin, normal)`` pairs now.
    """
    bindings.set_uniform("cm_clipPlanes", lambda: FloatArray(
        texture_planes(planes(), model.world_from_index()).ravel()))


class ClipPlaneSetting:
    """``set_clip_planes`` for a grid or a world, the same for both.

    It checks the planes; the binding gives ``options`` and ``follow_clip_planes(remake)``,
    which draws with ``options``' planes (``remake``: their number changed).
    """

    @needs_open_plotter
    def set_clip_planes(self, clip_planes) -> None:
        """Cut the grid by planes, or by none (``None``); shown at the next frame.

        ``clip_planes``: six numbers a plane, a point then the normal to the side kept (as
        ``add_voxels(clip_planes=)``). Moving planes changes a uniform; another number of
        planes remakes the shaders.

        Examples
        --------
        >>> actor.cubemarch.set_clip_planes([10, 0, 0, 1, 0, 0])      # doctest: +SKIP
        """
        try:
            values = [] if clip_planes is None else np.asarray(clip_planes, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"clip_planes must be numbers, six a plane (a point, then the "
                             f"normal to the side kept), or None; got {clip_planes!r}.") from None
        planes = tuple(float(v) for v in np.ravel(values)) or None   # [] clears them too
        options = replace(self.options, clip_planes=planes)
        options.check()
        self.own_planes = planes
        self._draw_planes((planes or ()) + self.mapper_planes)

    #: The planes ``clip_planes`` / :meth:`set_clip_planes` gave (None: as at add time).
    own_planes: tuple | None = ()
    #: The planes of the returned actor's mapper (PyVista's ``mapper.AddClippingPlane``,
    #: a plane widget's), six numbers each, read at each frame.
    mapper_planes: tuple = ()

    def follow_mapper_planes(self, actor) -> None:
        """At each frame: the returned actor's mapper's clipping planes cut the grid too.

        VTK would cut the box itself (the rays of the pixels it drops lost, the rest
        uncut): its clipping is left out of the box's shader (box_not_clipped.glsl), and
        the planes, read here, cut the rays as ``clip_planes`` do.
        """
        planes = actor.GetMapper().GetClippingPlanes()
        values: list[float] = []
        for index in range(planes.GetNumberOfItems() if planes is not None else 0):
            plane = planes.GetItem(index)
            values += [*plane.GetOrigin(), *plane.GetNormal()]
        found = tuple(float(v) for v in values)
        if found != self.mapper_planes:
            if self.own_planes == ():
                self.own_planes = self.options.clip_planes
            self.mapper_planes = found
            self._draw_planes((self.own_planes or ()) + found)

    def _draw_planes(self, planes: tuple) -> None:
        """Draw with ``planes`` (six numbers each) from the next frame."""
        options = replace(self.options, clip_planes=tuple(planes) or None)
        remake = clip_count(options) != clip_count(self.options)
        self.options = options
        self.follow_clip_planes(remake)
