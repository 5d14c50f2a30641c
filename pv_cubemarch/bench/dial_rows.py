"""The rows of ``bench dial``: a setting's time and error, a target's choice, an orbit."""

from __future__ import annotations

import contextlib
import os
import tempfile
from dataclasses import dataclass

from ..quality import cache


@dataclass
class SweepRow:
    """One rung of a technique's ladder on a scene: its time and whole-frame PSNR."""

    scene: str
    technique: str
    setting: str
    median_ms: float
    psnr: float
    default: bool = False
    pareto: bool = False


@dataclass
class InteractionRow:
    """A scripted orbit with ``frame_budget_ms``: moving frames within it, then the stop."""

    scene: str
    technique: str
    size: list
    budget_ms: float
    moving_frames: int
    within_budget: float
    median_moving_ms: float
    steps: str
    knob: str
    still_value: float
    still_ms: float
    still_psnr: float


@dataclass
class DialRow:
    """``quality=target``: what it chose and how that compares with the sweep."""

    scene: str
    technique: str
    target: float
    chosen: str
    psnr: float
    estimated: float
    met: bool
    cheapest: str | None
    cost_ratio: float | None
    calibration_s: float


def label(setting: dict) -> str:
    """A setting as keywords (``step_scale=0.5``)."""
    return ", ".join(f"{k}={v:g}" if isinstance(v, (int, float)) else f"{k}={v}"
                     for k, v in setting.items())


def mark_front(rows: list[SweepRow]) -> list[SweepRow]:
    """Star the rows no other row beats in both time and PSNR (the Pareto front)."""
    for row in rows:
        row.pareto = not any(o.median_ms <= row.median_ms and o.psnr >= row.psnr and
                             (o.median_ms < row.median_ms or o.psnr > row.psnr) for o in rows)
    return rows


@contextlib.contextmanager
def fresh_cache():
    """A cache folder of its own for the block, so every choice is calibrated afresh."""
    saved = os.environ.get(cache.CACHE_ENV)
    with tempfile.TemporaryDirectory() as folder:
        os.environ[cache.CACHE_ENV] = folder
        cache.forget()
        try:
            yield
        finally:
            if saved is None:
                os.environ.pop(cache.CACHE_ENV, None)
            else:
                os.environ[cache.CACHE_ENV] = saved
            cache.forget()
