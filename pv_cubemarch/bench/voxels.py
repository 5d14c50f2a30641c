"""``pv-cubemarch bench voxels``: material grids, our traversals against PyVista's paths.

Builds the seed's scenes with fixed seeds and times, side by side in one run (frames drawn
in turn), the fixed step, the DDA with 0-3 occupancy levels, PyVista's thresholded cells
(``add_mesh``, with and without ``extract_surface``) and PyVista's ``add_volume`` with
nearest interpolation. Every row draws unlit palette colours, so each image is compared
pixel by pixel with the CPU traversal's (:func:`~pv_cubemarch.reference.voxels.render_voxels`):
a pixel is wrong when it shows another material's colour (or none).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import pyvista

from ..api import add_voxels
from ..core.camera import Camera
from ..core.progress import progress
from ..core.rendering import offscreen_plotter, read_pixels, render_frame
from ..models.voxels import Palette
from ..reference.voxels import render_voxels
from .harness import time_frames_side_by_side

PALETTE = np.array([[0, 0, 0, 0], [0.85, 0.65, 0.13, 1], [0.27, 0.51, 0.71, 1],
                    [0.7, 0.13, 0.13, 1]], dtype=np.float32)
BACKGROUND = (1.0, 1.0, 1.0)
#: A pixel is wrong when a channel differs from the reference by more than this (0-1).
WRONG = 10.0 / 255.0


def scenes(large: int = 256) -> dict[str, np.ndarray]:
    """The seed's scenes, deterministic (labels 1..3).

    An almost empty and a sphere grid of ``large``³, terrain, a torus, 1 % noise and a
    checkerboard.
    """
    rng = np.random.default_rng(2023)
    n = large
    empty = np.zeros((n, n, n), np.uint8)
    empty[n // 2, n // 2, n // 2] = 1
    x, y, z = np.ogrid[0:n, 0:n, 0:n]
    r2 = (x - n / 2 + 0.5) ** 2 + (y - n / 2 + 0.5) ** 2 + (z - n / 2 + 0.5) ** 2
    sphere = (r2 < (0.3 * n) ** 2).astype(np.uint8)
    t = 128
    tx, ty = np.meshgrid(np.arange(t), np.arange(t), indexing="ij")
    height = sum(np.sin(tx * f * 0.05 + p) * np.cos(ty * f * 0.043 + q) * 10 / f
                 for f, p, q in ((1, 0.3, 1.1), (2, 2.0, 0.4), (4, 1.2, 2.2), (8, 0.7, 0.1)))
    height = (height - height.min()) / np.ptp(height) * 48 + 4
    tz = np.arange(64)[None, None, :]
    terrain = np.where(tz < height[..., None] - 6, 2, np.where(tz < height[..., None], 1, 0))
    u, v, w = np.ogrid[-1:1:128j, -1:1:128j, -1:1:128j]
    torus = ((np.sqrt(u**2 + v**2) - 0.6) ** 2 + w**2 < 0.2**2).astype(np.uint8)
    noise = np.where(rng.random((128, 128, 128)) < 0.01, rng.integers(1, 4, (128,) * 3), 0)
    i, j, k = np.ogrid[0:64, 0:64, 0:64]
    checker = ((i // 8 + j // 8 + k // 8) % 2) * (1 + (i // 16 + k // 16) % 3)
    return {f"empty {n}^3": empty, f"sphere {n}^3": sphere, "terrain 128x128x64": terrain,
            "torus 128^3": torus, "random 1% 128^3": noise, "checker 64^3": checker}


def _lookup() -> pyvista.LookupTable:
    """The palette as a ready lookup table (label 0 transparent, the others opaque)."""
    lut = pyvista.LookupTable()
    lut.values = np.round(np.column_stack([PALETTE[:, :3] * 255, PALETTE[:, 3] * 255]))
    lut.scalar_range = (0, len(PALETTE) - 1)
    return lut


def _pyvista_mesh(plotter, labels: np.ndarray, surface: bool):
    grid = pyvista.ImageData(dimensions=np.array(labels.shape) + 1)
    grid.cell_data["labels"] = labels.ravel(order="F")
    mesh = grid.threshold(0.5, scalars="labels")
    if surface:
        mesh = mesh.extract_surface(algorithm="dataset_surface")
    # Each cell's palette colour as RGB (a colormap over the labels would be resampled).
    colors = np.round(PALETTE[np.asarray(mesh.cell_data["labels"]).astype(int), :3] * 255)
    mesh.cell_data["rgb"] = colors.astype(np.uint8)
    plotter.add_mesh(mesh, scalars="rgb", rgb=True, lighting=False, show_scalar_bar=False)
    return int(mesh.actual_memory_size * 1024)


def _pyvista_volume(plotter, labels: np.ndarray):
    grid = pyvista.ImageData(dimensions=labels.shape, origin=(0.5, 0.5, 0.5))
    grid.point_data["labels"] = labels.ravel(order="F").astype(np.float32)
    # A ready lookup table carries the opacities (label 0 clear): pyvista 0.49 scales an
    # opacity array given to add_volume down to almost nothing.
    actor = plotter.add_volume(grid, scalars="labels", cmap=_lookup(), clim=(0, 3),
                               opacity_unit_distance=0.01, mapper="gpu", shade=False,
                               show_scalar_bar=False)
    actor.prop.interpolation_type = "nearest"
    actor.mapper.SetAutoAdjustSampleDistances(False)
    actor.mapper.SetUseJittering(False)
    actor.mapper.SetSampleDistance(0.5)
    return int(labels.size * 4)


ROWS: dict[str, Callable] = {
    "fixed 0.1": lambda pl, lab: _ours(pl, lab, traversal="fixed", step_scale=0.1),
    "dda": lambda pl, lab: _ours(pl, lab, mip_levels=0),
    "dda mip 1": lambda pl, lab: _ours(pl, lab, mip_levels=1),
    "dda mip 2": lambda pl, lab: _ours(pl, lab, mip_levels=2),
    "dda mip 3": lambda pl, lab: _ours(pl, lab, mip_levels=3),
    "pyvista cells": lambda pl, lab: _pyvista_mesh(pl, lab, surface=False),
    "pyvista surface": lambda pl, lab: _pyvista_mesh(pl, lab, surface=True),
    "pyvista volume": _pyvista_volume,
}


def _ours(plotter, labels, **options) -> int:
    actor = add_voxels(plotter, labels, palette=Palette(PALETTE.copy()), shading="unlit",
                       **options)
    return actor.cubemarch.nbytes


@dataclass
class VoxelRow:
    """One scene and row: frame times, setup time, bytes and wrong pixels."""

    scene: str
    row: str
    frame_ms: list[float]
    setup_ms: float
    nbytes: int
    wrong_percent: float
    extra: dict = field(default_factory=dict)

    @property
    def median_ms(self) -> float:
        """Median frame time."""
        return float(np.median(self.frame_ms))


def run_voxels(size: Sequence[int] = (512, 512), frames: int = 3, large: int = 256,
               rows: Sequence[str] = tuple(ROWS), only: Sequence[str] | None = None,
               progress_bar: bool | None = None) -> list[VoxelRow]:
    """Time every row on every scene side by side; measure wrong pixels against the CPU."""
    unknown = [r for r in rows if r not in ROWS]
    if unknown:
        raise ValueError(f"Unknown rows {unknown}; choose from {list(ROWS)}.")
    size = (int(size[0]), int(size[1]))
    results = []
    chosen = {k: v for k, v in scenes(large).items() if not only or k in only}
    for name, labels in progress(chosen.items(), desc="bench voxels", enabled=progress_bar):
        m = np.array(labels.shape, dtype=float)
        camera = Camera(position=tuple(m * (1.55, -0.55, 1.35)), focal_point=tuple(m / 2),
                        view_up=(0, 0, 1), view_angle=30.0)
        plotters, setup, nbytes = {}, {}, {}
        try:
            for row in rows:
                pl = offscreen_plotter(size)
                pl.disable_anti_aliasing()
                pl.ren_win.SetMultiSamples(0)
                pl.set_background(BACKGROUND)
                start = time.perf_counter()
                nbytes[row] = ROWS[row](pl, labels)
                camera.apply_to(pl.camera)
                pl.renderer.ResetCameraClippingRange()
                render_frame(pl)
                setup[row] = (time.perf_counter() - start) * 1e3
                plotters[row] = pl
            times = time_frames_side_by_side(plotters, frames)
            near = plotters[rows[0]].camera.clipping_range[0]
            shot = Camera.from_pyvista(plotters[rows[0]].camera)
            reference = render_voxels(labels, np.eye(4), PALETTE, shot, size, BACKGROUND,
                                      near=near)
            for row in rows:
                image = read_pixels(plotters[row]).astype(float) / 255.0
                wrong = np.abs(image - reference).max(axis=-1) > WRONG
                results.append(VoxelRow(name, row, times[row], setup[row], nbytes[row],
                                        100.0 * float(wrong.mean())))
        finally:
            for pl in plotters.values():
                pl.close()
    return results


def format_voxel_table(results: list[VoxelRow]) -> str:
    """The table: per scene and row, frame and setup time, ratio to plain DDA, bytes, wrong."""
    lines = [f"{'scene':<20} {'row':<16} {'frame ms':>9} {'x dda':>6} {'setup ms':>9} "
             f"{'bytes':>13} {'wrong %':>8}", "-" * 86]
    for scene in dict.fromkeys(r.scene for r in results):
        rows = [r for r in results if r.scene == scene]
        dda = next((r.median_ms for r in rows if r.row == "dda"), None)
        for r in rows:
            ratio = f"{r.median_ms / dda:6.2f}" if dda else "     -"
            lines.append(f"{scene:<20} {r.row:<16} {r.median_ms:9.1f} {ratio} "
                         f"{r.setup_ms:9.0f} {r.nbytes:13,} {r.wrong_percent:8.3f}")
    return "\n".join(lines)


def write_voxel_json(results: list[VoxelRow], path, meta: dict) -> None:
    """Every frame time and measure, for later comparison."""
    rows = [dict(scene=r.scene, row=r.row, frame_ms=r.frame_ms, setup_ms=r.setup_ms,
                 nbytes=r.nbytes, wrong_percent=r.wrong_percent) for r in results]
    with open(path, "w") as handle:
        json.dump({"meta": meta, "results": rows}, handle, indent=2)
