"""The options of the surface techniques, validated in one place."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyvista

from ..core.options import positive_number, whole_number
from ..models.surface import ACTIVE_TESTS

ROOTS = ("march", "exact")
SHADINGS = ("unlit", "flat", "blinn")
#: Most steps along the domain's diagonal (the seed's M; 5000 in its tables).
MAX_STEPS = 100_000
#: Most bisection steps refining a bracketed root (float32 halves it 24 times at most).
MAX_REFINE_STEPS = 40


@dataclass(frozen=True)
class SurfaceOptions:
    """How a field's zero set is found along each pixel's ray and how it is shaded.

    ``steps``: the seed's M, samples along the domain's diagonal (in cell units): each cell
    crossed is sampled every ``diagonal / steps`` from where the ray enters it, its exit
    included; ``refine_steps``: bisections on the first sign change (the seed's 10).
    ``root``: ``'march'`` (the seed's) or ``'exact'`` (the first root of the cell's
    degree-6 polynomial along the ray, by Bernstein subdivision: none missed at any
    ``steps``; ``technique='active'`` only). ``active_test``: ``'bernstein'`` (exact: no crossed
    cell is ever left out) or ``'sample'`` (the seed's: a ``active_samples``³ lattice per
    cell). ``color``: the surface's colour; ``shading``: ``'unlit'``, ``'flat'`` (Lambert
    from the scene's lights) or ``'blinn'`` (plus a highlight), with ``ambient``,
    ``specular``, ``specular_power``; both sides are lit (open surfaces show their back).
    """

    steps: int = 500
    refine_steps: int = 10
    root: str = "march"
    active_test: str = "bernstein"
    active_samples: int = 4
    color: object = "white"
    shading: str = "blinn"
    ambient: float = 0.2
    specular: float = 0.3
    specular_power: float = 30.0

    def check(self) -> None:
        """Raise a clear error for a bad option."""
        whole_number("steps", self.steps, 1, MAX_STEPS)
        whole_number("refine_steps", self.refine_steps, 0, MAX_REFINE_STEPS)
        if self.root not in ROOTS:
            raise ValueError(f"root must be one of {ROOTS}, got {self.root!r}.")
        if self.active_test not in ACTIVE_TESTS:
            raise ValueError(f"active_test must be one of {ACTIVE_TESTS}, got "
                             f"{self.active_test!r}.")
        whole_number("active_samples", self.active_samples, 2, 64)
        if self.shading not in SHADINGS:
            raise ValueError(f"shading must be one of {SHADINGS}, got {self.shading!r}.")
        try:
            pyvista.Color(self.color)
        except ValueError as error:
            raise ValueError(f"color={self.color!r} is not a colour: {error}") from None
        positive_number("ambient", self.ambient, 0.0, 1.0, closed_low=True)
        positive_number("specular", self.specular, 0.0, 1.0, closed_low=True)
        positive_number("specular_power", self.specular_power, 0.0, 1e4)

    def check_model(self, model) -> None:
        """Nothing the field can refuse yet (any grid of cells is drawn)."""

    @property
    def rgb(self) -> tuple[float, float, float]:
        """The colour as linear floats."""
        return tuple(float(v) for v in pyvista.Color(self.color).float_rgb)

    def step_length(self, dimensions) -> float:
        """Cell units between samples: the domain's diagonal over ``steps``."""
        return float(np.linalg.norm(np.asarray(dimensions, dtype=np.float64))) / self.steps
