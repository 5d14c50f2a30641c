"""Voxel edges as VTK draws a mesh's ``show_edges``, on the CPU (numpy only).

A pixel on a drawn face is covered by the face's edges by ``0.5 + w / 2 - d``, clamped to
[0, 1], times the edges' opacity: ``d`` is the distance in pixels from the pixel's centre
to the nearest of the face's four edge lines as the camera projects them, ``w`` the line
width, never under 1.1 pixels (VTK's: measured on its images, line widths 0.5 and 1 draw
alike). The face's unlit colour and diffuse term go to the edge colour by the coverage;
the highlight stays.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..core.camera import Camera

#: The thinnest edge VTK draws, in pixels (see the module docstring).
THINNEST_EDGE = 1.1


def window_points(camera: Camera, size: Sequence[int], points: np.ndarray) -> np.ndarray:
    """Pixel coordinates ``(x from the left, y from the top)`` of world ``points``, ``(n, 2)``.

    Pixel ``(col, row)`` spans ``[col, col + 1] x [row, row + 1]``: its centre is where
    :meth:`Camera.rays` sends its ray.
    """
    width, height = (int(v) for v in size)
    right, up, forward = camera.basis()
    offset = np.asarray(points, dtype=np.float64) - np.asarray(camera.position, np.float64)
    x, y, z = offset @ right, offset @ up, offset @ forward
    aspect = width / height
    if camera.parallel_projection:
        half = float(camera.parallel_scale)
        ndc_x, ndc_y = x / (half * aspect), y / half
    else:
        half = np.tan(np.radians(camera.view_angle) / 2.0)
        ndc_x, ndc_y = x / (z * half * aspect), y / (z * half)
    return np.stack([(ndc_x + 1.0) * 0.5 * width, (1.0 - ndc_y) * 0.5 * height], axis=1)


def edge_coverage(hits, world_from_index: np.ndarray, camera: Camera, size: Sequence[int],
                  line_width: float = 1.0, opacity: float = 1.0) -> np.ndarray:
    """``(h, w)`` coverage of each pixel's hit face by that face's edges (0 off faces).

    ``hits``: :func:`~pv_cubemarch.reference.voxels.trace_voxels` of the same camera and
    size (a ray that starts inside its voxel entered no face: no edges).
    """
    width, height = (int(v) for v in size)
    coverage = np.zeros((height, width))
    rows, cols = np.nonzero((hits.material > 0) & (hits.face >= 0))
    if len(rows) == 0:
        return coverage
    matrix = np.asarray(world_from_index, dtype=np.float64)
    axis = hits.face[rows, cols] // 2
    voxel = hits.index[rows, cols].astype(np.float64)
    point = hits.point[rows, cols]
    centre = np.stack([cols + 0.5, rows + 0.5], axis=1)
    nearest = np.full(len(rows), np.inf)
    pick = np.arange(len(rows))
    for shift in (1, 2):
        held = (axis + shift) % 3          # the axis whose coordinate the line holds
        along = (axis + 3 - shift) % 3     # the axis it runs along
        for side in (0.0, 1.0):
            start = point.copy()
            start[pick, held] = voxel[pick, held] + side
            end = start.copy()
            end[pick, along] += 1e-3
            a = window_points(camera, size, start @ matrix[:3, :3].T + matrix[:3, 3])
            b = window_points(camera, size, end @ matrix[:3, :3].T + matrix[:3, 3])
            direction, across = b - a, centre - a
            run = np.linalg.norm(direction, axis=1)
            cross = np.abs(direction[:, 0] * across[:, 1] - direction[:, 1] * across[:, 0])
            distance = np.where(run > 1e-300, cross / np.maximum(run, 1e-300),
                                np.linalg.norm(across, axis=1))
            nearest = np.minimum(nearest, distance)
    half = 0.5 * max(float(line_width), THINNEST_EDGE)
    coverage[rows, cols] = np.clip(0.5 + half - nearest, 0.0, 1.0) * float(opacity)
    return coverage


def _line_distance(camera: Camera, size, world_from_index: np.ndarray, centre: np.ndarray,
                   start: np.ndarray, along: np.ndarray) -> np.ndarray:
    """Pixels from each pixel ``centre`` to the window image of a line, index space.

    The line runs through ``start`` along ``along`` (both ``(n, 3)``).
    """
    matrix = np.asarray(world_from_index, dtype=np.float64)
    end = start + 1e-3 * along / np.maximum(np.linalg.norm(along, axis=1), 1e-300)[:, None]
    a = window_points(camera, size, start @ matrix[:3, :3].T + matrix[:3, 3])
    b = window_points(camera, size, end @ matrix[:3, :3].T + matrix[:3, 3])
    direction, across = b - a, centre - a
    run = np.linalg.norm(direction, axis=1)
    cross = np.abs(direction[:, 0] * across[:, 1] - direction[:, 1] * across[:, 0])
    return np.where(run > 1e-300, cross / np.maximum(run, 1e-300),
                    np.linalg.norm(across, axis=1))


def _label_at(drawn: np.ndarray, voxel: np.ndarray) -> np.ndarray:
    """The drawn label of each index ``(n, 3)`` (0 outside the grid or where not drawn)."""
    shape = np.array(drawn.shape)
    inside = np.all((voxel >= 0) & (voxel < shape), axis=1)
    out = np.zeros(len(voxel), dtype=drawn.dtype)
    at = voxel[inside]
    out[inside] = drawn[at[:, 0], at[:, 1], at[:, 2]]
    return out


def label_edge_coverage(hits, drawn: np.ndarray, world_from_index: np.ndarray,
                        camera: Camera, size: Sequence[int], line_width: float = 1.0,
                        opacity: float = 1.0, clip_planes=None) -> np.ndarray:
    """``(h, w)`` coverage by the edges between different labels only (``edge_mode='labels'``).

    ``drawn``: the label of each voxel as drawn (0 where empty or hidden). On a face, an
    edge counts where the surface across it shows another label: the voxel diagonally in
    front if drawn (the surface steps toward the eye), else the neighbour in the face's
    layer, else empty. Where a ray starts on a clip plane inside its voxel, the lines where
    the plane crosses the voxel's faces count where the voxel across that face has another
    label: a cut shows the boundaries between the labels it crosses.
    """
    width, height = (int(v) for v in size)
    coverage = np.zeros((height, width))
    nearest = np.full((height, width), np.inf)
    seen = hits.index[..., 0] >= 0
    half = 0.5 * max(float(line_width), THINNEST_EDGE)
    rows, cols = np.nonzero(seen & (hits.face >= 0))
    if len(rows):
        axis = hits.face[rows, cols] // 2
        toward = np.where(hits.face[rows, cols] % 2 == 1, -1, 1)   # moving +axis: eye at -
        voxel = hits.index[rows, cols]
        own = _label_at(drawn, voxel)
        point = hits.point[rows, cols]
        centre = np.stack([cols + 0.5, rows + 0.5], axis=1)
        pick = np.arange(len(rows))
        best = np.full(len(rows), np.inf)
        for shift in (1, 2):
            held = (axis + shift) % 3
            along = (axis + 3 - shift) % 3
            for side in (0, 1):
                start = point.copy()
                start[pick, held] = voxel[pick, held] + side
                direction = np.zeros_like(start)
                direction[pick, along] = 1.0
                distance = _line_distance(camera, (width, height), world_from_index, centre,
                                          start, direction)
                neighbour = voxel.copy()
                neighbour[pick, held] += 2 * side - 1
                front = neighbour.copy()
                front[pick, axis] += toward
                ahead, beside = _label_at(drawn, front), _label_at(drawn, neighbour)
                across = np.where(ahead != 0, ahead, beside)
                best = np.where(across != own, np.minimum(best, distance), best)
        nearest[rows, cols] = best
    rows, cols = np.nonzero(seen & (hits.face < 0))
    if len(rows) and clip_planes:
        matrix = np.asarray(world_from_index, dtype=np.float64)
        voxel = hits.index[rows, cols]
        own = _label_at(drawn, voxel)
        point = hits.point[rows, cols]
        world = point @ matrix[:3, :3].T + matrix[:3, 3]
        centre = np.stack([cols + 0.5, rows + 0.5], axis=1)
        best = np.full(len(rows), np.inf)
        for origin, normal in clip_planes:
            normal = np.asarray(normal, dtype=np.float64)
            on = np.abs((world - np.asarray(origin, dtype=np.float64)) @ normal) <= 1e-6 * (
                1.0 + np.abs(world).max(axis=1)) * np.linalg.norm(normal)
            n_index = matrix[:3, :3].T @ normal   # the plane's normal in index space
            for axis in range(3):
                unit = np.zeros(3)
                unit[axis] = 1.0
                along = np.cross(n_index, unit)
                if np.linalg.norm(along) < 1e-12:
                    continue   # the plane runs parallel to these faces: it crosses none
                within = unit - n_index * (n_index @ unit) / (n_index @ n_index)
                for side in (0, 1):
                    level = voxel[:, axis] + side
                    step = (level - point[:, axis]) / within[axis]
                    start = point + step[:, None] * within
                    distance = _line_distance(camera, (width, height), world_from_index,
                                              centre, start, np.tile(along, (len(rows), 1)))
                    neighbour = voxel.copy()
                    neighbour[:, axis] += 2 * side - 1
                    across = _label_at(drawn, neighbour)
                    best = np.where(on & (across != own), np.minimum(best, distance), best)
        nearest[rows, cols] = np.minimum(nearest[rows, cols], best)
    covered = np.isfinite(nearest)
    coverage[covered] = np.clip(0.5 + half - nearest[covered], 0.0, 1.0) * float(opacity)
    return coverage
