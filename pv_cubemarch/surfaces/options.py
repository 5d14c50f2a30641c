"""The options of the surface techniques, validated in one place."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyvista

from ..core.options import positive_number, whole_number
from ..models.surface import ACTIVE_TESTS

ROOTS = ("march", "exact")
#: How ``technique='active'`` finds its active cells: one traversal per pixel through their
#: brick index, or the seed's boxes (a fragment per cell).
TRAVERSALS = ("index", "cell_boxes")
COLOR_BY = ("curvature", "field")
SHADINGS = ("unlit", "flat", "blinn", "normals")
#: Loop iterations one fragment may run. Mesa's llvmpipe stops every loop of a fragment once
#: its limiter is spent (65535 decrements; measured: about 32,000 iterations of our loops, a
#: ray of more samples losing its far hits); this keeps under it with room.
LOOP_BUDGET = 30_000
#: Most steps along the domain's diagonal (the seed's M; 5000 in its tables): a ray of the
#: full march takes at most this many samples, within LOOP_BUDGET.
MAX_STEPS = 25_000
#: Loop iterations of traversal='index' per cell a ray crosses: its moves and descents
#: through blocks, bricks and cells, and a marched cell's sample count rounded up.
INDEX_ITERATIONS_PER_CELL = 4
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
    ``steps``; ``technique='active'`` only). ``traversal`` (``technique='active'``):
    ``'index'`` (one ray per pixel through the active cells' bricks, stopping at the first
    root) or ``'cell_boxes'`` (the seed's: each active cell's box drawn, a fragment marching
    its own cell, the depth test keeping the nearest). ``active_test``: ``'bernstein'``
    (exact: no crossed cell is ever left out) or ``'sample'`` (the seed's: a
    ``active_samples``³ lattice per cell). ``color``: the surface's colour; ``shading``:
    ``'unlit'``, ``'flat'`` (Lambert from the scene's lights) or ``'blinn'`` (plus a
    highlight), with ``ambient``, ``specular``, ``specular_power``; both sides are lit
    (open surfaces show their back); ``'normals'`` shows the view-space normal facing the
    eye as the colour ``0.5 + 0.5 n`` (for checking normals against a reference).
    ``color_by``: ``None`` (``color``), ``'curvature'`` (the mean curvature, per world unit,
    positive where the surface bends like a ball) or ``'field'`` (a second field's value,
    the model's ``color_values``), through ``cmap`` over ``clim`` (by default the second
    field's coefficients' range, or for curvature plus and minus 4 / the domain's smallest
    side: a ball filling the domain's narrowest way sits at half the range).
    """

    steps: int = 500
    refine_steps: int = 10
    root: str = "march"
    traversal: str = "index"
    active_test: str = "bernstein"
    active_samples: int = 4
    color: object = "white"
    shading: str = "blinn"
    ambient: float = 0.2
    specular: float = 0.3
    specular_power: float = 30.0
    color_by: str | None = None
    cmap: str = "viridis"
    clim: tuple[float, float] | None = None

    def check(self) -> None:
        """Raise a clear error for a bad option."""
        whole_number("steps", self.steps, 1, MAX_STEPS)
        whole_number("refine_steps", self.refine_steps, 0, MAX_REFINE_STEPS)
        if self.root not in ROOTS:
            raise ValueError(f"root must be one of {ROOTS}, got {self.root!r}.")
        if self.traversal not in TRAVERSALS:
            raise ValueError(f"traversal must be one of {TRAVERSALS}, got {self.traversal!r}.")
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
        if self.color_by is not None and self.color_by not in COLOR_BY:
            raise ValueError(f"color_by must be None, one of {COLOR_BY} or a field's values, "
                             f"got {self.color_by!r}.")
        if self.clim is not None:
            low, high = (float(v) for v in self.clim)
            if not (np.isfinite(low) and np.isfinite(high) and high > low):
                raise ValueError(f"clim must be two finite numbers, low < high, got "
                                 f"{self.clim!r}.")
        try:
            pyvista.LookupTable(self.cmap)
        except Exception as error:
            raise ValueError(f"cmap={self.cmap!r} is not a colormap name: {error}") from None

    def check_model(self, model) -> None:
        """Refuse ``color_by='field'`` on a field without colour values."""
        if self.color_by == "field" and getattr(model, "color_values", None) is None:
            raise ValueError("color_by='field' colours by the field's color_values, which "
                             "this field has none of: pass the values as color_by=.")

    def color_range(self, model) -> tuple[float, float]:
        """``clim``, or the default range of what ``color_by`` colours by."""
        if self.clim is not None:
            return float(self.clim[0]), float(self.clim[1])
        if self.color_by == "field":
            low, high = float(model.color_values.min()), float(model.color_values.max())
            return (low, high) if high > low else (low - 0.5, low + 0.5)
        bounds = np.asarray(model.world_bounds()).reshape(3, 2)
        bend = 4.0 / max(float((bounds[:, 1] - bounds[:, 0]).min()), 1e-300)
        return -bend, bend

    def lookup_table(self) -> np.ndarray:
        """``(256, 3)`` float colours of ``cmap``, low to high."""
        return np.asarray(pyvista.LookupTable(self.cmap, n_values=256).values[:, :3],
                          dtype=np.float64) / 255.0

    @property
    def rgb(self) -> tuple[float, float, float]:
        """The colour as linear floats."""
        return tuple(float(v) for v in pyvista.Color(self.color).float_rgb)

    def index_iterations(self, dimensions) -> int:
        """Loop iterations a ray of ``traversal='index'`` may take on this grid, at most.

        Every cell along the longest ray (at most ``nx + ny + nz``), all of ``steps``
        samples, the refinement (``root='exact'`` adds up to about 200 per cell it solves,
        not counted: such rays have few).
        """
        cells = int(sum(int(n) for n in dimensions))
        return INDEX_ITERATIONS_PER_CELL * cells + int(self.steps) + int(self.refine_steps)

    def step_length(self, dimensions) -> float:
        """Cell units between samples: the domain's diagonal over ``steps``."""
        return float(np.linalg.norm(np.asarray(dimensions, dtype=np.float64))) / self.steps
