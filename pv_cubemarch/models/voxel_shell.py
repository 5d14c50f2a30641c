"""The brick shell: outer faces of a grid's filled bricks, where rays start.

A depth pass draws them and each pixel's ray starts where it first meets them, so pixels
that meet none run nothing.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .voxel_levels import block_any

#: Occupancy levels whose bricks' outer faces may start the rays (``proxy='bricks'``),
#: finest first: the first whose shell has at most SHELL_FACE_BUDGET faces is used (finer
#: bricks start rays nearer their hits; scattered content makes too many faces, whose depth
#: pass then costs more than it saves).
SHELL_LEVELS = (1, 2, 3)

SHELL_FACE_BUDGET = 16384

#: How far (voxels) the brick faces stand off the bricks, so rasterisation never drops a
#: pixel whose ray enters a brick near its silhouette (vertex positions are float32).
PROXY_MARGIN = 1.0 / 64.0

def occupied_bricks(labels: np.ndarray, brick: int) -> np.ndarray:
    """Per brick of ``brick``³ voxels (the last ones cut by the grid), whether any is filled."""
    return block_any(np.asarray(labels) != 0, brick)

def face_rectangles(mask: np.ndarray) -> np.ndarray:
    """Cover the true cells of ``mask`` (``(layers, nu, nv)``) with disjoint rectangles.

    Rows ``(layer, u0, u1, v0, v1)``, ends excluded: runs along ``v``, then runs of equal
    extent in consecutive ``u`` merged. Vectorised (no loop over cells); fewer, larger faces
    draw faster on a rasteriser that shades 4x4 blocks (llvmpipe).
    """
    mask = np.asarray(mask, dtype=bool)
    if mask.ndim == 2:
        mask = mask[None]
    padded = np.pad(mask, ((0, 0), (0, 0), (1, 1)))
    change = np.diff(padded.astype(np.int8), axis=2)
    layer, u, v0 = np.nonzero(change == 1)
    v1 = np.nonzero(change == -1)[2]          # the same runs, in the same order
    if not len(u):
        return np.zeros((0, 5), np.int64)
    order = np.lexsort((u, v1, v0, layer))    # runs of equal (layer, v0, v1) by u
    layer, u, v0, v1 = layer[order], u[order], v0[order], v1[order]
    same = np.zeros(len(u), bool)   # whether a run continues the one before it
    same[1:] = ((layer[1:] == layer[:-1]) & (v0[1:] == v0[:-1]) & (v1[1:] == v1[:-1])
                & (u[1:] == u[:-1] + 1))
    starts = np.flatnonzero(~same)
    ends = np.append(starts[1:], len(u)) - 1
    return np.stack([layer[starts], u[starts], u[ends] + 1, v0[starts], v1[starts]],
                    axis=-1).astype(np.int64).reshape(-1, 5)

def brick_shell(labels: np.ndarray, brick: int, margin: float = PROXY_MARGIN,
                max_faces: int | None = None,
                occupied: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """The outer faces of the filled bricks, as quads facing out: ``(points, quads)``.

    A face is kept where a filled brick meets an empty one or the grid's side, so the
    faces close around every filled voxel and a ray meets one before its first hit;
    coplanar faces are merged into rectangles (:func:`face_rectangles`). Each quad stands
    ``margin`` voxels off its bricks and reaches ``2 margin`` past its edges, beyond the
    planes of the faces it meets, so no seam or edge leaves a crack (seen: a pixel lost
    where two faces met at an edge with different vertices). Faces beyond what is needed
    only start some rays earlier, which changes no hit. Index space; ``points`` is ``(4 n, 3)``
    float64, ``quads`` ``(n, 4)`` indices, counter-clockwise seen from outside. ``None``
    when it would have more than ``max_faces`` faces (given). ``occupied``: the bricks'
    occupancy (:func:`occupied_bricks`), if already made.
    """
    if occupied is None:
        occupied = occupied_bricks(labels, brick)
    return shell_faces(occupied, brick, np.asarray(labels).shape, margin, max_faces)

def shell_faces(occupied: np.ndarray, brick: int, dimensions: Sequence[int],
                margin: float = PROXY_MARGIN,
                max_faces: int | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """The outer faces of the bricks ``occupied`` marks, as :func:`brick_shell` makes them.

    ``dimensions``: the grid's voxels (bricks at its far sides are cut there). A negative
    ``margin`` stands the faces inside the bricks and shrinks them by ``2 |margin|``.
    """
    if max_faces is not None and _exposed_faces(occupied) > 16 * max_faces:
        return None   # merging rarely saves that much: not worth merging to find out
    dims = np.array(dimensions, dtype=np.float64)
    corners = []
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3   # (axis, u, v) right-handed: u x v = axis
        for side in (-1, 1):
            neighbour = np.zeros_like(occupied)
            inner = [slice(None)] * 3
            outer = [slice(None)] * 3
            if side > 0:
                inner[axis], outer[axis] = slice(None, -1), slice(1, None)
            else:
                inner[axis], outer[axis] = slice(1, None), slice(None, -1)
            neighbour[tuple(inner)] = occupied[tuple(outer)]
            exposed = np.transpose(occupied & ~neighbour, (axis, u, v))
            cells = face_rectangles(exposed).astype(np.float64)
            if not len(cells):
                continue
            plane = np.minimum((cells[:, 0] + (side > 0)) * brick, dims[axis]) + side * margin
            reach = 2.0 * margin   # past the perpendicular faces' planes: no gap at edges
            u0 = cells[:, 1] * brick - reach
            u1 = np.minimum(cells[:, 2] * brick, dims[u]) + reach
            v0 = cells[:, 3] * brick - reach
            v1 = np.minimum(cells[:, 4] * brick, dims[v]) + reach
            ring = ((u0, v0), (u1, v0), (u1, v1), (u0, v1))
            if side < 0:
                ring = ring[::-1]
            face = np.empty((len(cells), 4, 3))
            face[:, :, axis] = plane[:, None]
            for k, (cu, cv) in enumerate(ring):
                face[:, k, u] = cu
                face[:, k, v] = cv
            corners.append(face.reshape(-1, 3))
    points = np.concatenate(corners) if corners else np.zeros((0, 3))
    quads = np.arange(len(points)).reshape(-1, 4)
    if max_faces is not None and len(quads) > max_faces:
        return None
    return points, quads

def brick_faces(cells: np.ndarray, brick: int, dimensions: Sequence[int],
                margin: float = PROXY_MARGIN) -> tuple[np.ndarray, np.ndarray]:
    """The six outward faces of each brick ``cells`` (``(n, 3)`` brick indices), unmerged.

    As :func:`brick_shell` draws them (standing ``margin`` off, reaching ``2 margin`` past
    the edges): bricks added to a shell by an edit, faces toward filled neighbours included
    (harmless: a ray meets an outer face first).
    """
    cells = np.asarray(cells, dtype=np.float64).reshape(-1, 3)
    dims = np.asarray(dimensions, dtype=np.float64)
    low = cells * brick
    high = np.minimum((cells + 1) * brick, dims)
    corners = []
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        for side in (-1, 1):
            ring = ((0, 0), (1, 0), (1, 1), (0, 1))
            if side < 0:
                ring = ring[::-1]
            face = np.empty((len(cells), 4, 3))
            face[:, :, axis] = (high[:, axis] + margin if side > 0
                                else low[:, axis] - margin)[:, None]
            for k, (a, b) in enumerate(ring):
                face[:, k, u] = high[:, u] + 2 * margin if a else low[:, u] - 2 * margin
                face[:, k, v] = high[:, v] + 2 * margin if b else low[:, v] - 2 * margin
            corners.append(face.reshape(-1, 3))
    points = np.concatenate(corners) if len(cells) else np.zeros((0, 3))
    return points, np.arange(len(points)).reshape(-1, 4)

def brick_bounds(occupied: np.ndarray, brick: int,
                 dimensions: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """``(lower, upper)`` index-space corners of the filled bricks (zeros when none)."""
    if not occupied.any():
        return np.zeros(3), np.zeros(3)
    where = np.argwhere(occupied)
    lower = where.min(axis=0) * brick
    upper = np.minimum((where.max(axis=0) + 1) * brick, np.asarray(dimensions))
    return lower.astype(np.float64), upper.astype(np.float64)

def _exposed_faces(occupied: np.ndarray) -> int:
    """How many brick faces border an empty brick or the grid's side (before merging)."""
    padded = np.pad(occupied, 1)
    return int(sum((padded & ~np.roll(padded, shift, axis)).sum()
                   for axis in range(3) for shift in (-1, 1)))

@dataclass(frozen=True)
class BrickShell:
    """The outer faces (:func:`brick_shell`) of the filled bricks of occupancy ``level``."""

    level: int
    points: np.ndarray
    quads: np.ndarray
    occupied: np.ndarray   # per brick, whether it holds a filled voxel

def choose_shell(labels: np.ndarray,
                 levels: Sequence[np.ndarray] = ()) -> BrickShell | None:
    """The finest shell of :data:`SHELL_LEVELS` within :data:`SHELL_FACE_BUDGET` faces.

    ``levels``: the grid's occupancy levels from 1 on, where made already (level ``l`` is
    the occupancy of bricks of ``2^l`` voxels).
    """
    for level in SHELL_LEVELS:
        occupied = (levels[level - 1].view(bool) if level <= len(levels)
                    else occupied_bricks(labels, 1 << level))
        shell = brick_shell(labels, 1 << level, max_faces=SHELL_FACE_BUDGET,
                            occupied=occupied)
        if shell is not None:
            return BrickShell(level, *shell, occupied)
    return None
