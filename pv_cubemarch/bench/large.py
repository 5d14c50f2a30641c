"""``pv-cubemarch bench voxel-large``: volumes larger than any one texture, sparse.

``labels``: a 2048 x 2048 x 512 uint8 grid (``scale`` shrinks it, for tests) that is 99.7 %
empty: 20 balls of 5 materials, a one-voxel-thick plane and a one-voxel-thin wall, as a
segmentation of that size would be; ``add_voxels`` draws it in chunks by itself (too many
bytes for one texture), and the frame is compared with the CPU traversal of the whole grid.
``terrain``: a 4096 x 4096 x 256 FBM terrain (4.3 G voxels) made chunk by chunk
(:meth:`~pv_cubemarch.models.world.VoxelWorld.from_function`: never one array), chunks of
128; too large for the CPU traversal, so not compared (the chunk tests are). Reported:
setup, the first and later frames, GPU and host bytes in all and per filled voxel.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..api import add_voxels
from ..core.camera import Camera
from ..core.rendering import offscreen_plotter, read_pixels, render_frame
from ..models.procedural import terrain
from ..models.world import VoxelWorld
from ..reference.voxels import trace_voxels
from ..voxels.indexed_world import IndexedWorldBinding

SHAPE = (2048, 2048, 512)
PALETTE = np.array([[0, 0, 0], [0.9, 0.1, 0.1], [0.1, 0.7, 0.1], [0.1, 0.2, 0.9],
                    [0.9, 0.8, 0.1], [0.7, 0.1, 0.8]])
BACKGROUND = (1.0, 1.0, 1.0)


def sparse_labels(scale: float = 1.0, seed: int = 0) -> np.ndarray:
    """The volume: balls of radius 20-60 voxels, a plane at 400 and a wall at 1500 (scaled)."""
    shape = tuple(max(8, int(n * scale)) for n in SHAPE)
    rng = np.random.default_rng(seed)
    labels = np.zeros(shape, np.uint8)
    for number in range(20):
        radius = max(2, int(rng.integers(20, 61) * scale))
        center = [int(rng.integers(radius, n - radius)) for n in shape]
        box = tuple(slice(c - radius, c + radius + 1) for c in center)
        x, y, z = np.ogrid[box]
        ball = (x - center[0]) ** 2 + (y - center[1]) ** 2 + (z - center[2]) ** 2 <= radius ** 2
        labels[box][ball] = 1 + number % 5
    nx, ny, nz = shape
    labels[nx // 8:nx // 2, ny // 8:ny // 2, int(nz * 400 / 512)] = 2     # a plane, 1 thick
    labels[int(nx * 1500 / 2048), ny // 4:3 * ny // 4, :nz // 2] = 4      # a wall, 1 thin
    return labels


@dataclass
class LargeResult:
    """One run: shape, chunks, times, bytes and wrong pixels."""

    shape: tuple[int, int, int]
    filled_voxels: int
    chunks_stored: int
    chunks_uniform: int
    setup_s: float
    first_frame_s: float
    frame_ms: float
    gpu_bytes: int
    host_bytes: int
    covered_pixels: int
    wrong_pixels: int | None
    #: How the world was drawn: ``'index'``, ``'per_chunk'`` or ``'one grid'``.
    drawn_as: str = "one grid"


#: The terrain scene's full size and chunk edge.
TERRAIN_SHAPE = (4096, 4096, 256)
TERRAIN_CHUNK = 128


def terrain_world(scale: float = 1.0, progress_bar: bool | None = None) -> VoxelWorld:
    """The terrain scene as a world filled chunk by chunk.

    Its surface lies in the lower half (a gentle relief), so the upper chunks are empty.
    """
    shape = tuple(max(8, int(n * scale)) for n in TERRAIN_SHAPE)
    chunk = max(8, int(TERRAIN_CHUNK * scale))
    return VoxelWorld.from_function(
        shape, chunk, lambda box: terrain(shape, feature_size=shape[0] / 16, seed=5,
                                          ground=0.25, relief=0.1, region=box),
        palette=PALETTE[:4], progress_bar=progress_bar, name="terrain")


def run_large(size: Sequence[int] = (800, 600), scale: float = 1.0, frames: int = 3,
              reference: bool = True, scene: str = "labels",
              progress_bar: bool | None = None,
              world_traversal: str | None = None) -> LargeResult:
    """Draw a scene (``'labels'`` or ``'terrain'``) with the defaults and measure it.

    The ``labels`` frame is compared with the CPU traversal when ``reference``;
    ``world_traversal`` forces how the chunks are drawn (None: the default choice).
    """
    if scene not in ("labels", "terrain"):
        raise ValueError(f"scene must be 'labels' or 'terrain', got {scene!r}.")
    size = tuple(int(v) for v in size)
    start = time.perf_counter()
    if scene == "labels":
        labels = sparse_labels(scale)
    else:
        labels = terrain_world(scale, progress_bar)
        reference = False
    made = time.perf_counter() - start
    pl = offscreen_plotter(size)
    try:
        pl.disable_anti_aliasing()
        pl.ren_win.SetMultiSamples(0)
        pl.set_background(BACKGROUND)
        start = time.perf_counter()
        colors = {"palette": PALETTE} if scene == "labels" else {}   # a world has its own
        actor = add_voxels(pl, labels, shading="unlit", world_traversal=world_traversal,
                           **colors)
        n = np.array(labels.dimensions if scene == "terrain" else labels.shape, float)
        Camera(position=tuple(n * np.array([1.3, -0.4, 1.6])), focal_point=tuple(n / 2),
               view_up=(0, 0, 1), view_angle=40.0).apply_to(pl.camera)
        pl.renderer.ResetCameraClippingRange()
        setup = time.perf_counter() - start + made
        start = time.perf_counter()
        render_frame(pl)
        read_pixels(pl)
        first = time.perf_counter() - start
        times = []
        for _ in range(frames):
            pl.camera.Modified()
            start = time.perf_counter()
            pl.ren_win.Render()
            image = read_pixels(pl)
            times.append((time.perf_counter() - start) * 1e3)
        binding = actor.cubemarch
        world = binding.model
        chunked = isinstance(world, VoxelWorld)   # else drawn whole: one stored grid
        stored = len(world.stored) if chunked else 1
        uniform = len(world.uniform) if chunked else 0
        covered = wrong = None
        if reference:
            hits = trace_voxels(labels, np.eye(4), Camera.from_pyvista(pl.camera), size,
                                near=pl.camera.clipping_range[0])
            expected = np.where(hits.material[..., None] > 0, PALETTE[hits.material],
                                np.asarray(BACKGROUND))
            off = np.abs(image.astype(float) / 255.0 - expected).max(axis=-1) > 3.0 / 255.0
            covered, wrong = int((hits.material > 0).sum()), int((off & ~hits.near_edge).sum())
        filled = int(np.count_nonzero(labels)) if scene == "labels" else _filled(world)
        drawn_as = ("one grid" if not chunked else "index"
                    if isinstance(binding, IndexedWorldBinding) else "per_chunk")
        return LargeResult(tuple(int(v) for v in n), filled, stored, uniform,
                           setup, first, float(np.median(times)), int(binding.nbytes),
                           int(world.nbytes), covered or 0, wrong, drawn_as)
    finally:
        pl.close()


def _filled(world: VoxelWorld) -> int:
    """Filled voxels of a world: its stored chunks' and its uniform chunks' whole boxes."""
    return sum(int(np.count_nonzero(c)) for c in world.stored.values()) + sum(
        int(np.prod(world.chunk_box(key)[1])) for key in world.uniform)


def format_large(result: LargeResult) -> str:
    """The run as lines of text, bytes also per filled voxel."""
    r = result
    per = max(r.filled_voxels, 1)
    wrong = "not compared" if r.wrong_pixels is None else \
        f"{r.wrong_pixels} of {r.covered_pixels} covered pixels"
    return "\n".join([
        f"grid {'x'.join(map(str, r.shape))}: {r.filled_voxels:,} filled voxels "
        f"({100.0 * r.filled_voxels / np.prod(r.shape):.2f} %)",
        f"chunks: {r.chunks_stored} stored, {r.chunks_uniform} uniform, drawn {r.drawn_as}",
        f"setup {r.setup_s:.1f} s, first frame {r.first_frame_s:.1f} s, "
        f"later frames {r.frame_ms:.0f} ms",
        f"GPU {r.gpu_bytes / 2**20:.0f} MiB ({r.gpu_bytes / per:.1f} B per filled voxel), "
        f"host {r.host_bytes / 2**20:.0f} MiB ({r.host_bytes / per:.1f} B per filled voxel)",
        f"wrong pixels against the CPU traversal (away from voxel edges): {wrong}",
    ])
