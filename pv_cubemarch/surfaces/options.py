"""The options of the surface techniques, validated in one place."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyvista

from ..core.declared import (
    AUTO,
    Control,
    Option,
    blinn_terms,
    declare,
    preset_or_number,
    scalar_bar_terms,
)
from ..models.surface import ACTIVE_TESTS
from ..volume.clipping import clip_plane_list, plane_pairs

ROOTS = ("march", "exact")
#: How ``technique='active'`` finds its active cells: one traversal per pixel through their
#: brick index, or their boxes (a fragment per cell).
TRAVERSALS = ("index", "cell_boxes")
COLOR_BY = ("curvature", "field")
SHADINGS = ("unlit", "flat", "blinn", "normals")
#: Loop iterations one fragment may run. Mesa's llvmpipe stops every loop of a fragment once
#: its limiter is spent (65535 decrements; measured: about 32,000 iterations of our loops, a
#: ray of more samples losing its far hits); this keeps under it with room.
LOOP_BUDGET = 30_000
#: Most steps along the domain's diagonal (the benchmarks go up to 5000): a ray of the
#: full march takes at most this many samples, within LOOP_BUDGET.
MAX_STEPS = 25_000
#: Loop iterations of traversal='index' per cell a ray crosses: its moves and descents
#: through blocks, bricks and cells, and a marched cell's sample count rounded up.
INDEX_ITERATIONS_PER_CELL = 4
#: Most bisection steps refining a bracketed root (float32 halves it 24 times at most).
MAX_REFINE_STEPS = 40


ACTIVE = ("active",)
#: Every option of the surface techniques, declared once (:mod:`pv_cubemarch.core.declared`).
(TECHNIQUE, STEPS, REFINE_STEPS, ROOT, TRAVERSAL, ACTIVE_TEST, ACTIVE_SAMPLES, COLOR, SHADING,
 AMBIENT, DIFFUSE, SPECULAR, SPECULAR_POWER, COLOR_BY_OPTION, CMAP, CLIM, OPACITY, QUALITY,
 FRAME_BUDGET_MS, CLIP_PLANES) = declare(
    Option("technique", "surface", str, "active", "active (only the cells the surface can "
           "cross) or full (every cell)", choices=("active", "full"),
           usd="surfaceTechnique", cli="--surface-technique", control=Control("select")),
    Option("steps", "surface", int, 500, "samples along the domain's diagonal (M)", low=1,
           high=MAX_STEPS, control=Control("slider", "steps (M)", 10, 5000, 10,
                                           help="samples along the diagonal")),
    Option("refine_steps", "surface", int, 10, "bisections of the first sign change", low=0,
           high=MAX_REFINE_STEPS, control=Control("select", "refine steps",
                                                  choices=(0, 5, 10, 20, 40))),
    Option("root", "surface", str, "march", "march (sampled) or exact (the cell polynomial's "
           "first root)", choices=ROOTS, control=Control("select")),
    Option("traversal", "surface", str, "index", "through the active cells' brick index, "
           "or a box per cell", ACTIVE, choices=TRAVERSALS, usd="surfaceTraversal",
           cli="--surface-traversal", control=Control("select", "traversal")),
    Option("active_test", "surface", str, "bernstein", "which cells are active: bernstein "
           "(exact) or sample (a lattice per cell)", ACTIVE, choices=ACTIVE_TESTS,
           control=Control("select", "active test")),
    Option("active_samples", "surface", int, 4, "lattice points per cell edge of "
           "active_test='sample'", ACTIVE, low=2, high=64,
           control=Control("select", "active samples", choices=(2, 3, 4, 8))),
    Option("color", "surface", str, "white", "the surface's colour", cli="--surface-color",
           usd_type="color3f",
           without={"knob": "any colour PyVista names; set in Python, the CLI or USD"}),
    Option("shading", "surface", str, "blinn", "unlit, flat, blinn or normals (view-space "
           "normals as colours)", choices=SHADINGS, control=Control("select")),
    *blinn_terms("surface"),
    Option("color_by", "surface", str, None, "colour by the mean curvature or a second "
           "field, through cmap", choices=COLOR_BY, optional=True,
           control=Control("select", "colour by", choices=(AUTO, *COLOR_BY))),
    Option("cmap", "surface", str, "viridis", "colormap of color_by", cli="--surface-cmap",
           without={"knob": "any matplotlib colormap name; set in Python, the CLI or USD"}),
    Option("clim", "surface", tuple, None, "the range of color_by (or of isosurfaces coloured "
           "by value) the colormap spans",
           optional=True, cli="--surface-clim", usd="surfaceClim",
           without={"knob": "two numbers in the data's units; set in Python, the CLI or "
                            "USD"}),
    Option("opacity", "surface", float, 1.0, "below 1, every crossing along the ray is "
           "composited front to back, each covering this much (traversal='index')", ACTIVE,
           low=0.0, high=1.0, cli="--surface-opacity", usd="surfaceOpacity",
           control=Control("slider", "opacity", 0.0, 1.0, 0.05)),
    Option("quality", "surface", str, None, "error budget: the fewest steps whose PSNR "
           "against the CPU reference meets this many dB, fast / balanced / best (30 / 40 / "
           "50), or exact (root='exact')", optional=True, parse=preset_or_number,
           control=Control("select", "quality", choices=(AUTO, "fast", "balanced", "best",
                                                         "exact"),
                           help="calibrated against the CPU reference")),
    Option("frame_budget_ms", "surface", float, None, "while the view moves, the most steps "
           "(below 100, fewer pixels) keeping frames within this many ms (the still ones "
           "when it stops)", low=0.0,
           closed_low=False, optional=True,
           control=Control("select", "frame budget (ms)", choices=(AUTO, 16, 33, 66, 100),
                           help="fewer steps, then pixels, while the view moves")),
    Option("clip_planes", "surface", tuple, None, "planes that cut the surface, six numbers "
           "each: a point, then the normal to the side kept (the cut left open, as a "
           "clipped mesh)", optional=True,
           without={"knob": "six numbers a plane; set in Python, the CLI or USD "
                            "(actor.cubemarch.set_clip_planes moves them)"}),
)
#: The scalar bar's keywords, as every kind declares them.
declare(*scalar_bar_terms("surface"))


@dataclass(frozen=True)
class SurfaceOptions:
    """How a field's zero set is found along each pixel's ray and how it is shaded.

    ``steps``: samples along the domain's diagonal (in cell units): each cell crossed is
    sampled every ``diagonal / steps`` from where the ray enters it, its exit included;
    ``refine_steps``: bisections on the first sign change (10 by default). ``root``:
    ``'march'`` (default: samples at fixed steps) or ``'exact'`` (the first root of the
    cell's degree-6 polynomial along the ray, by Bernstein subdivision: none missed at any
    ``steps``; ``technique='active'`` only). ``traversal`` (``technique='active'``):
    ``'index'`` (one ray per pixel through the active cells' bricks, stopping at the first
    root) or ``'cell_boxes'`` (each active cell's box drawn, a fragment marching its own
    cell, the depth test keeping the nearest). ``active_test``: ``'bernstein'``
    (exact: no crossed cell is ever left out) or ``'sample'`` (a lattice of
    ``active_samples ** 3`` points per cell). ``color``: the surface's colour; ``shading``:
    ``'unlit'``, ``'flat'`` (Lambert from the scene's lights) or ``'blinn'`` (plus a
    highlight), with ``ambient``, ``specular``, ``specular_power``; both sides are lit
    (open surfaces show their back); ``'normals'`` shows the view-space normal facing the
    eye as the colour ``0.5 + 0.5 n`` (for checking normals against a reference).
    ``color_by``: ``None`` (``color``), ``'curvature'`` (the mean curvature, per world unit,
    positive where the surface bends like a ball) or ``'field'`` (a second field's value,
    the model's ``color_values``), through ``cmap`` over ``clim`` (by default the second
    field's coefficients' range, or for curvature plus and minus 4 / the domain's shortest
    edge in the world, whatever its turn: a ball filling the domain's narrowest way sits
    at half the range).
    ``opacity``: below 1, every crossing along a pixel's ray up to the opaque scene is
    composited front to back, each lit and covering ``opacity`` of what lies behind
    (``traversal='index'``).
    """

    steps: int = STEPS.field()
    refine_steps: int = REFINE_STEPS.field()
    root: str = ROOT.field()
    traversal: str = TRAVERSAL.field()
    active_test: str = ACTIVE_TEST.field()
    active_samples: int = ACTIVE_SAMPLES.field()
    color: object = COLOR.field()
    shading: str = SHADING.field()
    ambient: float = AMBIENT.field()
    diffuse: float = DIFFUSE.field()
    specular: float = SPECULAR.field()
    specular_power: float = SPECULAR_POWER.field()
    color_by: str | None = COLOR_BY_OPTION.field()
    cmap: str = CMAP.field()
    clim: tuple[float, float] | None = CLIM.field()
    opacity: float = OPACITY.field()
    clip_planes: tuple | None = CLIP_PLANES.field()

    def check(self) -> None:
        """Raise a clear error for a bad option."""
        for item in (STEPS, REFINE_STEPS, ROOT, TRAVERSAL, ACTIVE_TEST, ACTIVE_SAMPLES,
                     SHADING):
            item.check(getattr(self, item.name))
        try:
            pyvista.Color(self.color)
        except ValueError as error:
            raise ValueError(f"color={self.color!r} is not a colour: {error}") from None
        for item in (AMBIENT, DIFFUSE, SPECULAR, SPECULAR_POWER, OPACITY):
            item.check(getattr(self, item.name))
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
        CLIP_PLANES.check(self.clip_planes)
        if self.clip_planes is not None:
            clip_plane_list(self.clip_planes)   # six finite numbers a plane, normals not 0

    @property
    def world_planes(self) -> tuple:
        """The clip planes as ``(origin, normal)`` pairs in world coordinates."""
        return plane_pairs(self.clip_planes)

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
        # the grid's edges in the world, not its world bounds: a turn leaves them be
        edges = np.linalg.norm(model.world_from_index()[:3, :3], axis=0) * model.dimensions
        bend = 4.0 / max(float(edges.min()), 1e-300)
        return -bend, bend

    def lookup_table(self) -> np.ndarray:
        """``(256, 3)`` float colours of ``cmap``, low to high."""
        return np.asarray(pyvista.LookupTable(self.cmap, n_values=256).values[:, :3],
                          dtype=np.float64) / 255.0

    @property
    def translucent(self) -> bool:
        """Whether the surface is drawn translucent (every crossing composited)."""
        return float(self.opacity) < 1.0

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

    def step_length(self, field) -> float:
        """Cell units between samples: the diagonal of ``field``'s domain over ``steps``.

        The domain drawn, not the grid: point samples' hull is a cell shorter an axis.
        """
        lower, upper = field.domain_corners()
        return float(np.linalg.norm(np.asarray(upper - lower, dtype=np.float64))) / self.steps
