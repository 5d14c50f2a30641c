"""``pv-cubemarch bench dial``: whether ``quality=`` picks the cheapest setting meeting it.

Per scene and technique, in one run: every rung of the technique's ladder drawn from the
same camera and timed side by side with the technique's default (the sweep, with its
Pareto front: whether the default sits on it), each measured over the whole frame against
the CPU reference; then ``add_volume(quality=target)`` for each
target, calibrated afresh (no cache): the setting it chose, that setting's measured error,
its time against the cheapest rung of the sweep that meets the target, and how long the
calibration took.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pyvista

from ..api import add_surface, add_volume, add_voxels
from ..core.camera import Camera
from ..core.rendering import offscreen_plotter, read_pixels, render_frame
from ..image_metrics import compare_images
from ..quality import cache
from ..quality.ladders import volume_ladder
from ..reference.emission_absorption import render_emission_absorption
from ..volume.options import DEFAULT_SAMPLE_FACTOR, STEP_SCALE, fitting_face_size
from .dial_rows import DialRow, InteractionRow, SweepRow, fresh_cache, label, mark_front
from .dial_surfaces import LOOK as SURFACE_LOOK
from .dial_surfaces import (
    SURFACE_SCENES,
    run_surface_dial,
    surface_plotter,
    surface_reference,
    surface_scene,
)
from .dial_voxels import VOXEL_KEYWORDS, VOXEL_SCENES, voxel_reference, voxel_scene
from .harness import time_frames_side_by_side
from .sort_last import phantom

SCENES = ("ct", "smoke", "blobs", "cells")
TECHNIQUES = ("direct", "vtk", "cubemap", "active")
#: What the frame-budget orbits drive: the volume techniques ('auto' too) and the surfaces.
ORBIT_TECHNIQUES = ("direct", "vtk", "cubemap", "auto", "active", "voxels")
TARGETS = (30.0, 40.0, 50.0)
DATASETS = Path(__file__).resolve().parents[2] / "datasets"


def _scene(name: str):
    """A grid in its real units and the look it is drawn with."""
    if name == "ct":   # Hounsfield units, anisotropic, far from the origin
        values = phantom((64, 48, 40))
        grid = pyvista.ImageData(dimensions=values.shape, spacing=(0.8, 1.0, 1.3),
                                 origin=(-100.0, 20.0, 5.0))
        grid.point_data["hu"] = values.ravel(order="F")
        return grid, {"cmap": "bone", "opacity": "sigmoid", "clim": (-200.0, 1500.0)}
    if name == "smoke":
        grid = pyvista.read(DATASETS / "smoke_density.vti")
        return grid, {"cmap": "inferno", "opacity": "linear"}
    if name == "blobs":   # a signed field (negative and positive lobes), extent not at 0
        axes = [np.linspace(-1.0, 1.0, n) for n in (56, 56, 56)]
        x, y, z = np.meshgrid(*axes, indexing="ij")
        field = (np.exp(-8 * ((x - 0.3) ** 2 + y ** 2 + z ** 2))
                 - np.exp(-8 * ((x + 0.35) ** 2 + (y - 0.2) ** 2 + z ** 2))) * 500.0
        grid = pyvista.ImageData(dimensions=field.shape, spacing=(0.5, 0.5, 0.5))
        grid.origin = (10.0, -40.0, 3.0)
        grid.point_data["signal"] = field.ravel(order="F")
        return grid, {"cmap": "coolwarm", "opacity": [0.8, 0.3, 0.0, 0.3, 0.8],
                      "clim": (-500.0, 500.0)}
    if name == "cells":   # uint16 microscopy: bright thin membranes over a dim background
        rng = np.random.default_rng(3)
        axes = [np.arange(n, dtype=np.float64) for n in (72, 60, 40)]
        x, y, z = np.meshgrid(*axes, indexing="ij")
        signal = np.full(x.shape, 120.0)
        for cx, cy, cz, r in zip(rng.uniform(10, 62, 12), rng.uniform(10, 50, 12),
                                 rng.uniform(8, 32, 12), rng.uniform(5, 11, 12),
                                 strict=True):
            distance = np.sqrt((x - cx) ** 2 + (y - cy) ** 2 + ((z - cz) * 1.5) ** 2)
            signal += 3000.0 * np.exp(-((distance - r) ** 2) / 1.5)
        grid = pyvista.ImageData(dimensions=signal.shape, spacing=(0.2, 0.2, 0.3))
        grid.point_data["uint16"] = np.clip(signal, 0, 65535).astype(np.uint16).ravel(
            order="F")
        return grid, {"cmap": "viridis", "opacity": "linear", "clim": (150.0, 2500.0)}
    raise ValueError(f"Unknown scene {name!r}; choose from {', '.join(SCENES)}.")


def _plotter(size):
    plotter = offscreen_plotter(size)
    plotter.set_background("black")
    plotter.ren_win.SetMultiSamples(0)
    return plotter


def run_dial(size: Sequence[int] = (320, 240), frames: int = 3,
             scenes: Sequence[str] = SCENES, techniques: Sequence[str] = TECHNIQUES,
             targets: Sequence[float] = TARGETS,
             surface_scenes: Sequence[str] = SURFACE_SCENES
             ) -> tuple[list[SweepRow], list[DialRow]]:
    """The sweeps and the choices of every scene and technique (see the module's text).

    The volume techniques run on ``scenes``, the surfaces' (``'active'``) on
    ``surface_scenes``.
    """
    size = (int(size[0]), int(size[1]))
    sweep_rows, dial_rows = [], []
    volumes = [t for t in techniques if t not in ("active", "voxels")]
    for name in scenes if volumes else ():
        grid, look = _scene(name)
        for technique in volumes:
            rows, dials = _one(name, grid, look, technique, size, frames, targets)
            sweep_rows += rows
            dial_rows += dials
    if "active" in techniques:
        rows, dials = run_surface_dial(size, frames, surface_scenes, targets)
        sweep_rows += rows
        dial_rows += dials
    return sweep_rows, dial_rows


def _one(name, grid, look, technique, size, frames, targets):
    ladder = volume_ladder(technique, grid.dimensions)
    default = _default_setting(technique, grid)
    settings = [r.setting for r in ladder]
    if default not in settings:   # else the rung it equals is the default's row
        settings.append(default)
    plotters = {}
    try:
        for index, setting in enumerate(settings):
            plotters[index] = plotter = _plotter(size)
            actor = add_volume(plotter, grid, technique=technique, **look, **setting)
            if index == 0:
                camera = Camera.from_pyvista(plotter.camera)
                model = actor.cubemarch.model
            camera.apply_to(plotter.camera)
        times = time_frames_side_by_side(plotters, frames)
        near = plotters[0].camera.clipping_range[0]
        reference = render_emission_absorption(model, camera, size, step_voxels=0.1,
                                               near=near)
        psnrs = {i: compare_images(read_pixels(p), reference).psnr for i, p in plotters.items()}
    finally:
        for plotter in plotters.values():
            plotter.close()
    every = mark_front([SweepRow(name, technique, label(setting), float(np.median(times[i])),
                                 psnrs[i], default=setting == default)
                        for i, setting in enumerate(settings)])
    rows = every[:len(ladder)]
    dials = []
    for target in targets:
        cache.forget()
        plotter = _plotter(size)
        try:
            camera.apply_to(plotter.camera)
            plotter.camera_set = True
            with fresh_cache():
                actor = add_volume(plotter, grid, technique=technique, quality=target, **look)
            choice = actor.cubemarch.quality
        finally:
            plotter.close()
        chosen = next(i for i, rung in enumerate(ladder) if rung.setting == choice.setting)
        meeting = [r for r in rows if r.psnr >= target]
        cheapest = min(meeting, key=lambda r: r.median_ms) if meeting else None
        dials.append(DialRow(name, technique, float(target), rows[chosen].setting,
                             rows[chosen].psnr, choice.psnr, rows[chosen].psnr >= target,
                             None if cheapest is None else cheapest.setting,
                             None if cheapest is None else
                             rows[chosen].median_ms / cheapest.median_ms, choice.seconds))
    return every, dials


def _default_setting(technique: str, grid) -> dict:
    """What ``add_volume`` draws ``technique`` with when no setting is given."""
    if technique == "cubemap":
        return {"face_size": fitting_face_size(grid.dimensions),
                "sample_factor": DEFAULT_SAMPLE_FACTOR}
    return {"step_scale": STEP_SCALE.default}


def format_dial(sweep: list[SweepRow], dials: list[DialRow]) -> str:
    """The sweeps (Pareto rungs starred) and the choices, as two text tables."""
    lines = [f"{'scene':13}{'technique':10}{'setting':30}{'ms':>8}{'PSNR':>8}  front  default"]
    for r in sweep:
        lines.append(f"{r.scene:13}{r.technique:10}{r.setting:30}{r.median_ms:8.1f}"
                     f"{r.psnr:8.1f}  {'*' if r.pareto else ' ':5}  {'<-' if r.default else ''}")
    lines += ["", f"{'scene':13}{'technique':10}{'target':>7}  {'chosen':30}{'PSNR':>7}"
                  f"{'est.':>7}{'met':>5}  {'cheapest meeting':30}{'x cost':>7}{'calib s':>8}"]
    for d in dials:
        ratio = "-" if d.cost_ratio is None else f"{d.cost_ratio:.2f}"
        lines.append(f"{d.scene:13}{d.technique:10}{d.target:7.0f}  {d.chosen:30}"
                     f"{d.psnr:7.1f}{d.estimated:7.1f}{'yes' if d.met else 'no':>5}  "
                     f"{d.cheapest or '(none)':30}{ratio:>7}{d.calibration_s:8.2f}")
    met = [d for d in dials if d.cheapest is not None]
    if met:
        share = sum(d.met for d in met) / len(met)
        worst = max((d.target - d.psnr for d in met if not d.met), default=0.0)
        ratios = [d.cost_ratio for d in met if d.met and d.cost_ratio is not None
                  and math.isfinite(d.cost_ratio)]
        lines.append(f"\nreachable targets met: {share:.0%} (worst miss {worst:.1f} dB); "
                     f"cost over the cheapest meeting: median {np.median(ratios):.2f}x, "
                     f"worst {max(ratios):.2f}x" if ratios else "")
    return "\n".join(lines)


def run_interaction(size: Sequence[int] = (800, 600), budget_ms: float = 100.0,
                    frames: int = 32, scenes: Sequence[str] = SCENES,
                    techniques: Sequence[str] = ORBIT_TECHNIQUES, target: float = 40.0,
                    surface_scenes: Sequence[str] = SURFACE_SCENES) -> list[InteractionRow]:
    """Orbits with ``quality=target`` and ``frame_budget_ms``, then the stop.

    Each scene: ``frames`` moving frames (the render window's desired update rate raised,
    as an interactor's drag does), then the drag's end. Reported: the share of moving
    frames (after the first, which has no time to predict from) within the budget, and
    the still frame's time (the refinement back to the chosen setting) and its PSNR over
    the whole frame. Volumes on ``scenes``, surfaces (``'active'``) on ``surface_scenes``,
    voxels on :data:`VOXEL_SCENES` (unlit, no quality: their traversal is the exact one).
    """
    size = (int(size[0]), int(size[1]))
    rows = []
    volumes = [t for t in techniques if t not in ("active", "voxels")]
    for name in scenes if volumes else ():
        grid, look = _scene(name)
        for technique in volumes:
            plotter = _plotter(size)
            try:
                with fresh_cache():
                    actor = add_volume(plotter, grid, technique=technique, quality=target,
                                       frame_budget_ms=budget_ms, **look)
                rows.append(_orbit(name, technique, plotter, actor, frames, lambda p, a: (
                    render_emission_absorption(a.cubemarch.model,
                                               Camera.from_pyvista(p.camera), size,
                                               step_voxels=0.1,
                                               near=p.camera.clipping_range[0]))))
            finally:
                plotter.close()
    for name in surface_scenes if "active" in techniques else ():
        source, isovalue = surface_scene(name)
        plotter = surface_plotter(size)
        try:
            with fresh_cache():
                actor = add_surface(plotter, source, isovalue=isovalue, quality=target,
                                    frame_budget_ms=budget_ms, **SURFACE_LOOK)
            rows.append(_orbit(name, "active", plotter, actor, frames,
                               lambda p, a: surface_reference(p, a.cubemarch.model, size)))
        finally:
            plotter.close()
    for name in VOXEL_SCENES if "voxels" in techniques else ():
        plotter = _plotter(size)
        try:
            actor = add_voxels(plotter, voxel_scene(name), shading="unlit",
                               frame_budget_ms=budget_ms, **VOXEL_KEYWORDS.get(name, {}))
            plotter.reset_camera()
            rows.append(_orbit(name, "voxels", plotter, actor, frames,
                               lambda p, a: voxel_reference(p, a, size)))
        finally:
            plotter.close()
    return rows


def _orbit(name, technique, plotter, actor, frames, reference) -> InteractionRow:
    """``frames`` moving frames around the scene, then the stop, as one row."""
    budget = actor.cubemarch.frame_budget
    render_frame(plotter)
    plotter.ren_win.SetDesiredUpdateRate(15.0)
    for _ in range(frames):
        plotter.camera.Azimuth(360.0 / frames)
        render_frame(plotter)
    plotter.ren_win.SetDesiredUpdateRate(0.0001)
    render_frame(plotter)
    still = budget.frames[-1]
    psnr = compare_images(read_pixels(plotter), reference(plotter, actor)).psnr
    moving = [f for f in budget.frames if f.moving][1:]
    steps = sorted({f.value for f in moving})
    return InteractionRow(
        name, technique, list(plotter.window_size), float(budget.budget_ms), len(moving),
        sum(f.ms <= budget.budget_ms for f in moving) / max(1, len(moving)),
        float(np.median([f.ms for f in moving])) if moving else 0.0,
        "; ".join(budget.describe(s) for s in steps), budget.knob.name, still.value, still.ms,
        psnr)


def format_interaction(rows: list[InteractionRow]) -> str:
    """The orbits as a text table."""
    lines = [f"{'scene':16}{'technique':10}{'budget':>7}{'frames':>7}{'within':>8}"
             f"{'median ms':>10}  {'knob':11}{'still':>6}{'still ms':>9}{'PSNR':>7}  moving"]
    for r in rows:
        lines.append(f"{r.scene:16}{r.technique:10}{r.budget_ms:7.0f}{r.moving_frames:7d}"
                     f"{r.within_budget:8.0%}{r.median_moving_ms:10.1f}  {r.knob:11}"
                     f"{r.still_value:6g}{r.still_ms:9.1f}{r.still_psnr:7.1f}  {r.steps}")
    return "\n".join(lines)
