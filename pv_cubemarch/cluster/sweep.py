"""Option sweeps on a Dask cluster (:func:`sweep_options`): time against error per setting.

Every setting of a grid is built and drawn on a worker. The builds, warm-up frames and
error measurements run in parallel; the timed frames hold a cluster-wide lock, so one
worker times at a time and no row's time includes another row's work (the ratios stay
side by side, as in one process). The reference image is made once, as a task.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..core.camera import Camera
from ..core.progress import progress
from ..core.rendering import offscreen_plotter, read_pixels, render_frame
from ..image_metrics import compare_images
from .frames import _checked_size, _gl_thread, _same, as_camera, local_client

#: The lock every timed section holds, cluster-wide.
TIMING_LOCK = "pv-cubemarch-timing"


@dataclass
class SweepRow:
    """One setting: its frame times and its errors against the reference."""

    setting: dict
    frame_ms: list[float]
    median_ms: float
    errors: dict = field(default_factory=dict)
    pareto: bool = False
    timed: tuple[float, float] = (0.0, 0.0)   # wall-clock span of the timed frames


def option_grid(grid) -> list[dict]:
    """The settings of ``grid``: ``{name: [values]}`` (every combination) or a list of dicts."""
    if isinstance(grid, Mapping):
        names = list(grid)
        values = []
        for name in names:
            choices = grid[name]
            if isinstance(choices, (str, bytes)) or not isinstance(choices, Sequence):
                raise ValueError(f"grid[{name!r}] must be a list of values, got {choices!r}.")
            if not choices:
                raise ValueError(f"grid[{name!r}] is empty: give at least one value.")
            values.append(list(choices))
        return [dict(zip(names, combo, strict=True)) for combo in itertools.product(*values)]
    settings = list(grid)
    if not settings or not all(isinstance(s, Mapping) for s in settings):
        raise ValueError("grid must be {option: [values]} or a non-empty list of settings "
                         "(dicts of keywords).")
    return [dict(s) for s in settings]


def mark_front(rows: list[SweepRow]) -> None:
    """Mark the rows no other row beats on both time and PSNR (the Pareto front)."""
    for row in rows:
        psnr = row.errors.get("psnr")
        row.pareto = psnr is not None and not any(
            other is not row and other.errors.get("psnr") is not None
            and other.median_ms <= row.median_ms and other.errors["psnr"] >= psnr
            and (other.median_ms < row.median_ms or other.errors["psnr"] > psnr)
            for other in rows)


def sweep_options(build: Callable, grid, camera, size: tuple[int, int] = (640, 480), *,
                  reference=None, frames: int = 5, warmup: int = 2, client=None,
                  workers: int | None = None,
                  progress_bar: bool | None = None) -> list[SweepRow]:
    """Time and compare every setting of ``grid`` on a Dask cluster.

    Parameters
    ----------
    build : callable
        Picklable ``build(plotter, **setting)`` adding the scene drawn with one setting.
    grid : dict or list of dict
        ``{option: [values]}`` (every combination is a setting) or a list of settings.
    camera : camera
        :class:`pv_cubemarch.Camera`, ``pyvista.Camera`` or camera position.
    size : tuple of int
        ``(width, height)`` of the frames.
    reference : numpy.ndarray or callable, optional
        The right image (``(height, width, 3)`` uint8 or float in [0, 1]), or a picklable
        ``reference(camera, size)`` making it (run once, on a worker). Without one, only
        times are measured.
    frames : int
        Timed frames per setting (the median is reported).
    warmup : int
        Untimed frames before them (uploads, shader builds), run in parallel.
    client : dask.distributed.Client, optional
        The cluster; by default a ``LocalCluster`` of ``workers`` processes, closed after.
    workers : int, optional
        Processes of the default ``LocalCluster`` (default 2).
    progress_bar : bool, optional
        Show a bar as settings finish (default: on a terminal).

    Returns
    -------
    list of SweepRow
        One per setting, in the grid's order, its Pareto flag set (time against PSNR).

    Examples
    --------
    >>> import pyvista as pv
    >>> import pv_cubemarch
    >>> def build(plotter, theta_resolution):
    ...     plotter.add_mesh(pv.Sphere(theta_resolution=theta_resolution))
    >>> rows = pv_cubemarch.sweep_options(
    ...     build, {"theta_resolution": [8, 32, 128]},
    ...     [(4, 0, 0), (0, 0, 0), (0, 0, 1)])  # doctest: +SKIP
    """
    settings = option_grid(grid)
    camera = as_camera(camera)
    size = _checked_size(size)
    for name, value, least in (("frames", frames, 1), ("warmup", warmup, 0)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or \
                value < least:
            raise ValueError(f"{name} must be an integer of at least {least}, got {value!r}.")
    if not callable(build):
        raise TypeError(f"build must be a function build(plotter, **setting), got "
                        f"{type(build).__name__}.")
    with local_client(client, workers) as client:
        if callable(reference):
            shared = client.submit(reference, camera, size, pure=False)
        else:
            shared = None if reference is None else client.submit(
                _same, np.asarray(reference), pure=False)
        futures = [client.submit(measure_setting, build, setting, camera, size, frames,
                                 warmup, shared, pure=False) for setting in settings]
        rows: list = [None] * len(settings)
        index_of = {future.key: i for i, future in enumerate(futures)}
        from distributed import as_completed

        for future in progress(as_completed(futures), desc="sweeping options",
                               total=len(futures), enabled=progress_bar):
            rows[index_of[future.key]] = future.result()
    mark_front(rows)
    return rows


def measure_setting(build, setting: dict, camera: Camera, size, frames: int, warmup: int,
                    reference) -> SweepRow:
    """On a worker: one setting built and warmed, timed under the lock, then compared."""
    from distributed import Lock

    plotter = _gl_thread.submit(_warm, build, setting, camera, size, warmup).result()
    try:
        with Lock(TIMING_LOCK):
            start = time.time()
            times = _gl_thread.submit(_timed, plotter, frames).result()
            timed = (start, time.time())
        image = _gl_thread.submit(read_pixels, plotter).result()
    finally:
        _gl_thread.submit(plotter.close).result()
    errors = {} if reference is None else compare_images(image, reference).as_dict()
    return SweepRow(dict(setting), times, float(np.median(times)), errors, timed=timed)


def _warm(build, setting, camera: Camera, size, warmup: int):
    plotter = offscreen_plotter(size)
    try:
        build(plotter, **setting)
        camera.apply_to(plotter.camera)
        plotter.camera_set = True
        if camera.clipping_range is None:
            plotter.renderer.ResetCameraClippingRange()
        for _ in range(warmup):
            render_frame(plotter)
            read_pixels(plotter)
    except BaseException:
        plotter.close()
        raise
    return plotter


def _timed(plotter, frames: int) -> list[float]:
    times = []
    for _ in range(frames):
        start = time.perf_counter()
        plotter.ren_win.Render()
        read_pixels(plotter)
        times.append((time.perf_counter() - start) * 1e3)
    return times


def format_sweep(rows: list[SweepRow]) -> str:
    """The rows as a text table: setting, median ms, PSNR, SSIM, Pareto."""
    lines = [f"{'setting':48} {'median ms':>9} {'PSNR dB':>8} {'SSIM':>6} {'front':>5}"]
    for row in rows:
        text = ", ".join(f"{k}={v}" for k, v in row.setting.items())
        psnr, ssim = row.errors.get("psnr"), row.errors.get("ssim")
        lines.append(f"{text[:48]:48} {row.median_ms:>9.2f} "
                     f"{'-' if psnr is None else format(psnr, '.2f'):>8} "
                     f"{'-' if ssim is None else format(ssim, '.4f'):>6} "
                     f"{'*' if row.pareto else '':>5}")
    return "\n".join(lines)
