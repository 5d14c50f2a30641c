"""``pv-cubemarch bench voxels``: material grids, our traversals against PyVista's paths.

Builds the voxel report's scenes with fixed seeds and times, side by side in one run (frames drawn
in turn), the fixed step, the DDA with 1-3 and the default occupancy levels and with
distance fields 1-3, PyVista's thresholded cells
(``add_mesh``, with and without ``extract_surface``) and PyVista's ``add_volume`` with
nearest interpolation. Every row draws unlit palette colours, so each image is compared
pixel by pixel with the CPU traversal's (:func:`~pv_cubemarch.reference.voxels.trace_voxels`):
a pixel is wrong when it shows another material's colour (or none); pixels whose ray passes
within 1e-4 voxel of an edge, where float32 may break a tie the other way, are counted apart.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import pyvista

from ..api import add_voxels
from ..cluster.offload import Offload
from ..core.camera import Camera
from ..core.progress import progress
from ..core.rendering import offscreen_plotter, read_pixels, render_frame
from ..models.voxels import Palette
from ..reference.voxels import trace_voxels
from .harness import time_frames_side_by_side

PALETTE = np.array([[0, 0, 0, 0], [0.85, 0.65, 0.13, 1], [0.27, 0.51, 0.71, 1],
                    [0.7, 0.13, 0.13, 1]], dtype=np.float32)
BACKGROUND = (1.0, 1.0, 1.0)
#: A pixel is wrong when a channel differs from the reference by more than this (0-1).
WRONG = 10.0 / 255.0


def scenes(large: int = 256) -> dict[str, np.ndarray]:
    """The voxel report's scenes, deterministic (labels 1..3).

    Empty grids (one voxel in the middle) of 128³ and ``large``³, a filled 128³ grid, a
    sphere of 128³ and ``large``³, sine-wave terrain, a torus, 1 % random fill and a
    checkerboard.
    """
    rng = np.random.default_rng(2023)
    result = {}
    for n in dict.fromkeys((128, large)):
        empty = np.zeros((n, n, n), np.uint8)
        empty[n // 2, n // 2, n // 2] = 1
        result[f"empty {n}^3"] = empty
    result["filled 128^3"] = np.ones((128,) * 3, np.uint8)
    for n in dict.fromkeys((128, large)):
        x, y, z = np.ogrid[0:n, 0:n, 0:n]
        r2 = (x - n / 2 + 0.5) ** 2 + (y - n / 2 + 0.5) ** 2 + (z - n / 2 + 0.5) ** 2
        result[f"sphere {n}^3"] = (r2 < (0.3 * n) ** 2).astype(np.uint8)
    t = 128
    tx, ty = np.meshgrid(np.arange(t), np.arange(t), indexing="ij")
    height = sum(np.sin(tx * f * 0.05 + p) * np.cos(ty * f * 0.043 + q) * 10 / f
                 for f, p, q in ((1, 0.3, 1.1), (2, 2.0, 0.4), (4, 1.2, 2.2), (8, 0.7, 0.1)))
    height = (height - height.min()) / np.ptp(height) * 48 + 4
    tz = np.arange(64)[None, None, :]
    result["waves 128x128x64"] = np.where(tz < height[..., None] - 6, 2,
                                          np.where(tz < height[..., None], 1, 0))
    u, v, w = np.ogrid[-1:1:128j, -1:1:128j, -1:1:128j]
    result["torus 128^3"] = ((np.sqrt(u**2 + v**2) - 0.6) ** 2 + w**2 < 0.2**2).astype(np.uint8)
    result["random 1% 128^3"] = np.where(rng.random((128, 128, 128)) < 0.01,
                                         rng.integers(1, 4, (128,) * 3), 0)
    i, j, k = np.ogrid[0:64, 0:64, 0:64]
    result["checker 64^3"] = ((i // 8 + j // 8 + k // 8) % 2) * (1 + (i // 16 + k // 16) % 3)
    return result


def _lookup() -> pyvista.LookupTable:
    """The palette as a ready lookup table (label 0 transparent, the others opaque)."""
    lut = pyvista.LookupTable()
    lut.values = np.round(np.column_stack([PALETTE[:, :3] * 255, PALETTE[:, 3] * 255]))
    lut.scalar_range = (0, len(PALETTE) - 1)
    return lut


#: What a row holds in memory, read after its first frame: (GPU bytes, host bytes).
MemoryProbe = Callable[[], tuple[int, int]]


def _drawn_polydata(actor):
    """The polygons VTK's mapper draws for a mesh actor (a grid's surface, made by VTK)."""
    mapper = actor.GetMapper()
    inner = mapper.GetPolyDataMapper() if hasattr(mapper, "GetPolyDataMapper") else mapper
    return inner.GetInput()


def _pyvista_mesh(plotter, labels: np.ndarray, surface: bool) -> MemoryProbe:
    grid = pyvista.ImageData(dimensions=np.array(labels.shape) + 1)
    grid.cell_data["labels"] = labels.ravel(order="F")
    mesh = grid.threshold(0.5, scalars="labels")
    if surface:
        mesh = mesh.extract_surface(algorithm="dataset_surface")
    # Each cell's palette colour as RGB (a colormap over the labels would be resampled).
    colors = np.round(PALETTE[np.asarray(mesh.cell_data["labels"]).astype(int), :3] * 255)
    mesh.cell_data["rgb"] = colors.astype(np.uint8)
    actor = plotter.add_mesh(mesh, scalars="rgb", rgb=True, lighting=False,
                             show_scalar_bar=False)

    def memory() -> tuple[int, int]:
        drawn = _drawn_polydata(actor)
        host = mesh.actual_memory_size * 1024
        if drawn is not None and drawn is not mesh:
            host += drawn.GetActualMemorySize() * 1024
        if drawn is None:
            return 0, host
        # GPU, estimated from what VTK uploads: float32 positions, one RGBA8 colour per
        # cell, and 32-bit triangle indices (a quad is two triangles).
        sizes = np.diff(pyvista.convert_array(drawn.GetPolys().GetOffsetsArray()))
        triangles = int(np.maximum(sizes - 2, 0).sum())
        gpu = drawn.GetNumberOfPoints() * 12 + drawn.GetNumberOfCells() * 4 + triangles * 12
        return int(gpu), int(host)

    return memory


def _pyvista_volume(plotter, labels: np.ndarray) -> MemoryProbe:
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
    # The float32 labels, on the GPU as one 32-bit texel per voxel and on the host.
    return lambda: (int(labels.size * 4), int(grid.actual_memory_size * 1024))


def _ours(plotter, labels, **options) -> MemoryProbe:
    actor = add_voxels(plotter, labels, palette=Palette(PALETTE.copy()), shading="unlit",
                       **options)
    binding = actor.cubemarch
    # The host keeps the labels (to pick, and to remake the skipping structures, whose host
    # copies go once uploaded).
    return lambda: (binding.nbytes, binding.model.nbytes
                    + sum(t.host_nbytes for t in binding.derived_textures)
                    + (binding.shell.host_nbytes if binding.shell is not None else 0))


#: Rows of our technique: the traversals on the grid's whole box (so they measure the
#: traversal alone), then the defaults (the brick shell starts the rays).
ROWS: dict[str, Callable] = {
    "fixed 0.1": lambda pl, lab: _ours(pl, lab, traversal="fixed", step_scale=0.1,
                                       proxy="box"),
    "dda": lambda pl, lab: _ours(pl, lab, mip_levels=0, proxy="box"),
    **{f"dda mip {n}": (lambda pl, lab, n=n: _ours(pl, lab, mip_levels=n, proxy="box"))
       for n in (1, 2, 3)},
    "dda mip all": lambda pl, lab: _ours(pl, lab, proxy="box"),
    **{f"dda df {n}": (lambda pl, lab, n=n: _ours(pl, lab, mip_levels=0, distance_field=n,
                                                  proxy="box"))
       for n in (1, 2, 3)},
    "default": lambda pl, lab: _ours(pl, lab),
    "pyvista cells": lambda pl, lab: _pyvista_mesh(pl, lab, surface=False),
    "pyvista surface": lambda pl, lab: _pyvista_mesh(pl, lab, surface=True),
    "pyvista volume": _pyvista_volume,
}


@dataclass
class VoxelRow:
    """One scene, image size and row: frame times, setup time, bytes and wrong pixels.

    ``wrong_percent``: pixels showing another material than the CPU traversal, away from
    voxel edges; ``edge_pixels``: differing pixels whose ray passes within 1e-4 voxel of an
    edge (ties float32 may break the other way).
    """

    scene: str
    row: str
    size: tuple[int, int]
    frame_ms: list[float]
    setup_ms: float
    gpu_bytes: int
    host_bytes: int
    wrong_percent: float
    edge_pixels: int = 0

    @property
    def median_ms(self) -> float:
        """Median frame time."""
        return float(np.median(self.frame_ms))


def _camera_for(labels: np.ndarray) -> Camera:
    """The bench's view of a grid: from above one corner, the whole grid in sight."""
    m = np.array(labels.shape, dtype=float)
    return Camera(position=tuple(m * (1.55, -0.55, 1.35)), focal_point=tuple(m / 2),
                  view_up=(0, 0, 1), view_angle=30.0)


def _run_scene(labels: np.ndarray, name: str, size: tuple[int, int], frames: int,
               rows: Sequence[str], offload: Offload) -> list[VoxelRow]:
    """Every row on one scene at one size, frames drawn in turn; wrong pixels per row."""
    camera = _camera_for(labels)
    plotters, setup, memory = {}, {}, {}
    try:
        for row in rows:
            pl = offscreen_plotter(size)
            pl.disable_anti_aliasing()
            pl.ren_win.SetMultiSamples(0)
            pl.set_background(BACKGROUND)
            start = time.perf_counter()
            memory[row] = ROWS[row](pl, labels)
            camera.apply_to(pl.camera)
            pl.renderer.ResetCameraClippingRange()
            render_frame(pl)
            setup[row] = (time.perf_counter() - start) * 1e3
            plotters[row] = pl
        # The CPU traversal first (on a cluster: in bands, waited for before any timing).
        near = plotters[rows[0]].camera.clipping_range[0]
        shot = Camera.from_pyvista(plotters[rows[0]].camera)
        hits = offload.banded(trace_voxels, size, labels, np.eye(4), shot, size,
                              near=near).result()
        # The first frame is drawn (shaders built, data uploaded): no more warm-up; rows of
        # seconds per frame (the fixed step at 1000x1000) stop after 3 s. Every frame is
        # timed as if the view turned (the brick shell's depth pass runs each frame).
        times = time_frames_side_by_side(plotters, frames, warmup=0, row_budget_ms=3000.0,
                                         camera_moves=True)
        # The unlit image: each hit's palette colour, the background elsewhere.
        reference = np.where(hits.material[..., None] > 0,
                             PALETTE[np.clip(hits.material, 0, len(PALETTE) - 1), :3],
                             np.asarray(BACKGROUND))
        results = []
        for row in rows:
            image = read_pixels(plotters[row]).astype(float) / 255.0
            differs = np.abs(image - reference).max(axis=-1) > WRONG
            gpu, host = memory[row]()
            results.append(VoxelRow(
                name, row, size, times[row], setup[row], gpu, host,
                100.0 * float((differs & ~hits.near_edge).mean()),
                int((differs & hits.near_edge).sum())))
        return results
    finally:
        for pl in plotters.values():
            pl.close()


def run_voxels(sizes: Sequence[Sequence[int]] = ((1000, 1000), (400, 400)), frames: int = 3,
               large: int = 256, rows: Sequence[str] = tuple(ROWS),
               only: Sequence[str] | None = None,
               progress_bar: bool | None = None,
               offload: Offload | None = None) -> list[VoxelRow]:
    """Time every row on every scene and size side by side; wrong pixels against the CPU.

    Parameters
    ----------
    sizes : sequence of (width, height)
        Image sizes; each scene is drawn at each.
    frames : int
        Timed frames per row (the median is reported).
    large : int
        Edge of the large empty and sphere grids (the voxel report's 256).
    rows : sequence of str
        Rows of :data:`ROWS` to run.
    only : sequence of str, optional
        Scene names of :func:`scenes` to run (all by default).
    progress_bar : bool, optional
        Show a progress bar (default: when attached to a terminal).
    offload : Offload, optional
        Where the CPU traversal runs: a Dask cluster's workers, in bands of rows
        (:mod:`pv_cubemarch.cluster.offload`), before the rows are timed. By default, here.
    """
    unknown = [r for r in rows if r not in ROWS]
    if unknown:
        raise ValueError(f"Unknown rows {unknown}; choose from {list(ROWS)}.")
    built = scenes(large)
    missing = [name for name in (only or ()) if name not in built]
    if missing:
        raise ValueError(f"Unknown scenes {missing}; choose from {list(built)}.")
    chosen = {k: v for k, v in built.items() if not only or k in only}
    sizes = [(int(w), int(h)) for w, h in sizes]
    steps = [(name, size) for name in chosen for size in sizes]
    results = []
    for name, size in progress(steps, desc="bench voxels", enabled=progress_bar):
        results += _run_scene(chosen[name], name, size, frames, list(rows),
                              offload or Offload())
    return results


def format_voxel_table(results: list[VoxelRow]) -> str:
    """Per size, scene and row: frame and setup time, ratio to plain DDA, bytes, wrong."""
    lines = [f"{'size':<10} {'scene':<18} {'row':<16} {'frame ms':>9} {'x dda':>6} "
             f"{'setup ms':>9} {'GPU MB':>8} {'host MB':>8} {'wrong %':>8} {'edge px':>7}",
             "-" * 108]
    for size, scene in dict.fromkeys((r.size, r.scene) for r in results):
        rows = [r for r in results if r.scene == scene and r.size == size]
        dda = next((r.median_ms for r in rows if r.row == "dda"), None)
        for r in rows:
            ratio = f"{r.median_ms / dda:6.2f}" if dda else "     -"
            lines.append(f"{size[0]}x{size[1]:<5} {scene:<18} {r.row:<16} {r.median_ms:9.1f} "
                         f"{ratio} {r.setup_ms:9.0f} {r.gpu_bytes / 1e6:8.2f} "
                         f"{r.host_bytes / 1e6:8.2f} {r.wrong_percent:8.3f} "
                         f"{r.edge_pixels:7d}")
    return "\n".join(lines)


#: The voxel report's published frame times (M1 Pro, 1000x1000): (its table, scene, row, ms).
SEED_TIMES = (
    [("1", scene, row, ms) for scene, fvta, fixed in
     (("sphere 128^3", 3, 10), ("waves 128x128x64", 4, 15), ("torus 128^3", 6, 17))
     for row, ms in (("dda", fvta), ("fixed 0.1", fixed))]
    + [("2", scene, row, ms) for scene, fvta, fixed in
       (("empty 128^3", 7, 25), ("empty 256^3", 19, 65), ("filled 128^3", 0.2, 0.2))
       for row, ms in (("dda", fvta), ("fixed 0.1", fixed))]
    + [("5", "empty 256^3", row, ms) for row, ms in
       (("fixed 0.1", 65), ("dda", 22), ("dda df 1", 14), ("dda df 2", 11), ("dda df 3", 10))]
    + [("6", "empty 256^3", row, ms) for row, ms in
       (("fixed 0.1", 65), ("dda", 22), ("dda mip 1", 12), ("dda mip 2", 7), ("dda mip 3", 5))]
)


def seed_ratios(results: list[VoxelRow], size: tuple[int, int]) -> list[dict]:
    """The voxel report's tables as speed-ups over plain DDA, the report's and ours side by side.

    Absolute times on a 16-core GPU and on llvmpipe do not compare; the speed-up of each
    row over the same scene's DDA does. Rows or scenes not run are left out.
    """
    ours = {(r.scene, r.row): r.median_ms for r in results if r.size == tuple(size)}
    # Each table against its own DDA time (the report's empty 256^3 is 19 ms in one table and
    # 22 ms in the two others).
    seed = {(table, scene, row): ms for table, scene, row, ms in SEED_TIMES}
    out = []
    for table, scene, row, ms in SEED_TIMES:
        if (scene, row) not in ours or (scene, "dda") not in ours:
            continue
        out.append(dict(table=table, scene=scene, row=row,
                        seed_speedup=seed[table, scene, "dda"] / ms,
                        our_speedup=ours[scene, "dda"] / ours[scene, row]))
    return out


def format_seed_ratios(results: list[VoxelRow], size: tuple[int, int]) -> str:
    """:func:`seed_ratios` as a table (speed-up over DDA: above 1 is faster)."""
    lines = [f"the voxel report's tables at {size[0]}x{size[1]}: speed-up over DDA on the "
             "same scene",
             f"{'table':<6} {'scene':<18} {'row':<12} {'seed':>7} {'ours':>7}", "-" * 54]
    for r in seed_ratios(results, size):
        lines.append(f"{r['table']:<6} {r['scene']:<18} {r['row']:<12} "
                     f"{r['seed_speedup']:7.2f} {r['our_speedup']:7.2f}")
    return "\n".join(lines)


def write_voxel_json(results: list[VoxelRow], path, meta: dict) -> None:
    """Every frame time and measure, and the voxel report's tables as ratios, for comparison."""
    rows = [dict(scene=r.scene, row=r.row, size=list(r.size), frame_ms=r.frame_ms,
                 setup_ms=r.setup_ms, gpu_bytes=r.gpu_bytes, host_bytes=r.host_bytes,
                 wrong_percent=r.wrong_percent, edge_pixels=r.edge_pixels) for r in results]
    sizes = list(dict.fromkeys(r.size for r in results))
    seed = {f"{w}x{h}": seed_ratios(results, (w, h)) for w, h in sizes}
    with open(path, "w") as handle:
        json.dump({"meta": meta, "results": rows, "seed_tables": seed}, handle, indent=2)
