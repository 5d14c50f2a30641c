"""What ``quality=`` accepts: a PSNR target in dB, or a named one."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

#: The named targets, in dB of PSNR against the technique's CPU reference.
NAMED_TARGETS = {"fast": 30.0, "balanced": 40.0, "best": 50.0}
#: Targets past this are refused: 8-bit images differ by rounding alone at about 60 dB.
HIGHEST_TARGET = 60.0


@dataclass(frozen=True)
class QualityTarget:
    """A PSNR target (dB) and the name it was asked by (``'40 dB'``, ``'balanced'``)."""

    psnr: float
    name: str

    @property
    def exact(self) -> bool:
        """Whether the reference itself is asked for (``quality='exact'``)."""
        return self.name == "exact"


def parse_quality(value, exact: bool = False) -> QualityTarget:
    """Read ``quality=``: a number of dB in (0, 60], or 'fast', 'balanced', 'best'.

    ``exact``: the technique can draw its reference exactly, so ``'exact'`` is accepted
    (a target of infinite PSNR).

    Raises
    ------
    ValueError
        For anything else, naming what is accepted ('exact' among them, which the
        emission/absorption techniques cannot reach: their reference integrates finer).
    """
    if isinstance(value, QualityTarget):
        return value
    if isinstance(value, str):
        word = value.strip().lower()
        if word in NAMED_TARGETS:
            return QualityTarget(NAMED_TARGETS[word], word)
        if word == "exact" and exact:
            return QualityTarget(math.inf, "exact")
        if word == "exact":
            raise ValueError("quality='exact' is for techniques that can draw their reference "
                             "exactly (voxels, surfaces); the emission/absorption techniques "
                             "approximate an integral: give a PSNR in dB (up to "
                             f"{HIGHEST_TARGET:g}) or one of {', '.join(NAMED_TARGETS)}.")
        try:
            value = float(word.removesuffix("db").strip())
        except ValueError:
            raise ValueError(f"quality={value!r} is not a target: give a PSNR in dB (30, "
                             f"'45dB') or one of {', '.join(NAMED_TARGETS)}.") from None
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise ValueError(f"quality={value!r} is not a target: give a PSNR in dB or one of "
                         f"{', '.join(NAMED_TARGETS)}.")
    value = float(value)
    if not math.isfinite(value) or not 0.0 < value <= HIGHEST_TARGET:
        raise ValueError(f"quality={value:g} dB is out of range: give a PSNR in (0, "
                         f"{HIGHEST_TARGET:g}] dB (8-bit images differ by their rounding "
                         "alone at about 60 dB).")
    return QualityTarget(value, f"{value:g} dB")
