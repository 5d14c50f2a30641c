"""Long runs: memory per 100 frames of each technique under random cameras and edits.

``pv-cubemarch bench soak``: one offscreen plotter per technique draws ``frames`` frames,
each from a random camera around the data (seeded); every few frames the data is edited
(new volume values, voxels set, the surface's field replaced) and every 100 frames the actor
is removed and added again. After each 100 frames the process's resident memory and the GPU
bytes our techniques hold are read: a leak shows as a slope, a flat run as none.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..api import add_surface, add_volume, add_voxels
from ..core.progress import progress
from ..core.rendering import offscreen_plotter, render_frame

#: Frames between reads of the memory.
WINDOW = 100
#: Frames between edits.
EDIT_EVERY = 5


def _resident_bytes() -> int:
    """Resident memory of the process (Linux /proc; 0 elsewhere)."""
    try:
        with open("/proc/self/statm") as statm:
            pages = int(statm.read().split()[1])
    except (OSError, IndexError, ValueError):
        return 0
    import resource
    return pages * resource.getpagesize()


def _ball(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    centre = rng.uniform(-0.3, 0.3, 3)
    x, y, z = np.mgrid[-1:1:n * 1j, -1:1:n * 1j, -1:1:n * 1j]
    return np.exp(-4 * ((x - centre[0]) ** 2 + (y - centre[1]) ** 2 + (z - centre[2]) ** 2)
                  ).astype(np.float32)


def _labels(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return (rng.random((n, n, n)) < 0.2).astype(np.uint8) * rng.integers(1, 4, (n, n, n),
                                                                         dtype=np.uint8)


def _volume(technique: str) -> tuple[Callable, Callable]:
    def add(pl):
        return add_volume(pl, _ball(32, 0), technique=technique, name="soak")

    def edit(pl, actor, k):
        actor.cubemarch.set_values(_ball(32, k))
    return add, edit


def _voxels() -> tuple[Callable, Callable]:
    def add(pl):
        return add_voxels(pl, _labels(24, 0), name="soak")

    def edit(pl, actor, k):
        rng = np.random.default_rng(k)
        actor.cubemarch.set_voxels(tuple(int(v) for v in rng.integers(0, 24, 3)),
                                   int(rng.integers(0, 4)))
    return add, edit


def _surface() -> tuple[Callable, Callable]:
    def add(pl, seed=0):
        return add_surface(pl, _ball(16, seed) - 0.5, isovalue=0.0, name="soak")

    def edit(pl, actor, k):   # a new field: the surface's actor is made again
        pl.cubemarch.remove(actor)
        return add(pl, k)
    return add, edit


#: What is soaked: name, (add, edit); an edit may return a new actor.
TECHNIQUES: dict[str, Callable] = {
    "volume vtk": lambda: _volume("vtk"), "volume direct": lambda: _volume("direct"),
    "volume cubemap": lambda: _volume("cubemap"), "voxels": _voxels,
    "surface active": _surface,
}


@dataclass
class SoakRow:
    """One technique's run: memory after each window of frames, and its slope."""

    technique: str
    frames: int
    resident_mib: list[float] = field(default_factory=list)
    gpu_bytes: list[int] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def growth_mib_per_100(self) -> float:
        """Least-squares slope of resident memory per 100 frames, after the first window.

        The first frames compile shaders and fill caches.
        """
        values = self.resident_mib[1:]
        if len(values) < 2:
            return 0.0
        return float(np.polyfit(np.arange(len(values)), values, 1)[0]) * 100 / WINDOW


def _random_camera(pl, rng) -> None:
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    centre = np.array(pl.bounds).reshape(3, 2).mean(axis=1)
    radius = float(np.linalg.norm(np.ptp(np.array(pl.bounds).reshape(3, 2), axis=1)))
    pl.camera.position = tuple(centre + direction * radius * rng.uniform(0.3, 2.5))
    pl.camera.focal_point = tuple(centre)
    pl.camera.up = (0.0, 0.0, 1.0) if abs(direction[2]) < 0.9 else (0.0, 1.0, 0.0)
    pl.renderer.ResetCameraClippingRange()


def soak(technique: str, frames: int, size=(160, 120), seed: int = 25) -> SoakRow:
    """Draw ``frames`` frames of ``technique`` with random cameras, edits and re-adds."""
    add, edit = TECHNIQUES[technique]()
    rng = np.random.default_rng(seed)
    pl = offscreen_plotter(size)
    row = SoakRow(technique, frames)
    start = time.perf_counter()
    try:
        actor = add(pl)
        for frame in range(1, frames + 1):
            _random_camera(pl, rng)
            if frame % EDIT_EVERY == 0:
                actor = edit(pl, actor, frame) or actor
            if frame % WINDOW == 0:
                pl.cubemarch.remove(actor)
                actor = add(pl)
            render_frame(pl)
            if frame % WINDOW == 0:
                row.resident_mib.append(_resident_bytes() / 2**20)
                row.gpu_bytes.append(int(sum(pl.cubemarch.memory.values())))
    finally:
        pl.close()
    row.seconds = time.perf_counter() - start
    return row


def run_soak(frames: int = 500, techniques=None, size=(160, 120),
             progress_bar: bool | None = None) -> list[SoakRow]:
    """Soak each technique in turn."""
    names = list(techniques or TECHNIQUES)
    return [soak(name, frames, size) for name in progress(names, desc="soaking",
                                                          enabled=progress_bar)]


def format_soak(rows: list[SoakRow]) -> str:
    """The table: resident MiB after each 100 frames, the slope, GPU bytes at the end."""
    width = max(len(r.resident_mib) for r in rows) if rows else 0
    head = "technique        " + "".join(f"{(k + 1) * WINDOW:>8}" for k in range(width)) + \
        "   MiB/100 frames   GPU bytes   s"
    lines = [head]
    for r in rows:
        cells = "".join(f"{v:8.1f}" for v in r.resident_mib)
        lines.append(f"{r.technique:<17}{cells}{r.growth_mib_per_100:>15.2f}"
                     f"{(r.gpu_bytes or [0])[-1]:>14,}{r.seconds:>6.0f}")
    return "\n".join(lines)
