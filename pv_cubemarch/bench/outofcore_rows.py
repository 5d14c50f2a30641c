"""What ``bench outofcore`` measures of one streamed row, whatever it streams.

One row: add a multiscale source to an offscreen plotter, frame until every wanted brick is
drawn (or a timeout), and keep the times, bytes, memory and the image's error against the
in-memory drawing of the same view. Also what its procedural sources share: pyramids of
halved levels, fields of separable waves.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.rendering import offscreen_plotter, read_pixels, render_frame
from ..models.multiscale import Level, MultiscaleSource


@dataclass
class OutOfCoreRow:
    """One way of drawing one view of one scene, and what it cost."""

    scene: str
    view: str
    row: str
    first_frame_s: float | None = None
    converged_s: float | None = None
    frames: int = 0
    longest_frame_ms: float | None = None
    bytes_read: int | None = None
    held_brick_bytes: int | None = None
    peak_rss_mb: float | None = None
    gpu_mb: float | None = None
    psnr_db: float | None = None
    #: Labels: pixels whose colour differs from the in-memory image (percent of the image).
    wrong_percent: float | None = None
    note: str = ""
    extra: dict = field(default_factory=dict)


def rss_mb() -> float:
    """Resident memory of this process now (MiB), from /proc."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def place_camera(pl, extent: np.ndarray, view: str) -> None:
    """Far: the whole volume; mid: a quarter of it; close: inside, near a corner."""
    centre = extent / 2.0
    if view == "far":
        eye, focal = centre + np.array([1.2, -1.6, 1.1]) * extent.max(), centre
    elif view == "mid":
        focal = extent * np.array([0.3, 0.3, 0.5])
        eye = focal + np.array([0.25, -0.35, 0.2]) * extent.max()
    else:
        focal = extent * np.array([0.22, 0.2, 0.5])
        eye = focal + np.array([0.02, -0.03, 0.01]) * extent.max()
    pl.camera_position = [tuple(eye), tuple(focal), (0, 0, 1)]
    pl.renderer.ResetCameraClippingRange()


def psnr(image: np.ndarray, reference: np.ndarray) -> float:
    diff = (image.astype(np.float64) - reference.astype(np.float64)) / 255.0
    return float(10 * np.log10(1.0 / max(np.mean(diff ** 2), 1e-12)))


def stream_row(scene, view, row, add, source, extent, size, timeout, expected,
               compare=None) -> tuple[OutOfCoreRow, np.ndarray]:
    """Row ``row``: ``add(plotter)`` the source, then frames until converged or ``timeout``.

    ``compare(row, image, expected)`` fills in the error (PSNR by default).
    """
    pl = offscreen_plotter(size)
    pl.set_background("black")
    result = OutOfCoreRow(scene, view, row)
    base = rss_mb()
    peak = base
    try:
        start = time.perf_counter()
        actor = add(pl)
        place_camera(pl, extent, view)
        render_frame(pl)
        image = read_pixels(pl)
        result.first_frame_s = time.perf_counter() - start
        binding = actor.cubemarch
        longest, frames = 0.0, 1
        while not binding.converged and time.perf_counter() - start < timeout:
            binding.wait_for_bricks(0.2)
            began = time.perf_counter()
            render_frame(pl)
            longest = max(longest, time.perf_counter() - began)
            frames += 1
            peak = max(peak, rss_mb())
        image = read_pixels(pl)
        peak = max(peak, rss_mb())
        stats = binding.stats()
        result.converged_s = time.perf_counter() - start if binding.converged else None
        result.frames = frames
        result.longest_frame_ms = longest * 1e3 if frames > 1 else None
        result.bytes_read = int(stats["bytes_read"])
        pager = binding.pager
        itemsize = np.dtype(source.dtype).itemsize
        result.held_brick_bytes = int(len(pager.slot_of) * (pager.brick + 2 * pager.apron) ** 3
                                      * itemsize)
        result.peak_rss_mb = peak - base
        result.gpu_mb = binding.nbytes / 2**20
        result.extra = {k: stats[k] for k in ("resident", "slots", "missing", "over_budget")}
        if not binding.converged:
            result.note = f"not converged in {timeout:g} s"
        if expected is not None:
            if compare is None:
                result.psnr_db = psnr(image, expected)
            else:
                compare(result, image, expected)
        return result, image
    finally:
        pl.close()


def whole_row(scene, view, extent, size, draw) -> tuple[OutOfCoreRow, np.ndarray]:
    """The reference row: the whole array read in memory and drawn.

    ``draw(plotter)`` adds it and returns its actor and the bytes it read; timed from
    there to the first frame.
    """
    pl = offscreen_plotter(size)
    pl.set_background("black")
    result = OutOfCoreRow(scene, view, "whole array in memory")
    base = rss_mb()
    try:
        start = time.perf_counter()
        actor, read = draw(pl)
        place_camera(pl, extent, view)
        render_frame(pl)
        image = read_pixels(pl)
        result.first_frame_s = result.converged_s = time.perf_counter() - start
        result.frames = 1
        result.bytes_read = int(read)
        result.peak_rss_mb = rss_mb() - base
        result.gpu_mb = actor.cubemarch.nbytes / 2**20
        return result, image
    finally:
        pl.close()


def halved_pyramid(make_level, shape, coarsest: int, name: str) -> MultiscaleSource:
    """Levels halved until the largest side is ``coarsest``.

    Level ``L`` sits at the centres of the finest level's ``2^L`` blocks;
    ``make_level(size, L)`` gives each level's array.
    """
    levels, number, size = [], 0, tuple(int(n) for n in shape)
    while True:
        factor = 2.0 ** number
        levels.append(Level(make_level(size, number), size, np.full(3, factor),
                            np.full(3, (factor - 1.0) / 2.0)))
        if max(size) <= coarsest:
            break
        size = tuple(-(-n // 2) for n in size)
        number += 1
    return MultiscaleSource(levels, name)


def wave_octaves(amplitude: float, decay: float, frequencies, octaves: int, seed: int):
    """Seeded octaves ``(amplitude, frequency per axis, phase per axis)``.

    Each has twice the frequency and ``1 / decay`` the amplitude of the one before.
    """
    rng = np.random.default_rng(seed)
    return [(amplitude / decay ** k, rng.uniform(*frequencies, 3) * 2.0 ** k,
             rng.uniform(0, 2 * np.pi, 3)) for k in range(octaves)]


def separable_waves(octaves, axes) -> np.ndarray:
    """The octaves' sum on the grid of the coordinate arrays ``axes`` (x, y, z).

    ``sum_k a_k sin(f_kx x + p_kx) sin(f_ky y + p_ky) sin(f_kz z + p_kz)``.
    """
    values = np.zeros([len(a) for a in axes])
    for amplitude, frequency, phase in octaves:
        x, y, z = (np.sin(f * a + p) for f, a, p in zip(frequency, axes, phase, strict=True))
        values += amplitude * x[:, None, None] * y[None, :, None] * z[None, None, :]
    return values
