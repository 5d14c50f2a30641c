"""The speed/accuracy instrument: frame time against error versus the CPU reference.

:func:`run_tradeoff` renders a scene once per quality setting of a technique (plus PyVista's
stock ``add_volume`` on the same data, camera and transfer function), times real frames
(drawn and read back), and compares each image with the CPU reference composited over the
same opaque meshes. A technique's sweep comes from its registration
(:func:`pv_cubemarch.core.registry.register_technique`).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyvista

from ..api import add_volume
from ..cluster.offload import Offload
from ..core import vtk_classes as vtk
from ..core.camera import Camera
from ..core.progress import progress
from ..core.registry import describe_setting, techniques
from ..core.rendering import offscreen_plotter, read_depth, read_pixels, render_frame
from ..image_metrics import compare_images
from ..models.transfer import shift_value
from ..models.volume import VolumeModel
from ..reference.emission_absorption import render_emission_absorption
from ..reference.projections import render_blended
from ..scene.model import Scene

Builder = Callable[[pyvista.Plotter, VolumeModel, dict], object]


@dataclass
class BenchSweep:
    """The rows of one technique in a run: its settings and how to add a volume with one."""

    technique: str
    settings: list[dict]
    build: Builder
    describe: Callable[[dict], str]
    reference: Callable


@dataclass
class TradeoffResult:
    """One row: a technique at one setting, its frame times and its error."""

    technique: str
    setting: str
    parameters: dict
    frame_ms: list[float]
    errors: dict
    pareto: bool = False
    extra: dict = field(default_factory=dict)

    @property
    def median_ms(self) -> float:
        """Median frame time in milliseconds."""
        return float(np.median(self.frame_ms))


def _add_with(technique: str) -> Builder:
    def build(plotter, volume, setting):
        return add_volume(plotter, volume, technique=technique, **setting)
    return build


def _build_stock(plotter, volume: VolumeModel, setting):
    """PyVista's own ``add_volume`` given the same colours, opacities and sample distance."""
    transfer = volume.transfer
    # the user's unit distance: the projections draw the opacity at it as it is
    unit = transfer.spec.opacity_unit_distance if transfer.spec is not None else 1.0
    opacity = -np.expm1(-transfer.table[:, 3].astype(np.float64) * unit)
    # A ready lookup table: pyvista 0.49's add_volume scales a float opacity *array* to
    # almost nothing, so colours and opacities go in as the table VTK will use.
    lut = pyvista.LookupTable()
    lut.values = np.column_stack([transfer.table[:, :3] * 255.0, opacity * 255.0]).round()
    lut.scalar_range = transfer.clim
    grid = volume.grid.copy()
    grid.point_data["values"] = volume.values.ravel(order="F")
    blending = setting.get("blending", "composite")
    actor = plotter.add_volume(grid, scalars="values", cmap=lut, clim=transfer.clim,
                               opacity_unit_distance=unit, mapper="gpu", shade=False,
                               show_scalar_bar=False,
                               blending="composite" if blending == "isosurface" else blending)
    if blending == "isosurface":   # VTK has the mode; PyVista does not name it
        actor.mapper.SetBlendMode(vtk.vtkVolumeMapper.ISOSURFACE_BLEND)
        levels = actor.prop.GetIsoSurfaceValues()
        stored = _stored_levels(volume, setting["isosurfaces"])
        levels.SetNumberOfContours(len(stored))
        for index, level in enumerate(stored):
            levels.SetValue(index, level)
    actor.prop.interpolation_type = "linear"   # as every technique here samples
    mapper = actor.mapper
    mapper.SetAutoAdjustSampleDistances(False)
    mapper.SetLockSampleDistanceToInputSpacing(False)
    mapper.SetSampleDistance(setting["step_scale"] * float(np.min(volume.grid.spacing)))
    actor.user_matrix = np.asarray(volume.transform)
    return actor


def _stored_levels(volume: VolumeModel, levels) -> list[float]:
    """Isosurface levels (data units) in the volume's stored units."""
    return [shift_value(v, volume.value_offset) for v in levels]


def blend_setting(mode: str, volume: VolumeModel) -> dict:
    """What a bench row of blend ``mode`` adds to its setting.

    The mode, and for 'isosurface' three levels evenly inside the data's range (data units).
    """
    if mode != "isosurface":
        return {"blending": mode}
    finite = volume.values[np.isfinite(volume.values)]
    inside = np.linspace(float(finite.min()), float(finite.max()), 5)[1:-1]
    return {"blending": mode,
            "isosurfaces": tuple(float(v) + float(volume.value_offset) for v in inside)}


def sweeps() -> dict[str, BenchSweep]:
    """Every technique's registered sweep, and PyVista's stock ``add_volume`` as a row."""
    found = {t.name: BenchSweep(t.name, list(t.sweep.settings), _add_with(t.name),
                                t.sweep.describe, t.reference)
             for t in techniques("volume") if t.sweep is not None}
    found["pyvista"] = BenchSweep("pyvista", [{"step_scale": s} for s in (1.0, 0.5)],
                                  _build_stock, describe_setting, render_emission_absorption)
    return found


def opaque_layer(scene: Scene, camera: Camera, size) -> tuple[np.ndarray, np.ndarray]:
    """The scene's meshes alone: colour in [0, 1] and distance along each pixel's ray.

    The reference composites the volume over this layer, so mesh shading (which the CPU
    reference does not model) is the same in every image and only the volume is measured.
    """
    plotter = _bench_plotter(size)
    try:
        _meshes_only(scene).add_to(plotter, camera=camera)
        render_frame(plotter)
        color = read_pixels(plotter).astype(np.float64) / 255.0
        zbuffer = read_depth(plotter).astype(np.float64)
        near, far = plotter.camera.clipping_range
        used = Camera.from_pyvista(plotter.camera)
    finally:
        plotter.close()
    ndc = 2.0 * zbuffer - 1.0
    if used.parallel_projection:
        depth = near + zbuffer * (far - near)
    else:
        depth = 2.0 * near * far / ((far + near) - ndc * (far - near))
    _, directions = used.rays(size)
    _, _, forward = used.basis()
    distance = depth / np.maximum(directions @ forward, 1e-12)
    distance = np.where(zbuffer >= 1.0, np.inf, distance)
    return color, distance


def _meshes_only(scene: Scene) -> Scene:
    """The scene without its volumes (lights, meshes and background kept)."""
    return Scene(meshes=scene.meshes, lights=scene.lights, up_axis=scene.up_axis,
                 background=scene.background)


def _bench_plotter(size):
    """A plotter without multisampling, the same for every row and the opaque layer.

    Mesh edges then match the reference's opaque layer in every row (the direct marcher
    turns multisampling off anyway).
    """
    plotter = offscreen_plotter(size)
    plotter.ren_win.SetMultiSamples(0)
    return plotter


def time_frames_side_by_side(plotters: dict, frames: int = 3, warmup: int = 2,
                             finish=read_pixels,
                             row_budget_ms: float | None = None,
                             camera_moves: bool = False) -> dict[str, list[float]]:
    """Milliseconds of ``frames`` frames of each plotter, drawn in turn.

    Frame ``i`` of every plotter is drawn before frame ``i + 1`` of any, so a slow spell of
    a shared machine falls on every row alike and the ratios between rows hold.
    ``row_budget_ms``: a row whose frames so far add up to more stops there (after at least
    one): a frame of seconds varies little, and the others keep their turns.
    ``camera_moves``: mark each camera modified before its timed frame (untimed), so work
    kept while the view stays (a depth pass) is redone as when the user turns the view.
    """
    for plotter in plotters.values():
        for _ in range(warmup):
            render_frame(plotter)
            finish(plotter)
    times: dict[str, list[float]] = {name: [] for name in plotters}
    for _ in range(frames):
        for name, plotter in plotters.items():
            if row_budget_ms is not None and sum(times[name]) > row_budget_ms:
                continue
            if camera_moves:
                plotter.camera.Modified()
            start = time.perf_counter()
            plotter.ren_win.Render()
            finish(plotter)
            times[name].append((time.perf_counter() - start) * 1e3)
    return times


def run_tradeoff(technique: str | Sequence[str], scene: Scene, size: Sequence[int] = (640, 480),
                 frames: int = 3, include_stock: bool = True, reference_step: float = 0.1,
                 progress_bar: bool | None = None,
                 blending: Sequence[str] = ("composite",),
                 offload: Offload | None = None) -> list[TradeoffResult]:
    """Sweep ``technique``'s settings on ``scene``'s first volume; return one row per setting.

    Parameters
    ----------
    technique : str or sequence of str
        One or more techniques with a registered sweep (``'vtk'``, ``'direct'``,
        ``'cubemap'``, and ``'pyvista'`` for the stock mapper; see :func:`sweeps`),
        measured side by side in the same run.
    scene : Scene
        Meshes, lights, camera and the volume to measure.
    size : sequence of int
        ``(width, height)`` of every frame.
    frames : int
        Timed frames per setting (median reported), after two warm-up frames; the settings
        are drawn in turn, frame by frame, so a slow spell of the machine weighs on all.
    include_stock : bool
        Add PyVista's stock ``add_volume`` rows to the same run.
    reference_step : float
        Step of the CPU reference, in voxels.
    progress_bar : bool, optional
        Show progress over the settings being set up; by default only on a terminal.
    blending : sequence of str
        Blend modes to measure (any of ``BLEND_MODES``; 'isosurface' at three levels inside
        the data's range, :func:`blend_setting`): every row
        once per mode, against that mode's CPU reference, and against PyVista's own
        ``add_volume`` of the mode at its finest setting (``extra['psnr_vs_pyvista']``, with
        ``include_stock``). The Pareto front is marked per mode.
    offload : Offload, optional
        Where the CPU references are computed: a Dask cluster's workers, in bands of rows,
        in parallel (:mod:`pv_cubemarch.cluster.offload`); they are waited for before any
        row is timed. By default, here.
    """
    available = sweeps()
    chosen = [technique] if isinstance(technique, str) else list(technique)
    unknown = [t for t in chosen if t not in available]
    if unknown or not chosen:
        raise ValueError(f"Unknown technique {unknown or technique!r}; choose from "
                         f"{sorted(available)}.")
    if not scene.volumes:
        raise ValueError("The scene has no volume to measure.")
    if frames < 3:
        raise ValueError(f"frames must be at least 3 for a median, got {frames}.")
    size = (int(size[0]), int(size[1]))
    volume = scene.volumes[0]
    camera = scene.camera or scene.default_camera(size[0] / size[1])
    color, distance = opaque_layer(scene, camera, size)
    near = camera.clipping_range[0] if camera.clipping_range else None
    modes = {mode: blend_setting(mode, volume) for mode in blending}
    offload = offload or Offload()
    pending = {mode: _reference(offload, modes[mode], available[chosen[0]], volume, camera,
                                size, reference_step, distance, color, near)
               for mode in blending}
    references = {mode: future.result() for mode, future in pending.items()}
    runs = [(available[name], dict(s, **modes[mode])) for mode in blending
            for name in chosen for s in available[name].settings]
    if include_stock and "pyvista" not in chosen:
        runs += [(available["pyvista"], dict(s, **modes[mode])) for mode in blending
                 for s in available["pyvista"].settings]
    plotters = {}
    results = []
    try:
        for index, (sweep, setting) in enumerate(progress(runs, desc="tradeoff",
                                                          enabled=progress_bar)):
            plotters[index] = plotter = _bench_plotter(size)
            _meshes_only(scene).add_to(plotter, camera=camera)
            sweep.build(plotter, volume, dict(setting))
            camera.apply_to(plotter.camera)
        times = time_frames_side_by_side(plotters, frames)
        images = {index: read_pixels(plotters[index]) for index in plotters}
        stock = {setting["blending"]: images[index] for index, (sweep, setting)
                 in enumerate(runs) if sweep.technique == "pyvista"}   # the last: finest
        for index, (sweep, setting) in enumerate(runs):
            mode = setting["blending"]
            errors = compare_images(images[index], references[mode]).as_dict()
            extra = {} if mode not in stock else {
                "psnr_vs_pyvista": compare_images(images[index], stock[mode]).psnr}
            label = sweep.describe({k: v for k, v in setting.items()
                                    if k not in ("blending", "isosurfaces")})
            results.append(TradeoffResult(sweep.technique, label, dict(setting), times[index],
                                          errors, extra=extra))
    finally:
        for plotter in plotters.values():
            plotter.close()
    for mode in blending:
        mark_pareto([r for r in results if r.parameters.get("blending") == mode])
    return results


def _reference(offload: Offload, blend: dict, sweep, volume, camera, size, step, distance,
               color, near):
    """The right image of a blend setting, as a future of ``offload``.

    The technique's reference for composite (in bands of rows on a cluster), else the
    blend modes' (:func:`~pv_cubemarch.reference.projections.render_blended`), whole.
    """
    if blend["blending"] == "composite":
        return offload.banded(sweep.reference, size, volume, camera, size, step_voxels=step,
                              near=near, sliced={"opaque_depth": distance,
                                                 "opaque_color": color})
    levels = _stored_levels(volume, blend.get("isosurfaces", ()))
    return offload.submit(render_blended, volume, camera, size, blend["blending"],
                          isosurfaces=levels, step_voxels=step, opaque_depth=distance,
                          opaque_color=color, near=near)


def mark_pareto(results: list[TradeoffResult]) -> None:
    """Flag rows that no other row beats on both time and error (RMSE via PSNR)."""
    for row in results:
        row.pareto = not any(
            other.median_ms <= row.median_ms and other.errors["psnr"] >= row.errors["psnr"]
            and (other.median_ms < row.median_ms or other.errors["psnr"] > row.errors["psnr"])
            for other in results)


def format_table(results: list[TradeoffResult]) -> str:
    """A plain-text table, times also as ratios to the fastest row of the same run."""
    fastest = min(r.median_ms for r in results)
    header = (f"{'technique':<10} {'blending':<10} {'setting':<24} {'median ms':>10} "
              f"{'x fastest':>9} {'PSNR dB':>8} {'SSIM':>7} {'max err':>8} {'vs PyVista':>10} "
              f"{'pareto':>6}")
    lines = [header, "-" * len(header)]
    for r in results:
        e = r.errors
        versus = r.extra.get("psnr_vs_pyvista")
        shown = "" if versus is None else f"{versus:.2f}"
        mode = r.parameters.get("blending", "composite")
        lines.append(f"{r.technique:<10} {mode:<10} {r.setting:<24} {r.median_ms:>10.1f} "
                     f"{r.median_ms / fastest:>9.2f} {e['psnr']:>8.2f} {e['ssim']:>7.4f} "
                     f"{e['max_abs']:>8.0f} {shown:>10} {'*' if r.pareto else '':>6}")
    return "\n".join(lines)


def write_json(results: list[TradeoffResult], path, meta: dict) -> None:
    """Write rows and run metadata (size, scene, GL renderer) as JSON."""
    payload = {"meta": meta, "results": [
        {"technique": r.technique, "setting": r.setting, "parameters": r.parameters,
         "frame_ms": r.frame_ms, "median_ms": r.median_ms, "errors": r.errors,
         "pareto": r.pareto, **r.extra} for r in results]}
    Path(path).write_text(json.dumps(payload, indent=2))


def plot_pareto(results: list[TradeoffResult], path, title: str = "") -> None:
    """Error (RMSE in 8-bit levels, from PSNR) against frame time, the Pareto front joined."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    def rmse(row):
        return 255.0 * 10 ** (-row.errors["psnr"] / 20.0)

    fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=100)
    for technique in dict.fromkeys(r.technique for r in results):
        rows = [r for r in results if r.technique == technique]
        ax.scatter([r.median_ms for r in rows], [rmse(r) for r in rows], label=technique)
        for r in rows:
            ax.annotate(r.setting, (r.median_ms, rmse(r)), fontsize=7, xytext=(3, 3),
                        textcoords="offset points")
    front = sorted((r for r in results if r.pareto), key=lambda r: r.median_ms)
    ax.plot([r.median_ms for r in front], [rmse(r) for r in front], "k--", lw=1,
            label="Pareto front")
    ax.set_xlabel("median frame time (ms)")
    ax.set_ylabel("RMSE vs CPU reference (8-bit levels)")
    ax.set_yscale("log")
    ax.set_title(title)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(str(path))
    plt.close(fig)
