"""Overlapping volumes marched as one medium: the group, and how volumes fall into groups.

Where members overlap their extinctions add and the emission is their extinction-weighted
mean, on the GPU (``joint_sample.glsl``) as in the CPU reference. Numpy only.
"""

from __future__ import annotations

import math

import numpy as np

from .volume import VolumeModel, checked_values

#: Most members one joint group marches (GLSL 1.50 needs one set of uniforms per member).
MAX_GROUP_MEMBERS = 4
#: The virtual grid of a group has at most this many times the points of its largest
#: member's longest axis along the union box's longest axis (see :class:`VolumeGroup`).
GROUP_GRID_FACTOR = 2


class VolumeGroup:
    """Overlapping volumes drawn as one: the union of their world boxes on a virtual grid.

    The grid is axis-aligned in the world; it holds no data, only the placement the
    marchers step through. It is as fine as the finest member's voxels, but has at most
    ``GROUP_GRID_FACTOR`` times the largest member's points along the union box's longest
    axis: a tiny member inside a huge one would otherwise make every ray across the union
    box take millions of steps. The march cuts each ray where it enters or leaves a member's
    box and steps every piece on the finest grid over it (this grid or a member's own,
    ``ea_march.glsl``), so a member finer than the grid is still stepped at its own spacing.
    Each member keeps its own data, transfer function and placement. The channels of one
    multi-component volume are such a group too, co-located (``channel_mix`` says how they
    mix, :mod:`.channels`).
    """

    def __init__(self, members: list[VolumeModel], name: str | None = None,
                 channel_mix: str | None = None):
        if not 2 <= len(members) <= MAX_GROUP_MEMBERS:
            raise ValueError(f"A joint group holds 2 to {MAX_GROUP_MEMBERS} volumes, got "
                             f"{len(members)}; split the scene or keep fewer volumes "
                             "overlapping.")
        sizes = {m.transfer.n_colors for m in members}
        if len(sizes) != 1:
            raise ValueError("Overlapping volumes need transfer tables of the same size "
                             f"(n_colors), got {sorted(sizes)}.")
        self.members = list(members)
        #: A channel volume's mixing ('composite' or 'additive'; models/channels.py), or
        #: None for volumes that merely overlap (marched as one medium).
        self.channel_mix = channel_mix
        self.name = name or "+".join(m.name for m in members)
        bounds = np.array([m.world_bounds() for m in members])
        self.lower = bounds[:, 0::2].min(axis=0)
        upper = bounds[:, 1::2].max(axis=0)
        spacing = min(float(np.linalg.norm(m.world_from_index()[:3, :3], axis=0).min())
                      for m in members)
        most_points = GROUP_GRID_FACTOR * max(max(m.dimensions) for m in members)
        spacing = max(spacing, float((upper - self.lower).max()) / (most_points - 1))
        extent = np.maximum(upper - self.lower, spacing)
        self.shape = tuple(int(math.ceil(e / spacing - 1e-9)) + 1 for e in extent)
        self.spacing = extent / (np.array(self.shape) - 1.0)
        self.transfer = members[0].transfer  # the table size, shared by every member

    def shared_transform(self) -> np.ndarray | None:
        """The placement every member shares (a channel volume's), or None if they differ."""
        first = np.asarray(self.members[0].transform, dtype=np.float64)
        same = all(np.array_equal(np.asarray(m.transform, dtype=np.float64), first)
                   for m in self.members[1:])
        return first if same else None

    @property
    def dimensions(self) -> tuple[int, int, int]:
        """Points of the virtual grid along x, y, z."""
        return self.shape

    def world_from_index(self) -> np.ndarray:
        """4x4 from the virtual grid's point indices to world."""
        matrix = np.eye(4)
        matrix[:3, :3] = np.diag(self.spacing)
        matrix[:3, 3] = self.lower
        return matrix

    def world_bounds(self) -> np.ndarray:
        """``(xmin, xmax, ymin, ymax, zmin, zmax)`` of the union box."""
        upper = self.lower + self.spacing * (np.array(self.shape) - 1.0)
        return np.column_stack([self.lower, upper]).ravel()

    def set_member_values(self, member: str | None, values) -> int:
        """Replace the data of the member named ``member`` (same shape); return its index."""
        names = [m.name for m in self.members]
        if member not in names:
            raise ValueError(f"member must name one of the volumes marched jointly, {names}; "
                             f"got {member!r}.")
        index = names.index(member)
        target = self.members[index]
        if getattr(target, "colors", None) is not None:
            raise ValueError(f"{target.name!r} is an RGBA volume marched jointly; its colours "
                             "change by adding the volumes again (pv_cubemarch.add_volumes).")
        values, _ = checked_values(values, target.name, "raise", offset=target.value_offset)
        if values.shape != target.values.shape:
            raise ValueError(f"values must keep {target.name!r}'s shape {target.values.shape}, "
                             f"got {values.shape}.")
        target.values = np.ascontiguousarray(values, dtype=np.float32)
        return index


def boxes_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two world bounds ``(xmin, xmax, ...)`` share a volume (touching is not)."""
    return bool(all(a[2 * i] < b[2 * i + 1] and b[2 * i] < a[2 * i + 1] for i in range(3)))


def overlap_groups(volumes: list[VolumeModel]) -> list[list[VolumeModel]]:
    """Volumes partitioned into groups of overlapping boxes (directly or through others).

    A volume alone is a group of one; the order of first appearance is kept.
    """
    bounds = [v.world_bounds() for v in volumes]
    parent = list(range(len(volumes)))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i in range(len(volumes)):
        for j in range(i + 1, len(volumes)):
            if boxes_overlap(bounds[i], bounds[j]):
                parent[root(j)] = root(i)
    groups: dict[int, list[VolumeModel]] = {}
    for i, volume in enumerate(volumes):
        groups.setdefault(root(i), []).append(volume)
    return list(groups.values())
