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
        remake = clip_count(options) != clip_count(self.options)
        self.options = options
        self.follow_clip_planes(remake)
