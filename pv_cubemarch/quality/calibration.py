"""Calibration: the cheapest rung whose error against the CPU reference meets the target.

The GPU draws the whole frame (its cost and its level of detail are the view's); the CPU
reference traces only a few thousand pixels spread over the volume's footprint, so
calibrating costs little more than a few frames. Their error stands for the footprint's,
and the whole frame's PSNR is estimated from it and the footprint's share of the frame
(pixels outside the volume are the background in both images).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..core.camera import Camera
from ..image_metrics import to_uint8
from .ladders import DB_PER_HALVING, Rung
from .targets import QualityTarget

#: Calibration aims this far past the target: a sample stands for the frame only roughly.
MARGIN_DB = 0.5
#: Pixels of the footprint the CPU reference traces.
SAMPLES = 4096


@dataclass
class QualityChoice:
    """What ``quality=`` chose, and what was measured to choose it.

    ``psnr`` is the kept setting's whole-frame PSNR (dB) as estimated from the sample;
    ``met`` whether it reaches the target; ``measured`` every rung tried, in order, with
    its estimate and relative cost. When no rung meets the target, the one with the best
    estimate is kept.
    """

    target: QualityTarget
    setting: dict
    psnr: float
    met: bool
    measured: list[dict] = field(default_factory=list)
    seconds: float = 0.0
    size: tuple[int, int] = (0, 0)
    traced: int = 0
    cached: bool = False

    @property
    def setting_text(self) -> str:
        """The chosen setting as keywords (``step_scale=0.5``, ``root=exact``)."""
        return ", ".join(f"{k}={v:g}" if isinstance(v, (int, float)) else f"{k}={v}"
                         for k, v in self.setting.items())

    def __str__(self) -> str:
        setting = self.setting_text
        how = "from the cache" if self.cached else (
            f"{len(self.measured)} settings tried in {self.seconds:.2f} s")
        verdict = "" if self.met else "; the target is out of reach, the best tried is drawn"
        return (f"quality {self.target.name}: {setting} ({self.psnr:.1f} dB estimated, "
                f"{how}{verdict})")

    def as_dict(self) -> dict:
        """JSON-friendly fields (the cache and the benches store these)."""
        return {"target": self.target.psnr, "name": self.target.name, "setting": self.setting,
                "psnr": self.psnr, "met": self.met, "measured": self.measured,
                "seconds": self.seconds, "size": list(self.size), "traced": self.traced}


def footprint(camera: Camera, size: Sequence[int], bounds) -> tuple[int, int, int, int]:
    """Pixel rectangle ``(x0, y0, x1, y1)`` (rows from the top) the box ``bounds`` covers.

    The whole frame when the eye is inside the box or a corner lies behind the eye.
    """
    width, height = (int(v) for v in size)
    b = np.asarray(bounds, dtype=np.float64)
    corners = np.array([[x, y, z] for x in b[0:2] for y in b[2:4] for z in b[4:6]])
    right, up, forward = camera.basis()
    relative = corners - np.asarray(camera.position, dtype=np.float64)
    depth = relative @ forward
    aspect = width / height
    if camera.parallel_projection:
        half = float(camera.parallel_scale)
        ndc_x = relative @ right / (half * aspect)
        ndc_y = relative @ up / half
    else:
        if np.any(depth <= 1e-9 * max(1.0, float(np.abs(relative).max()))):
            return 0, 0, width, height
        half = math.tan(math.radians(camera.view_angle) / 2.0)
        ndc_x = relative @ right / (depth * half * aspect)
        ndc_y = relative @ up / (depth * half)
    xs = (ndc_x + 1.0) / 2.0 * width
    ys = (1.0 - ndc_y) / 2.0 * height
    tiny = 1e-6   # a corner on a pixel's edge by rounding does not take the next pixel
    x0, x1 = (int(np.clip(v, 0, width)) for v in (np.floor(xs.min() + tiny),
                                                   np.ceil(xs.max() - tiny)))
    y0, y1 = (int(np.clip(v, 0, height)) for v in (np.floor(ys.min() + tiny),
                                                    np.ceil(ys.max() - tiny)))
    return x0, y0, x1, y1


def sample_pixels(rect, count: int = SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    """About ``count`` pixels ``(rows, columns)`` on an even lattice over ``rect``.

    Spread over the whole footprint (its empty margins and its sharpest edges alike), so
    their mean squared error estimates the footprint's without bias; windows would miss
    an error that gathers on a thin shell.
    """
    x0, y0, x1, y1 = rect
    width, height = x1 - x0, y1 - y0
    if width < 1 or height < 1:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    stride = max(1, int(math.sqrt(width * height / float(count))))
    columns = np.arange(x0 + stride // 2, x1, stride)
    rows = np.arange(y0 + stride // 2, y1, stride)
    grid_rows, grid_columns = np.meshgrid(rows, columns, indexing="ij")
    return grid_rows.ravel(), grid_columns.ravel()


def estimated_psnr(image: np.ndarray, pixels, reference: np.ndarray, share: float,
                   fraction: float = 1.0) -> float:
    """The whole frame's PSNR from the sampled pixels' error and the footprint's share.

    Outside the footprint both images are the background, so the frame's mean squared
    error is the footprint's times its share of the frame. ``fraction``: the share of the
    footprint's pixels the sample holds. Below 1 the sample's mean stands for the
    footprint's only up to its standard error, which is large when few pixels carry the
    error (a thin sheet missed: tens of pixels); the estimate is then the mean plus two
    standard errors (``sqrt((1 - fraction) / n)``, ``n`` the pixels the error is spread
    over: ``(sum e)**2 / sum e**2``), so a sparse error is not under-counted by chance.
    """
    rows, columns = pixels
    drawn = image[rows, columns].astype(np.float64)
    traced = to_uint8(reference).reshape(-1, 3).astype(np.float64)
    per_pixel = ((drawn - traced) ** 2).mean(axis=-1)
    total = float(per_pixel.sum())
    if total == 0.0:
        return math.inf
    mse = total / per_pixel.size * share
    if fraction < 1.0:
        spread = total ** 2 / float((per_pixel ** 2).sum())
        mse *= 1.0 + 2.0 * math.sqrt((1.0 - fraction) / spread)
    return 10.0 * math.log10(255.0 ** 2 / mse)


def search(count: int, psnr_at: Callable[[int], float], goal: float, start: int) -> int | None:
    """The first rung whose PSNR reaches ``goal``, or None: model-guided, then bisected.

    Each measurement predicts how many rungs away the goal lies (a rung gains about
    :data:`DB_PER_HALVING`); the next rung tried is that guess, kept strictly between the
    highest rung known to miss and the lowest known to meet (the bisection's midpoint when
    the guess was tried already), until the two are neighbours.
    """
    low, high = -1, count     # low: the highest rung known to miss; high: lowest to meet
    measured: set[int] = set()
    index = min(max(start, 0), count - 1)
    while high - low > 1:
        measured.add(index)
        psnr = psnr_at(index)
        if psnr >= goal:
            high = index
            gap = psnr - goal
            step = -max(1, int(gap // DB_PER_HALVING)) if math.isfinite(gap) else -count
        else:
            low = index
            step = max(1, math.ceil((goal - psnr) / DB_PER_HALVING)) \
                if math.isfinite(goal - psnr) else count
        if high - low <= 1:
            break
        guess = min(max(index + step, low + 1), high - 1)
        index = guess if guess not in measured else (low + high) // 2
    return None if high == count else high


def calibrate(tracks: Sequence[Sequence[Rung]], render: Callable[[dict], np.ndarray],
              reference: Callable[[tuple[np.ndarray, np.ndarray]], np.ndarray], camera: Camera,
              size: Sequence[int], bounds, target: QualityTarget, start: int | None = None,
              samples: int = SAMPLES) -> QualityChoice:
    """Keep the cheapest rung whose estimated PSNR meets ``target``, over every track.

    ``render(setting)`` draws the whole frame (uint8 ``(h, w, 3)``); ``reference(pixels)``
    traces the sampled pixels on the CPU (floats in [0, 1]). Each track is searched from ``start``
    (its middle by default) as :func:`search` guides; of the tracks' first rungs that meet
    the target, the one of least cost is kept, else the best measured. ``samples``: about
    how many pixels the reference traces.
    """
    began = time.perf_counter()
    size = (int(size[0]), int(size[1]))
    rect = footprint(camera, size, bounds)
    pixels = sample_pixels(rect, samples)
    if not pixels[0].size:
        raise ValueError("quality=: what is added lies outside the view, so there is "
                         "nothing to measure; set the camera first (or give the settings "
                         "themselves).")
    area = (rect[2] - rect[0]) * (rect[3] - rect[1])
    share = area / float(size[0] * size[1])
    fraction = min(1.0, pixels[0].size / float(area))
    traced = reference(pixels)
    estimates: dict[tuple[int, int], float] = {}
    measured: list[dict] = []

    def psnr_of(track: int, index: int) -> float:
        if (track, index) not in estimates:
            rung = tracks[track][index]
            image = np.asarray(render(dict(rung.setting)))
            estimates[track, index] = estimated_psnr(image, pixels, traced, share, fraction)
            measured.append({"setting": rung.setting, "psnr": estimates[track, index],
                             "cost": rung.cost})
        return estimates[track, index]

    winners = []
    for number, track in enumerate(tracks):
        first = len(track) // 2 if start is None else start
        kept = search(len(track), lambda i, n=number: psnr_of(n, i),
                      target.psnr + MARGIN_DB, first)
        if kept is not None:
            winners.append((track[kept].cost, number, kept))
    if winners:
        _, number, index = min(winners)
    else:   # none meets it: the best measured (the finest step is not always the best:
        # rounding accumulates over thousands of steps)
        number, index = max(estimates, key=lambda k: (estimates[k], -tracks[k[0]][k[1]].cost))
    psnr = psnr_of(number, index)
    return QualityChoice(target, dict(tracks[number][index].setting), psnr,
                         psnr >= target.psnr, measured, time.perf_counter() - began, size,
                         int(pixels[0].size))
