"""``bench dial`` for implicit surfaces: the steps ladder, the exact root and the default.

Timed side by side, then what ``add_surface(quality=)`` chooses for each target. Each
surface is lit by one headlight (the light calibration measures with) and measured over
the whole frame against the CPU reference traced at the plotter's camera, near plane and
light.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pyvista

from ..api import add_surface
from ..core.camera import Camera
from ..core.rendering import offscreen_plotter, read_pixels
from ..image_metrics import compare_images
from ..models.lights import VolumeLight
from ..quality.surfaces import surface_tracks
from ..quality.targets import parse_quality
from ..reference.surfaces import render_surface
from ..surfaces.options import STEPS, SurfaceOptions
from .dial_rows import DialRow, SweepRow, fresh_cache, label, mark_front
from .harness import time_frames_side_by_side
from .surfaces import shape_field

SURFACE_SCENES = ("sheets", "holey sphere", "blobs")
#: The surfaces' look: one colour, lit.
LOOK = {"color": "tan", "shading": "blinn"}


def surface_scene(name: str):
    """``(field or samples, isovalue)`` of a surface scene, in its real units."""
    if name == "sheets":   # millimetres around 250, sheets thinner than a cell in places
        shape = (48, 40, 32)
        i, j, k = np.meshgrid(*(np.linspace(-1.0, 1.0, n) for n in shape), indexing="ij")
        values = 250.0 + 1000.0 * (0.04 - np.abs(0.6 * np.sin(5 * i + 2 * j) - k)
                                   + 0.03 * np.cos(7 * j))
        grid = pyvista.ImageData(dimensions=shape, spacing=(0.5, 0.7, 0.9),
                                 origin=(-300.0, 40.0, 1000.0))
        grid.point_data["mm"] = values.ravel(order="F")
        return grid, 250.0
    if name in ("holey sphere", "blobs"):
        return shape_field(name, 48), None
    raise ValueError(f"Unknown surface scene {name!r}; choose from "
                     f"{', '.join(SURFACE_SCENES)}.")


def surface_plotter(size):
    """A plotter lit by one headlight over black, single-sampled."""
    plotter = offscreen_plotter(size)
    plotter.set_background("black")
    plotter.ren_win.SetMultiSamples(0)
    plotter.remove_all_lights()
    plotter.add_light(pyvista.Light(light_type="headlight"))
    return plotter


def surface_reference(plotter, model, size) -> np.ndarray:
    """The CPU reference of the frame the plotter draws (its camera, near plane, lights)."""
    lights = [VolumeLight.from_pyvista(light, plotter.camera)
              for light in plotter.renderer.GetLights()]
    return render_surface(model, Camera.from_pyvista(plotter.camera), size,
                          color=pyvista.Color(LOOK["color"]).float_rgb,
                          near=plotter.camera.clipping_range[0], lights=lights,
                          shading=LOOK["shading"])


def run_surface_dial(size: Sequence[int], frames: int, scenes: Sequence[str],
                     targets: Sequence) -> tuple[list[SweepRow], list[DialRow]]:
    """Every scene's sweep (steps, the exact root, the default) and each target's choice."""
    size = (int(size[0]), int(size[1]))
    sweep, dials = [], []
    for name in scenes:
        source, isovalue = surface_scene(name)
        rows, chosen = _one(name, source, isovalue, size, frames, targets)
        sweep += rows
        dials += chosen
    return sweep, dials


def _one(name, source, isovalue, size, frames, targets):
    first = surface_plotter(size)
    model = add_surface(first, source, isovalue=isovalue, **LOOK).cubemarch.model
    first.close()
    ladder = surface_tracks(SurfaceOptions(), model.dimensions, parse_quality(40))[0]
    settings = {label(r.setting): r.setting for r in ladder}
    settings["root=exact"] = {"root": "exact"}
    settings[f"default (steps={STEPS.default})"] = {}
    plotters = {}
    try:
        for key, setting in settings.items():
            plotters[key] = plotter = surface_plotter(size)
            add_surface(plotter, model, **LOOK, **setting)
            if not len(plotters) - 1:
                camera = Camera.from_pyvista(plotter.camera)
            camera.apply_to(plotter.camera)
            plotter.renderer.ResetCameraClippingRange()
        times = time_frames_side_by_side(plotters, frames)
        psnrs = {key: compare_images(read_pixels(plotter),
                                     surface_reference(plotter, model, size)).psnr
                 for key, plotter in plotters.items()}
    finally:
        for plotter in plotters.values():
            plotter.close()
    rows = mark_front([SweepRow(name, "active", key, float(np.median(times[key])), psnrs[key],
                                default=key.startswith("default"))
                       for key in settings])
    ladder_rows = rows[:len(ladder)]
    dials = []
    for target in [*targets, "exact"]:
        plotter = surface_plotter(size)
        try:
            camera.apply_to(plotter.camera)
            plotter.camera_set = True
            with fresh_cache():
                actor = add_surface(plotter, model, quality=target, **LOOK)
            choice = actor.cubemarch.quality
        finally:
            plotter.close()
        row = next(r for r in rows if r.setting == choice.setting_text)
        goal = float("inf") if target == "exact" else float(target)
        meeting = [r for r in ladder_rows if r.psnr >= goal] if target != "exact" else []
        cheapest = min(meeting, key=lambda r: r.median_ms) if meeting else None
        dials.append(DialRow(name, "active", goal, row.setting, row.psnr, choice.psnr,
                             choice.met if target == "exact" else row.psnr >= goal,
                             None if cheapest is None else cheapest.setting,
                             None if cheapest is None else row.median_ms / cheapest.median_ms,
                             choice.seconds))
    return rows, dials
