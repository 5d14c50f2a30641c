"""``add_voxels(..., quality=)``: the exact traversal, with its error measured and reported.

The voxel DDA visits every voxel a ray crosses, so it draws the CPU reference itself; the
settings that trade accuracy for time (fixed steps, level of detail) were not found
cheaper where measured (``bench voxels``: fixed steps 1.3-10x slower than the DDA;
``bench voxel-world``: level of detail no faster on a 256³ terrain), so every target gets
the DDA. Its error is still measured, on a probe frame of the window's size against the
reference over that whole frame (0.4 s at 640x480), and reported as any choice is, so a
drawing that differs from the reference is seen ('exact' too: met only when the
measurement shows it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .interaction import check_frame_budget
from .ladders import Rung
from .probe import ProbeCalibration, margined_bounds
from .targets import QualityTarget, parse_quality

#: What quality= chooses for voxels; the settings it rules out.
EXACT = {"traversal": "dda"}


def check_voxel_quality(quality, traversal: str, step_scale, lod: bool) -> QualityTarget:
    """Read ``quality=`` for voxels and refuse the settings that would contradict it."""
    target = parse_quality(quality, exact=True)
    if traversal != "dda" or step_scale is not None or lod:
        raise ValueError("quality= draws every voxel a ray crosses (traversal='dda', no lod): "
                         "leave traversal, step_scale and lod out with it.")
    return target


def check_opaque(model) -> None:
    """Refuse ``quality=`` for a grid with translucent labels (the reference has none)."""
    alpha = np.asarray(model.palette.rgba)[1:, 3]
    if ((alpha > 0.0) & (alpha < 1.0)).any():
        raise ValueError("quality= measures against the voxel reference, which draws labels "
                         "opaque or hidden; this grid has translucent labels (opacity "
                         "between 0 and 1): leave quality out, or make them opaque.")


def check_voxel_budget(frame_budget_ms, model, per_chunk: str | None = None) -> None:
    """Refuse a frame budget a grid's moving frames cannot be held to.

    The budget draws the grid at fewer pixels (one opaque actor into reduced targets): a
    grid drawn whole, or a world drawn by one traversal over its chunk index; not a world
    drawn per chunk (``per_chunk``: why it is), nor translucent labels (drawn in layers of
    their own).
    """
    if frame_budget_ms is None:
        return
    check_frame_budget(frame_budget_ms, "voxels", 1)
    if per_chunk is not None:
        raise ValueError("frame_budget_ms draws one traversal at fewer pixels while the view "
                         f"moves; this world is drawn by a box per chunk ({per_chunk}): "
                         "leave the budget out, or draw it with world_traversal='index'.")
    alpha = np.asarray(model.palette.rgba)[1:, 3]
    if ((alpha > 0.0) & (alpha < 1.0)).any():
        raise ValueError("frame_budget_ms draws a grid's opaque voxels at fewer pixels while "
                         "the view moves; this grid has translucent labels (drawn in layers "
                         "of their own): leave the budget out, or make them opaque.")


@dataclass
class VoxelCalibration(ProbeCalibration):
    """``quality=`` of a voxel grid: the DDA, measured over the window's frame.

    ``look`` holds the reference's keywords for the grid's look (shading, edges ...).
    """

    look: dict | None = None
    kind = "voxels"
    samples = 1 << 40   # every pixel of the footprint (the reference traces the frame)

    def tracks(self) -> list[list[Rung]]:
        return [[Rung(dict(EXACT), 1.0)]]

    def key_parts(self) -> tuple:
        model = self.model
        return (np.asarray(model.labels), np.asarray(model.palette.rgba),
                np.asarray(model.world_from_index()),
                sorted((k, repr(v)) for k, v in self.keep.items()))

    def bounds(self) -> np.ndarray:
        return margined_bounds(self.model)

    def shading(self) -> str:
        return self.look.get("shading", "unlit")

    def trace(self, camera, size, background, near, pixels) -> np.ndarray:
        model = self.model
        frame = self.reference(model.labels, model.world_from_index(), model.palette.rgba,
                               camera, size, background=background, near=near,
                               lights=self.probe_lights(), **self.look)
        rows, columns = pixels
        return frame[rows, columns][None]

    def apply(self, binding, setting: dict) -> None:
        """Nothing to change: the grid is drawn by the DDA already."""
