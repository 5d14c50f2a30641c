"""``pv-cubemarch bench sortlast``: one volume (and one label grid) split over a LocalCluster.

Rows, per grid, in one run: one plotter drawing the whole grid in a loop (the reference
every frame is compared with), and :func:`~pv_cubemarch.render_sort_last` with 2, 4, 8 ...
slabs on LocalClusters of the given sizes, started before the clock and warmed by one frame
(each worker's slabs read and uploaded). Measured per frame: seconds, the client's
compositing time, the bytes the workers sent, the share of frames that took a second
round (rays whose whole march stops inside a slab behind others), and the error against the
whole render (the lowest PSNR of the orbit for a volume; for labels, pixels that differ,
apart and then among those whose ray grazes a voxel's edge, where the CPU traversal in
float64 says a float32 traversal may legitimately hit another voxel, as ``bench voxels``
counts them).
The grids sit in a zarr store, chunked along x, so each worker reads only its slabs.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pyvista

from ..api import add_volume, add_voxels
from ..cluster.frames import orbit
from ..cluster.sort_last import render_sort_last
from ..cluster.split_grid import hashed_color
from ..core.camera import Camera
from ..core.rendering import offscreen_plotter, render_image
from ..image_metrics import compare_images
from ..reference.voxels import trace_voxels

#: Where the phantom's points lie: anisotropic, away from the origin.
SPACING = (0.8, 0.8, 1.2)
ORIGIN = (-120.0, 40.0, 300.0)


@dataclass
class SortLastRow:
    """One way of drawing one grid's orbit, and what a frame cost."""

    grid: str
    row: str
    partitions: int | str | None   # slabs along x, or bricks per axis as 2x2x2
    workers: int
    frames: int
    frame_s: float
    composite_ms: float | None = None
    sent_mb: float | None = None
    #: Share of frames that took a second round (rays stopping inside a slab behind others).
    second_pass_share: float | None = None
    psnr_min: float | None = None
    wrong_pixels: int | None = None
    edge_pixels: int | None = None


def phantom(shape) -> np.ndarray:
    """A CT-like volume in Hounsfield units: air, a soft-tissue body, a bone shell, a core."""
    axes = [np.linspace(-1.0, 1.0, n, dtype=np.float32) for n in shape]
    x, y, z = np.meshgrid(*axes, indexing="ij")
    r = np.sqrt(x**2 + (1.3 * y) ** 2 + (0.8 * z) ** 2)
    body = np.where(r < 0.85, 40.0 + 30.0 * np.sin(9.0 * x) * np.cos(7.0 * z), -1000.0)
    shell = 1200.0 * np.exp(-((r - 0.7) / 0.05) ** 2)
    core = 300.0 * np.exp(-(((x - 0.25) ** 2 + y**2 + (z + 0.2) ** 2) / 0.02))
    return (body + shell + core).astype(np.float32)


def segmentation(shape, cells: int = 300, seed: int = 0) -> np.ndarray:
    """uint32 ids of random balls (ids far apart, as a segmentation's are), 0 between."""
    rng = np.random.default_rng(seed)
    labels = np.zeros(shape, np.uint32)
    grid = np.indices(shape, dtype=np.float32)
    for index in range(cells):
        centre = rng.random(3) * np.asarray(shape)
        radius = rng.uniform(2.0, max(3.0, min(shape) / 8.0))
        near = np.sum((grid - centre[:, None, None, None]) ** 2, axis=0) < radius**2
        labels[near] = (index + 1) * 7919 + 2**31
    return labels


def _store(path, data: np.ndarray, partitions: Sequence) -> str:
    """The grid in a zarr store, chunked so each slab or brick reads only its chunks."""
    import zarr

    counts = [max([p[axis] for p in partitions if isinstance(p, tuple)]
                  + [p for p in partitions if not isinstance(p, tuple) and axis == 0] + [1])
              for axis in range(3)]
    chunks = tuple(max(1, -(-n // c)) for n, c in zip(data.shape, counts, strict=True))
    array = zarr.open_array(str(path), mode="w", shape=data.shape, dtype=data.dtype,
                            chunks=chunks)
    array[:] = data
    return str(path)


def _whole(data, cameras, size, labels: bool) -> tuple[list[np.ndarray], float, list]:
    """One plotter drawing the whole grid for every camera.

    Returns the frames, the seconds per frame and each frame's near plane.
    """
    plotter = offscreen_plotter(size)
    try:
        if labels:
            plotter.disable_anti_aliasing()
            grid = pyvista.ImageData(dimensions=np.asarray(data.shape) + 1, spacing=SPACING,
                                     origin=ORIGIN)
            grid.cell_data["ids"] = data.ravel(order="F")
            add_voxels(plotter, grid, palette=hashed_color)
        else:
            grid = pyvista.ImageData(dimensions=data.shape, spacing=SPACING, origin=ORIGIN)
            grid.point_data["hu"] = data.ravel(order="F")
            add_volume(plotter, grid, technique="direct", show_scalar_bar=False,
                       cmap="bone", opacity="sigmoid")
        frames, nears = [], []
        start = None
        for index, camera in enumerate(cameras):
            camera.apply_to(plotter.camera)
            plotter.camera_set = True
            if camera.clipping_range is None:
                plotter.renderer.ResetCameraClippingRange()
            frames.append(render_image(plotter))
            nears.append(plotter.camera.clipping_range[0])
            if index == 0:   # the first frame uploads: timed apart, as the slabs' are
                start = time.perf_counter()
        spent = time.perf_counter() - start
        return frames, spent / max(len(cameras) - 1, 1), nears
    finally:
        plotter.close()


def run_sort_last(shape=(192, 128, 96), frames: int = 16, size=(320, 240),
                  partitions: Sequence = (2, 4, 8, (2, 2, 2)),
                  workers: Sequence[int] = (2,)) -> list[SortLastRow]:
    """Every row of both grids, measured in one run (module docstring)."""
    from distributed import Client, LocalCluster

    size = tuple(int(v) for v in size)
    rows = []
    centre = np.asarray(ORIGIN) + np.asarray(SPACING) * (np.asarray(shape) - 1) / 2.0
    reach = float(np.linalg.norm(np.asarray(SPACING) * np.asarray(shape)))
    start = Camera(tuple(centre + reach * np.array([1.1, -0.9, 0.5])), tuple(centre),
                   (0, 0, 1))
    cameras = orbit(start, frames + 1)   # the first frame warms: uploads, builds
    with tempfile.TemporaryDirectory() as folder:
        for labels in (False, True):
            data = segmentation(shape) if labels else phantom(shape)
            name = f"{'labels' if labels else 'volume'} {'x'.join(map(str, shape))}"
            path = _store(f"{folder}/{'labels' if labels else 'volume'}.zarr", data,
                          partitions)
            expected, whole_s, nears = _whole(data, cameras, size, labels)
            rows.append(SortLastRow(name, "one plotter, whole grid", None, 1, frames, whole_s))
            look = {} if labels else {"cmap": "bone", "opacity": "sigmoid"}
            grazing = _grazing(data, cameras, size, nears) if labels else None
            for count in workers:
                with LocalCluster(n_workers=count, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as cluster, \
                        Client(cluster) as client:
                    for slabs in partitions:
                        rows.append(_split_row(name, path, cameras, size, slabs, client,
                                               count, labels, look, expected, grazing))
    return rows


def _grazing(labels, cameras, size, nears) -> list[np.ndarray]:
    """Per frame, the pixels whose ray passes within a hair of a voxel's edge.

    The CPU traversal in float64 says where a float32 traversal may legitimately hit
    another voxel.
    """
    world_from_index = np.eye(4)
    world_from_index[:3, :3] = np.diag(SPACING)
    world_from_index[:3, 3] = ORIGIN
    return [trace_voxels(labels, world_from_index, camera, size, near=near).near_edge
            for camera, near in zip(cameras[1:], nears[1:], strict=True)]


def _split_row(name, path, cameras, size, slabs, client, count, labels, look,
               expected, grazing) -> SortLastRow:
    keywords = dict(partitions=slabs, axis=None if isinstance(slabs, tuple) else 0,
                    spacing=SPACING, origin=ORIGIN, client=client,
                    technique="voxels" if labels else "direct", progress_bar=False, **look)
    render_sort_last(path, cameras[0], size, **keywords)   # warm: slabs read and uploaded
    report: dict = {}
    start = time.perf_counter()
    images = render_sort_last(path, cameras[1:], size, report=report, **keywords)
    spent = time.perf_counter() - start
    row = SortLastRow(name, "render_sort_last, LocalCluster",
                      "x".join(map(str, slabs)) if isinstance(slabs, tuple) else slabs,
                      count, len(images),
                      spent / len(images), report["composite_s"] * 1e3,
                      report["bytes"] / 2**20)
    if labels:
        differs = [np.any(a != b, axis=-1) for a, b in zip(images, expected[1:], strict=True)]
        row.wrong_pixels = int(sum((d & ~edge).sum() for d, edge in zip(differs, grazing,
                                                                         strict=True)))
        row.edge_pixels = int(sum((d & edge).sum() for d, edge in zip(differs, grazing,
                                                                       strict=True)))
    else:
        row.second_pass_share = report["second_passes"]
        row.psnr_min = min(compare_images(a, b).psnr
                           for a, b in zip(images, expected[1:], strict=True))
    return row


def format_sort_last(rows: list[SortLastRow]) -> str:
    """The rows as a text table."""
    lines = [f"{'grid':18} {'row':32} {'slabs':>5} {'workers':>7} {'frames':>6} "
             f"{'s/frame':>8} {'comp. ms':>8} {'sent MB':>8} {'2nd pass':>8} {'PSNR min':>8} "
             f"{'wrong':>6} {'edge':>5}"]

    def cell(value, width: int, spec: str = "") -> str:
        return "-".rjust(width) if value is None else format(value, f">{width}{spec}")
    for r in rows:
        lines.append(f"{r.grid:18} {r.row:32} {cell(r.partitions, 5)} {r.workers:>7} "
                     f"{r.frames:>6} {r.frame_s:>8.3f} {cell(r.composite_ms, 8, '.1f')} "
                     f"{cell(r.sent_mb, 8, '.2f')} {cell(r.second_pass_share, 8, '.0%')} "
                     f"{cell(r.psnr_min, 8, '.1f')} "
                     f"{cell(r.wrong_pixels, 6)} {cell(r.edge_pixels, 5)}")
    return "\n".join(lines)
