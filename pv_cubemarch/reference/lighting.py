"""Lit samples on the CPU: transmittance toward each light through the medium itself."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..models.group import VolumeGroup
from ..models.lights import VolumeLight
from .rays import data_per_world, ray_box_interval, sample, trilinear
from .transfer import extinction


def transmittance_toward(medium, points_index: np.ndarray, light: VolumeLight,
                         step_voxels: float = 0.25, clip_planes=None) -> np.ndarray:
    """Transmittance from each point (``medium``'s grid index coordinates) toward ``light``.

    ``medium`` is a :class:`VolumeModel`, or a :class:`~pv_cubemarch.VolumeGroup` whose
    members' extinctions add (index coordinates of its virtual grid). Marched with midpoint
    steps of ``step_voxels`` of the smallest voxel, up to the box or to a point light inside.
    Where ``clip_planes`` (world ``(origin, normal)``) cut the medium, it absorbs nothing.
    """
    world_from_index = medium.world_from_index()
    index_from_world = np.linalg.inv(world_from_index)
    points = np.asarray(points_index, dtype=np.float64).reshape(-1, 3)
    world = points @ world_from_index[:3, :3].T + world_from_index[:3, 3]
    if light.kind == "point":
        delta = np.asarray(light.position, dtype=np.float64) - world
        distance = np.linalg.norm(delta, axis=1)
        toward = delta / np.maximum(distance, 1e-300)[:, None]
    else:
        direction = -np.asarray(light.direction, dtype=np.float64)
        toward = np.broadcast_to(direction / np.linalg.norm(direction), world.shape)
        distance = np.full(len(world), np.inf)
    toward_index = toward @ index_from_world[:3, :3].T
    upper = np.array(medium.dimensions, dtype=np.float64) - 1.0
    _, t_exit = ray_box_interval(points, toward_index, np.zeros(3), upper)
    t_end = np.clip(np.minimum(t_exit, distance), 0.0, None)
    voxel = np.linalg.norm(world_from_index[:3, :3], axis=0)
    step = float(step_voxels) * float(voxel.min())
    scale = data_per_world(medium, toward)   # data units per world unit of the path
    depth = np.zeros(len(points))
    t = np.zeros(len(points))
    active = np.nonzero(t_end > 0)[0]
    while active.size:
        end = np.minimum(t[active] + step, t_end[active])
        middle = 0.5 * (t[active] + end)
        sample = points[active] + toward_index[active] * middle[:, None]
        sigma = extinction_at(medium, sample)
        if clip_planes:
            sigma = sigma * kept(sample @ world_from_index[:3, :3].T + world_from_index[:3, 3],
                                 clip_planes)
        depth[active] += sigma * (end - t[active]) * scale[active]
        t[active] = end
        keep = (end < t_end[active]) & (depth[active] < 30.0)
        active = active[keep]
    return np.exp(-depth)


def kept(world_points: np.ndarray, planes) -> np.ndarray:
    """1 where every plane keeps the world point (``normal . (x - origin) >= 0``), else 0."""
    keep = np.ones(len(world_points), dtype=bool)
    for origin, normal in planes:
        keep &= (world_points - np.asarray(origin, float)) @ np.asarray(normal, float) >= 0
    return keep.astype(np.float64)


def extinction_at(medium, points_index: np.ndarray) -> np.ndarray:
    """Extinction of ``medium`` (a volume, or a group: its members' sum) at index points."""
    if not isinstance(medium, VolumeGroup):
        return extinction(medium, sample(medium, points_index))
    world_from_group = medium.world_from_index()
    sigma = np.zeros(len(points_index))
    for member in medium.members:
        member_from_group = np.linalg.inv(member.world_from_index()) @ world_from_group
        local = points_index @ member_from_group[:3, :3].T + member_from_group[:3, 3]
        upper = np.array(member.dimensions, dtype=np.float64) - 1.0
        inside = np.all((local >= 0.0) & (local <= upper), axis=1)
        if inside.any():
            sigma[inside] += extinction(member, sample(member, local[inside]))
    return sigma


def light_grid(volume, lights: Sequence[VolumeLight], spacing_voxels: float = 0.5,
               max_points: int = 96, step_voxels: float = 0.5,
               clip_planes=None) -> np.ndarray:
    """Transmittance toward each light on a fine grid over the volume's (or group's) box.

    Returns ``(n_lights, gx, gy, gz)``; grid points span index 0 to ``dims - 1`` per axis,
    ``spacing_voxels`` apart (at most ``max_points`` per axis). The reference interpolates
    it trilinearly; :func:`transmittance_toward` gives exact values to check that against.
    Each point's march steps half a voxel: on the CT phantom lit from the side, the image
    is within 60 dB of quarter-voxel steps, in 0.55 of the time (the grid's spacing matters
    more: a voxel apart is 40 dB off half a voxel apart).
    """
    dims = np.array(volume.dimensions)
    counts = np.minimum(np.ceil((dims - 1) / spacing_voxels).astype(int) + 1, max_points)
    counts = np.maximum(counts, 2)
    axes = [np.linspace(0.0, d - 1.0, c) for d, c in zip(dims, counts, strict=True)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    return np.stack([transmittance_toward(volume, grid, li, step_voxels,
                                          clip_planes).reshape(counts) for li in lights])


def lit_emission(volume, rgb: np.ndarray, points_index: np.ndarray,
                 lights: Sequence[VolumeLight], grids: np.ndarray, ambient: float) -> np.ndarray:
    """``rgb`` of samples at ``points_index`` scaled by the light reaching them."""
    dims = np.array(volume.dimensions, dtype=np.float64)
    light = np.zeros_like(rgb)
    for light_spec, grid in zip(lights, grids, strict=True):
        scale = (np.array(grid.shape) - 1.0) / np.maximum(dims - 1.0, 1.0)
        transmittance = trilinear(grid, points_index * scale)
        light += transmittance[:, None] * light_spec.radiance
    return rgb * (ambient + (1.0 - ambient) * light)
