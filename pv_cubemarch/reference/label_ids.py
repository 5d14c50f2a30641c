"""Reference traversal of label ids of any integer type (numpy only).

The grid's own ids are made dense here, by ``np.unique``, independently of the renderer's
compaction; the exact traversal runs on those and the hits are reported as the ids.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..core.camera import Camera
from .voxels import VoxelHits, trace_voxels


def trace_ids(labels: np.ndarray, world_from_index: np.ndarray, camera: Camera,
              size: tuple[int, int], near: float | None = None, shown=None,
              background: int = 0, crop: Sequence[int] | None = None,
              clip_planes: Sequence | None = None) -> tuple[VoxelHits, np.ndarray]:
    """The first drawn voxel along every pixel's ray, for ids of any value.

    ``shown``: the ids drawn (default every id but ``background``); ``clip_planes``: world
    ``(origin, normal)`` planes cutting the rays, as ``trace_voxels`` takes them. Returns
    the hits of
    :func:`~pv_cubemarch.reference.voxels.trace_voxels` with ``material`` replaced by the
    hit voxel's id (in ``labels``' type; ``background`` on a miss), and the hit mask.
    """
    labels = np.asarray(labels)
    values, dense = np.unique(labels, return_inverse=True)
    dense = dense.reshape(labels.shape) + 1   # 1..n: np.unique's ranks, 0 never used
    drawn = values != labels.dtype.type(background)
    if shown is not None:
        wanted = np.atleast_1d(np.asarray(shown))
        if wanted.dtype.kind not in "iu" or not np.can_cast(wanted.dtype, values.dtype):
            # Python ints of any size: keep those the labels' type holds, exactly
            info = np.iinfo(values.dtype)
            wanted = np.asarray([int(v) for v in wanted.ravel()
                                 if info.min <= int(v) <= info.max], dtype=values.dtype)
        drawn &= np.isin(values, wanted.astype(values.dtype))
    visible = np.concatenate([[False], drawn])
    hits = trace_voxels(dense, world_from_index, camera, size, near=near, visible=visible,
                        crop=crop, clip_planes=clip_planes)
    hit = hits.index[..., 0] >= 0
    ids = np.full(hit.shape, labels.dtype.type(background), dtype=labels.dtype)
    ids[hit] = values[hits.material[hit] - 1]
    hits.material = ids
    return hits, hit
