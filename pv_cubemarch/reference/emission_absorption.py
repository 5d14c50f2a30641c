"""The emission/absorption CPU reference: what the right image of a volume is.

:func:`render_emission_absorption` integrates the emission/absorption model along every
pixel's ray with fine steps, trilinear sampling and colours derived from matplotlib on its
own (:mod:`.transfer`), never from the renderer's table. It is vectorised over rays and
compacts the active set as rays finish, so 256x256 takes seconds.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..core.camera import Camera
from ..models.group import VolumeGroup
from ..models.volume import VolumeModel
from .channels import render_additive_channels
from .lighting import light_fields, lit_emission
from .rays import (
    checked_pixels,
    clip_interval,
    data_per_world,
    index_rays,
    sample,
    sample_colors,
)
from .transfer import medium as transfer_medium
from .volume_shading import ShadeSetup


def render_emission_absorption(
    volume: VolumeModel | VolumeGroup | Sequence[VolumeModel | VolumeGroup],
    camera: Camera,
    size: Sequence[int] = (256, 256),
    background: Sequence[float] = (0.0, 0.0, 0.0),
    step_voxels: float = 0.1,
    opaque_depth: np.ndarray | None = None,
    opaque_color: np.ndarray | None = None,
    near: float | None = None,
    min_transmittance: float = 1e-6,
    lights: Sequence | None = None,
    ambient: float = 0.2,
    crop: Sequence[int] | None = None,
    shade: ShadeSetup | None = None,
    clip_planes: Sequence | None = None,
    pixels: tuple | None = None,
) -> np.ndarray:
    """Render ``volume`` as an emission/absorption medium, returning ``(h, w, 3)`` floats.

    Parameters
    ----------
    volume : VolumeModel, VolumeGroup or sequence of them
        The volume, its placement and its transfer function; several volumes are marched
        together (where they overlap their extinctions add, the emitted colour is the
        extinction-weighted mean), so interpenetrating media are right. With ``lights``,
        a volume is lit through itself and the members of a :class:`VolumeGroup` through
        the whole group, as the GPU lights them.
    camera : Camera
        The view; rays run through pixel centres, rows top to bottom.
    size : sequence of int
        ``(width, height)`` in pixels.
    background : sequence of float
        RGB behind the volume where ``opaque_color`` is not given.
    step_voxels : float
        Step length as a fraction of the smallest world voxel size (0.1 is "very fine").
    opaque_depth, opaque_color : numpy.ndarray, optional
        Per-pixel distance along the ray to opaque geometry (``inf`` where none) and its
        colour: rays stop there and composite over that colour.
    near : float, optional
        Distance along the view axis of the near clipping plane; rays start there.
    min_transmittance : float
        Rays stop once their transmittance falls below this (an error below this bound).
    lights : sequence of VolumeLight, optional
        Light the samples: emission times ``ambient + (1 - ambient) * sum colour * T``,
        ``T`` the transmittance toward each light, from a lattice of rays toward it
        (:func:`pv_cubemarch.reference.lighting.light_fields`).
    ambient : float
        Share of the emission no light modulates (with ``lights``).
    crop : sequence of int, optional
        ``(x, y, width, height)`` of a pixel window (from the top-left) of the ``size``
        image: only those rays are traced, e.g. to check a 4K frame on a few crops.
    pixels : (rows, columns) of int arrays, optional
        Only the rays through these pixels of the ``size`` image (rows from the top), as
        a ``(1, n, 3)`` image: a sample of a frame spread over it, where ``crop`` takes a
        window. Not with ``crop``.
    shade : ShadeSetup, optional
        Gradient shading of each sample's colour, as VTK's ``shade=True``
        (:mod:`pv_cubemarch.reference.volume_shading`).
    clip_planes : sequence of (origin, normal), optional
        World planes cutting the media: a plane keeps ``normal . (x - origin) >= 0``, as
        VTK's volume mapper does (:func:`pv_cubemarch.reference.rays.clip_interval`).
    """
    if isinstance(volume, VolumeGroup) and volume.channel_mix == "additive":
        return render_additive_channels(
            volume, render_emission_absorption, camera, size, background, opaque_color,
            step_voxels=step_voxels,
            opaque_depth=opaque_depth, near=near, min_transmittance=min_transmittance,
            crop=crop, clip_planes=clip_planes, pixels=pixels)
    width, height = (int(v) for v in size)
    origins, directions = camera.rays((width, height))
    if pixels is not None:
        rows, columns = checked_pixels(pixels, crop, width, height)
        origins, directions = origins[rows, columns][None], directions[rows, columns][None]
    if crop is not None:
        x, y, width, height = (int(v) for v in crop)
        origins = origins[y:y + height, x:x + width]
        directions = directions[y:y + height, x:x + width]
        if origins.shape[:2] != (height, width):
            raise ValueError(f"crop {tuple(crop)} does not fit in an image of size {size}.")
    items = [volume] if isinstance(volume, (VolumeModel, VolumeGroup)) else list(volume)
    if not items:
        raise ValueError("Give at least one volume to render.")
    # A group's members are lit through the whole group (they shade each other), as the GPU
    # lights a group it marches jointly; separate volumes are lit each through itself.
    volumes, lit_through = [], []
    for item in items:
        for member in (item.members if isinstance(item, VolumeGroup) else [item]):
            volumes.append(member)
            lit_through.append(item)
    grids = None
    if lights:
        grids = {id(item): light_fields(item, lights, clip_planes=clip_planes)
                 for item in items}
    origins_shape = origins.shape   # (height, width, 3), a crop's, or (1, n, 3)
    origins = origins.reshape(-1, 3)
    directions = directions.reshape(-1, 3)
    n_rays = origins.shape[0]
    if opaque_color is None:
        backdrop = np.broadcast_to(np.asarray(background, dtype=np.float64), (n_rays, 3)).copy()
    else:
        backdrop = np.asarray(opaque_color, dtype=np.float64).reshape(n_rays, 3).copy()
    t_stop = np.full(n_rays, np.inf) if opaque_depth is None else np.asarray(
        opaque_depth, dtype=np.float64).reshape(n_rays)

    rays = [index_rays(v, origins, directions) for v in volumes]
    scales = [data_per_world(item, directions) for item in lit_through]
    t0 = np.min([r[2] for r in rays], axis=0)
    t1 = np.max([r[3] for r in rays], axis=0)
    t0 = np.maximum(t0, 0.0)
    if near is not None:
        _, _, forward = camera.basis()
        t0 = np.maximum(t0, near / np.maximum(directions @ forward, 1e-12))
    t1 = np.minimum(t1, t_stop)
    t0, t1 = clip_interval(origins, directions, t0, t1, clip_planes)

    step = float(step_voxels) * min(float(np.linalg.norm(v.world_from_index()[:3, :3],
                                                          axis=0).min()) for v in volumes)
    color = np.zeros((n_rays, 3))
    trans = np.ones(n_rays)
    active = np.nonzero(t1 > t0)[0]
    t = t0[active].copy()
    while active.size:
        seg_end = np.minimum(t + step, t1[active])
        length = seg_end - t
        mid = 0.5 * (t + seg_end)
        sigma = np.zeros(active.size)
        emitted = np.zeros((active.size, 3))
        # Overlapping media add their extinctions; the emitted colour is their
        # extinction-weighted mean (one medium alone: its own colour and extinction).
        for index, (v, (o_idx, d_idx, v0, v1)) in enumerate(zip(volumes, rays, strict=True)):
            inside = (mid >= v0[active]) & (mid <= v1[active])
            if not inside.any():
                continue
            pts = o_idx[active][inside] + d_idx[active][inside] * mid[inside, None]
            rgb, sig = transfer_medium(v, sample(v, pts))
            if getattr(v, "colors", None) is not None:   # RGBA: its own colour
                rgb = sample_colors(v, pts)
            if shade is not None:
                rgb = shade.apply(v, pts, rgb, directions[active][inside])
            if grids is not None:
                medium = lit_through[index]
                if medium is not v:  # the member's index points in the group's grid
                    group_from_member = np.linalg.inv(medium.world_from_index()) \
                        @ v.world_from_index()
                    pts = pts @ group_from_member[:3, :3].T + group_from_member[:3, 3]
                rgb = lit_emission(medium, rgb, pts, lights, grids[id(medium)], ambient)
            sig = sig * scales[index][active][inside]   # per world unit of this ray
            sigma[inside] += sig
            emitted[inside] += sig[:, None] * rgb
        with np.errstate(invalid="ignore", divide="ignore"):
            rgb = np.where(sigma[:, None] > 0, emitted / sigma[:, None], 0.0)
        alpha = -np.expm1(-sigma * length)
        color[active] += (trans[active] * alpha)[:, None] * rgb
        trans[active] *= 1.0 - alpha
        t = seg_end
        keep = (t < t1[active]) & (trans[active] > min_transmittance)
        active, t = active[keep], t[keep]
    image = color + trans[:, None] * backdrop
    return image.reshape(origins_shape)
