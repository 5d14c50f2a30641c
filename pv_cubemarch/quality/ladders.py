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


def volume_tracks(technique: str, dimensions) -> list[list[Rung]]:
    """The ladders of an emission/absorption technique on a grid of ``dimensions`` points.

    'vtk' and 'direct': one, ``step_scale`` from 4 to 1/16 texel. 'cubemap': one per
    ``sample_factor`` (1 and 2), each over ``face_size`` from 32 to the first power of two
    past twice the grid's longest axis (a finer face adds no detail of the data). Along a
    track the error falls; between tracks it does not compare (a finer step helps a sharp
    CT shell by 10 dB and smooth smoke not at all), so each is searched on its own and
    the cheapest winner kept. Cube-map cost: the face's texels, a fifth more per extra
    sample per texel (measured on llvmpipe over three scenes: 3.7-7.5 ms at face 32-64,
    +10-40 % at sample_factor 2).
    """
    if technique in ("vtk", "direct"):
        finest = STEP_SCALES[-1]
        return [[Rung({"step_scale": s}, finest / s) for s in STEP_SCALES]]
    if technique == "cubemap":
        longest = int(max(dimensions))
        top = max(64, 1 << int(np.ceil(np.log2(max(2 * longest, 2)))))
        faces = [f for f in (32, 64, 128, 256, 512, 1024) if f <= min(top, 1024)]
        work = {(f, k): f * f * (1.0 + 0.2 * (k - 1.0)) for f in faces for k in (1.0, 2.0)}
        most = max(work.values())
        return [[Rung({"face_size": f, "sample_factor": k}, work[f, k] / most) for f in faces]
                for k in (1.0, 2.0)]
    raise ValueError(f"quality= picks the settings of 'vtk', 'direct' or 'cubemap', not "
                     f"technique={technique!r}: name one of those ('auto' switches between "
                     "two per frame, whose settings are calibrated apart).")


def volume_ladder(technique: str, dimensions) -> list[Rung]:
    """Every rung of the technique's tracks, cheapest first."""
    rungs = [r for track in volume_tracks(technique, dimensions) for r in track]
    return sorted(rungs, key=lambda r: r.cost)
