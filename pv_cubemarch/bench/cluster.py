"""``pv-cubemarch bench cluster``: an orbit of frames on a Dask LocalCluster, side by side.

Scenes: the shipped scene files, and a scene of each technique alone (a CT phantom by the
direct marcher and by cube-map imposters, a segmentation by the voxel traversal, an
implicit surface by the active-cell march). Rows, per scene, in one run: the serial loop
over one plotter (the reference every frame is compared with, pixel for pixel), a
``multiprocessing.Pool`` of PyVista plotters that builds the scene again for every frame
(what users write by hand today), and :func:`~pv_cubemarch.render_frames` on a
LocalCluster of 1, 2 ... processes, started before the clock. Measured: seconds, frames
per second, speed-up over the serial loop and its efficiency per worker, the time per
frame the cluster adds over a perfect split of the serial loop's (scheduling, transfer,
each worker's build), and whether every frame equals the serial one.
"""

from __future__ import annotations

import multiprocessing
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyvista

from ..api import add_surface, add_volume, add_voxels
from ..cluster.frames import orbit, render_frames
from ..core.camera import Camera
from ..core.rendering import offscreen_plotter, render_image
from ..scene.io import load_scene
from .sort_last import phantom, segmentation
from .surfaces import shape_field

DATASETS = Path(__file__).resolve().parents[2] / "datasets"
#: Grid points (volumes), voxels and cells a side of the scenes of one technique each.
TECHNIQUE_GRID = 96


def _ct_grid() -> pyvista.ImageData:
    grid = pyvista.ImageData(dimensions=(TECHNIQUE_GRID,) * 3, spacing=(1.0, 1.0, 1.0))
    grid.point_data["hu"] = phantom((TECHNIQUE_GRID,) * 3).ravel(order="F")
    return grid


def draw_direct(plotter) -> None:
    """A CT phantom, the direct marcher."""
    add_volume(plotter, _ct_grid(), technique="direct", cmap="bone", opacity="sigmoid",
               show_scalar_bar=False)


def draw_cubemap(plotter) -> None:
    """The same phantom, cube-map imposters."""
    add_volume(plotter, _ct_grid(), technique="cubemap", cmap="bone", opacity="sigmoid",
               show_scalar_bar=False)


def draw_voxels(plotter) -> None:
    """A segmentation of 60 balls of uint32 ids, the exact voxel traversal."""
    add_voxels(plotter, segmentation((TECHNIQUE_GRID,) * 3, cells=60))


def draw_surface(plotter) -> None:
    """The 'blobs' implicit surface on 32 cells a side, the active-cell polynomial march."""
    add_surface(plotter, shape_field("blobs", 32, progress_bar=False), color="tan")


#: What each row set draws: the shipped scene files (a smoke volume with a torus; meshes,
#: a volume, a surface and voxels), and a scene of each technique alone.
SCENES = {"smoke": DATASETS / "smoke_scene.usda", "mixed": DATASETS / "mixed_scene.usda",
          "direct": draw_direct, "cubemap": draw_cubemap, "voxels": draw_voxels,
          "surface": draw_surface}


@dataclass
class ClusterRow:
    """One way of rendering one scene's orbit, and what it cost."""

    scene: str
    row: str
    workers: int
    frames: int
    seconds: float
    fps: float = 0.0
    speedup: float | None = None
    efficiency: float | None = None
    overhead_ms: float | None = None
    equal: bool | None = None


def _draw(source, plotter) -> None:
    """A scene file loaded into ``plotter``, or a build function run on it."""
    if callable(source):
        source(plotter)
    else:
        load_scene(source, progress_bar=False).add_to(plotter, progress_bar=False)


def _start_camera(source, size) -> Camera:
    """A scene file's camera (or its default), or the one a fresh plotter fits to a build."""
    if not callable(source):
        scene = load_scene(source, progress_bar=False)
        return scene.camera or scene.default_camera(size[0] / size[1])
    plotter = offscreen_plotter(size)
    try:
        source(plotter)
        plotter.view_isometric()
        plotter.camera.zoom(1.3)
        shot = Camera.from_pyvista(plotter.camera)
        return Camera(shot.position, shot.focal_point, shot.view_up, shot.view_angle)
    finally:
        plotter.close()


def serial_frames(path, cameras: Sequence[Camera], size) -> list[np.ndarray]:
    """One plotter, the scene loaded once, a frame per camera."""
    plotter = offscreen_plotter(size)
    try:
        _draw(path, plotter)
        frames = []
        for camera in cameras:
            camera.apply_to(plotter.camera)
            if camera.clipping_range is None:   # as render_frames' workers do
                plotter.renderer.ResetCameraClippingRange()
            frames.append(render_image(plotter, converge=True))
        return frames
    finally:
        plotter.close()


def _scene_per_frame(job) -> np.ndarray:
    """A pool task as users write it: a plotter and the scene made for this frame alone."""
    path, camera, size = job
    return serial_frames(path, [camera], size)[0]


def run_cluster(scenes: Sequence[str] = ("smoke",), frames: int = 64, size=(320, 240),
                workers: Sequence[int] = (1, 2)) -> list[ClusterRow]:
    """Every row of every scene, measured in one run (module docstring)."""
    from distributed import Client, LocalCluster

    size = tuple(int(v) for v in size)
    rows = []
    for name in scenes:
        if name not in SCENES:
            raise ValueError(f"scene must be one of {sorted(SCENES)}, got {name!r}.")
        path = SCENES[name]
        cameras = orbit(_start_camera(path, size), frames)
        start = time.perf_counter()
        expected = serial_frames(path, cameras, size)
        serial = time.perf_counter() - start
        rows.append(_row(name, "serial loop, one plotter", 1, frames, serial, serial, True))
        most = max(workers)
        context = multiprocessing.get_context("spawn")
        with context.Pool(most) as pool:
            pool.map(_scene_per_frame, [(path, cameras[0], size)] * most)   # imports warm
            start = time.perf_counter()
            images = pool.map(_scene_per_frame, [(path, c, size) for c in cameras])
            took = time.perf_counter() - start
        rows.append(_row(name, "multiprocessing.Pool, scene per frame", most, frames, took,
                         serial, _all_equal(images, expected)))
        for count in workers:
            with LocalCluster(n_workers=count, threads_per_worker=1, processes=True,
                              dashboard_address=":0") as cluster, Client(cluster) as client:
                start = time.perf_counter()
                images = render_frames(path, cameras, size, client=client, progress_bar=False)
                took = time.perf_counter() - start
            rows.append(_row(name, "render_frames, LocalCluster", count, frames, took, serial,
                             _all_equal(images, expected)))
    return rows


def _all_equal(images, expected) -> bool:
    return len(images) == len(expected) and all(
        np.array_equal(a, b) for a, b in zip(images, expected, strict=True))


def _row(scene, row, workers, frames, seconds, serial, equal) -> ClusterRow:
    speedup = serial / seconds
    return ClusterRow(scene, row, workers, frames, seconds, frames / seconds, speedup,
                      speedup / workers, (seconds - serial / workers) / frames * 1e3, equal)


def format_cluster(rows: list[ClusterRow]) -> str:
    """The rows as a text table."""
    lines = [f"{'scene':7} {'row':38} {'workers':>7} {'frames':>6} {'s':>7} {'fps':>7} "
             f"{'speedup':>7} {'eff.':>5} {'+ms/frame':>9} {'equal':>5}"]
    for r in rows:
        lines.append(f"{r.scene:7} {r.row:38} {r.workers:>7} {r.frames:>6} {r.seconds:>7.2f} "
                     f"{r.fps:>7.1f} {r.speedup:>7.2f} {r.efficiency:>5.2f} "
                     f"{r.overhead_ms:>9.1f} {str(r.equal):>5}")
    return "\n".join(lines)
