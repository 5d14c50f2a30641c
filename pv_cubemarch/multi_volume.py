"""Many volumes in one scene (000 section 3.4), and overlapping volumes marched jointly.

* :func:`classify` makes the paper's per-volume, per-frame choice between the cube map and
  direct marching: the cube map's visible texels against the volume's projected pixels.
  ``technique='auto'`` builds both for a volume and shows one per frame
  (:class:`AutoBinding`); the user can force either.
* Volumes whose boxes do not overlap are drawn by the scene overlay farthest first, which
  composites them in the right order. The paper leaves overlapping volumes as a limitation;
  :func:`add_volumes` groups volumes whose boxes overlap into a :class:`VolumeGroup`,
  marched as one medium over the union box (``joint_sample.glsl``): where members overlap
  their extinctions add and the emission is their extinction-weighted mean, as in the CPU
  reference (:func:`pv_cubemarch.render_emission_absorption` with several volumes).
"""

from __future__ import annotations

import math

import numpy as np
import pyvista
import vtk

from .cubemap_lod import cube_corners
from .gl_resources import Texture
from .volume import VolumeModel

#: Most members one joint group marches (GLSL 1.50 needs one set of uniforms per member).
MAX_GROUP_MEMBERS = 4


class VolumeGroup:
    """Overlapping volumes drawn as one: the union of their world boxes on a virtual grid.

    The grid is axis-aligned in the world, as fine as the finest member's voxels; it holds
    no data, only the placement the marchers step through. Each member keeps its own data,
    transfer function and placement.
    """

    def __init__(self, members: list[VolumeModel], name: str | None = None):
        if not 2 <= len(members) <= MAX_GROUP_MEMBERS:
            raise ValueError(f"A joint group holds 2 to {MAX_GROUP_MEMBERS} volumes, got "
                             f"{len(members)}; split the scene or keep fewer volumes "
                             "overlapping.")
        sizes = {m.transfer.n_colors for m in members}
        if len(sizes) != 1:
            raise ValueError("Overlapping volumes need transfer tables of the same size "
                             f"(n_colors), got {sorted(sizes)}.")
        self.members = list(members)
        self.name = name or "+".join(m.name for m in members)
        bounds = np.array([m.world_bounds() for m in members])
        self.lower = bounds[:, 0::2].min(axis=0)
        upper = bounds[:, 1::2].max(axis=0)
        spacing = min(float(np.linalg.norm(m.world_from_index()[:3, :3], axis=0).min())
                      for m in members)
        extent = np.maximum(upper - self.lower, spacing)
        self.shape = tuple(int(math.ceil(e / spacing - 1e-9)) + 1 for e in extent)
        self.spacing = extent / (np.array(self.shape) - 1.0)
        self.transfer = members[0].transfer  # the table size, shared by every member
        self._textures: dict = {}  # one upload per member, shared by every pass that binds

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

    def bind(self, target) -> None:
        """Give ``target`` (bindings or a pass) every member's data, table and placement."""
        from .emission_absorption import world_from_texture

        group_to_world = world_from_texture(self)
        for index, member in enumerate(self.members):
            if index not in self._textures:
                table = member.transfer.table.reshape(1, -1, 4)
                self._textures[index] = (Texture(member.values, kind="3d", interpolate=True),
                                         Texture(table, kind="2d"))
            data, table = self._textures[index]
            target.add_texture(f"cm_member{index}", data)
            target.add_texture(f"cm_memberTable{index}", table)
            target.set_uniform(f"cm_memberClim{index}", member.transfer.clim)
            target.set_uniform(f"cm_memberFromGroup{index}",
                               np.linalg.inv(world_from_texture(member)) @ group_to_world)
            target.set_uniform(f"cm_memberDims{index}",
                               tuple(float(n) for n in member.dimensions))

    def set_member_values(self, member: str | None, values) -> None:
        """Replace the data of the member named ``member`` (same shape) and its GPU copy."""
        from .volume import _checked_values

        names = [m.name for m in self.members]
        if member not in names:
            raise ValueError(f"member must name one of the volumes marched jointly, {names}; "
                             f"got {member!r}.")
        index = names.index(member)
        target = self.members[index]
        values = _checked_values(np.asarray(values), target.name, "raise")
        if values.shape != target.values.shape:
            raise ValueError(f"values must keep {target.name!r}'s shape {target.values.shape}, "
                             f"got {values.shape}.")
        target.values = np.ascontiguousarray(values, dtype=np.float32)
        if index in self._textures:
            self._textures[index][0].set_data(target.values)

    @property
    def defines(self) -> dict:
        """Feature switches of a joint shader."""
        return {"CM_JOINT": True, "CM_VOLUME_COUNT": len(self.members)}


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


def add_volumes(plotter: pyvista.Plotter, volumes, **options) -> list:
    """Add several volumes; those whose boxes overlap are marched jointly as one medium.

    Parameters
    ----------
    plotter : pyvista.Plotter
        The plotter to draw in.
    volumes : sequence of VolumeModel
        Volumes with their transfer functions and placements (see
        :func:`pv_cubemarch.make_volume`).
    **options
        Options of :func:`pv_cubemarch.add_volume` for every volume (or group).
        ``technique='vtk'`` cannot march a group; groups take ``'direct'`` then.

    Returns
    -------
    list
        One actor per group, in the order of the groups' first volumes.

    Examples
    --------
    >>> import numpy as np, pyvista as pv, pv_cubemarch as cm
    >>> shift = np.eye(4)
    >>> shift[0, 3] = 8.0  # half a box along x: the two boxes overlap
    >>> a = cm.make_volume(np.random.rand(16, 16, 16), name="a")
    >>> b = cm.make_volume(np.random.rand(16, 16, 16), name="b", transform=shift)
    >>> pl = pv.Plotter(off_screen=True)
    >>> actors = cm.add_volumes(pl, [a, b], technique="cubemap")  # doctest: +SKIP
    """
    from .emission_absorption import add_volume

    actors = []
    for group in overlap_groups(list(volumes)):
        if len(group) == 1:
            actors.append(add_volume(plotter, group[0], **options))
            continue
        joint = dict(options)
        if joint.get("technique", "vtk") == "vtk":
            joint["technique"] = "direct"
        for start in range(0, len(group), MAX_GROUP_MEMBERS):
            chunk = group[start:start + MAX_GROUP_MEMBERS]
            item = VolumeGroup(chunk) if len(chunk) > 1 else chunk[0]
            actors.append(add_volume(plotter, item, **joint))
    return actors


# ----------------------------------------------------------------------------------------
# Per-volume choice between the cube map and direct marching


def projected_pixels(clip_from_local: np.ndarray, size) -> float:
    """Pixels the box covers on screen (its projected hull clipped to the viewport)."""
    width, height = size
    clip = np.column_stack([cube_corners(), np.ones(8)]) @ clip_from_local.T
    if (clip[:, 3] <= 0).any():
        return float(width * height)  # the eye is close or inside: the box fills the view
    points = (clip[:, :2] / clip[:, 3:4] + 1.0) * 0.5 * np.array([width, height])
    hull = _clip_polygon(_convex_hull(points), width, height)
    if len(hull) < 3:
        return 0.0
    x, y = hull[:, 0], hull[:, 1]
    return float(0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _convex_hull(points: np.ndarray) -> np.ndarray:
    pts = sorted(map(tuple, points))

    def turn(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    def half(seq):
        chain = []
        for p in seq:
            while len(chain) >= 2 and turn(chain[-2], chain[-1], p) <= 0:
                chain.pop()
            chain.append(p)
        return chain

    lower, upper = half(pts), half(reversed(pts))
    return np.array(lower[:-1] + upper[:-1])


def _clip_polygon(polygon: np.ndarray, width: float, height: float) -> np.ndarray:
    """Sutherland-Hodgman clipping of a convex polygon to [0, width] x [0, height]."""
    for axis, bound, keep_below in ((0, 0.0, False), (0, width, True), (1, 0.0, False),
                                    (1, height, True)):
        if len(polygon) == 0:
            break
        out = []
        for a, b in zip(polygon, np.roll(polygon, -1, axis=0), strict=True):
            a_in = a[axis] <= bound if keep_below else a[axis] >= bound
            b_in = b[axis] <= bound if keep_below else b[axis] >= bound
            if a_in:
                out.append(a)
            if a_in != b_in:
                t = (bound - a[axis]) / (b[axis] - a[axis])
                out.append(a + t * (b - a))
        polygon = np.array(out)
    return polygon


def classify(visible_faces: int, face_size: int, pixels: float) -> str:
    """The paper's choice of technique for one volume in one frame.

    March the cube map when its visible texels are fewer than the pixels the volume covers,
    else march every pixel directly.
    """
    texels = visible_faces * face_size * face_size
    return "cubemap" if texels < pixels else "direct"


class AutoBinding:
    """A volume drawn by the cube map or directly, chosen per frame (``technique='auto'``).

    ``force`` (``None``, ``'cubemap'`` or ``'direct'``) overrides the choice; ``choice``
    and ``choices`` (a count per technique) say what was drawn.
    """

    technique = "auto"

    def __init__(self, plotter, direct_actor, cube_actor):
        self.renderer = plotter.renderer
        self.direct_actor = direct_actor
        self.cube_actor = cube_actor
        self.direct = direct_actor.cubemarch
        self.cubemap = cube_actor.cubemarch
        self.model = self.direct.model
        self.light_map = None
        self.force: str | None = None
        self.choice = "direct"
        self.choices = {"cubemap": 0, "direct": 0}
        self.actor = None
        self.extra_release: list = []
        frame = self.cubemap.frame
        update = frame.update
        self.cubemap.cube_pass.run_when = lambda: self.choice == "cubemap" and update()
        # Before anything draws: the direct box is drawn by this renderer's translucent pass.
        self._tag = self.renderer.AddObserver(vtk.vtkCommand.StartEvent, self._choose, 2.0)

    def _choose(self, *_):
        frame = self.cubemap.frame
        frame.update()
        if self.force in ("cubemap", "direct"):
            choice = self.force
        else:
            from .direct_march import _camera_matrices

            view, projection = _camera_matrices(self.renderer)
            pixels = projected_pixels(projection @ view @ frame.world_from_local,
                                      self.renderer.GetSize())
            choice = classify(bin(frame.face_mask).count("1"), frame.lod.level_size, pixels)
        self.choice = choice
        self.choices[choice] += 1
        self.direct_actor.SetVisibility(choice == "direct")
        self.cube_actor.SetVisibility(choice == "cubemap")

    @property
    def name(self) -> str:
        """The volume's name."""
        return self.model.name

    @property
    def bindings(self):
        """The direct box's bindings (the one drawn by the plotter's renderer)."""
        return self.direct.bindings

    @property
    def recipe(self):
        """The direct box's recipe."""
        return self.direct.recipe

    @property
    def lod(self):
        """The cube map's last LOD choice."""
        return self.cubemap.lod

    @property
    def memory(self) -> dict[str, int]:
        """GPU bytes of both paths (the cube map's targets exist once it was chosen)."""
        memory = dict(self.cubemap.memory)
        memory["direct"] = self.direct.nbytes
        if self.light_map is not None:
            memory["light_map"] = self.light_map.nbytes
        return memory

    @property
    def nbytes(self) -> int:
        """All GPU bytes of the volume."""
        return sum(self.memory.values())

    def set_transform(self, transform) -> None:
        """Move the volume (both paths follow; see ``VolumeBinding.set_transform``)."""
        from .emission_absorption import follow_placement

        self.direct.set_transform(transform)
        self.cubemap.set_transform(transform)
        follow_placement(self)

    def set_values(self, values, member: str | None = None) -> None:
        """Replace the data of both paths (same shape; ``member`` names one of a group)."""
        self.direct.set_values(values, member)
        self.cubemap.set_values(values, member)

    def release(self) -> None:
        """Free both paths."""
        self.renderer.RemoveObserver(self._tag)
        self.direct.release()
        self.cubemap.release()
        for release in self.extra_release:
            release()
        self.extra_release = []
        if self.light_map is not None:
            self.light_map.release()


def build_auto_actor(plotter, model: VolumeModel, options, step_scale: float,
                     stop_opacity: float, skip_empty: bool, light_map, volume_texture):
    """Both paths of a ``technique='auto'`` volume; returns the direct box's actor."""
    from .cubemap import build_cubemap_actor
    from .direct_march import build_direct_actor

    # The cube map first: it turns multisampling off, which the direct box must know.
    cube_actor = build_cubemap_actor(plotter, model, options, stop_opacity, skip_empty,
                                     light_map, volume_texture)
    direct_actor = build_direct_actor(plotter, model, step_scale, stop_opacity, skip_empty,
                                      1, light_map, volume_texture)
    cube_actor.cubemarch.actor = cube_actor
    cube_actor.cubemarch.renderer.AddActor(cube_actor)
    direct_actor.cubemarch.actor = direct_actor
    binding = AutoBinding(plotter, direct_actor, cube_actor)
    object.__setattr__(direct_actor, "cubemarch", binding)
    return direct_actor
