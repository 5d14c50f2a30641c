"""Calibration: the cheapest rung whose error against CPU reference crops meets the target.

The GPU draws the whole frame (its cost and its level of detail are the view's); the CPU
reference traces only a few crops inside the volume's footprint, so calibrating costs
little more than a few frames. The crops' error stands for the footprint's, and the whole
frame's PSNR is estimated from it and the footprint's share of the frame (pixels outside
the volume are the background in both images).
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

#: Calibration aims this far past the target: crops stand for the frame only roughly.
MARGIN_DB = 0.5
#: Side of each crop the CPU reference traces, in pixels.
CROP = 40


@dataclass
class QualityChoice:
    """What ``quality=`` chose, and what was measured to choose it.

    ``psnr`` is the kept setting's whole-frame PSNR (dB) as estimated from the crops;
    ``met`` whether it reaches the target (when no rung does, the finest is kept);
    ``measured`` every rung tried, in order, with its estimate and relative cost.
    """

    target: QualityTarget
    setting: dict
    psnr: float
    met: bool
    measured: list[dict] = field(default_factory=list)
    seconds: float = 0.0
    size: tuple[int, int] = (0, 0)
    crops: list[tuple[int, int, int, int]] = field(default_factory=list)
    cached: bool = False

    def __str__(self) -> str:
        setting = ", ".join(f"{k}={v:g}" for k, v in self.setting.items())
        how = "from the cache" if self.cached else (
            f"{len(self.measured)} settings tried in {self.seconds:.2f} s")
        verdict = "" if self.met else "; the target is out of reach, the finest is drawn"
        return (f"quality {self.target.name}: {setting} ({self.psnr:.1f} dB estimated, "
                f"{how}{verdict})")

    def as_dict(self) -> dict:
        """JSON-friendly fields (the cache and the benches store these)."""
        return {"target": self.target.psnr, "name": self.target.name, "setting": self.setting,
                "psnr": self.psnr, "met": self.met, "measured": self.measured,
                "seconds": self.seconds, "size": list(self.size),
                "crops": [list(c) for c in self.crops]}


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


def crop_windows(rect, side: int = CROP) -> list[tuple[int, int, int, int]]:
    """Up to three ``(x, y, w, h)`` crops in ``rect``: its centre and two diagonal points."""
    x0, y0, x1, y1 = rect
    width, height = x1 - x0, y1 - y0
    if width < 1 or height < 1:
        return []
    w, h = min(side, width), min(side, height)
    found = []
    for fx, fy in ((0.5, 0.5), (0.25, 0.3), (0.75, 0.7)):
        x = int(np.clip(round(x0 + fx * width - w / 2), x0, x1 - w))
        y = int(np.clip(round(y0 + fy * height - h / 2), y0, y1 - h))
        if (x, y, w, h) not in found:
            found.append((x, y, w, h))
    return found


def estimated_psnr(image: np.ndarray, references: dict, share: float) -> float:
    """The whole frame's PSNR from the crops' mean squared error and the footprint's share."""
    errors = [((image[y:y + h, x:x + w].astype(np.float64)
                - to_uint8(reference).astype(np.float64)) ** 2).ravel()
              for (x, y, w, h), reference in references.items()]
    mse = float(np.concatenate(errors).mean()) * share
    return math.inf if mse == 0.0 else 10.0 * math.log10(255.0 ** 2 / mse)


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
            step = max(1, math.ceil((goal - psnr) / DB_PER_HALVING))
        if high - low <= 1:
            break
        guess = min(max(index + step, low + 1), high - 1)
        index = guess if guess not in measured else (low + high) // 2
    return None if high == count else high


def calibrate(ladder: Sequence[Rung], render: Callable[[dict], np.ndarray],
              reference: Callable[[tuple[int, int, int, int]], np.ndarray], camera: Camera,
              size: Sequence[int], bounds, target: QualityTarget, start: int | None = None
              ) -> QualityChoice:
    """Keep the cheapest rung of ``ladder`` whose estimated PSNR meets ``target``.

    ``render(setting)`` draws the whole frame (uint8 ``(h, w, 3)``); ``reference(crop)``
    traces one crop on the CPU (floats in [0, 1]). Rungs are tried from ``start`` (the
    middle by default) as :func:`search` guides.
    """
    began = time.perf_counter()
    size = (int(size[0]), int(size[1]))
    rect = footprint(camera, size, bounds)
    crops = crop_windows(rect)
    if not crops:
        raise ValueError("quality=: the volume is outside the view, so there is nothing to "
                         "measure; set the camera first (or give the settings themselves).")
    share = (rect[2] - rect[0]) * (rect[3] - rect[1]) / float(size[0] * size[1])
    references = {crop: reference(crop) for crop in crops}
    estimates: dict[int, float] = {}
    measured: list[dict] = []

    def psnr_at(index: int) -> float:
        if index not in estimates:
            image = np.asarray(render(dict(ladder[index].setting)))
            estimates[index] = estimated_psnr(image, references, share)
            measured.append({"setting": ladder[index].setting, "psnr": estimates[index],
                             "cost": ladder[index].cost})
        return estimates[index]

    first = len(ladder) // 2 if start is None else start
    kept = search(len(ladder), psnr_at, target.psnr + MARGIN_DB, first)
    index = len(ladder) - 1 if kept is None else kept
    psnr = psnr_at(index)
    return QualityChoice(target, dict(ladder[index].setting), psnr, psnr >= target.psnr,
                         measured, time.perf_counter() - began, size, crops)
