"""``pv-cubemarch bench labels``: segmentations of many ids against what PyVista users have.

Scenes (fixed seeds): ``cells``, a Voronoi partition of an ``n``³ grid into ``cells`` cells
with uint32 ids scattered over their range (a cell segmentation); ``million``, 10^6 uint64
ids near 2^40 in a small grid (a fine watershed), and the same cells relabelled to 255 ids
(the frame-time comparison); ``frog``, PyVista's frog tissue segmentation (uint8, the real
file), subsampled by ``stride``. Rows: ours (default, and per option), ``threshold`` +
``add_mesh`` (cells coloured by id), ``contour_labels`` (surface nets), and VTK's fixed-step
volume ray cast of the labels. Measured in one run: setup to the first frame, later frames,
host and GPU bytes, wrong-id pixels against the CPU traversal
(:func:`~pv_cubemarch.reference.label_ids.trace_ids`), and the time and bytes to recolour
1 / 1000 / all ids and to hide half of them. A small segmentation is drawn once by each
tool first (:func:`warm_up`), so no row pays the process's first GL context and shaders.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import pyvista

from ..api import add_voxels
from ..core.camera import Camera
from ..core.progress import progress
from ..core.rendering import offscreen_plotter, read_pixels, render_frame
from ..models.voxels import fits_one_texture
from ..reference.label_ids import trace_ids

#: Scenes by name: what they hold.
SCENES = ("cells", "million", "frog")


def voronoi_ids(n: int, cells: int, seed: int, ids: np.ndarray) -> np.ndarray:
    """An ``n``³ grid split into the Voronoi cells of ``cells`` random seeds, cell k = ids[k].

    Made an x-slab at a time (memory: the labels and one slab's points), with empty space
    outside a ball of radius 0.48 n, as segmentations have.
    """
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(seed)
    sites = rng.random((cells, 3)) * n
    tree = cKDTree(sites)
    labels = np.zeros((n, n, n), ids.dtype)
    y, z = np.meshgrid(np.arange(n) + 0.5, np.arange(n) + 0.5, indexing="ij")
    inside_yz = (y - n / 2) ** 2 + (z - n / 2) ** 2
    slab = max(1, (1 << 21) // (n * n))
    for start in progress(range(0, n, slab), desc=f"Voronoi cells of {n}^3", enabled=None
                          if n >= 512 else False):
        x = np.arange(start, min(start + slab, n)) + 0.5
        points = np.empty((len(x), n, n, 3))
        points[..., 0] = x[:, None, None]
        points[..., 1] = y
        points[..., 2] = z
        owner = tree.query(points.reshape(-1, 3), workers=-1)[1].reshape(len(x), n, n)
        inside = (x[:, None, None] - n / 2) ** 2 + inside_yz <= (0.48 * n) ** 2
        labels[start:start + len(x)] = np.where(inside, ids[owner], 0)
    return labels


def scene_labels(scene: str, n: int, cells: int, stride: int) -> np.ndarray:
    """The labels of a scene (module docstring)."""
    rng = np.random.default_rng(7)
    if scene == "cells":
        ids = (rng.choice(2**32 - 2, cells, replace=False) + 1).astype(np.uint32)
        return voronoi_ids(n, cells, 11, ids)
    if scene == "million":
        ids = (2**40 + rng.choice(10**9, cells, replace=False)).astype(np.uint64)
        return voronoi_ids(n, cells, 12, ids)
    if scene == "frog":
        from pyvista import examples

        grid = pyvista.read(f"{examples.__path__[0]}/frog_tissues.vti")
        values = np.asarray(grid.point_data[grid.array_names[0]]).reshape(
            grid.dimensions, order="F")
        return np.ascontiguousarray(values[::stride, ::stride, ::stride])
    raise ValueError(f"scene must be one of {SCENES}, got {scene!r}.")


def to_255(labels: np.ndarray) -> np.ndarray:
    """The same cells with 255 ids (1..255 by rank), background kept: the frame comparison."""
    values, rank = np.unique(labels, return_inverse=True)
    rank = rank.reshape(labels.shape)
    out = (rank % 255 + 1).astype(np.uint8)
    out[labels == 0] = 0
    return out


@dataclass
class LabelRow:
    """One way of drawing one scene, and what it cost."""

    scene: str
    row: str
    ids: int
    voxels: int
    setup_s: float | None
    median_ms: float | None
    host_bytes: int | None
    gpu_bytes: int | None
    label_bytes_per_voxel: float | None
    wrong_id_pixels: int | None
    covered_pixels: int | None
    #: name -> {"ms": to the finished next frame, "bytes": uploaded}
    changes: dict = field(default_factory=dict)
    #: Why a row could not run (its tool refused the data), else empty.
    note: str = ""
    #: Bytes of labels, levels and distance field sent again by all the changes (ours).
    labels_resent_bytes: int | None = None


def _camera(shape, pl) -> Camera:
    n = np.asarray(shape, float)
    camera = Camera(position=tuple(n * np.array([1.6, -0.7, 1.3])), focal_point=tuple(n / 2),
                    view_up=(0, 0, 1), view_angle=35.0)
    camera.apply_to(pl.camera)
    pl.renderer.ResetCameraClippingRange()
    return Camera.from_pyvista(pl.camera)


def _frames(pl, frames: int) -> tuple[float, np.ndarray]:
    times, image = [], None
    for _ in range(frames):
        pl.camera.Modified()
        start = time.perf_counter()
        render_frame(pl)
        image = read_pixels(pl)
        times.append((time.perf_counter() - start) * 1e3)
    return float(np.median(times)), image


def _timed(pl, change: Callable[[], int | None], sent: Callable[[], int] | None = None
           ) -> dict:
    """Milliseconds from a change to the finished next frame, and the bytes it uploaded.

    ``change`` returns the bytes it will send, or ``sent`` (a counter read before and after
    the frame) tells them.
    """
    before = sent() if sent is not None else 0
    start = time.perf_counter()
    estimate = change()
    render_frame(pl)
    read_pixels(pl)
    elapsed = (time.perf_counter() - start) * 1e3
    return {"ms": elapsed, "bytes": int(sent() - before if sent is not None else estimate)}


def _plotter(size):
    pl = offscreen_plotter(size)
    pl.disable_anti_aliasing()
    pl.ren_win.SetMultiSamples(0)
    pl.set_background("black")
    return pl


def _wrong_ids(image: np.ndarray, present: np.ndarray, reference, camera, near
               ) -> tuple[int | None, int | None]:
    """Pixels whose label (read back from rank colours) is not the reference's, and hits.

    Pixels within the reference's tie tolerance of a voxel edge are not counted (either
    side is right there).
    """
    if reference is None:
        return None, None
    hits, hit = reference(camera, near)
    expected = np.zeros(image.shape, np.uint8)
    expected[hit] = _rank_colours(hits.material[hit], present)
    return (int((np.any(image != expected, axis=-1) & ~hits.near_edge).sum()),
            int(hit.sum()))


def _host_label_bytes(model) -> int:
    """Bytes of labels the host keeps: a grid's rows, or a world's stored chunks."""
    if hasattr(model, "stored"):
        return sum(int(chunk.nbytes) for chunk in model.stored.values())
    return int(model.labels.nbytes)


def _gpu_label_bytes(binding) -> int:
    """GPU bytes of labels and their levels: a grid's, a world's chunks' or its pool."""
    if hasattr(binding, "chunks"):
        return sum(int(chunk.labels.nbytes) for chunk in binding.chunks.values())
    return int(binding.pool.nbytes if hasattr(binding, "pool") else binding.labels.nbytes)


def ours(scene: str, labels: np.ndarray, size, frames: int, reference, row: str = "ours",
         **options) -> LabelRow:
    """add_voxels with ``options``: setup, frames, bytes, exactness and per-label changes.

    Drawn unlit (as the mesh rows); after the timed frames every label takes its rank as a
    24-bit colour through the per-label table, and the next frame is read back as ids and
    compared with the CPU traversal (any grid size, unlike ``mode='id'``).
    """
    pl = _plotter(size)
    try:
        start = time.perf_counter()
        actor = add_voxels(pl, labels, lighting=False, **options)
        camera = _camera(labels.shape, pl)
        render_frame(pl)
        read_pixels(pl)
        setup = time.perf_counter() - start
        median, _ = _frames(pl, frames)
        binding = actor.cubemarch
        model = binding.model
        ids = model.ids.ids if not model.ids.identity else np.unique(labels[labels > 0])
        wrong = covered = None
        if reference is not None:
            binding.set_label_color(ids, _rank_colours(ids, ids))
            render_frame(pl)
            wrong, covered = _wrong_ids(read_pixels(pl), ids, reference, camera,
                                        pl.camera.clipping_range[0])
        host = int(_host_label_bytes(model) + model.palette.rgba.nbytes
                   + (model.ids.ids.nbytes if not model.ids.identity else 0))
        gpu = int(binding.nbytes)
        rng = np.random.default_rng(0)
        palette = binding.palette_texture

        def sent():   # everything our textures send: palette, labels, levels
            return palette.uploaded_bytes + binding.uploaded_bytes

        labels_before = binding.uploaded_bytes
        changes = {}
        for name, count in (("recolour 1", 1), ("recolour 1000", 1000),
                            ("recolour all", len(ids))):
            if count <= len(ids):
                chosen = ids if count >= len(ids) else rng.choice(ids, count, replace=False)
                colours = rng.random((len(chosen), 3))
                changes[name] = _timed(
                    pl, lambda chosen=chosen, colours=colours: binding.set_label_color(
                        chosen, colours), sent)
        changes["hide half"] = _timed(pl, lambda: binding.hide_labels(ids[::2]), sent)
        return LabelRow(scene, row, int(len(ids)), int(labels.size), setup, median, host, gpu,
                        _gpu_label_bytes(binding) / labels.size, wrong, covered, changes,
                        labels_resent_bytes=int(binding.uploaded_bytes - labels_before))
    finally:
        pl.close()


def _image(labels: np.ndarray) -> pyvista.ImageData:
    grid = pyvista.ImageData(dimensions=np.array(labels.shape) + 1)
    grid.cell_data["labels"] = labels.ravel(order="F")
    return grid


def _rank_colours(values: np.ndarray, present: np.ndarray) -> np.ndarray:
    """Each value's rank among ``present`` (+1) as 24-bit RGB, for reading ids back."""
    rank = np.searchsorted(present, values) + 1
    return np.stack([rank & 255, (rank >> 8) & 255, (rank >> 16) & 255], -1).astype(np.uint8)


def threshold_mesh(scene: str, labels: np.ndarray, size, frames: int, reference) -> LabelRow:
    """PyVista's ``threshold`` + ``add_mesh``, each cell coloured by its id (as RGB, unlit)."""
    present = np.unique(labels[labels > 0])
    pl = _plotter(size)
    try:
        start = time.perf_counter()
        mesh = _image(labels).threshold(0.5, scalars="labels")
        cell_ids = np.asarray(mesh.cell_data["labels"])
        mesh.cell_data["rgb"] = _rank_colours(cell_ids, present)
        actor = pl.add_mesh(mesh, scalars="rgb", rgb=True, lighting=False,
                            show_scalar_bar=False)
        camera = _camera(labels.shape, pl)
        render_frame(pl)
        read_pixels(pl)
        setup = time.perf_counter() - start
        median, image = _frames(pl, frames)
        wrong, covered = _wrong_ids(image, present, reference, camera,
                                    pl.camera.clipping_range[0])
        host = int(mesh.actual_memory_size * 1024)
        rng = np.random.default_rng(0)
        colours = mesh.cell_data["rgb"]

        def recolour(count):
            chosen = present if count >= len(present) else rng.choice(present, count,
                                                                      replace=False)

            def change():
                where = np.isin(cell_ids, chosen)
                colours[where] = rng.integers(0, 256, (int(where.sum()), 3))
                mesh.cell_data["rgb"] = colours
                actor.mapper.Modified()
                return colours.nbytes   # the mapper sends every cell's colour again
            return change

        changes = {}
        for name, count in (("recolour 1", 1), ("recolour 1000", 1000),
                            ("recolour all", len(present))):
            if count <= len(present):
                changes[name] = _timed(pl, recolour(count))

        def hide_half():
            kept = mesh.extract_cells(np.flatnonzero(~np.isin(cell_ids, present[::2])))
            actor.mapper.SetInputData(kept)
            return kept.actual_memory_size * 1024

        changes["hide half"] = _timed(pl, hide_half)
        return LabelRow(scene, "threshold + add_mesh", int(len(present)), int(labels.size),
                        setup, median, host, None, None, wrong, covered, changes)
    finally:
        pl.close()


def contour_mesh(scene: str, labels: np.ndarray, size, frames: int,
                 boundary_style: str = "all") -> LabelRow:
    """PyVista's ``contour_labels`` (surface nets, smoothed as by default) + ``add_mesh``.

    ``'all'``: every label a closed surface (what hiding or making a label translucent
    needs); ``'external'`` (PyVista's default): only the surface facing the background.
    Ids VTK cannot take (its labels are C ints) are renumbered 1..n first, in the timing:
    the step a user of these ids must add.
    """
    pl = _plotter(size)
    count = int(len(np.unique(labels)) - 1)
    row = f"contour_labels('{boundary_style}') + add_mesh"
    try:
        start = time.perf_counter()
        info = np.iinfo(np.int32)
        renumbered = labels.min() < info.min or labels.max() > info.max
        if renumbered:
            _, ranks = np.unique(labels, return_inverse=True)
            grid_values = ranks.reshape(labels.shape).astype(np.int32)
            del ranks
        else:
            grid_values = labels
        renumbering = time.perf_counter() - start
        try:
            surface = _image(grid_values).contour_labels(boundary_style,
                                                         progress_bar=False)
        except (OverflowError, ValueError, TypeError, MemoryError) as error:
            return LabelRow(scene, row, count, int(labels.size), None, None, None, None, None,
                            None, None, note=f"fails: {type(error).__name__}: "
                            f"{str(error)[:60]}")
        pl.add_mesh(surface, lighting=False, show_scalar_bar=False)
        _camera(labels.shape, pl)
        render_frame(pl)
        read_pixels(pl)
        setup = time.perf_counter() - start
        median, _ = _frames(pl, frames)
        return LabelRow(scene, row, count, int(labels.size), setup, median,
                        int(surface.actual_memory_size * 1024), None, None, None, None,
                        note=f"ids renumbered 1..n first (VTK takes int labels): "
                        f"{renumbering:.2f} s of the setup" if renumbered else "")
    finally:
        pl.close()


def volume_cast(scene: str, labels: np.ndarray, size, frames: int) -> LabelRow:
    """VTK's GPU volume ray cast of the labels (nearest, a categorical table), fixed step."""
    pl = _plotter(size)
    try:
        start = time.perf_counter()
        grid = _image(labels.astype(np.float32))
        actor = pl.add_volume(grid, scalars="labels", cmap="tab20", opacity="linear",
                              mapper="gpu", show_scalar_bar=False)
        actor.mapper.SetAutoAdjustSampleDistances(False)
        actor.mapper.SetSampleDistance(0.5)
        _camera(labels.shape, pl)
        render_frame(pl)
        read_pixels(pl)
        setup = time.perf_counter() - start
        median, _ = _frames(pl, frames)
        return LabelRow(scene, "add_volume (fixed step 0.5)", int(len(np.unique(labels)) - 1),
                        int(labels.size), setup, median, int(grid.actual_memory_size * 1024),
                        int(labels.size * 4), 4.0, None, None)
    finally:
        pl.close()


def warm_up(size) -> None:
    """Draw a small segmentation once with each tool before any timed row.

    What a process pays once (the GL context, the first shaders, imports, thread pools)
    would otherwise land in whichever row runs first.
    """
    labels = voronoi_ids(16, 20, 3, np.arange(1, 21, dtype=np.uint32) * 7919)
    for draw in (lambda pl: add_voxels(pl, labels, lighting=False),
                 lambda pl: pl.add_mesh(_image(labels).threshold(0.5, scalars="labels"),
                                        lighting=False, show_scalar_bar=False),
                 lambda pl: pl.add_mesh(_image(labels).contour_labels(progress_bar=False),
                                        lighting=False, show_scalar_bar=False)):
        pl = _plotter(size)
        try:
            draw(pl)
            _camera(labels.shape, pl)
            render_frame(pl)
            read_pixels(pl)
        finally:
            pl.close()


def run_labels(scenes: Sequence[str] = SCENES, size=(1000, 1000), n: int = 128,
               cells: int = 20000, million: int = 10**6, million_n: int = 128,
               stride: int = 2, frames: int = 3, reference: bool = True,
               pyvista_rows: bool = True) -> list[LabelRow]:
    """Every row of every scene, side by side in one run (module docstring)."""
    rows = []
    size = tuple(int(v) for v in size)
    warm_up(size)
    for scene in scenes:
        count = million if scene == "million" else cells
        labels = scene_labels(scene, million_n if scene == "million" else n, count, stride)
        check = None
        if reference:
            traced = {}

            def check(camera, near, labels=labels, traced=traced):
                key = (camera.position, camera.focal_point, round(float(near), 9))
                if key not in traced:   # rows of the same camera share one traversal
                    traced[key] = trace_ids(labels, np.eye(4), camera, size, near=near)
                return traced[key]
        rows.append(ours(scene, labels, size, frames, check))
        if fits_one_texture(labels.shape, np.uint8):   # else a world of chunks: its default
            rows.append(ours(scene, labels, size, frames, check, row="ours, mip_levels=0",
                             mip_levels=0))
            rows.append(ours(scene, labels, size, frames, check, row="ours, proxy='box'",
                             proxy="box"))
        if scene == "million":
            rows.append(ours(scene, to_255(labels), size, frames, None,
                             row="ours, same cells as 255 ids"))
        if pyvista_rows:
            rows.append(threshold_mesh(scene, labels, size, frames, check))
            for style in ("all", "external"):
                rows.append(contour_mesh(scene, labels, size, frames, style))
            rows.append(volume_cast(scene, labels, size, frames))
    return rows


def _number(value) -> str:
    return "-" if value is None else f"{value:.2f}"


def format_labels(rows: list[LabelRow]) -> str:
    """The rows as a text table, changes as ms / bytes."""
    names = ("recolour 1", "recolour 1000", "recolour all", "hide half")
    head = (f"{'scene':8} {'row':30} {'ids':>8} {'setup s':>8} {'frame ms':>9} "
            f"{'host MB':>8} {'GPU MB':>7} {'B/vox':>6} {'wrong':>6} "
            + " ".join(f"{n + ' ms/KB':>20}" for n in names))
    lines = [head]

    def mb(v):
        return f"{v / 2**20:.1f}" if v is not None else "-"

    for r in rows:
        cells = [f"{r.changes[n]['ms']:.0f}/{r.changes[n]['bytes'] / 1024:.1f}" if n in r.changes
                 else "-" for n in names]
        lines.append(
            f"{r.scene:8} {r.row:30} {r.ids:>8} {_number(r.setup_s):>8} "
            f"{_number(r.median_ms):>9} "
            f"{mb(r.host_bytes):>8} {mb(r.gpu_bytes):>7} "
            f"{_number(r.label_bytes_per_voxel):>6} "
            f"{r.wrong_id_pixels if r.wrong_id_pixels is not None else '-':>6} "
            + " ".join(f"{c:>20}" for c in cells) + (f"  {r.note}" if r.note else ""))
    return "\n".join(lines)
