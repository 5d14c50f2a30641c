"""Validated option types: numbers checked once, with errors that name the argument."""

from __future__ import annotations

import numpy as np


def positive_number(name: str, value, low: float = 0.0, high: float = np.inf,
                    closed_low: bool = False) -> float:
    """``value`` as a float in (low, high] (or [low, high]), or a ValueError naming ``name``."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}.") from None
    above = number >= low if closed_low else number > low
    if not (np.isfinite(number) and above and number <= high):
        bracket = "[" if closed_low else "("
        raise ValueError(f"{name} must be in {bracket}{low:g}, {high:g}], got {value!r}.")
    return number


def whole_number(name: str, value, low: int, high: int | None = None) -> int:
    """``value`` as an int in [low, high], or a ValueError naming ``name``."""
    try:
        ok = float(value) == int(value)
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok or int(value) < low or (high is not None and int(value) > high):
        span = f"from {low} to {high}" if high is not None else f">= {low}"
        raise ValueError(f"{name} must be a whole number {span}, got {value!r}.")
    return int(value)
