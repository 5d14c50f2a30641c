"""Rows of the translucency benches (voxel and surface layers): drawn in turn, scored.

Each row is a plotter drawing one way of showing the same translucent scene; their frames
are timed side by side and each image is scored against a CPU reference (PSNR, and the
share of pixels more than :data:`WRONG` off).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..core.camera import Camera
from ..core.rendering import offscreen_plotter, read_pixels, render_frame
from .harness import time_frames_side_by_side

#: A pixel is wrong when a channel differs from the reference by more than this (0-1).
WRONG = 10.0 / 255.0


@dataclass
class LayerRow:
    """One scene and row: frame times, setup, and its error against the reference."""

    scene: str
    row: str
    frame_ms: list[float]
    setup_ms: float
    psnr_db: float
    wrong_percent: float

    @property
    def median_ms(self) -> float:
        """The median frame time."""
        return float(np.median(self.frame_ms))


def draw_rows(scene: str, rows: dict[str, Callable], size: Sequence[int], camera: Camera,
              frames: int, reference: Callable, background=(0.0, 0.0, 0.0)) -> list[LayerRow]:
    """Each of ``rows`` drawn at ``camera``, timed in turn, and scored.

    ``rows``: name to ``add(plotter)``; ``reference(plotter)`` (given the first row's
    plotter: its camera and near plane) returns the ``(height, width, 3)`` image in 0-1.
    """
    plotters, setup = {}, {}
    try:
        for row, add in rows.items():
            pl = offscreen_plotter(tuple(size))
            pl.ren_win.SetMultiSamples(0)   # peeling draws nothing multisampled here
            pl.set_background(background)
            start = time.perf_counter()
            add(pl)
            camera.apply_to(pl.camera)
            pl.renderer.ResetCameraClippingRange()
            render_frame(pl)
            setup[row] = (time.perf_counter() - start) * 1e3
            plotters[row] = pl
        times = time_frames_side_by_side(plotters, frames, warmup=0)
        expected = reference(next(iter(plotters.values())))
        results = []
        for row, pl in plotters.items():
            image = read_pixels(pl).astype(float) / 255.0
            error = float(np.mean((image - expected) ** 2))
            wrong = np.abs(image - expected).max(axis=-1) > WRONG
            results.append(LayerRow(scene, row, times[row], setup[row],
                                    10 * np.log10(1.0 / max(error, 1e-12)),
                                    100.0 * float(wrong.mean())))
        return results
    finally:
        for pl in plotters.values():
            pl.close()


def format_layer_table(results: list[LayerRow], ours_row: str) -> str:
    """The rows as a text table, each row's time over ``ours_row``'s on the same scene."""
    width = max(len(r.scene) for r in results)
    lines = [f"{'grid':>{width}} {'row':<31} {'frame ms':>9} {'x ours':>7} {'setup ms':>9} "
             f"{'PSNR dB':>8} {'wrong %':>8}"]
    ours = {r.scene: r.median_ms for r in results if r.row == ours_row}
    for r in results:
        lines.append(f"{r.scene:>{width}} {r.row:<31} {r.median_ms:9.1f} "
                     f"{r.median_ms / max(ours[r.scene], 1e-9):7.2f} {r.setup_ms:9.0f} "
                     f"{r.psnr_db:8.1f} {r.wrong_percent:8.2f}")
    return "\n".join(lines)
