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


def is_count(isosurfaces) -> bool:
    """Whether ``isosurfaces=`` is a count of levels (an int), not the levels."""
    return isinstance(isosurfaces, (int, np.integer)) and not isinstance(isosurfaces, bool)


def spread_levels(count, values: np.ndarray) -> tuple[float, ...]:
    """``count`` levels from the finite ``values``' smallest to largest, as contour does.

    :meth:`pyvista.DataSetFilters.contour` spreads ``isosurfaces=count`` so.
    """
    if count < 1:
        raise ValueError(f"isosurfaces as a count must be at least 1, got {count}.")
    values = np.asarray(values, dtype=np.float64)
    values = values[np.isfinite(values)]
    return tuple(float(v) for v in np.linspace(values.min(), values.max(), int(count)))


def level_values(isosurfaces) -> list:
    """The levels ``isosurfaces=`` gives (one or more finite numbers), as given."""
    levels = list(np.atleast_1d(np.asarray(isosurfaces, dtype=object)).ravel())
    try:
        finite = [np.isfinite(float(v)) for v in levels]
    except (TypeError, ValueError):
        raise ValueError(f"isosurfaces must be numbers (data values) or a count, got "
                         f"{isosurfaces!r}.") from None
    if not levels or not all(finite):
        raise ValueError(f"isosurfaces must be one or more finite numbers, got "
                         f"{isosurfaces!r}.")
    return levels
