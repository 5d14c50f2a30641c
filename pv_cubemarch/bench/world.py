"""Chunked voxel worlds: one grid against many chunks.

``pv-cubemarch bench voxel-world``: an FBM terrain as one grid of ``2 chunk``³ voxels and as
``count x count`` chunks of ``chunk``³ (the voxel report: 256³ against 10 x 10 chunks of
128³), the same terrain with a long low valley across the diagonal (``terrain*``, a worst
case), the chunked terrain seen from a camera standing on it (``inside``: with a row drawing
only the chunks a pixel shows, so the cost of those behind the camera or hidden is
measured), and ``count x count`` empty chunks; each drawn with plain DDA, the default
occupancy levels, the defaults and level of detail, frames drawn in turn as if the view
turned. Per row: median frame time, setup, GPU/host bytes and the share of pixels showing
another material than the CPU traversal of the whole grid (the level of detail's error; 0
for every other row).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..api import add_voxels
from ..core.camera import Camera
from ..core.progress import progress
from ..core.rendering import offscreen_plotter, read_pixels, render_frame
from ..models.procedural import terrain
from ..reference.voxels import trace_voxels
from .harness import time_frames_side_by_side

PALETTE = np.array([[0, 0, 0], [0.13, 0.55, 0.13], [0.55, 0.27, 0.07], [0.41, 0.41, 0.41]])
BACKGROUND = (1.0, 1.0, 1.0)
#: Rows: the options each draws with (chunked scenes add their chunk size). Chunked scenes
#: are drawn by one traversal over the chunk index except in ``per chunk`` (a box per
#: chunk, culled and ordered: the other design, measured side by side).
ROWS = {
    "dda": {"mip_levels": 0, "proxy": "box"},
    "dda mip": {"proxy": "box"},
    "default": {},
    "lod": {"lod": True},
    "per chunk": {"world_traversal": "per_chunk"},
}
#: The inside scene's extra row: the defaults on the chunks the reference sees, all others
#: emptied; its time against ``default`` is what the chunks behind the camera or hidden
#: behind the terrain cost.
SEEN_ONLY = "seen only"


def world_scenes(chunk: int = 128, count: int = 10) -> dict[str, tuple[np.ndarray, int | None]]:
    """Scene name to ``(labels, chunk size or None)``, deterministic.

    The scene whose name starts with ``inside`` is the chunked terrain seen from a camera
    standing on it (:func:`_camera`).
    """
    side = chunk * count
    ground = terrain((side, side, chunk), feature_size=side / 8, seed=1)
    valley = ground.copy()
    x, y = np.meshgrid(np.arange(side), np.arange(side), indexing="ij")
    low = np.abs(x - y) < side // 16          # a long low valley across the diagonal
    valley[low, chunk // 8:] = 0
    one = terrain((2 * chunk,) * 3, feature_size=chunk / 4, seed=1, ground=0.25, relief=0.09)
    return {
        f"terrain {2 * chunk}^3": (one, None),
        f"terrain {count}x{count}x{chunk}^3": (ground, chunk),
        f"terrain* {count}x{count}x{chunk}^3": (valley, chunk),
        f"inside {count}x{count}x{chunk}^3": (ground, chunk),
        f"empty {count}x{count}x{chunk}^3": (np.zeros((side, side, chunk), np.uint8), chunk),
    }


@dataclass
class WorldRow:
    """One scene and row: frame times, setup, bytes and wrong pixels."""

    scene: str
    row: str
    frame_ms: list[float]
    setup_ms: float
    gpu_bytes: int
    host_bytes: int
    covered_pixels: int
    wrong_percent: float

    @property
    def median_ms(self) -> float:
        """Median frame time."""
        return float(np.median(self.frame_ms))


def _camera(name: str, labels: np.ndarray) -> Camera:
    """From above one corner, the whole grid in sight; ``inside``: on the ground.

    Inside, the eye stands a few voxels over the terrain near one corner and looks along
    the diagonal with a 60 degree view: chunks behind it, and most in front hidden behind
    the nearer hills.
    """
    n = np.array(labels.shape, dtype=float)
    if name.startswith("inside"):
        corner = (int(n[0] * 0.15), int(n[1] * 0.2))
        height = float(np.count_nonzero(labels[corner]))
        eye = np.array([corner[0] + 0.5, corner[1] + 0.5, height + max(n[2] / 20, 1.5)])
        return Camera(position=tuple(eye), focal_point=tuple(eye + [n[0] / 2, n[1] * 0.4,
                                                                     -n[2] / 16]),
                      view_up=(0, 0, 1), view_angle=60.0)
    return Camera(position=tuple(n / 2 + max(n) * np.array([0.75, -0.55, 0.7])),
                  focal_point=tuple(n / 2), view_up=(0, 0, 1), view_angle=40.0)


def run_world(size: Sequence[int] = (640, 480), chunk: int = 128, count: int = 10,
              frames: int = 3, progress_bar: bool | None = None) -> list[WorldRow]:
    """Every row on every scene of :func:`world_scenes`, frames drawn in turn per scene."""
    size = tuple(int(v) for v in size)
    results = []
    scenes = world_scenes(chunk, count)
    for name, (labels, chunk_size) in progress(scenes.items(), total=len(scenes),
                                               desc="worlds", enabled=progress_bar):
        plotters, setup, memory = {}, {}, {}
        camera = _camera(name, labels)
        try:
            for row, options in ROWS.items():
                if chunk_size is None and "world_traversal" in options:
                    continue   # a grid drawn whole has no chunks to traverse otherwise
                plotters[row], setup[row], memory[row] = _draw_row(size, camera, labels,
                                                                   chunk_size, options)
            first = plotters["dda"]
            hits = trace_voxels(labels, np.eye(4), Camera.from_pyvista(first.camera), size,
                                near=first.camera.clipping_range[0])
            if name.startswith("inside"):
                seen = _seen_chunks(labels, hits, chunk_size)
                plotters[SEEN_ONLY], setup[SEEN_ONLY], memory[SEEN_ONLY] = _draw_row(
                    size, camera, seen, chunk_size, {})
            times = time_frames_side_by_side(plotters, frames, warmup=0, camera_moves=True)
            reference = np.where(hits.material[..., None] > 0,
                                 PALETTE[np.clip(hits.material, 0, len(PALETTE) - 1)],
                                 np.asarray(BACKGROUND))
            for row in plotters:
                image = read_pixels(plotters[row]).astype(float) / 255.0
                wrong = (np.abs(image - reference).max(axis=-1) > 3.0 / 255.0) \
                    & ~hits.near_edge
                results.append(WorldRow(name, row, times[row], setup[row], *memory[row],
                                        int((hits.material > 0).sum()),
                                        100.0 * float(wrong.mean())))
        finally:
            for pl in plotters.values():
                pl.close()
    return results


def _draw_row(size, camera: Camera, labels: np.ndarray, chunk_size: int | None,
              options: dict) -> tuple:
    """A plotter showing ``labels`` with ``options``: ``(plotter, setup ms, (GPU, host bytes))``.

    Setup runs from the call to the first frame.
    """
    pl = offscreen_plotter(size)
    pl.disable_anti_aliasing()
    pl.ren_win.SetMultiSamples(0)
    pl.set_background(BACKGROUND)
    start = time.perf_counter()
    actor = add_voxels(pl, labels, palette=PALETTE.copy(), shading="unlit",
                       chunk_size=chunk_size, **options)
    camera.apply_to(pl.camera)
    pl.renderer.ResetCameraClippingRange()
    render_frame(pl)
    setup = (time.perf_counter() - start) * 1e3
    binding = actor.cubemarch   # a grid's or a world's: labels kept on the host
    return pl, setup, (binding.nbytes, binding.model.nbytes)


def _seen_chunks(labels: np.ndarray, hits, chunk: int) -> np.ndarray:
    """``labels`` with every chunk that holds no voxel a pixel shows emptied."""
    seen = np.zeros_like(labels)
    for key in {tuple(k) for k in hits.index[hits.material > 0] // chunk}:
        box = tuple(slice(c * chunk, (c + 1) * chunk) for c in key)
        seen[box] = labels[box]
    return seen


def format_world_table(results: list[WorldRow]) -> str:
    """The rows as a text table, with each row's time over the one-grid scene's same row.

    ``x one``: frame time over the one grid's; ``x one/px``: the same per covered pixel
    (the chunked terrain covers more of the screen than the one grid).
    """
    first = [r for r in results if r.scene == results[0].scene]
    base = {r.row: r.median_ms for r in first}
    per_pixel = {r.row: r.median_ms / max(r.covered_pixels, 1) for r in first}
    lines = ["scene                      row       frame ms  x one  x one/px  setup ms   GPU MB"
             "  host MB  covered px  wrong %", "-" * 112]
    for r in results:
        ratio = r.median_ms / base[r.row] if r.row in base else float("nan")
        pixel_ratio = (r.median_ms / r.covered_pixels / per_pixel[r.row]
                       if r.row in per_pixel and r.covered_pixels else float("nan"))
        lines.append(f"{r.scene:26s} {r.row:9s}{r.median_ms:9.1f} "
                     f"{ratio:6.2f} {pixel_ratio:9.2f} {r.setup_ms:9.0f} "
                     f"{r.gpu_bytes / 1e6:8.1f} {r.host_bytes / 1e6:8.1f} "
                     f"{r.covered_pixels:11d} {r.wrong_percent:8.3f}")
    return "\n".join(lines)
