"""Maximum- and minimum-intensity projections on the CPU: the right image of those blend modes.

The extreme scalar along each pixel's ray (fine steps, sampled as the volume's
``interpolation`` says) is drawn with the
colour and the opacity per unit distance that :mod:`.transfer` derives for it, over the
background, as VTK's ``MAXIMUM_INTENSITY_BLEND`` and ``MINIMUM_INTENSITY_BLEND`` draw it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..core.camera import Camera
from .rays import index_rays, sample
from .transfer import medium

#: The reduction each blend mode applies along a ray.
REDUCTIONS = {"maximum": (np.maximum, -np.inf), "minimum": (np.minimum, np.inf)}


def render_intensity_projection(volume, camera: Camera, size: Sequence[int] = (256, 256),
                                blending: str = "maximum",
                                background: Sequence[float] = (0.0, 0.0, 0.0),
                                step_voxels: float = 0.1,
                                near: float | None = None,
                                opaque_depth: np.ndarray | None = None,
                                opaque_color: np.ndarray | None = None) -> np.ndarray:
    """The ``blending`` projection of ``volume`` (a VolumeModel): ``(h, w, 3)`` floats.

    ``opaque_depth`` / ``opaque_color``: per-pixel distance to opaque meshes and their
    colour; rays stop there, the projection is drawn over that colour.
    """
    reduce, start = REDUCTIONS[blending]
    width, height = (int(v) for v in size)
    origins, directions = camera.rays((width, height))
    origins, directions = origins.reshape(-1, 3), directions.reshape(-1, 3)
    o_idx, d_idx, t0, t1 = index_rays(volume, origins, directions)
    t0 = np.maximum(t0, 0.0)
    if opaque_depth is not None:
        t1 = np.minimum(t1, np.asarray(opaque_depth, dtype=np.float64).reshape(-1))
    if near is not None:
        forward = camera.basis()[2]
        t0 = np.maximum(t0, near / np.maximum(directions @ forward, 1e-12))
    step = float(step_voxels) * float(np.linalg.norm(volume.world_from_index()[:3, :3],
                                                     axis=0).min())
    extreme = np.full(len(origins), start)
    active = np.nonzero(t1 > t0)[0]
    t = t0[active].copy()
    while active.size:
        end = np.minimum(t + step, t1[active])
        middle = 0.5 * (t + end)
        points = o_idx[active] + d_idx[active] * middle[:, None]
        extreme[active] = reduce(extreme[active], sample(volume, points))
        t = end
        keep = t < t1[active]
        active, t = active[keep], t[keep]
    hit = np.isfinite(extreme)
    rgb, sigma = medium(volume, np.where(hit, extreme, 0.0))
    unit = volume.transfer.spec.opacity_unit_distance if volume.transfer.spec else 1.0
    alpha = np.where(hit, -np.expm1(-sigma * unit), 0.0)
    behind = np.asarray(background, float) if opaque_color is None else np.asarray(
        opaque_color, dtype=np.float64).reshape(-1, 3)
    image = rgb * alpha[:, None] + (1.0 - alpha[:, None]) * behind
    return image.reshape(height, width, 3)
