"""Procedural material grids: signed-distance shapes and their combinations, FBM terrain.

Every generator is vectorised numpy and deterministic (noise takes a ``seed``); each returns
labels ready for :func:`pv_cubemarch.add_voxels` (uint8, 0 = empty). Shapes are written in
the grid's index space: voxel ``(i, j, k)`` is filled when the shape's signed distance at
its centre ``(i + 0.5, j + 0.5, k + 0.5)`` is at most 0 (negative inside).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

Distance = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


class Shape:
    """A signed distance (negative inside), voxelised with :meth:`voxels`.

    Shapes combine with ``|`` (union), ``&`` (intersection) and ``-`` (difference).

    Examples
    --------
    >>> from pv_cubemarch.models.procedural import sphere, box
    >>> shape = box((16, 16, 16), (12, 12, 12)) - sphere((16, 16, 16), 14)
    >>> labels = shape.voxels((32, 32, 32), material=2)
    """

    def __init__(self, distance: Distance):
        self.distance = distance

    def __call__(self, points) -> np.ndarray:
        """The signed distance at ``points`` (``(..., 3)``, index space)."""
        points = np.asarray(points, dtype=np.float64)
        return self.distance(points[..., 0], points[..., 1], points[..., 2])

    def __or__(self, other: Shape) -> Shape:
        return Shape(lambda x, y, z: np.minimum(self.distance(x, y, z), other.distance(x, y, z)))

    def __and__(self, other: Shape) -> Shape:
        return Shape(lambda x, y, z: np.maximum(self.distance(x, y, z), other.distance(x, y, z)))

    def __sub__(self, other: Shape) -> Shape:
        return Shape(lambda x, y, z: np.maximum(self.distance(x, y, z),
                                                -other.distance(x, y, z)))

    def voxels(self, dimensions: Sequence[int], material: int = 1,
               into: np.ndarray | None = None) -> np.ndarray:
        """Labels of a grid of ``dimensions`` with ``material`` where the shape is.

        ``into``: an existing label grid to paint over (returned); else a new uint8 grid.
        """
        dims = tuple(int(n) for n in dimensions)
        if len(dims) != 3 or min(dims) < 1:
            raise ValueError(f"dimensions must be three positive sizes, got {dimensions!r}.")
        if not 0 <= int(material) <= np.iinfo(np.uint16).max:
            raise ValueError(f"material must be in 0..65535, got {material!r}.")
        labels = np.zeros(dims, np.uint8 if material < 256 else np.uint16) \
            if into is None else into
        if labels.shape != dims:
            raise ValueError(f"into has shape {labels.shape}, not {dims}.")
        x, y, z = (np.arange(n, dtype=np.float64) + 0.5 for n in dims)
        for k in range(dims[2]):   # a slab at a time: memory stays that of the labels
            inside = self.distance(x[:, None], y[None, :], np.full((1, 1), z[k])) <= 0.0
            labels[:, :, k][inside] = material
        return labels


def sphere(center: Sequence[float], radius: float) -> Shape:
    """A ball of ``radius`` around ``center``."""
    cx, cy, cz = (float(v) for v in center)
    return Shape(lambda x, y, z: np.sqrt((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2)
                 - radius)


def box(center: Sequence[float], half_size: Sequence[float]) -> Shape:
    """An axis-aligned box: ``center`` ± ``half_size`` along each axis."""
    cx, cy, cz = (float(v) for v in center)
    hx, hy, hz = (float(v) for v in half_size)

    def distance(x, y, z):
        qx, qy, qz = np.abs(x - cx) - hx, np.abs(y - cy) - hy, np.abs(z - cz) - hz
        outside = np.sqrt(np.maximum(qx, 0) ** 2 + np.maximum(qy, 0) ** 2
                          + np.maximum(qz, 0) ** 2)
        return outside + np.minimum(np.maximum(qx, np.maximum(qy, qz)), 0.0)

    return Shape(distance)


def torus(center: Sequence[float], major: float, minor: float) -> Shape:
    """A torus around the z axis through ``center``: ring radius ``major``, tube ``minor``."""
    cx, cy, cz = (float(v) for v in center)
    return Shape(lambda x, y, z: np.sqrt((np.sqrt((x - cx) ** 2 + (y - cy) ** 2) - major) ** 2
                                         + (z - cz) ** 2) - minor)


def octahedron(center: Sequence[float], size: float) -> Shape:
    """The octahedron ``|x| + |y| + |z| <= size`` around ``center`` (a bound, exact inside)."""
    cx, cy, cz = (float(v) for v in center)
    return Shape(lambda x, y, z: (np.abs(x - cx) + np.abs(y - cy) + np.abs(z - cz) - size)
                 / np.sqrt(3.0))


def capsule(start: Sequence[float], end: Sequence[float], radius: float) -> Shape:
    """The points within ``radius`` of the segment ``start``-``end``."""
    a = np.asarray(start, dtype=np.float64)
    ab = np.asarray(end, dtype=np.float64) - a
    length2 = max(float(ab @ ab), 1e-300)

    def distance(x, y, z):
        px, py, pz = x - a[0], y - a[1], z - a[2]
        h = np.clip((px * ab[0] + py * ab[1] + pz * ab[2]) / length2, 0.0, 1.0)
        return np.sqrt((px - h * ab[0]) ** 2 + (py - h * ab[1]) ** 2
                       + (pz - h * ab[2]) ** 2) - radius

    return Shape(distance)


def _lattice(seed: int, size: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """A seeded permutation table (doubled) and per-entry unit gradients and values."""
    rng = np.random.default_rng(seed)
    permutation = rng.permutation(size)
    angles = rng.random(size) * 2.0 * np.pi
    return np.concatenate([permutation, permutation]), np.stack(
        [np.cos(angles), np.sin(angles), rng.random(size) * 2.0 - 1.0], axis=-1)


def noise2(x: np.ndarray, y: np.ndarray, kind: str = "perlin", seed: int = 0) -> np.ndarray:
    """2D lattice noise in about [-1, 1]: ``'perlin'`` (gradient) or ``'value'`` noise.

    Smooth (quintic fade), period 256 cells, deterministic for a ``seed``.
    """
    if kind not in ("perlin", "value"):
        raise ValueError(f"kind must be 'perlin' or 'value', got {kind!r}.")
    table, entries = _lattice(seed)
    x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = x - x0, y - y0
    ix, iy = x0.astype(np.int64) & 255, y0.astype(np.int64) & 255

    def corner(dx, dy):
        entry = table[table[(ix + dx) & 255] + ((iy + dy) & 255)]
        if kind == "value":
            return entries[entry, 2]
        return entries[entry, 0] * (fx - dx) + entries[entry, 1] * (fy - dy)

    def fade(t):
        return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)

    u, v = fade(fx), fade(fy)
    bottom = corner(0, 0) + u * (corner(1, 0) - corner(0, 0))
    top = corner(0, 1) + u * (corner(1, 1) - corner(0, 1))
    scale = np.sqrt(2.0) if kind == "perlin" else 1.0   # gradient noise peaks at 1/sqrt 2
    return (bottom + v * (top - bottom)) * scale


def fbm2(x: np.ndarray, y: np.ndarray, octaves: int = 5, hurst: float = 1.0,
         kind: str = "perlin", seed: int = 0) -> np.ndarray:
    """Fractal Brownian motion over :func:`noise2`.

    ``octaves`` layers, each at twice the frequency and ``G = 2^-hurst`` times the amplitude
    of the one before.
    """
    if int(octaves) < 1:
        raise ValueError(f"octaves must be at least 1, got {octaves!r}.")
    if not 0.0 <= float(hurst) <= 1.0:
        raise ValueError(f"hurst (H) must be in [0, 1], got {hurst!r}.")
    gain = 2.0 ** -float(hurst)
    total = np.zeros(np.broadcast_shapes(np.shape(x), np.shape(y)))
    frequency, amplitude = 1.0, 1.0
    for octave in range(int(octaves)):
        total += amplitude * noise2(np.asarray(x) * frequency, np.asarray(y) * frequency, kind,
                                    seed + octave)
        frequency *= 2.0
        amplitude *= gain
    return total


def terrain(dimensions: Sequence[int], octaves: int = 5, hurst: float = 1.0,
            feature_size: float = 64.0, noise: str = "perlin", seed: int = 0,
            layers: Sequence[tuple[int, int]] = ((1, 1), (2, 3)),
            bedrock: int = 3, ground: float = 0.5, relief: float = 0.35,
            region: tuple[slice, slice, slice] | None = None) -> np.ndarray:
    """A height-field terrain of FBM noise, filled from z = 0 up to the surface.

    ``feature_size``: voxels per noise cell of the first octave. The surface lies at
    ``(ground + relief * fbm) * nz``. ``layers``: ``(material, thickness)`` from the
    surface down (grass, then dirt, by default); below them ``bedrock``. ``region``: only
    this box (three slices, step 1) of the terrain, the same voxels as
    ``terrain(dimensions)[region]``: a world too large for memory is made chunk by chunk.
    """
    nx, ny, nz = (int(n) for n in dimensions)
    if min(nx, ny, nz) < 1 or float(feature_size) <= 0:
        raise ValueError("dimensions must be positive and feature_size above 0.")
    ranges = [np.arange(n)[part] for n, part in zip(
        (nx, ny, nz), region if region is not None else (slice(None),) * 3, strict=True)]
    x = (ranges[0] + 0.5)[:, None] / float(feature_size)
    y = (ranges[1] + 0.5)[None, :] / float(feature_size)
    height = (ground + relief * fbm2(x, y, octaves, hurst, noise, seed)) * nz
    depth = height[:, :, None] - (ranges[2] + 0.5)[None, None, :]   # > 0 below ground
    labels = np.where(depth > 0, bedrock, 0).astype(np.uint8)
    top = 0.0
    for material, thickness in layers:
        band = (depth > top) & (depth <= top + thickness)
        labels[band] = material
        top += thickness
    return labels
