"""Frame time against viewport resolution, per technique, on this machine.

:func:`run_resolution` draws three scenarios built from a scene (its volume alone, the
volume with the scene's meshes, and several copies of the volume side by side) with the
cube-map technique, the direct screen-space marcher and PyVista's stock ``add_volume`` at
1920x1080, 2560x1440 and 3840x2160, all in one run, and measures each image against the
CPU reference on a few crops (a 4K reference of the whole frame would take minutes). A
``scene only`` row (no volume) is the floor every technique pays; ``cubemap (resample
only)`` marches a 1-texel cube map, which leaves the resampling pass and the pass overhead:
together they say where the cube map's time goes.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..cluster.offload import Offload
from ..core import vtk_classes as vtk
from ..core.camera import Camera
from ..core.progress import progress
from ..core.rendering import read_pixels
from ..image_metrics import compare_images
from ..reference.emission_absorption import render_emission_absorption
from ..scene.model import Scene
from .harness import (
    _bench_plotter,
    _build_stock,
    _meshes_only,
    opaque_layer,
    time_frames_side_by_side,
)

SIZES = ((1920, 1080), (2560, 1440), (3840, 2160))
TECHNIQUES = ("scene only", "cubemap", "cubemap (resample only)", "direct", "pyvista")
COMPARABLE_FACE_SIZES = (128, 64)
FACE_SIZE_ROW = "cubemap face_size="  # rows of smaller cube maps, at the largest size only
COMPARABLE_DB = 0.5  # "comparable error": at most this much below the direct marcher's PSNR


@dataclass
class ResolutionRow:
    """One scenario, technique and size: frame times, error on the crops, GPU memory."""

    scenario: str
    technique: str
    size: tuple[int, int]
    frame_ms: list[float]
    errors: dict | None
    memory: dict = field(default_factory=dict)

    @property
    def median_ms(self) -> float:
        """Median frame time in milliseconds."""
        return float(np.median(self.frame_ms))


def scenarios(scene: Scene, copies: int = 4) -> dict[str, Scene]:
    """The three scenes of the table, from ``scene``'s first volume, meshes and lights."""
    if not scene.volumes:
        raise ValueError("The scene has no volume to measure.")
    volume = scene.volumes[0]
    alone = Scene(volumes=[volume], lights=scene.lights, up_axis=scene.up_axis,
                  background=scene.background, cameras=dict(scene.cameras))
    with_meshes = Scene(meshes=scene.meshes, volumes=[volume], lights=scene.lights,
                        up_axis=scene.up_axis, background=scene.background,
                        cameras=dict(scene.cameras))
    bounds = volume.world_bounds()
    width = bounds[1] - bounds[0]
    depth = bounds[5] - bounds[4]
    placed = []
    columns = int(np.ceil(np.sqrt(copies)))
    for index in range(copies):
        shift = np.eye(4)
        shift[0, 3] = (index % columns - (columns - 1) / 2) * width * 1.2
        shift[2, 3] = -(index // columns) * depth * 1.2
        placed.append(dataclasses.replace(volume, transform=shift @ volume.transform,
                                          name=f"{volume.name}_{index}"))
    several = Scene(volumes=placed, lights=scene.lights, up_axis=scene.up_axis,
                    background=scene.background)
    return {"smoke": alone, "mesh inside": with_meshes, f"{copies} volumes": several}


def finish_frame(plotter) -> None:
    """Wait for the frame to be drawn: reading one pixel back forces completion."""
    pixel = vtk.vtkUnsignedCharArray()
    plotter.ren_win.GetPixelData(0, 0, 0, 0, 0, pixel, 0)


def crop_windows(scene: Scene, camera: Camera, size, crop: int) -> list[tuple[int, int, int, int]]:
    """Three ``crop``-pixel windows over the volumes: their centre and halfway to each side."""
    corners = []
    for volume in scene.volumes:
        b = volume.world_bounds()
        corners += [(x, y, z) for x in b[:2] for y in b[2:4] for z in b[4:]]
    pixels = project(camera, np.array(corners), size)
    width, height = size
    lo, hi = pixels.min(axis=0), pixels.max(axis=0)
    centre = np.clip((lo + hi) / 2, 0, [width, height])
    spread = np.clip((hi - lo)[0] / 4, 0, width / 4)
    windows = []
    for dx in (0.0, -spread, spread):
        x = int(np.clip(centre[0] + dx - crop / 2, 0, width - crop))
        y = int(np.clip(centre[1] - crop / 2, 0, height - crop))
        windows.append((x, y, crop, crop))
    return windows


def project(camera: Camera, points: np.ndarray, size) -> np.ndarray:
    """Pixel positions (x right, y down) of world points seen by ``camera``."""
    right, up, forward = camera.basis()
    width, height = size
    rel = points - np.asarray(camera.position, dtype=np.float64)
    depth = np.maximum(rel @ forward, 1e-12)
    if camera.parallel_projection:
        half_h, scale = camera.parallel_scale, np.ones(len(points))
    else:
        half_h, scale = np.tan(np.radians(camera.view_angle) / 2.0), depth
    ndc_x = (rel @ right) / scale / (half_h * width / height)
    ndc_y = (rel @ up) / scale / half_h
    return np.column_stack([(ndc_x + 1) / 2 * width, (1 - ndc_y) / 2 * height])


def _add(plotter, scene: Scene, technique: str, camera: Camera) -> list:
    """Draw ``scene`` with ``technique``; return our volumes' bindings (for their memory)."""
    meshes = _meshes_only(scene)
    if technique in ("scene only", "pyvista"):
        meshes.add_to(plotter, camera=camera)
        if technique == "pyvista":
            for volume in scene.volumes:
                _build_stock(plotter, volume, {"step_scale": 0.5})
        return []
    options = {"technique": "direct"} if technique == "direct" else {"technique": "cubemap"}
    if technique == "cubemap (resample only)":
        options["face_size"] = 1
    elif technique.startswith(FACE_SIZE_ROW):
        options["face_size"] = int(technique[len(FACE_SIZE_ROW):])
    drawn = Scene(meshes=scene.meshes, volumes=scene.volumes, lights=scene.lights,
                  up_axis=scene.up_axis, background=scene.background,
                  volume_options={v.name: dict(options) for v in scene.volumes})
    actors = drawn.add_to(plotter, camera=camera)
    return [actors[volume.name].cubemarch for volume in scene.volumes]


def _memory(bindings: list) -> dict[str, int]:
    """GPU bytes by resource, summed over the volumes (after a frame allocated them)."""
    memory: dict[str, int] = {}
    for binding in bindings:
        for key, value in getattr(binding, "memory", {}).items():
            memory[key] = memory.get(key, 0) + int(value)
    return memory


def run_resolution(scene: Scene, sizes: Sequence[Sequence[int]] = SIZES, frames: int = 3,
                   crop: int = 128, reference_step: float = 0.1,
                   techniques: Sequence[str] = TECHNIQUES,
                   comparable_face_sizes: Sequence[int] = COMPARABLE_FACE_SIZES,
                   progress_bar: bool | None = None,
                   offload: Offload | None = None) -> list[ResolutionRow]:
    """Time every scenario x technique x size in one run and measure errors on crops.

    Parameters
    ----------
    scene : Scene
        Source of the volume, meshes, lights and camera (see :func:`scenarios`).
    sizes : sequence of (width, height)
        Viewport sizes; the growth factor is reported from the first to the last.
    frames : int
        Timed frames per row (median reported), after two warm-up frames; each frame is
        drawn to completion (one pixel read back), the full image is read once afterwards.
        The rows of one scenario and size are drawn in turn, frame by frame, so a slow
        spell of the machine weighs on all of them alike.
    crop : int
        Side of the three square crops compared with the CPU reference.
    reference_step : float
        Step of the CPU reference, in voxels.
    techniques : sequence of str
        Rows to measure, from :data:`TECHNIQUES`.
    comparable_face_sizes : sequence of int
        Smaller cube maps measured at the largest size only, so the cube map can also be
        compared with the direct marcher at comparable error, not only at default settings
        (which may be more accurate than direct). Empty to leave them out.
    progress_bar : bool, optional
        Show progress over the rows; by default only on a terminal.
    offload : Offload, optional
        Where the CPU references are computed: every scenario's and size's at once on a
        Dask cluster's workers (:mod:`pv_cubemarch.cluster.offload`), waited for before any
        row is timed. By default, here, one before each scenario's rows.
    """
    if frames < 3:
        raise ValueError(f"frames must be at least 3 for a median, got {frames}.")
    unknown = [t for t in techniques if t not in TECHNIQUES]
    if unknown:
        raise ValueError(f"Unknown technique(s) {unknown}; choose from {list(TECHNIQUES)}.")
    largest = tuple(int(v) for v in sizes[-1])
    extra = [f"{FACE_SIZE_ROW}{int(s)}" for s in comparable_face_sizes]
    jobs = [(name, sub, tuple(int(v) for v in size))
            for name, sub in scenarios(scene).items() for size in sizes]
    rows = []
    offload = offload or Offload()
    cameras = [sub.camera or sub.default_camera(size[0] / size[1]) for _, sub, size in jobs]
    pending = [] if offload.client is None else [
        offload.submit(_reference, sub, camera, size, crop, reference_step)
        for (_, sub, size), camera in zip(jobs, cameras, strict=True)]
    ready = [future.result() for future in pending]
    for index, (name, sub, size) in enumerate(progress(jobs, desc="resolution",
                                                       enabled=progress_bar)):
        camera = cameras[index]
        windows, reference = ready[index] if ready else _reference(sub, camera, size, crop,
                                                                   reference_step)
        plotters, bindings = {}, {}
        try:
            for technique in [*techniques, *(extra if size == largest else [])]:
                plotters[technique] = plotter = _bench_plotter(size)
                bindings[technique] = _add(plotter, sub, technique, camera)
                camera.apply_to(plotter.camera)
                if camera.clipping_range is None:
                    plotter.renderer.ResetCameraClippingRange()
            times = time_frames_side_by_side(plotters, frames, finish=finish_frame)
            for technique, plotter in plotters.items():
                image = read_pixels(plotter)
                errors = None if technique == "scene only" else compare_images(
                    _crops(image, windows), reference).as_dict()
                rows.append(ResolutionRow(name, technique, size, times[technique], errors,
                                          _memory(bindings[technique])))
        finally:
            for plotter in plotters.values():
                plotter.close()
    return rows


def _crops(image: np.ndarray, windows) -> np.ndarray:
    return np.concatenate([image[y:y + h, x:x + w] for x, y, w, h in windows], axis=1)


def _reference(scene: Scene, camera: Camera, size, crop: int, step: float):
    """Crop windows and the CPU reference over them, composited over the meshes."""
    color, distance = opaque_layer(scene, camera, size)
    used = camera
    if camera.clipping_range is None:
        plotter = _bench_plotter(size)
        try:
            scene.add_to(plotter, camera=camera)
            used = Camera.from_pyvista(plotter.camera)
        finally:
            plotter.close()
    windows = crop_windows(scene, used, size, crop)
    parts = []
    for x, y, w, h in windows:
        parts.append(render_emission_absorption(
            scene.volumes, used, size, step_voxels=step, crop=(x, y, w, h),
            opaque_depth=distance[y:y + h, x:x + w], opaque_color=color[y:y + h, x:x + w],
            near=used.clipping_range[0] if used.clipping_range else None))
    return windows, np.concatenate(parts, axis=1)


def format_resolution_table(rows: list[ResolutionRow]) -> str:
    """Frame times per size, growth from the first size to the last, errors, memory."""
    sizes = list(dict.fromkeys(r.size for r in rows))
    label = [f"{w}x{h}" for w, h in sizes]
    header = (f"{'scenario':<12} {'technique':<24} " + " ".join(f"{s:>10}" for s in label)
              + f" {'growth':>7} {'own':>6} " + " ".join(f"{'dB@' + s[:4]:>8}" for s in label))
    lines = [header, "-" * len(header)]
    by_key = {(r.scenario, r.technique, r.size): r for r in rows}
    for scenario in dict.fromkeys(r.scenario for r in rows):
        floor = [by_key.get((scenario, "scene only", s)) for s in sizes]
        for technique in dict.fromkeys(r.technique for r in rows if r.scenario == scenario):
            cells = [by_key.get((scenario, technique, s)) for s in sizes]
            times = [c.median_ms if c else float("nan") for c in cells]
            growth = times[-1] / times[0]
            own = float("nan")
            if technique != "scene only" and all(floor):
                own = (times[-1] - floor[-1].median_ms) / max(times[0] - floor[0].median_ms,
                                                              1e-9)
            # The resample-only rows draw a 1-texel cube map: their images are not compared.
            psnr = [c.errors["psnr"] if c and c.errors and "only" not in technique
                    else float("nan") for c in cells]
            lines.append(f"{scenario:<12} {technique:<24} "
                         + " ".join(f"{t:>8.0f}ms" if np.isfinite(t) else f"{'-':>10}"
                                    for t in times)
                         + f" {_ratio(growth):>7} {_ratio(own):>6} "
                         + " ".join(f"{p:>8.1f}" if np.isfinite(p) else f"{'-':>8}"
                                    for p in psnr))
        cube = by_key.get((scenario, "cubemap", sizes[-1]))
        direct = by_key.get((scenario, "direct", sizes[-1]))
        if cube and direct:
            memory = sum(cube.memory.get(k, 0) for k in ("cube_map", "cube_depth_map",
                                                          "light_map"))
            lines.append(f"{'':<12} at {label[-1]} the cube map is "
                         f"{direct.median_ms / cube.median_ms:.2f}x faster than direct "
                         f"({cube.errors['psnr']:.1f} vs {direct.errors['psnr']:.1f} dB); "
                         f"extra memory {memory:,} bytes ({memory / 2**20:.2f} MiB)")
            matched = comparable_cubemap(rows, scenario, sizes[-1])
            if matched is not None and matched is not cube:
                lines.append(f"{'':<12} at comparable error ({matched.technique[8:]}: "
                             f"{matched.errors['psnr']:.1f} vs {direct.errors['psnr']:.1f} dB) "
                             f"{direct.median_ms / matched.median_ms:.2f}x faster")
    lines.append("growth: last size / first size; own: the same after subtracting the "
                 "'scene only' frame")
    return "\n".join(lines)


def comparable_cubemap(rows: list[ResolutionRow], scenario: str, size) -> ResolutionRow | None:
    """The fastest cube-map row of ``scenario`` at ``size`` at comparable error.

    That is at most :data:`COMPARABLE_DB` below the direct marcher's PSNR (``None`` without
    a direct row, or when no cube-map row is that accurate).
    """
    here = [r for r in rows if r.scenario == scenario and tuple(r.size) == tuple(size)
            and r.errors]
    direct = next((r for r in here if r.technique == "direct"), None)
    if direct is None:
        return None
    cubes = [r for r in here
             if r.technique == "cubemap" or r.technique.startswith(FACE_SIZE_ROW)]
    good = [r for r in cubes if r.errors["psnr"] >= direct.errors["psnr"] - COMPARABLE_DB]
    return min(good, key=lambda r: r.median_ms) if good else None


def _ratio(value: float) -> str:
    return f"{value:.2f}x" if np.isfinite(value) else "-"


def write_resolution_json(rows: list[ResolutionRow], path, meta: dict) -> None:
    """Write the rows and run metadata as JSON."""
    payload = {"meta": meta, "rows": [
        {"scenario": r.scenario, "technique": r.technique, "size": list(r.size),
         "frame_ms": r.frame_ms, "median_ms": r.median_ms, "errors": r.errors,
         "memory": r.memory} for r in rows]}
    Path(path).write_text(json.dumps(payload, indent=2))
