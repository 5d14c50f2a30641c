"""``pv-cubemarch bench outofcore``: multiscale volumes streamed by bricks, in a budget.

Scenes: ``procedural`` (by default 16384 x 16384 x 4096 uint16, 2 TiB, every level's
points computed on demand from a seeded field of a few octaves of separable waves, so
nothing is stored), ``procedural-dense`` (the same field under a transfer function that
stops rays within a few points: most bricks behind are hidden), ``procedural-small``
(the same field, 384³: small enough to draw whole in memory, the image every row is
compared with), and ``smoke`` (the shipped smoke
density written by :func:`~pv_cubemarch.build_pyramid` to an OME-Zarr store, then read
back). Views: far, mid and close. Rows: ours (``lod_bias`` 0), ours without culling the
bricks behind where the rays stop, ours with the finest level everywhere
(``lod_bias=-30``), the coarsest level only (what napari draws of a pyramid in 3D), and
the whole array in memory (``add_volume(technique='direct')``) where it fits.
Measured in one run, after a small pyramid was drawn once both ways (:func:`_warm_up`):
time to the first frame and to converged, frames while streaming and
their longest, bytes read against the bytes of the bricks the view finally holds, peak
host RSS over the run, GPU bytes, and PSNR against the in-memory image.
"""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pyvista

from ..api import add_volume
from ..core.rendering import offscreen_plotter, render_frame
from ..models.multiscale import MultiscaleSource, multiscale_source
from ..models.pyramid import build_pyramid
from .outofcore_labels import LABEL_SCENES, label_rows
from .outofcore_rows import (
    OutOfCoreRow,
    halved_pyramid,
    separable_waves,
    stream_row,
    wave_octaves,
    whole_row,
)

SCENES = ("procedural", "procedural-dense", "procedural-small", "smoke", *LABEL_SCENES)
VIEWS = ("far", "mid", "close")
#: The transfer function every row draws with (data units of the uint16 field).
KEYWORDS = dict(cmap="magma", clim=(20000.0, 60000.0), opacity="sigmoid")
#: ``procedural-dense``'s: opacity 0.43 per point at the field's mean, 32768.
DENSE = dict(cmap="bone", clim=(20000.0, 50000.0), opacity="linear")


class WaveLevel:
    """One level of the procedural field: points computed when sliced, never stored.

    The field at finest-level point ``p``: ``32768 + sum_k a_k sin(f_k . p + phi_k)``
    factored per axis (each octave a product of three 1D waves), uint16. A level's point
    ``i`` sits at finest point ``(i + 0.5) 2^L - 0.5``, as the block centres of a 2x
    pyramid.
    """

    def __init__(self, shape, level: int, seed: int = 0, octaves: int = 5):
        self.shape = tuple(int(n) for n in shape)
        self.dtype = np.dtype(np.uint16)
        self.ndim = 3
        self.level = int(level)
        self.waves = wave_octaves(9000.0, 1.7, (0.004, 0.012), octaves, seed)

    def __getitem__(self, box):
        box = tuple(slice(*s.indices(n)) for s, n in zip(box, self.shape, strict=True))
        factor = 2.0 ** self.level
        axes = [(np.arange(s.start, s.stop, s.step) + 0.5) * factor - 0.5 for s in box]
        values = 32768.0 + separable_waves(self.waves, axes)
        return np.clip(values, 0, 65535).astype(np.uint16)


def wave_source(shape, coarsest: int = 256, seed: int = 0) -> MultiscaleSource:
    """The procedural field's pyramid: levels halved until the largest side is ``coarsest``."""
    return halved_pyramid(lambda size, number: WaveLevel(size, number, seed), shape,
                          coarsest, "waves")


def smoke_pyramid(directory: Path) -> Path:
    """The shipped smoke density written as an OME-Zarr pyramid (uint16 over its range)."""
    grid = pyvista.read(Path(__file__).resolve().parents[2] / "datasets" / "smoke_density.vti")
    values = np.asarray(grid.point_data["density"]).reshape(grid.dimensions, order="F")
    scaled = (values - values.min()) / max(float(np.ptp(values)), 1e-30) * 65535
    path = directory / "smoke.ome.zarr"
    build_pyramid(scaled.astype(np.uint16), path, chunk_size=16, scale=grid.spacing,
                  translation=grid.origin, progress_bar=False, overwrite=True)
    return path


def _in_memory_row(scene, view, source, extent, size, keywords
                   ) -> tuple[OutOfCoreRow, np.ndarray]:
    """The finest level read whole and drawn by the direct marcher: the reference image."""
    def draw(pl):
        finest = source.levels[0]
        values = finest.read(tuple(slice(0, n) for n in finest.shape))
        grid = pyvista.ImageData(dimensions=values.shape, spacing=tuple(finest.scale),
                                 origin=tuple(finest.translation))
        grid.point_data["values"] = values.ravel(order="F")
        return add_volume(pl, grid, technique="direct", **keywords), values.nbytes

    return whole_row(scene, view, extent, size, draw)


def _warm_up(size) -> None:
    """Draw a small pyramid streamed and whole once before any timed row.

    What a process pays once (the GL context, the shaders' first compilation) would
    otherwise land in whichever row runs first.
    """
    source = wave_source((40, 40, 40), coarsest=16)
    for draw in (lambda pl: add_volume(pl, source, **KEYWORDS),
                 lambda pl: add_volume(pl, source.levels[0].read((slice(0, 40),) * 3),
                                       technique="direct", **KEYWORDS)):
        pl = offscreen_plotter(size)
        try:
            draw(pl)
            render_frame(pl)
        finally:
            pl.close()


def run_outofcore(scenes: Sequence[str] = SCENES, views: Sequence[str] = VIEWS,
                  size=(320, 240), shape=(16384, 16384, 4096), small: int = 384,
                  gpu_bytes: int = 256 * 2**20, host_bytes: int = 512 * 2**20,
                  timeout: float = 120.0) -> list[OutOfCoreRow]:
    """Every row of every scene and view, side by side in one run (module docstring)."""
    rows = []
    size = tuple(int(v) for v in size)
    _warm_up(size)
    scratch = Path(tempfile.mkdtemp(prefix="cubemarch-outofcore-"))
    try:
        for scene in scenes:
            if scene in LABEL_SCENES:
                rows += label_rows(scene, views, size, shape, small, gpu_bytes, host_bytes,
                                   timeout)
                continue
            keywords = DENSE if scene == "procedural-dense" else KEYWORDS
            if scene in ("procedural", "procedural-dense"):
                source = wave_source(shape)
            elif scene == "procedural-small":
                source = wave_source((small,) * 3, coarsest=48)
            elif scene == "smoke":
                source = multiscale_source(str(smoke_pyramid(scratch)))
            else:
                raise ValueError(f"scene must be one of {SCENES}, got {scene!r}.")
            finest = source.levels[0]
            extent = (np.asarray(finest.shape) - 1) * finest.scale + finest.translation
            fits = source.nbytes * 4 <= 2 * 2**30   # float32 in memory, and its texture
            for view in views:
                expected = None
                if fits:
                    row, expected = _in_memory_row(scene, view, source, extent, size,
                                                   keywords)
                    rows.append(row)
                for name, bias, cull in (("ours", 0.0, True), ("ours, no hidden culling",
                                                                0.0, False),
                                         ("ours, finest everywhere", -30.0, True),
                                         ("coarsest level only", 64.0, True)):
                    if bias < -1 and not fits:
                        continue   # the finest level over a whole 2 TiB view: no reference
                    def add(pl, bias=bias, source=source, cull=cull, keywords=keywords):
                        actor = add_volume(pl, source, lod_bias=bias, gpu_bytes=gpu_bytes,
                                           host_bytes=host_bytes, **keywords)
                        # off: its pager keeps no depth, so the depth pass never runs
                        actor.cubemarch.pager.cull_hidden &= cull
                        return actor

                    rows.append(stream_row(scene, view, name, add, source, extent, size,
                                           timeout, expected)[0])
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return rows


def _number(value, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def format_outofcore(rows: list[OutOfCoreRow]) -> str:
    """The rows as a text table."""
    head = (f"{'scene':17} {'view':5} {'row':24} {'first s':>8} {'conv. s':>8} {'frames':>6} "
            f"{'max ms':>8} {'read MB':>9} {'held MB':>8} {'RSS MB':>7} {'GPU MB':>7} "
            f"{'PSNR':>6} {'wrong%':>6}")
    lines = [head]
    for r in rows:
        read = None if r.bytes_read is None else r.bytes_read / 2**20
        held = None if r.held_brick_bytes is None else r.held_brick_bytes / 2**20
        lines.append(
            f"{r.scene:17} {r.view:5} {r.row:24} {_number(r.first_frame_s):>8} "
            f"{_number(r.converged_s):>8} {r.frames:>6} {_number(r.longest_frame_ms, 0):>8} "
            f"{_number(read, 1):>9} {_number(held, 1):>8} {_number(r.peak_rss_mb, 0):>7} "
            f"{_number(r.gpu_mb, 1):>7} {_number(r.psnr_db, 1):>6} "
            f"{_number(r.wrong_percent, 2):>6}"
            + (f"  {r.note}" if r.note else ""))
    return "\n".join(lines)
