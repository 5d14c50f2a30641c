"""Bricks hidden behind what the last frame drew: a depth pyramid of the frame, on the CPU.

A streamed source whose surface is opaque (a label grid) writes the depth of what it hits.
Kept from the last frame of an unchanged view, that depth says which bricks no ray can
reach: a brick whose nearest corner lies behind the farthest depth over the pixels it
covers. The farthest depth over any rectangle is read from a max-pyramid of the depth
(levels of 2x2 maxima) at the level where the rectangle spans at most 4 cells a side
(5 where it straddles their borders), so the test is conservative. What was drawn coarse
may be nearer than what refines behind it: the pager plans again after each frame that
uploaded bricks, with that frame's depth.
"""

from __future__ import annotations

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy

from ..core import vtk_classes as vtk
from ..gl.box import drawn_viewport


class DepthPyramid:
    """The max-pyramid of one frame's window depth (0 near .. 1 far) over a renderer."""

    def __init__(self, depth: np.ndarray, origin: tuple[int, int]):
        self.origin = origin
        self.levels = [np.asarray(depth, np.float32)]
        while max(self.levels[-1].shape) > 1:
            d = self.levels[-1]
            padded = np.pad(d, ((0, d.shape[0] % 2), (0, d.shape[1] % 2)), mode="edge")
            self.levels.append(np.maximum.reduce([padded[0::2, 0::2], padded[1::2, 0::2],
                                                  padded[0::2, 1::2], padded[1::2, 1::2]]))

    @classmethod
    def read(cls, renderer) -> DepthPyramid | None:
        """The depth the renderer's window holds now over its viewport (None: nothing)."""
        window = renderer.GetRenderWindow()
        x, y, width, height = drawn_viewport(renderer)
        if window is None or width < 1 or height < 1:
            return None
        values = vtk.vtkFloatArray()
        window.GetZbufferData(x, y, x + width - 1, y + height - 1, values)
        depth = vtk_to_numpy(values)
        if depth.size != width * height:
            return None
        return cls(depth.reshape(height, width), (x, y))

    def farthest(self, low: np.ndarray, high: np.ndarray) -> np.ndarray:
        """Per rectangle of pixels ``[low, high]`` (``(n, 2)`` x, y): its farthest depth."""
        height, width = self.levels[0].shape
        low = np.clip(np.floor(low), 0, [width - 1, height - 1]).astype(np.int64)
        high = np.clip(np.floor(high), 0, [width - 1, height - 1]).astype(np.int64)
        span = np.maximum(high - low, 0).max(axis=1) + 1
        level = np.clip(np.ceil(np.log2(span)).astype(np.int64) - 2, 0, len(self.levels) - 1)
        result = np.ones(len(low), np.float32)
        for number in np.unique(level):
            rows = level == number
            grid = self.levels[number]
            first, last = low[rows] >> number, high[rows] >> number
            value = np.zeros(int(rows.sum()), np.float32)
            for dx in range(5):
                for dy in range(5):
                    cx = np.minimum(first[:, 0] + dx, grid.shape[1] - 1)
                    cy = np.minimum(first[:, 1] + dy, grid.shape[0] - 1)
                    inside = (cx <= np.maximum(last[:, 0], first[:, 0])) & \
                        (cy <= np.maximum(last[:, 1], first[:, 1]))
                    value = np.where(inside, np.maximum(value, grid[cy, cx]), value)
            result[rows] = value
        return result


def hidden_boxes(pyramid: DepthPyramid, corners_clip: np.ndarray, size: tuple[int, int]
                 ) -> np.ndarray:
    """Which boxes (their 8 corners in clip space, ``(n, 8, 4)``) lie behind the depth.

    A box with a corner behind the eye is never hidden; its rectangle is the corners'
    window rectangle (cut to the viewport), its depth the nearest corner's.
    """
    w = corners_clip[..., 3]
    ahead = (w > 0).all(axis=1)
    hidden = np.zeros(len(corners_clip), bool)
    if not ahead.any():
        return hidden
    ndc = corners_clip[ahead, :, :3] / w[ahead, :, None]
    pixels = (ndc[..., :2] * 0.5 + 0.5) * np.asarray(size, float)
    nearest = (ndc[..., 2] * 0.5 + 0.5).min(axis=1)
    farthest = pyramid.farthest(pixels.min(axis=1), pixels.max(axis=1))
    hidden[np.flatnonzero(ahead)] = nearest > farthest + 1e-6
    return hidden


def opaque_scene_state(renderer, own: list) -> tuple:
    """What the depth of a frame owes to the renderer's props other than ``own``.

    Which are drawn and when each (its mapper, its input data) last changed: a mesh
    removed, hidden, moved or edited uncovers bricks its depth hid, so a plan keyed on this
    is made again.
    """
    props = renderer.GetViewProps()
    state = []
    for index in range(props.GetNumberOfItems()):
        prop = props.GetItemAsObject(index)
        if any(prop is item for item in own):
            continue
        mapper = prop.GetMapper() if hasattr(prop, "GetMapper") else None
        data = mapper.GetInputDataObject(0, 0) if mapper is not None \
            and mapper.GetNumberOfInputPorts() else None
        state.append((prop.__this__, prop.GetVisibility(), prop.GetMTime(),
                      mapper.GetMTime() if mapper is not None else 0,
                      data.GetMTime() if data is not None else 0))
    return tuple(state)

