"""Scenes: what a file holds that we draw (meshes, volumes, cameras, lights) and what we skipped."""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyvista
from PIL import Image

from ..api import add_surface, add_volumes, add_voxels
from ..core.camera import Camera
from ..core.errors import SceneWarning
from ..core.progress import progress
from ..core.rendering import offscreen_plotter, render_image
from ..models.channels import channel_grid, is_channels
from ..models.group import overlap_groups
from ..models.lights import VolumeLight
from ..models.surface import SplineField, point_hull
from ..models.volume import VolumeModel
from ..models.voxels import VoxelModel, count_labels, describe_labels, label_legend
from ..models.world import VoxelWorld
from .lighting import add_scene_lights
from .mesh_batches import batched
from .mesh_drawing import add_scene_mesh
from .parts import SceneLight, SceneMesh, SkippedPrim

DEFAULT_BACKGROUND = (0.1, 0.1, 0.12)


#: Label ids listed per voxel grid in a scene's summary.
LEGEND_ENTRIES = 10


@dataclass
class Scene:
    """Everything a scene file asks us to draw, in world coordinates.

    Build one with :func:`pv_cubemarch.load_scene`; draw it with :meth:`add_to` or
    :meth:`render`. ``volumes`` are drawn with :func:`pv_cubemarch.add_volumes` and the
    options in ``volume_options`` (by volume name); ``voxels`` (material grids) with
    :func:`pv_cubemarch.add_voxels` and the options in ``voxel_options`` (by grid name);
    ``surfaces`` (spline fields) with :func:`pv_cubemarch.add_surface` and the options in
    ``surface_options`` (by field name).
    """

    meshes: list[SceneMesh] = field(default_factory=list)
    volumes: list[VolumeModel] = field(default_factory=list)
    cameras: dict[str, Camera] = field(default_factory=dict)
    lights: list[SceneLight] = field(default_factory=list)
    skipped: list[SkippedPrim] = field(default_factory=list)
    up_axis: str = "Y"
    meters_per_unit: float = 1.0
    source: str = ""
    background: tuple[float, float, float] = DEFAULT_BACKGROUND
    volume_options: dict[str, dict] = field(default_factory=dict)
    voxels: list[VoxelModel | VoxelWorld] = field(default_factory=list)
    voxel_options: dict[str, dict] = field(default_factory=dict)
    surfaces: list[SplineField] = field(default_factory=list)
    surface_options: dict[str, dict] = field(default_factory=dict)
    #: The time code the file was read at (``None``: default values, nothing animated).
    time: float | None = None
    #: Lit as usdview lights a stage (a camera light when it has none), not as PyVista.
    usd_lighting: bool = False

    @property
    def camera(self) -> Camera | None:
        """The scene's first camera, or ``None``."""
        return next(iter(self.cameras.values()), None)

    def bounds(self) -> np.ndarray:
        """World bounds of all meshes, volume and voxel-grid boxes (a unit box if empty)."""
        boxes = [np.asarray(m.mesh.bounds) for m in self.meshes if m.mesh.n_points]
        boxes += [v.world_bounds() for v in (*self.volumes, *self.voxels, *self.surfaces)]
        if not boxes:
            return np.array([-1.0, 1.0, -1.0, 1.0, -1.0, 1.0])
        stack = np.array(boxes)
        return np.array([stack[:, 0].min(), stack[:, 1].max(), stack[:, 2].min(),
                         stack[:, 3].max(), stack[:, 4].min(), stack[:, 5].max()])

    def default_camera(self, aspect: float = 1.0) -> Camera:
        """A camera looking at the whole scene from the front, ``up_axis`` up."""
        return camera_for_bounds(self.bounds(), self.up_axis)

    def summary(self) -> str:
        """A human-readable account of what was loaded and what was skipped."""
        lines = [f"scene: {self.source}", f"up axis: {self.up_axis}, "
                 f"meters per unit: {self.meters_per_unit:g}",
                 f"meshes: {len(self.meshes)}"]
        lines += [f"  {m.name}: {m.mesh.n_points} points, {m.mesh.n_cells} faces"
                  for m in self.meshes]
        lines.append(f"volumes: {len(self.volumes)}")
        lines += [f"  {v.name}: " + (f"{len(v.members)} channels ({v.channel_mix}) of "
                                     f"{'x'.join(map(str, v.members[0].dimensions))} points"
                                     if is_channels(v) else
                                     f"{'x'.join(map(str, v.dimensions))} points")
                  for v in self.volumes]
        lines.append(f"voxel grids: {len(self.voxels)}")
        for g in self.voxels:
            lines.append(f"  {g.name}: {'x'.join(map(str, g.dimensions))} voxels, "
                         + (f"labels up to {int(g.labels.max())}" if isinstance(
                             g, VoxelModel) and g.ids.identity else
                            f"{len(g.stored) + len(g.uniform)} chunks of {g.chunk_size}^3"
                            if not isinstance(g, VoxelModel) else "compacted ids")
                         + f"; {describe_labels(g)}")
            legend = label_legend(g, LEGEND_ENTRIES)
            lines += [f"    {e['id']}: {e['color']}" + (f", opacity {e['opacity']:g}"
                      if e["opacity"] != 1.0 else "") for e in legend]
            if count_labels(g) > len(legend):
                lines.append(f"    ... {count_labels(g) - len(legend)} more")
        lines.append(f"surfaces: {len(self.surfaces)}")
        lines += [f"  {f.name}: {'x'.join(map(str, f.dimensions))} cells"
                  for f in self.surfaces]
        lines.append(f"cameras: {len(self.cameras)}")
        lines += [f"  {name}" for name in self.cameras]
        lines.append(f"lights: {len(self.lights)}")
        lines += [f"  {li.name}: {li.kind}, intensity {li.intensity:g}" for li in self.lights]
        lines.append(f"skipped: {len(self.skipped)}")
        lines += [f"  {s.path}: {s.reason}" for s in self.skipped]
        return "\n".join(lines)

    def to_multiblock(self) -> pyvista.MultiBlock:
        """The scene's meshes, volumes and voxel grids as a ``pyvista.MultiBlock``.

        This is what ``pv.read`` returns. A voxel grid is an ImageData with its labels in
        the cell data array ``"labels"`` (one cell per voxel), placed in the world, so
        ``pv_cubemarch.add_voxels(plotter, block)`` draws it where the scene does; a voxel
        world gives one such block per chunk that holds voxels. A surface is an ImageData
        with its field at each cell's centre in the array ``"field"`` (zero on the
        surface): ``pv_cubemarch.add_surface(plotter, block, isovalue=0.0)`` interpolates
        those values again, the same field where it came from samples or a mesh. Its values
        are cell data, or point data for a field drawn up to its samples (one made from
        point data: its ``domain`` is their hull), so that it is drawn there again.
        """
        blocks = pyvista.MultiBlock()
        for m in self.meshes:
            blocks[m.name] = m.mesh
        for v in self.volumes:
            grid = channel_grid(v) if is_channels(v) else v.grid.copy()
            transform = v.members[0].transform if is_channels(v) else v.transform
            if not np.allclose(transform, np.eye(4)):
                grid = grid.transform(transform, inplace=False)
            blocks[v.name] = grid
        for g in self.voxels:
            if isinstance(g, VoxelModel):
                blocks[g.name] = _cell_image(g, "labels", g.labels)
                continue
            for key in sorted(set(g.stored) | set(g.uniform)):   # a world: block per chunk
                chunk = g.chunk_model(key, whole=True)
                blocks[chunk.name] = _cell_image(chunk, "labels", chunk.labels)
        for f in self.surfaces:
            centred = f.on_lattice(1, centred=True)
            blocks[f.name] = _point_image(f, "field", centred) if f.domain is not None and \
                np.allclose(f.domain, point_hull(f.dimensions)) else \
                _cell_image(f, "field", centred)
        return blocks

    def add_to(self, plotter: pyvista.Plotter, camera: str | Camera | None = None,
               progress_bar: bool | None = None) -> dict:
        """Add meshes, lights, volumes, voxel grids, surfaces and the camera; return the actors.

        The actors come by name.

        ``camera`` picks a scene camera by name, or gives one; by default the scene's first
        camera, else a view of the whole scene.
        """
        actors = {}
        plotter.set_background(self.background)
        # parts that draw alike are one actor (20 000 actors would take minutes to add)
        for part, names in progress(batched(self.meshes), desc="adding meshes",
                                    enabled=progress_bar):
            try:
                actor = add_scene_mesh(plotter, part, self._report)
            except (ValueError, TypeError, IndexError, OSError, MemoryError) as exc:
                for name in names:                 # drawn without them
                    self._report(name, f"could not be drawn ({type(exc).__name__}: {exc})")
                continue
            actors.update(dict.fromkeys(names, actor))
        self._add_lights(plotter)
        # Volumes whose boxes overlap are marched jointly, with the first one's options; a
        # channel volume (already a group of its channels) is drawn as it is.
        groups = overlap_groups([v for v in self.volumes if not is_channels(v)]) + [
            [v] for v in self.volumes if is_channels(v)]
        if any(o.get("quality") is not None for o in (*self.volume_options.values(),
                                                       *self.surface_options.values(),
                                                       *self.voxel_options.values())):
            # quality= calibrates on the view: the scene's camera must be in place first
            self._apply_camera(plotter, camera)
            plotter.camera_set = True
        for group in progress(groups, desc="uploading volumes", enabled=progress_bar):
            options = self.volume_options.get(group[0].name, {})
            if options.get("lights") == "scene" and self.usd_lighting:
                options = {**options, "lights": self.volume_lights()}
            try:
                added = add_volumes(plotter, group, **options)
            except ValueError as error:   # say which volume's options are wrong
                raise type(error)(f"volume {group[0].name!r}: {error}") from error
            for v in group:
                actors[v.name] = added[0] if len(added) == 1 else \
                    next(a for a in added if v.name in a.cubemarch.name.split("+"))
        for grid in progress(self.voxels, desc="uploading voxel grids", enabled=progress_bar):
            try:
                actors[grid.name] = add_voxels(plotter, grid,
                                               **self.voxel_options.get(grid.name, {}))
            except ValueError as error:   # say which grid's options or data are wrong
                raise type(error)(f"voxel grid {grid.name!r}: {error}") from error
        for surface in progress(self.surfaces, desc="uploading surfaces",
                                enabled=progress_bar):
            try:
                actors[surface.name] = add_surface(
                    plotter, surface, **self.surface_options.get(surface.name, {}))
            except ValueError as error:   # say which surface's options are wrong
                raise type(error)(f"surface {surface.name!r}: {error}") from error
        self._apply_camera(plotter, camera)
        return actors

    def _apply_camera(self, plotter: pyvista.Plotter, camera: str | Camera | None) -> None:
        """Set the plotter's camera to the scene's (by name, given, first, or the default)."""
        chosen = self.cameras.get(camera) if isinstance(camera, str) else camera
        if isinstance(camera, str) and chosen is None:
            raise KeyError(f"No camera named {camera!r}; the scene has {list(self.cameras)}.")
        chosen = chosen or self.camera
        if chosen is None:
            width, height = plotter.window_size
            chosen = self.default_camera(width / height)
        chosen.apply_to(plotter.camera)
        if chosen.clipping_range is None:
            plotter.renderer.ResetCameraClippingRange()

    def _report(self, path: str, reason: str) -> None:
        """Record what is drawn otherwise than authored (once per path and reason)."""
        entry = SkippedPrim(path, reason, problem=True)
        reported = self.__dict__.setdefault(    # a set: 20 000 reports stay linear
            "_reported", {(s.path, s.reason) for s in self.skipped if s.problem})
        if (path, reason) not in reported:
            reported.add((path, reason))
            self.skipped.append(entry)
            warnings.warn(f"{path}: {reason}", SceneWarning, stacklevel=3)

    def _add_lights(self, plotter: pyvista.Plotter) -> None:
        """The scene's lights, as usdview draws them; other scenes keep the plotter's."""
        if self.lights or self.usd_lighting:
            add_scene_lights(plotter, self.lights, self._report)

    def volume_lights(self) -> list[VolumeLight] | str:
        """The scene's lights as a volume sees them (``'scene'`` when it has none).

        Intensities are scaled so the strongest is at most 1: a volume's lights modulate
        its emission, which has no physical unit.
        """
        lights = [li for li in self.lights if li.kind != "dome"]
        if not lights:
            return "scene"
        scale = 1.0 / max(max(li.intensity * li.area for li in lights), 1.0)
        return [VolumeLight("directional", direction=li.direction, color=li.color,
                            intensity=li.intensity * li.area * scale) if li.kind == "distant" else
                VolumeLight("point", position=li.position, color=li.color,
                            intensity=li.intensity * li.area * scale) for li in lights]

    def plotter_lighting(self) -> str:
        """The ``lighting=`` of the plotter a render makes: PyVista's default light kit.

        A scene with no lights of its own keeps the plotter's; where a volume is lit by
        them (``lights='scene'``), PyVista's three lights (the kit's five are more than a
        volume takes).
        """
        lit_by_plotter = not (self.lights or self.usd_lighting) and any(
            o.get("lights") == "scene" for o in self.volume_options.values())
        return "three lights" if lit_by_plotter else "light kit"

    def render(self, path: str | os.PathLike | None = None, size: tuple[int, int] = (800, 600),
               camera: str | Camera | None = None, progress_bar: bool | None = None) -> np.ndarray:
        """Render offscreen to an RGB array, and to ``path`` (PNG) when given.

        Examples
        --------
        >>> import pv_cubemarch
        >>> scene = pv_cubemarch.load_scene("datasets/smoke_scene.usda")  # doctest: +SKIP
        >>> image = scene.render("smoke.png", size=(640, 480))  # doctest: +SKIP
        """
        plotter = offscreen_plotter(size, lighting=self.plotter_lighting())
        try:
            self.add_to(plotter, camera=camera, progress_bar=progress_bar)
            image = render_image(plotter)
        finally:
            plotter.close()
        if path is not None:
            Path(path).parent.mkdir(parents=True, exist_ok=True)
            Image.fromarray(image).save(str(path))
        return image


def _cell_image(grid, name: str, values: np.ndarray) -> pyvista.ImageData:
    """A placed grid of cells as a world ImageData, ``values`` (x, y, z) as cell data ``name``."""
    matrix = grid.world_from_index()
    spacing = np.linalg.norm(matrix[:3, :3], axis=0)
    image = pyvista.ImageData(dimensions=tuple(n + 1 for n in grid.dimensions),
                              spacing=tuple(spacing), origin=tuple(matrix[:3, 3]))
    image.direction_matrix = matrix[:3, :3] / spacing
    image.cell_data[name] = np.asarray(values).ravel(order="F")
    return image


def _point_image(grid, name: str, values: np.ndarray) -> pyvista.ImageData:
    """A placed grid of cells as a world ImageData of a point at each cell's centre.

    ``values`` (x, y, z) are its point data ``name``.
    """
    matrix = grid.world_from_index()
    spacing = np.linalg.norm(matrix[:3, :3], axis=0)
    image = pyvista.ImageData(dimensions=tuple(grid.dimensions), spacing=tuple(spacing),
                              origin=tuple(matrix[:3, :3] @ np.full(3, 0.5) + matrix[:3, 3]))
    image.direction_matrix = matrix[:3, :3] / spacing
    image.point_data[name] = np.asarray(values).ravel(order="F")
    return image


def camera_for_bounds(bounds, up_axis: str = "Z") -> Camera:
    """A camera looking at ``bounds`` (xmin, xmax, ...) from the front, ``up_axis`` up."""
    b = bounds
    center = np.array([b[0] + b[1], b[2] + b[3], b[4] + b[5]]) / 2.0
    radius = max(np.linalg.norm([b[1] - b[0], b[3] - b[2], b[5] - b[4]]) / 2.0, 1e-12)
    up = {"Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}[up_axis]
    back = np.array((0.35, 0.3, 1.0) if up_axis == "Y" else (0.35, -1.0, 0.3))
    back /= np.linalg.norm(back)
    distance = radius / np.sin(np.radians(30.0) / 2.0) * 1.05
    return Camera(position=tuple(center + back * distance), focal_point=tuple(center),
                  view_up=up, view_angle=30.0)
