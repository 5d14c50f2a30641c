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
