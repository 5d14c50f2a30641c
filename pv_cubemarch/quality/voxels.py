"""``add_voxels(..., quality=)``: the exact traversal, with its error measured and reported.

The voxel DDA visits every voxel a ray crosses, so it draws the CPU reference itself; the
settings that trade accuracy for time (fixed steps, level of detail) were not found
cheaper where measured (``bench voxels``: fixed steps 1.3-10x slower than the DDA;
``bench voxel-world``: level of detail no faster on a 256³ terrain), so every target gets
the DDA. Its error is still measured, on a probe frame of at most
:data:`PROBE_PIXELS` pixels against the reference over that whole frame, and reported as
any choice is, so a driver that draws wrong is seen.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .ladders import Rung
from .probe import ProbeCalibration
from .targets import QualityTarget, parse_quality

#: The probe frame's most pixels (the window's aspect kept): the reference traces all.
PROBE_PIXELS = 160 * 120
#: What quality= chooses for voxels; the settings it rules out.
EXACT = {"traversal": "dda"}


def check_voxel_quality(quality, traversal: str, step_scale, lod: bool, frame_budget_ms
                        ) -> QualityTarget:
    """Read ``quality=`` for voxels and refuse the settings that would contradict it."""
    target = parse_quality(quality, exact=True)
    if traversal != "dda" or step_scale is not None or lod:
        raise ValueError("quality= draws every voxel a ray crosses (traversal='dda', no lod): "
                         "leave traversal, step_scale and lod out with it.")
    if frame_budget_ms is not None:
        raise ValueError(_NO_BUDGET)
    return target


_NO_BUDGET = ("frame_budget_ms: voxels have no coarser setting that was measured cheaper "
              "than the exact traversal (bench voxels), so a moving view has nothing to "
              "coarsen; leave it out (mip_levels and proxy speed every frame up exactly).")


def refuse_voxel_budget(frame_budget_ms) -> None:
    """Refuse a frame budget for voxels, saying why."""
    if frame_budget_ms is not None:
        raise ValueError(_NO_BUDGET)


@dataclass
class VoxelCalibration(ProbeCalibration):
    """``quality=`` of a voxel grid: the DDA, measured on a small probe frame.

    ``look`` holds the reference's keywords for the grid's look (shading, edges ...).
    """

    look: dict | None = None
    kind = "voxels"
    samples = PROBE_PIXELS   # every pixel of the probe frame

    def tracks(self) -> list[list[Rung]]:
        return [[Rung(dict(EXACT), 1.0)]]

    def key_parts(self) -> tuple:
        model = self.model
        return (np.asarray(model.labels), np.asarray(model.palette.rgba),
                np.asarray(model.world_from_index()),
                sorted((k, repr(v)) for k, v in self.keep.items()))

    def probe_size(self, size: tuple[int, int]) -> tuple[int, int]:
        scale = min(1.0, math.sqrt(PROBE_PIXELS / float(size[0] * size[1])))
        return max(1, int(size[0] * scale)), max(1, int(size[1] * scale))

    def prepare(self, probe) -> None:
        self.light_by_headlight(probe, self.look.get("shading", "unlit"))

    def trace(self, camera, size, background, near, pixels) -> np.ndarray:
        model = self.model
        frame = self.reference(model.labels, model.world_from_index(), model.palette.rgba,
                               camera, size, background=background, near=near,
                               lights=self.probe_lights(), **self.look)
        rows, columns = pixels
        return frame[rows, columns][None]

    def settle(self, choice):
        if self.target.exact:   # the reference's own traversal; the estimate: its 8 bits
            choice.met = True
        return choice

    def apply(self, binding, setting: dict) -> None:
        """Nothing to change: the grid is drawn by the DDA already."""
