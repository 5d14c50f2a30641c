"""Clip planes of a label grid: the shaders' switch and the index-space planes they read."""

from __future__ import annotations

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
