"""Rays and boxes on the CPU: the one slab test, trilinear sampling, mesh depth, chords."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..core.camera import Camera


def ray_box_interval(origins, directions, lower, upper):
    """Entry and exit ``t`` of rays against an axis-aligned box (slab test, no epsilons).

    Rays parallel to an axis get infinite slab bounds (inside) or an empty interval
    (outside) through IEEE division, never a NaN.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / directions
        t_a = (lower - origins) * inv
        t_b = (upper - origins) * inv
    parallel = directions == 0
    inside = (origins >= lower) & (origins <= upper)
    # A parallel axis bounds nothing inside its slab and everything outside it: set the
    # slab's entry and exit themselves (taking min/max of +-inf afterwards would turn the
    # empty interval of a ray outside the slab into an unbounded one).
    t_near = np.where(parallel, np.where(inside, -np.inf, np.inf), np.minimum(t_a, t_b))
    t_far = np.where(parallel, np.where(inside, np.inf, -np.inf), np.maximum(t_a, t_b))
    return t_near.max(axis=-1), t_far.min(axis=-1)


def clip_interval(origins, directions, t0, t1, planes):
    """Cut each ray's ``[t0, t1]`` (world ``t``) to where every plane keeps it.

    ``planes``: ``(origin, normal)`` pairs in world coordinates; a plane keeps the points
    ``x`` with ``normal . (x - origin) >= 0``, as VTK's volume mapper does. The kept set is
    convex, so one interval per ray stays (empty where ``t1 <= t0``).
    """
    t0, t1 = np.array(t0, dtype=np.float64), np.array(t1, dtype=np.float64)
    for origin, normal in planes or ():
        normal = np.asarray(normal, dtype=np.float64)
        start = (origins - np.asarray(origin, dtype=np.float64)) @ normal
        rate = directions @ normal
        with np.errstate(divide="ignore", invalid="ignore"):
            crossing = -start / rate
        t0 = np.where(rate > 0, np.maximum(t0, crossing), t0)
        t1 = np.where(rate < 0, np.minimum(t1, crossing), t1)
        t1 = np.where((rate == 0) & (start < 0), -np.inf, t1)
    return t0, t1


def cut_normals(origins, directions, depth, planes, normals) -> np.ndarray:
    """``normals``, but where a ray's point at ``depth`` lies on a clip plane: its normal.

    On a plane, its unit normal facing back along the ray (a clipped mesh's cut, lit as a
    face of it). ``planes``: world ``(origin, normal)`` pairs; the point on the plane
    whose crossing is nearest ``depth``, within 1e-6 of it (relative).
    """
    out = np.array(normals, dtype=np.float64)
    nearest = np.full(len(out), np.inf)
    for origin, normal in planes or ():
        unit = np.asarray(normal, dtype=np.float64) / np.linalg.norm(normal)
        rate = directions @ unit
        with np.errstate(divide="ignore", invalid="ignore"):
            off = np.abs((np.asarray(origin, np.float64) - origins) @ unit / rate - depth)
        on = np.isfinite(off) & (off <= 1e-6 * np.maximum(1.0, np.abs(depth))) & (off < nearest)
        out[on] = np.where(rate[on, None] > 0, -unit, unit)
        nearest[on] = off[on]
    return out


def trilinear(values: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Sample ``values[i, j, k]`` at continuous indices ``points`` (n, 3), clamped to the grid."""
    dims = np.array(values.shape)
    p = np.clip(points, 0.0, dims - 1.0)
    base = np.minimum(np.floor(p).astype(np.int64), np.maximum(dims - 2, 0))
    frac = p - base
    if not (values.flags.c_contiguous or values.flags.f_contiguous):
        values = np.ascontiguousarray(values)
    # indexed through the array's own strides: a view in memory order, never a copy (a
    # copy per call made a 128^3 reference copy the volume at each of its 1700 steps)
    flat = values.ravel(order="K")
    sx, sy, sz = (int(s) // values.itemsize for s in values.strides)
    step = [np.where(dims[a] > 1, s, 0) for a, s in enumerate((sx, sy, sz))]
    index = base[:, 0] * sx + base[:, 1] * sy + base[:, 2] * sz
    fx, fy, fz = frac[:, 0], frac[:, 1], frac[:, 2]
    c00 = flat[index] * (1 - fx) + flat[index + step[0]] * fx
    c10 = flat[index + step[1]] * (1 - fx) + flat[index + step[1] + step[0]] * fx
    c01 = flat[index + step[2]] * (1 - fx) + flat[index + step[2] + step[0]] * fx
    i11 = index + step[2] + step[1]
    c11 = flat[i11] * (1 - fx) + flat[i11 + step[0]] * fx
    c0 = c00 * (1 - fy) + c10 * fy
    c1 = c01 * (1 - fy) + c11 * fy
    return c0 * (1 - fz) + c1 * fz


def nearest(values: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``values[i, j, k]`` of the point nearest each continuous index (n, 3), clamped."""
    dims = np.array(values.shape)
    index = np.clip(np.floor(np.asarray(points) + 0.5), 0, dims - 1).astype(np.int64)
    return values[index[:, 0], index[:, 1], index[:, 2]]


def sample(volume, points: np.ndarray) -> np.ndarray:
    """A volume's stored values at index points, as its ``interpolation`` reads them."""
    if getattr(volume, "interpolation", "linear") == "nearest":
        return nearest(volume.values, points)
    return trilinear(volume.values, points)


def sample_colors(volume, points: np.ndarray) -> np.ndarray:
    """A direct-colour (RGBA) volume's own colour at index points, each channel alone, in [0, 1]."""
    colors = np.asarray(volume.colors, dtype=np.float64) / 255.0
    read = nearest if getattr(volume, "interpolation", "linear") == "nearest" else trilinear
    return np.stack([read(colors[..., c], points) for c in range(3)], axis=-1)


def mesh_depth(mesh, camera: Camera, size: Sequence[int], chunk: int = 4096) -> np.ndarray:
    """Distance along each pixel's ray to the nearest triangle of ``mesh`` (``inf`` on a miss).

    Exact Moller-Trumbore ray/triangle intersection, vectorised over rays and triangles,
    for references of scenes with opaque meshes.
    """
    tri = mesh.triangulate()
    faces = np.asarray(tri.faces).reshape(-1, 4)[:, 1:]
    points = np.asarray(tri.points, dtype=np.float64)
    v0, e1, e2 = points[faces[:, 0]], points[faces[:, 1]] - points[faces[:, 0]], \
        points[faces[:, 2]] - points[faces[:, 0]]
    width, height = (int(v) for v in size)
    origins, directions = camera.rays((width, height))
    origins, directions = origins.reshape(-1, 3), directions.reshape(-1, 3)
    depth = np.full(origins.shape[0], np.inf)
    chunk = max(1, chunk * 256 // max(len(faces), 1))  # rays per batch, bounded memory
    for start in range(0, origins.shape[0], chunk):
        o = origins[start:start + chunk, None, :]
        d = directions[start:start + chunk, None, :]
        p = np.cross(d, e2[None])
        det = np.einsum("rtk,tk->rt", p, e1)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            s_vec = o - v0[None]
            u = np.einsum("rtk,rtk->rt", s_vec, p) * inv
            q = np.cross(s_vec, e1[None])
            v = np.einsum("rtk,rk->rt", q, d[:, 0, :]) * inv
            t = np.einsum("rtk,tk->rt", q, e2) * inv
        hit = (np.abs(det) > 1e-14) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
        t = np.where(hit, t, np.inf)
        depth[start:start + chunk] = t.min(axis=1)
    return depth.reshape(height, width)


def chord_lengths(volume, camera: Camera, size: Sequence[int]) -> np.ndarray:
    """World length of each pixel's ray inside the volume's box (0 where it misses).

    Tests use it to tell interior pixels from grazing silhouette ones, where a sub-pixel
    difference in rasterisation changes a very short path a lot.
    """
    width, height = (int(v) for v in size)
    origins, directions = camera.rays((width, height))
    index_from_world = np.linalg.inv(volume.world_from_index())
    o_idx = origins.reshape(-1, 3) @ index_from_world[:3, :3].T + index_from_world[:3, 3]
    d_idx = directions.reshape(-1, 3) @ index_from_world[:3, :3].T
    upper = np.array(volume.dimensions, dtype=np.float64) - 1.0
    t0, t1 = ray_box_interval(o_idx, d_idx, np.zeros(3), upper)
    return np.clip(t1 - np.maximum(t0, 0.0), 0.0, None).reshape(height, width)


def data_per_world(medium, directions: np.ndarray) -> np.ndarray:
    """Data units per world unit along each world direction, for a medium's lengths.

    A volume's lengths are measured in its grid's own frame, before its placement (its
    ``transform``), as VTK measures ``opacity_unit_distance``; a joint group's before the
    placement its members share (a channel volume's), else in the world.
    """
    directions = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    transform = medium.shared_transform() if hasattr(medium, "shared_transform") else \
        getattr(medium, "transform", None)
    if transform is None:
        return np.ones(len(directions))
    linear = np.linalg.inv(np.asarray(transform, dtype=np.float64))[:3, :3]
    return np.linalg.norm(directions @ linear.T, axis=1) / np.maximum(
        np.linalg.norm(directions, axis=1), 1e-300)


def index_rays(volume, origins, directions):
    """Rays in ``volume``'s index space and their interval inside its box (world ``t``)."""
    index_from_world = np.linalg.inv(volume.world_from_index())
    o_idx = origins @ index_from_world[:3, :3].T + index_from_world[:3, 3]
    d_idx = directions @ index_from_world[:3, :3].T
    upper = np.array(volume.dimensions, dtype=np.float64) - 1.0
    t0, t1 = ray_box_interval(o_idx, d_idx, np.zeros(3), upper)
    return o_idx, d_idx, t0, t1


def checked_pixels(pixels, crop, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """``(rows, columns)`` of a pixel sample of a ``width`` x ``height`` image, checked."""
    if crop is not None:
        raise ValueError("Give crop (a window) or pixels (a sample), not both.")
    rows, columns = (np.asarray(v, dtype=np.intp).ravel() for v in pixels)
    if rows.shape != columns.shape or (rows.size and (
            rows.min() < 0 or columns.min() < 0 or rows.max() >= height
            or columns.max() >= width)):
        raise ValueError(f"pixels must be rows and columns of equal length inside an image "
                         f"of {width} x {height}.")
    return rows, columns
