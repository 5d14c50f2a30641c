"""Lit samples on the CPU: transmittance toward each light through the medium itself."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

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
    # the marching points' own arrays, compacted as points finish (gathering every array
    # through an index at each step cost as much as the samples); a directional light's
    # direction and scale are one for all
    active = np.nonzero(t_end > 0)[0]
    uniform = light.kind != "point"
    origin, ends = points[active], t_end[active]
    ways = toward_index[:1] if uniform else toward_index[active]
    scales = scale[:1] if uniform else scale[active]
    t, optical = np.zeros(active.size), np.zeros(active.size)
    while active.size:
        end = np.minimum(t + step, ends)
        sample = origin + ways * (0.5 * (t + end))[:, None]
        sigma = extinction_at(medium, sample)
        if clip_planes:
            sigma = sigma * kept(sample @ world_from_index[:3, :3].T + world_from_index[:3, 3],
                                 clip_planes)
        optical += sigma * (end - t) * scales
        t = end
        going = (end < ends) & (optical < 30.0)
        if not going.all():
            depth[active[~going]] = optical[~going]
            active, origin, ends = active[going], origin[going], ends[going]
            t, optical = t[going], optical[going]
            if not uniform:
                ways, scales = ways[going], scales[going]
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


#: A directional light's lattice: at most this many rays across each way, and samples
#: along each (more would cost more than the image gains; 128³ grids reach them).
LATTICE_RAYS = 192
LATTICE_STEPS = 384
#: Rays marched at once through a directional light's lattice (bounds the arrays' memory).
RAYS_AT_ONCE = 4096


@dataclass(frozen=True)
class LightField:
    """Transmittance toward one light on a lattice, and the map from index points into it."""

    values: np.ndarray
    lattice_from_index: np.ndarray

    def at(self, points_index: np.ndarray) -> np.ndarray:
        """The transmittance at index points, interpolated trilinearly."""
        matrix = self.lattice_from_index
        return trilinear(self.values, points_index @ matrix[:3, :3].T + matrix[:3, 3])


def light_fields(volume, lights: Sequence[VolumeLight], spacing_voxels: float = 0.5,
                 max_points: int = 96, step_voxels: float = 0.5,
                 clip_planes=None) -> list[LightField]:
    """Transmittance toward each light over the volume's (or group's) box.

    A directional light: on a lattice of parallel rays toward it, ``spacing_voxels`` of the
    smallest voxel apart and sampled as often, each ray marched once through the box (its
    points' transmittances are the sums of what lies beyond them along it). A point light:
    on a grid over the box, ``spacing_voxels`` apart (at most ``max_points`` per axis),
    each point marched toward the light with steps of ``step_voxels``. Either is
    interpolated trilinearly; :func:`transmittance_toward` gives exact values to check
    them against. On the CT phantom lit from the side, half-voxel steps are within 60 dB
    of quarter-voxel ones; a grid a voxel apart was 40 dB off half a voxel apart.
    """
    return [_directional_field(volume, light, spacing_voxels, clip_planes)
            if light.kind != "point" else
            _grid_field(volume, light, spacing_voxels, max_points, step_voxels, clip_planes)
            for light in lights]


def _grid_field(volume, light, spacing_voxels, max_points, step_voxels,
                clip_planes) -> LightField:
    """A point light's field: each point of a grid over the box marched toward it."""
    dims = np.array(volume.dimensions)
    counts = np.minimum(np.ceil((dims - 1) / spacing_voxels).astype(int) + 1, max_points)
    counts = np.maximum(counts, 2)
    axes = [np.linspace(0.0, d - 1.0, c) for d, c in zip(dims, counts, strict=True)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    values = transmittance_toward(volume, grid, light, step_voxels,
                                  clip_planes).reshape(counts)
    scale = (counts - 1.0) / np.maximum(dims - 1.0, 1.0)
    return LightField(values, np.diag([*scale, 1.0]))


def _directional_field(medium, light, spacing_voxels, clip_planes) -> LightField:
    """A directional light's field: a lattice of rays toward it, each marched once.

    The lattice's axes are two directions across the light and the direction toward it
    (world units); it covers the box's corners. A ray's samples are the midpoints of the
    parts of its steps inside the box; a lattice point's optical depth is the sum of those
    beyond it, toward the light.
    """
    world_from_index = medium.world_from_index()
    index_from_world = np.linalg.inv(world_from_index)
    toward = -np.asarray(light.direction, dtype=np.float64)
    toward = toward / np.linalg.norm(toward)
    across = np.cross(toward, np.eye(3)[int(np.argmin(np.abs(toward)))])
    across = across / np.linalg.norm(across)
    basis = np.stack([across, np.cross(toward, across), toward])   # rows: u, v, s
    upper = np.array(medium.dimensions, dtype=np.float64) - 1.0
    corners = np.array(np.meshgrid(*[(0.0, u) for u in upper], indexing="ij")).reshape(3, -1).T
    projected = (corners @ world_from_index[:3, :3].T + world_from_index[:3, 3]) @ basis.T
    low, high = projected.min(axis=0), projected.max(axis=0)
    voxel = float(np.linalg.norm(world_from_index[:3, :3], axis=0).min())
    wanted = np.ceil((high - low) / (spacing_voxels * voxel)).astype(int) + 1
    counts = np.maximum(np.minimum(wanted, (LATTICE_RAYS, LATTICE_RAYS, LATTICE_STEPS)), 2)
    spacing = np.maximum((high - low) / (counts - 1), 1e-12 * voxel)
    lattice_from_world = np.eye(4)
    lattice_from_world[:3, :3] = basis / spacing[:, None]
    lattice_from_world[:3, 3] = -low / spacing
    u, v = np.meshgrid(np.arange(counts[0]), np.arange(counts[1]), indexing="ij")
    starts_world = (low[0] + u.ravel()[:, None] * spacing[0]) * basis[0] \
        + (low[1] + v.ravel()[:, None] * spacing[1]) * basis[1] + low[2] * basis[2]
    starts = starts_world @ index_from_world[:3, :3].T + index_from_world[:3, 3]
    way = index_from_world[:3, :3] @ toward   # index units per world unit toward the light
    enter, leave = ray_box_interval(starts, np.broadcast_to(way, starts.shape), np.zeros(3),
                                    upper)
    scale = float(data_per_world(medium, toward[None])[0])
    edges = np.arange(counts[2]) * spacing[2]     # the lattice points along a ray
    optical = np.zeros((len(starts), counts[2]))
    for first in range(0, len(starts), RAYS_AT_ONCE):
        rays = slice(first, first + RAYS_AT_ONCE)
        a = np.maximum(edges[None, :-1], enter[rays, None])
        b = np.minimum(edges[None, 1:], leave[rays, None])
        inside = b > a
        if not inside.any():
            continue
        which, step = np.nonzero(inside)
        middle = 0.5 * (a[inside] + b[inside])
        points = starts[rays][which] + middle[:, None] * way
        sigma = extinction_at(medium, points)
        if clip_planes:
            sigma = sigma * kept(points @ world_from_index[:3, :3].T + world_from_index[:3, 3],
                                 clip_planes)
        steps = np.zeros(a.shape)
        steps[which, step] = sigma * (b[inside] - a[inside]) * scale
        # a lattice point's depth: every step beyond it toward the light
        optical[rays, :-1] = np.cumsum(steps[:, ::-1], axis=1)[:, ::-1]
    values = np.exp(-optical).reshape(counts)
    return LightField(values, lattice_from_world @ world_from_index)


def lit_emission(volume, rgb: np.ndarray, points_index: np.ndarray,
                 lights: Sequence[VolumeLight], fields: Sequence[LightField],
                 ambient: float) -> np.ndarray:
    """``rgb`` of samples at ``points_index`` scaled by the light reaching them."""
    light = np.zeros_like(rgb)
    for light_spec, field in zip(lights, fields, strict=True):
        light += field.at(points_index)[:, None] * light_spec.radiance
    return rgb * (ambient + (1.0 - ambient) * light)
