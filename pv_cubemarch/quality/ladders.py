"""Each technique's settings for the error budget, cheapest first, with their relative cost.

A ladder holds the knobs whose error does not change with the view's size (the step along
the ray, the cube map's face and samples): the frame-time budget moves the others
(downsample, upscale). Along a ladder the error falls and the cost rises, which is the
model the search relies on; ``cost`` is the share of the finest rung's work a rung does
(samples marched), used to report and to order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: step_scale from coarse to fine: halving the step doubles the samples.
STEP_SCALES = (4.0, 2.0, 1.0, 0.5, 0.25, 0.125, 0.0625)
#: PSNR gained per rung, where the error is first order in the step (a halving: 6 dB).
DB_PER_HALVING = 6.02


@dataclass(frozen=True)
class Rung:
    """One setting of a ladder and its cost relative to the finest."""

    setting: dict
    cost: float


def volume_ladder(technique: str, dimensions) -> list[Rung]:
    """The rungs of an emission/absorption technique on a grid of ``dimensions`` points.

    'vtk' and 'direct': ``step_scale`` from 4 to 1/16 texel. 'cubemap': ``face_size`` from
    32 to the first power of two past twice the grid's longest axis (a finer face adds no
    detail of the data), then twice the samples per texel on the finest face.
    """
    if technique in ("vtk", "direct"):
        finest = STEP_SCALES[-1]
        return [Rung({"step_scale": s}, finest / s) for s in STEP_SCALES]
    if technique == "cubemap":
        longest = int(max(dimensions))
        top = max(64, 1 << int(np.ceil(np.log2(max(2 * longest, 2)))))
        faces = [f for f in (32, 64, 128, 256, 512, 1024) if f <= min(top, 1024)]
        # samples per ray follow the face (two per texel of the grid's axis, capped by the
        # face's texels): the work is about face^2 rays times their samples
        work = [f * f * min(f, 2 * longest) for f in faces] + [
            faces[-1] ** 2 * min(2 * faces[-1], 4 * longest)]
        settings = [{"face_size": f} for f in faces] + [
            {"face_size": faces[-1], "sample_factor": 2.0}]
        return [Rung(s, w / work[-1]) for s, w in zip(settings, work, strict=True)]
    raise ValueError(f"quality= picks the settings of 'vtk', 'direct' or 'cubemap', not "
                     f"technique={technique!r}: name one of those ('auto' switches between "
                     "two per frame, whose settings are calibrated apart).")
