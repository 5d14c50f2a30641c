"""``add_surface(..., quality=)``: the fewest samples along the rays that meet a PSNR target.

A marched surface's error is the roots its samples miss (a thin feature between two
samples) or find late; both fall as ``steps`` grows, so ``steps`` is the ladder, with
``refine_steps`` as given. ``quality='exact'`` draws the first root of each cell's
polynomial (``root='exact'``), which no number of steps misses. Candidates are lit by one
headlight on the probe and in the reference alike, so a root found late shows as a wrong
normal, not only a wrong silhouette.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, fields

import numpy as np

from ..models.surface import level_cells
from ..models.volume import box_world_bounds
from ..surfaces.options import LOOP_BUDGET, MAX_STEPS, SurfaceOptions
from ..surfaces.technique import surface_recipe
from .interaction import set_still_steps, surface_parts
from .ladders import Rung
from .probe import ProbeCalibration
from .targets import QualityTarget, parse_quality

#: Samples along the domain's diagonal, coarse to fine: each doubling halves the gap a
#: feature can hide in and the depth a root is found late by.
SURFACE_STEPS = (25, 50, 100, 200, 400, 800, 1600, 3200, 6400, 12800, 25000)
#: The most steps below the exact root on technique='active''s ladder.
STEPS_BELOW_EXACT = 1600
#: The settings quality= chooses for a surface.
PICKED = ("steps", "root")


def check_surface_quality(quality, given: dict, options: SurfaceOptions,
                          technique: str) -> QualityTarget:
    """Read ``quality=`` for a surface and refuse what calibration cannot measure, by name."""
    target = parse_quality(quality, exact=True)
    picked = [k for k in PICKED if k in given]
    if picked:
        raise ValueError(f"quality= chooses {', '.join(picked)} itself: give quality= or "
                         "the settings, not both.")
    if options.shading == "normals":
        raise ValueError("quality= measures the colours the CPU reference draws, which has no "
                         "shading='normals': give steps= (or root='exact') for it.")
    if target.exact and options.translucent:
        raise ValueError("quality='exact' draws each cell's exact first root; a translucent "
                         "surface composites every crossing, marched: give it a PSNR target.")
    if target.exact and technique != "active":
        raise ValueError("quality='exact' draws each cell's exact first root, which "
                         "technique='active' finds (root='exact'); technique='full' marches: "
                         "give it a PSNR target, or use technique='active'.")
    return target


def _cell_corners_box(grid_from_index: np.ndarray, cells: np.ndarray, lower,
                      upper) -> np.ndarray:
    """Bounds, in the field's frame, of every corner of ``cells`` cut to ``[lower, upper]``.

    Per frame axis, the extreme corner of each cell is the one the axis' row points to
    (no ``(8 n, 3)`` array of corners).
    """
    cells = np.asarray(cells, dtype=np.float64)
    bounds = []
    for row in np.asarray(grid_from_index, dtype=np.float64)[:3]:
        ends = []
        for sign in (-1.0, 1.0):
            corner = np.clip(cells + (sign * row[:3] > 0), lower, upper)
            ends.append(corner @ row[:3] + row[3])
        bounds += [ends[0].min(), ends[1].max()]
    return np.asarray(bounds)


def surface_tracks(options: SurfaceOptions, dimensions, target: QualityTarget,
                   technique: str = "active", exact_rung: bool = True) -> list[list[Rung]]:
    """The ladder of ``steps`` this surface can march (the exact root alone for 'exact').

    Steps a ray of ``traversal='index'`` could not finish within a fragment's loops on
    llvmpipe are left off, as ``add_surface`` would refuse them. With ``'active'`` the
    exact root is the top rung, after :data:`STEPS_BELOW_EXACT`: it misses nothing and
    costs about what 500 to 3200 steps cost (``bench surfaces``: 1.1-1.4x 500 steps;
    ``bench dial``: between 1600 and 3200), so more steps than that would be dearer and
    no better. ``exact_rung=False`` (a frame budget moves the steps): steps only.
    """
    if target.exact:
        return [[Rung({"root": "exact"}, 1.0)]]
    exact_rung = exact_rung and technique == "active" and not options.translucent
    top = STEPS_BELOW_EXACT if exact_rung else MAX_STEPS
    steps = [m for m in SURFACE_STEPS if m <= top and (
        options.traversal != "index"
        or dataclasses.replace(options, steps=m).index_iterations(dimensions) <= LOOP_BUDGET)]
    if not exact_rung:
        return [[Rung({"steps": m}, m / float(steps[-1])) for m in steps]]
    finest = 2.0 * steps[-1]   # the exact root costs about twice the last rung's steps
    return [[*(Rung({"steps": m}, m / finest) for m in steps), Rung({"root": "exact"}, 1.0)]]


@dataclass
class SurfaceCalibration(ProbeCalibration):
    """``quality=`` of an implicit surface: its steps, or its exact root.

    ``options`` are the surface's (its colour, shading and traversal); ``keep`` what the
    candidates are drawn with besides the rung. Several levels: ``levels``, their values
    less the model's zero, and ``level_colors``, one RGB each.
    """

    options: SurfaceOptions | None = None
    exact_rung: bool = True
    levels: tuple | None = None
    level_colors: tuple | None = None
    kind = "surface"
    #: A marched surface errs at few pixels (a thin feature missed), which a sparse
    #: sample sees by chance (3.8 dB off at 4096 of 25,000 pixels): the reference traces
    #: more of them (its rays stop at the first root, so a pixel costs little).
    samples = 16384

    def follow_binding(self, binding) -> None:
        """The look and clip planes set on the surface since it was added (to recalibrate).

        A colour or range the levels take apart from the options is kept as made.
        """
        options = binding.options
        names = {f.name for f in fields(options)} - (
            {"color", "clim"} if self.levels is not None else set())
        self.keep = {**self.keep, **{k: getattr(options, k) for k in self.keep if k in names}}
        self.options = options

    def tracks(self) -> list[list[Rung]]:
        return surface_tracks(self.options, self.model.dimensions, self.target,
                              self.technique, self.exact_rung)

    def key_parts(self) -> tuple:
        model = self.model
        return (np.asarray(model.coefficients), np.asarray(model.world_from_index()),
                np.asarray(model.domain_corners()),
                sorted((k, repr(v)) for k, v in self.keep.items()))

    def bounds(self) -> np.ndarray:
        """The returned prop's bounds, as ``surfaces.technique`` will draw it (not built yet).

        The prop holds the drawn corners in the field's own frame under its ``transform``,
        as a mesh of the data would: the box of those corners in the frame, placed. The
        corners: the active cells' box cut to the domain (the domain's for
        ``technique='full'``); with ``traversal='cell_boxes'`` each active cell's, cut.
        Opaque levels, each drawn apart, are framed by the prop standing for them, which
        spans every level's box.
        """
        model = self.model
        lower, upper = model.domain_corners()
        grid = np.asarray(model.grid_from_index, dtype=np.float64)
        frame = None
        if self.technique == "active":
            apart = self.levels is not None and not self.options.translucent
            groups = [(v,) for v in self.levels] if apart else [self.levels or (0.0,)]
            boxes = []
            for offsets in groups:
                cells = level_cells(model, offsets, self.options.active_test,
                                    self.options.active_samples)
                if not len(cells):
                    continue
                if self.options.traversal == "cell_boxes" and not apart:
                    frame = _cell_corners_box(grid, cells, lower, upper)
                boxes.append((np.maximum(lower, cells.min(axis=0)),
                              np.minimum(upper, cells.max(axis=0) + 1.0)))
            if boxes:
                lower = np.min([b[0] for b in boxes], axis=0)
                upper = np.max([b[1] for b in boxes], axis=0)
        if frame is None:
            frame = box_world_bounds(grid, upper, lower)
        frame = np.reshape(frame, (3, 2))
        return box_world_bounds(np.asarray(model.transform, dtype=np.float64), frame[:, 1],
                                frame[:, 0])

    def shading(self) -> str:
        return self.options.shading

    def trace(self, camera, size, background, near, pixels) -> np.ndarray:
        """The reference's colours of the sample, traced at once.

        Not in parts on threads: since the reference samples only the cells' segments that
        may hold a root, its steps are many small numpy calls that hold the GIL, and four
        parts took twice the time of one (2 cores; 0.8 against 0.4 s on the sheets).
        """
        options = self.options
        lights = self.probe_lights()
        look = {"opacity": float(options.opacity)}
        if options.color_by is not None:   # the colormap's 256 entries, over the range
            look.update(color_by=options.color_by, clim=options.color_range(self.model),
                        lookup_table=options.lookup_table())
        if self.levels is not None:
            look.update(levels=self.levels, level_colors=self.level_colors)
        if options.clip_planes is not None:
            look.update(clip_planes=options.world_planes)

        rows, columns = (np.asarray(v) for v in pixels)
        return self.reference(self.model, camera, size, color=options.rgb,
                              background=background, near=near, lights=lights,
                              shading=options.shading, ambient=options.ambient,
                              diffuse=options.diffuse, specular=options.specular,
                              specular_power=options.specular_power,
                              pixels=(rows, columns), **look)

    def start(self, tracks) -> int | None:
        return next((i for i, rung in enumerate(tracks[0])
                     if rung.setting.get("steps") == 400), None)

    def apply(self, binding, setting: dict) -> None:
        root = setting.get("root", "march")
        for part in surface_parts(binding):   # each level's own surface
            if part.options.root != root:   # the root finder is compiled in: recompile
                part.options = dataclasses.replace(part.options, root=root)
                part.recompile(surface_recipe(part.options, *part.recipe_args))
        if "steps" in setting:   # the still steps, at full size
            set_still_steps(binding, float(setting["steps"]))
