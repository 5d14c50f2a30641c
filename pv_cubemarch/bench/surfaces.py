"""Polynomial surfaces: time against error, with anchors.

``pv-cubemarch bench surfaces``: three shapes (PyVista's shipped ``nut.ply`` mesh by its
signed distance, an analytic thin holey sphere, a sampled field of blobs) on grids of
``N``³ cells, each drawn by the full-domain march, by the active cells through their brick
index (``active``) and as cell boxes (``boxes``), at several ``steps``, by the exact root,
and by the tools users have today: PyVista's contour (flying edges) of the field resampled
at 1, 2 and 4 samples per cell, drawn as a mesh, and VTK's GPU isosurface blend mode at
half-cell steps. Rows of a shape and grid are drawn in turn; a
row that does not fit (the dense layout over :data:`MAX_DENSE_BYTES`, cell boxes past
:data:`MAX_BOX_GRID` cells a side, resampling past :data:`MAX_CONTOUR_SAMPLES`) is listed
as not run, with the reason. Per row: median frame time, preprocessing (build + first
frame), GPU bytes, the active-cell share, and accuracy against the CPU reference's first
roots: coverage IoU, depth error (cells) median / p95 / max over pixels both cover, and the
pixels whose depth lies more than half a cell behind the reference's (a later root taken).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyvista
from pyvista import examples as pyvista_examples

from ..api import add_surface
from ..cluster.offload import Offload
from ..core import vtk_classes as vtk
from ..core.camera import Camera
from ..core.progress import progress
from ..core.rendering import offscreen_plotter, read_depth, read_pixels, render_frame
from ..models.field_sources import mesh_field
from ..models.surface import SplineField, active_cells, interpolating_coefficients
from ..reference.surfaces import trace_surface
from .harness import time_frames_side_by_side

SHAPES = ("nut", "holey sphere", "blobs")
#: Resampling the field for flying edges stops at this many samples a side (memory).
MAX_CONTOUR_SAMPLES = 513
#: The full march's dense layout (27 floats a cell) is run up to this many bytes.
MAX_DENSE_BYTES = 1 << 30
#: Cell boxes (traversal='cell_boxes') are drawn up to grids of this many cells a side.
MAX_BOX_GRID = 128
#: A row's frames stop once they add up to this (a frame of seconds varies little).
ROW_BUDGET_MS = 20_000.0


@dataclass
class SurfaceRow:
    """One shape, grid and row: times, bytes and errors against the reference."""

    shape: str
    cells: int
    row: str
    frame_ms: list[float]
    setup_ms: float
    gpu_bytes: int
    active_share: float | None
    iou: float
    depth_median: float | None
    depth_p95: float | None
    depth_max: float | None
    later_root_pixels: int | None
    extra: dict = field(default_factory=dict)
    #: Why the row was not run (its other fields are empty), or None.
    not_run: str | None = None

    @property
    def median_ms(self) -> float | None:
        """Median frame time (None: not run)."""
        return float(np.median(self.frame_ms)) if self.frame_ms else None


def shape_field(name: str, cells: int, progress_bar: bool | None = None) -> SplineField:
    """The field of shape ``name`` on about ``cells``³ cells (deterministic)."""
    if name == "nut":
        mesh = pyvista.read(Path(pyvista_examples.__file__).parent / "nut.ply")
        return mesh_field(mesh, cells - 4, progress_bar=progress_bar, name=name)
    if name not in SHAPES:
        raise ValueError(f"shape must be one of {SHAPES}, got {name!r}.")
    n = int(cells)
    axis = (np.arange(n) + 0.5) / n * 2.0 - 1.0   # cell centres in [-1, 1]
    values = np.empty((n, n, n))
    for k in range(n):   # a slab at a time: 512³ centres at once would take gigabytes
        x, y = np.meshgrid(axis, axis, indexing="ij")
        values[:, :, k] = _analytic(name, x, y, np.full_like(x, axis[k]))
    grid_from_index = np.diag([2.0 / n, 2.0 / n, 2.0 / n, 1.0])
    grid_from_index[:3, 3] = -1.0
    return SplineField(interpolating_coefficients(values), grid_from_index, name=name)


def _analytic(name: str, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The analytic shapes' fields at points of [-1, 1]³ (positive inside)."""
    if name == "holey sphere":
        # A shell of radius 0.7, 0.03 thick (2 cells at 128), with six round holes along
        # the axes: min(shell, outside every hole), a distance in domain units.
        shell = 0.015 - np.abs(np.sqrt(x * x + y * y + z * z) - 0.7)
        holes = np.minimum(np.minimum(np.hypot(y, z), np.hypot(x, z)), np.hypot(x, y)) - 0.25
        return np.minimum(shell, holes)
    rng = np.random.default_rng(3)   # blobs
    where = rng.uniform(-0.6, 0.6, (12, 3))
    return sum(np.exp(-((x - w[0]) ** 2 + (y - w[1]) ** 2 + (z - w[2]) ** 2) / 0.03)
               for w in where) - 0.4


def _camera(surface: SplineField) -> Camera:
    """From a corner above, the whole domain in sight."""
    lower, upper = (np.asarray(surface.world_bounds()).reshape(3, 2).T)
    centre, size = (lower + upper) / 2, float(np.linalg.norm(upper - lower))
    return Camera(position=tuple(centre + size * np.array([0.75, -0.55, 0.5])),
                  focal_point=tuple(centre), view_up=(0, 0, 1), view_angle=35.0)


def _plotter(size: Sequence[int]) -> pyvista.Plotter:
    pl = offscreen_plotter(tuple(size))
    pl.disable_anti_aliasing()
    pl.ren_win.SetMultiSamples(0)
    pl.set_background("black")
    return pl


def _samples(surface: SplineField, per_cell: int) -> pyvista.ImageData:
    """The field at ``per_cell`` samples per cell edge (corners included), as an ImageData."""
    values = surface.on_lattice(per_cell).astype(np.float32)
    matrix = surface.world_from_index()
    grid = pyvista.ImageData(dimensions=values.shape,
                             spacing=tuple(np.diag(matrix)[:3] / per_cell),
                             origin=tuple(matrix[:3, 3]))
    grid.point_data["f"] = values.ravel(order="F")
    return grid


def _vtk_isosurface(pl: pyvista.Plotter, surface: SplineField) -> int:
    """VTK's GPU isosurface blend mode on the field at the cell centres, half-cell steps."""
    values = surface.on_lattice(1, centred=True).astype(np.float32)
    matrix = surface.world_from_index()
    spacing = np.diag(matrix)[:3]
    image = pyvista.ImageData(dimensions=values.shape, spacing=tuple(spacing),
                              origin=tuple(matrix[:3, 3] + spacing / 2))
    image.point_data["f"] = values.ravel(order="F")
    mapper = vtk.vtkOpenGLGPUVolumeRayCastMapper()
    mapper.SetInputData(image)
    mapper.SetBlendModeToIsoSurface()
    mapper.AutoAdjustSampleDistancesOff()
    mapper.SetSampleDistance(float(spacing.min()) / 2)
    prop = vtk.vtkVolumeProperty()
    color = vtk.vtkColorTransferFunction()
    color.AddRGBPoint(float(values.min()), 1.0, 1.0, 1.0)
    color.AddRGBPoint(float(values.max()), 1.0, 1.0, 1.0)
    opacity = vtk.vtkPiecewiseFunction()
    opacity.AddPoint(float(values.min()), 1.0)
    opacity.AddPoint(float(values.max()), 1.0)
    prop.SetColor(color)
    prop.SetScalarOpacity(opacity)
    prop.GetIsoSurfaceValues().SetValue(0, 0.0)
    volume = vtk.vtkVolume()
    volume.SetMapper(mapper)
    volume.SetProperty(prop)
    pl.add_actor(volume, reset_camera=False)
    return int(values.nbytes)   # float32 on the GPU


def _rows(steps: Sequence[int], cells: int) -> dict:
    """Row name to how it is drawn: ``('surface', options)``, an anchor, or a reason not to."""
    rows: dict = {}
    dense = 27 * 4 * cells ** 3
    for m in steps:
        rows[f"full M={m}"] = ("surface", {"technique": "full", "steps": m}) \
            if dense <= MAX_DENSE_BYTES else ("not run", f"dense layout {dense / 1e9:.1f} GB")
    for m in steps:
        rows[f"active M={m}"] = ("surface", {"technique": "active", "steps": m})
    rows["active exact"] = ("surface", {"technique": "active", "root": "exact", "steps": 1})
    for m in steps:
        rows[f"boxes M={m}"] = ("surface", {"traversal": "cell_boxes", "steps": m}) \
            if cells <= MAX_BOX_GRID else ("not run", f"cell boxes past {MAX_BOX_GRID}³")
    for k in (1, 2, 4):
        rows[f"contour {k}/cell"] = ("contour", k) if cells * k + 1 <= MAX_CONTOUR_SAMPLES \
            else ("not run", f"{cells * k + 1}³ samples")
    rows["vtk isosurface"] = ("vtk", None)
    return rows


def _draw(size, camera: Camera, surface: SplineField, how) -> tuple:
    """A plotter showing the row: ``(plotter, setup ms, GPU bytes, active share)``."""
    pl = _plotter(size)
    start = time.perf_counter()
    share, nbytes = None, 0
    kind, setting = how
    if kind == "surface":
        actor = add_surface(pl, surface, **{"shading": "unlit", "color": "white",
                                            "refine_steps": 10, **setting})
        nbytes = actor.cubemarch.nbytes
        if actor.cubemarch.cells is not None:
            share = len(actor.cubemarch.cells) / float(np.prod(surface.dimensions))
    elif kind == "contour":
        mesh = _samples(surface, setting).contour([0.0], scalars="f", method="flying_edges")
        if mesh.n_points:   # a feature thinner than the samples leaves no triangle
            pl.add_mesh(mesh, color="white", lighting=False)
        nbytes = int(mesh.n_points * 12 + mesh.n_cells * 12)
    else:
        nbytes = _vtk_isosurface(pl, surface)
    camera.apply_to(pl.camera)
    pl.renderer.ResetCameraClippingRange()
    render_frame(pl)
    read_pixels(pl)
    return pl, (time.perf_counter() - start) * 1e3, nbytes, share


def _errors(pl: pyvista.Plotter, surface: SplineField, hits, cell: float) -> tuple:
    """Coverage IoU, depth error (cells) median / p95 / max, later-root pixels."""
    covered = read_pixels(pl).max(axis=-1) > 127
    sure = ~hits.ambiguous
    union = ((covered | hits.hit) & sure).sum()
    iou = float(((covered & hits.hit) & sure).sum() / max(union, 1))
    near, far = pl.camera.clipping_range
    depth = read_depth(pl)
    both = covered & hits.hit & sure & (depth < 1.0)
    if not both.any():
        return iou, None, None, None, None
    camera = Camera.from_pyvista(pl.camera)
    forward = np.subtract(camera.focal_point, camera.position)
    forward /= np.linalg.norm(forward)
    z_ref = (hits.point[both] - camera.position) @ forward
    z_got = far * near / (far - depth[both] * (far - near))
    error = (z_got - z_ref) / cell
    return (iou, float(np.median(np.abs(error))), float(np.percentile(np.abs(error), 95)),
            float(np.abs(error).max()), int((error > 0.5).sum()))


def normal_angles(image: np.ndarray, hits, camera: Camera) -> np.ndarray:
    """Degrees between the normals an image of ``shading='normals'`` shows and the reference's.

    Per pixel the reference hits and the image covers (away from tangents): the image's
    colour ``0.5 + 0.5 n`` back to a view-space ``n``, against the reference's world normal
    turned toward the eye and taken to view space. 8-bit colours resolve about 0.3 degrees.
    """
    forward = np.subtract(camera.focal_point, camera.position)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, camera.view_up)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    sure = hits.hit & ~hits.ambiguous & (image.max(axis=-1) > 0)
    normal = hits.normal[sure]
    toward_eye = np.asarray(camera.position) - hits.point[sure]
    normal = np.where((np.sum(normal * toward_eye, axis=1) < 0)[:, None], -normal, normal)
    expected = normal @ np.stack([right, up, -forward], axis=1)
    shown = image[sure][:, :3].astype(np.float64) / 255.0 * 2.0 - 1.0
    shown /= np.maximum(np.linalg.norm(shown, axis=1, keepdims=True), 1e-12)
    return np.degrees(np.arccos(np.clip(np.sum(shown * expected, axis=1), -1.0, 1.0)))


def _normal_errors(size, camera: Camera, surface: SplineField, setting: dict,
                   hits) -> tuple[float, float] | None:
    """Median and p95 degrees off the reference's normals, from a frame of the normals."""
    pl, *_ = _draw(size, camera, surface, ("surface", {**setting, "shading": "normals"}))
    try:
        angles = normal_angles(read_pixels(pl), hits, Camera.from_pyvista(pl.camera))
    finally:
        pl.close()
    if not len(angles):
        return None
    return float(np.median(angles)), float(np.percentile(angles, 95))


def _depth_quantum(pl: pyvista.Plotter, hits, cell: float) -> tuple[float, float] | None:
    """One step of a 24-bit depth buffer at the reference's hits, in cells (median, max).

    Depth errors are read back through the depth buffer: errors of this size are its
    resolution, not the technique's.
    """
    if not hits.hit.any():
        return None
    near, far = pl.camera.clipping_range
    camera = Camera.from_pyvista(pl.camera)
    forward = np.subtract(camera.focal_point, camera.position)
    forward /= np.linalg.norm(forward)
    z = (hits.point[hits.hit] - camera.position) @ forward
    step = z * z * (far - near) / (far * near) / float(1 << 24) / cell
    return float(np.median(step)), float(step.max())


def run_surfaces(size: Sequence[int] = (720, 720), grids: Sequence[int] = (32, 128),
                 steps: Sequence[int] = (50, 500, 5000), shapes: Sequence[str] = SHAPES,
                 frames: int = 3, progress_bar: bool | None = None,
                 offload: Offload | None = None) -> list[SurfaceRow]:
    """Every row on every shape and grid, rows of one shape and grid drawn in turn.

    ``offload``: where the CPU reference's roots are found (a Dask cluster's workers, in
    bands of rows, before the rows are timed; :mod:`pv_cubemarch.cluster.offload`).
    """
    size = tuple(int(v) for v in size)
    offload = offload or Offload()
    results = []
    cases = [(s, int(n)) for s in shapes for n in grids]
    for shape, cells in progress(cases, total=len(cases), desc="surfaces",
                                 enabled=progress_bar):
        surface = shape_field(shape, cells, progress_bar)
        camera = _camera(surface)
        cell = float(np.linalg.norm(surface.world_from_index()[:3, 0]))
        plotters, drawn = {}, {}
        skipped = []
        try:
            rows = _rows(steps, cells)
            for row, how in rows.items():
                if how[0] == "not run":
                    skipped.append(SurfaceRow(shape, cells, row, [], 0.0, 0, None, 0.0, None,
                                              None, None, None, not_run=how[1]))
                    continue
                plotters[row], *drawn[row] = _draw(size, camera, surface, how)
            first = next(iter(plotters.values()))
            hits = offload.banded(trace_surface, size, surface, active_cells(surface),
                                  Camera.from_pyvista(first.camera), size,
                                  near=first.camera.clipping_range[0]).result()
            times = time_frames_side_by_side(plotters, frames, warmup=0,
                                             row_budget_ms=ROW_BUDGET_MS)
            quantum = _depth_quantum(first, hits, cell)
            for row, pl in plotters.items():   # each window keeps its last frame
                setup, nbytes, share = drawn[row]
                extra = {"depth_quantum_cells": quantum}
                how = rows[row]
                if how[0] == "surface":   # drawn again showing its normals, not timed
                    extra["normal_degrees"] = _normal_errors(size, camera, surface, how[1],
                                                             hits)
                results.append(SurfaceRow(shape, cells, row, times[row], setup, nbytes, share,
                                          *_errors(pl, surface, hits, cell), extra=extra))
            results.extend(skipped)
        finally:
            for pl in plotters.values():
                pl.close()
    return results


def format_surfaces(results: list[SurfaceRow]) -> str:
    """The rows as a text table; ``x full``: the full march's time (same M) over the row's."""
    full = {(r.shape, r.cells, r.row.split()[-1]): r.median_ms for r in results
            if r.row.startswith("full") and r.not_run is None}
    lines = ["shape          cells  row               frame ms   x full  setup ms   GPU MB"
             "  active %     IoU  depth med   p95     max  later  normal° med/p95", "-" * 135]
    for r in results:
        if r.not_run is not None:
            lines.append(f"{r.shape:14s} {r.cells:5d}  {r.row:16s} not run: {r.not_run}")
            continue
        speedup = full.get((r.shape, r.cells, r.row.split()[-1])) if r.row.startswith(
            ("active M", "boxes M")) else None
        share = None if r.active_share is None else 100 * r.active_share
        lines.append(
            f"{r.shape:14s} {r.cells:5d}  {r.row:16s} {r.median_ms:9.1f} "
            f"{_number(speedup and speedup / r.median_ms, '8.1f'):>8s} {r.setup_ms:9.0f} "
            f"{r.gpu_bytes / 1e6:8.2f} {_number(share, '8.2f'):>9s} {r.iou:7.4f} "
            f"{_number(r.depth_median, '9.5f'):>10s} {_number(r.depth_p95, '7.4f'):>7s} "
            f"{_number(r.depth_max, '7.3f'):>7s} {_number(r.later_root_pixels, 'd'):>6s}"
            f"  {_degrees(r.extra.get('normal_degrees')):>15s}")
    quanta = {(r.shape, r.cells): r.extra["depth_quantum_cells"] for r in results
              if r.extra.get("depth_quantum_cells")}
    for (shape, cells), quantum in quanta.items():
        if quantum:
            lines.append(f"{shape} {cells}³: one depth-buffer step (24 bits) at the hits is "
                         f"{quantum[0]:.1e} cell (median), {quantum[1]:.1e} (max)")
    return "\n".join(lines)


def _degrees(pair) -> str:
    """``median/p95`` degrees, or ``-``."""
    return "-" if not pair else f"{pair[0]:.2f}/{pair[1]:.2f}"


def _number(value, form: str) -> str:
    """``value`` formatted, or ``-`` for none."""
    return "-" if value is None else format(value, form)
