"""A scene in a plotter whose techniques' knobs can be turned, each change drawn and timed.

No GUI here: :mod:`.app` binds these calls to controls. A change applies to every item of
its kind (every volume, voxel grid or surface of the scene), re-adds them with the new
options under the same names (which replaces and frees the old ones), and draws a frame.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field, replace

import numpy as np
import pyvista
from vtkmodules.vtkCommonCore import vtkCommand

from ..api import add_surface, add_volume, add_voxels
from ..bench.harness import opaque_layer
from ..core.camera import Camera
from ..core.declared import declared
from ..core.frame_errors import observe
from ..core.registry import get_technique, specific_option_names, techniques
from ..core.rendering import render_image
from ..image_metrics import compare_images
from ..models.group import overlap_groups
from ..models.surface import SplineField
from ..models.voxels import VoxelModel, label_legend
from ..models.world import VoxelWorld
from ..quality.surfaces import PICKED as SURFACE_PICKED
from ..quality.volumes import PICKED as VOLUME_PICKED
from ..scene.model import Scene
from ..voxels.paged_labels import PagedLabels
from .knobs import Knob, surface_knobs, volume_knobs, voxel_knobs

#: The kinds of items, in panel order.
KINDS = ("volume", "voxels", "surface")


@dataclass
class TunedItem:
    """One drawn model, its options, where it is and the binding that draws it now.

    ``name`` is its actor's name, ``renderer`` the index of its renderer in the plotter.
    """

    kind: str
    model: object
    options: dict = field(default_factory=dict)
    name: str = ""
    renderer: int = 0
    binding: object = None


class TuningSession:
    """A scene drawn in ``plotter`` with knobs per kind of technique.

    Parameters
    ----------
    scene : Scene or None
        What to draw (see :func:`pv_cubemarch.load_scene`), with its own options; ``None``
        adopts the techniques' actors ``plotter`` holds (see :meth:`from_plotter`).
    plotter : pyvista.Plotter
        Where; a scene is added to it now. Either way the items are what was drawn:
        volumes marched jointly are one item, re-added as their group.
    """

    def __init__(self, scene: Scene | None, plotter: pyvista.Plotter):
        self.scene = scene if scene is not None else Scene()
        self.plotter = plotter
        self.items: dict[str, TunedItem] = {}
        if scene is not None:
            scene.add_to(plotter)
        self._adopt(plotter)            # what was drawn, volumes marched jointly as one item
        if scene is None:
            self.scene.volumes = [i.model for i in self.items.values() if i.kind == "volume"]
            self.scene.background = tuple(pyvista.Color(plotter.background_color).float_rgb)
        else:
            self._take_scene_options(scene)
        self._originals = {name: item.model for name, item in self.items.items()}
        #: Each voxel grid's material opacities as loaded (shown again at these).
        self._opacities = {name: item.model.palette.rgba[:, 3].copy()
                           for name, item in self.items.items() if item.kind == "voxels"}
        self.level_shift = 0.0
        #: Milliseconds of the last frame drawn (after the last change).
        self.last_frame_ms: float | None = None
        #: Milliseconds of the last frame the window drew, whoever asked for it (a drag's
        #: frames are drawn by the view itself); nested renders count with their frame.
        self.window_frame_ms: float | None = None
        self._frame_depth, self._frame_started = 0, 0.0
        window = plotter.ren_win
        observe(window, vtkCommand.StartEvent, self._frame_begins)
        observe(window, vtkCommand.EndEvent, self._frame_ends, -10.0)

    def _frame_begins(self, *_) -> None:
        self._frame_depth += 1
        if self._frame_depth == 1:
            self._frame_started = time.perf_counter()

    def _frame_ends(self, *_) -> None:
        self._frame_depth = max(self._frame_depth - 1, 0)
        if self._frame_depth == 0:
            self.window_frame_ms = 1000.0 * (time.perf_counter() - self._frame_started)

    def _take_scene_options(self, scene: Scene) -> None:
        """The scene's own options for its items, and the technique each was drawn with.

        A volume marched jointly was drawn with its group's first volume's options (as
        :meth:`Scene.add_to` does), and ``'vtk'`` becomes ``'direct'`` for a group.
        """
        tables = {"volume": scene.volume_options, "voxels": scene.voxel_options,
                  "surface": scene.surface_options}
        leader = {v.name: group[0].name for group in overlap_groups(scene.volumes)
                  for v in group}
        for item in self.items.values():
            model = getattr(item.model, "members", [item.model])[0]
            key = leader.get(model.name, model.name) if item.kind == "volume" else model.name
            if key in tables[item.kind]:
                drawn = item.options.get("technique")
                item.options = dict(tables[item.kind][key])
                if drawn is not None:
                    item.options["technique"] = drawn

    @classmethod
    def from_plotter(cls, plotter: pyvista.Plotter) -> TuningSession:
        """A session over the volumes, voxel grids and surfaces already in ``plotter``.

        Their options are read back from their actors where the actors keep them (a
        volume's technique, and the step and stop opacity of marched ones; a voxel grid's
        and a surface's options and technique); the others (a cube map's face size, a
        volume's lights) are drawn at their defaults from the first change on. Meshes stay
        as they are; the error against the CPU reference leaves them out.
        """
        return cls(None, plotter)

    def _adopt(self, plotter: pyvista.Plotter) -> None:
        """Items for the techniques' actors the plotter holds.

        Labelled by actor name, suffixed by the renderer where one name is in several.
        """
        found = adoptable_actors(plotter)
        names = [name for name, _, _ in found]
        for name, actor, index in found:
            binding = actor.cubemarch
            model = binding.model
            if isinstance(model, SplineField):
                # the active-cell technique keeps its active cells; the full march has none
                kind, options = "surface", {
                    **_fields(binding.options),
                    "technique": "active" if binding.cells is not None else "full"}
            elif isinstance(model, (VoxelModel, VoxelWorld)):
                kind, options = "voxels", _fields(binding.options)
            else:
                kind, options = "volume", {"technique": binding.technique}
                reader = get_technique("volume", binding.technique)
                for option in ("step_scale", "stop_opacity", "downsample"):
                    if hasattr(binding, option) and (option in reader.option_names
                                                     or option == "stop_opacity"):
                        options[option] = getattr(binding, option)
                if getattr(binding, "blending", "composite") != "composite":
                    options["blending"] = binding.blending
                if getattr(binding, "isosurfaces", None) is not None:
                    options["isosurfaces"] = binding.isosurfaces
            options.update(plotter.cubemarch.scalar_bar_keywords(actor))
            label = name if names.count(name) == 1 else f"{name} (renderer {index})"
            self.items[label] = TunedItem(kind, model, options, name, index, binding)

    def _renderer_index(self, renderer) -> int:
        return list(self.plotter.renderers).index(renderer)

    def actor(self, item: TunedItem | str):
        """The actor an item (or the item of that label) is drawn by now."""
        item = self.items[item] if isinstance(item, str) else item
        return self.plotter.renderers[item.renderer].actors[item.name]

    def holds_all_of(self, plotter: pyvista.Plotter) -> bool:
        """Whether the items are still what ``plotter`` holds (none replaced, added or gone).

        Compared by binding: an actor added again under the same name is a new one.
        """
        found = {(index, name): actor.cubemarch for name, actor, index in
                 adoptable_actors(plotter)}
        ours = {(item.renderer, item.name): item.binding for item in self.items.values()}
        return found.keys() == ours.keys() and all(found[k] is ours[k] for k in found)

    def kinds(self) -> list[str]:
        """The kinds of items the scene holds, in panel order."""
        present = {item.kind for item in self.items.values()}
        return [kind for kind in KINDS if kind in present]

    def knobs(self, kind: str) -> tuple[Knob, ...]:
        """The knobs of ``kind``."""
        if kind == "volume":
            return volume_knobs()
        if kind == "voxels":
            return voxel_knobs(self._materials(), self._label_count())
        coefficients = np.concatenate([item.model.coefficients.ravel() for item in
                                       self._of("surface")])
        spread = float(np.ptp(coefficients)) or 1.0
        return surface_knobs((-spread / 2.0, spread / 2.0))

    def value(self, kind: str, name: str):
        """The knob's current value (the first item's; a change sets every item's)."""
        if kind == "surface" and name == "isovalue":
            return self.level_shift
        item = self._of(kind)[0]
        if kind == "voxels" and name == "materials":     # shown in any grid
            return [m for m in self._materials() if any(
                _shown_in(grid.model, m) for grid in self._of("voxels"))]
        if name in item.options:
            value = item.options[name]
            return "none" if name == "lights" and value is None else value
        return _default(kind, item.options.get("technique"), name)

    def set(self, kind: str, name: str, value) -> float:
        """Set a knob on every item of ``kind``, redraw; return the frame's milliseconds.

        A technique that does not read an option set for another is given the option left
        out (its default), as the panel greys the knob out. A value a technique refuses
        raises its ``ValueError`` and leaves every item as it was. The time returned is
        the second frame's: the first after adding builds the shaders. The voxel knob
        ``materials`` (the materials shown) changes only the palettes, a few bytes each.
        """
        if kind == "voxels" and name == "materials":
            self._show_materials(set(value))
            self.draw()
            return self.draw()
        done = []
        try:
            for item_name, item in self.items.items():
                if item.kind != kind:
                    continue
                done.append((item, item.model, dict(item.options), self.level_shift))
                if kind == "surface" and name == "isovalue":
                    self.level_shift = float(value)
                    original = self._originals[item_name]
                    item.model = replace(original, coefficients=original.coefficients
                                         - self.level_shift)
                else:
                    item.options[name] = None if name == "lights" and value == "none" \
                        else value
                    if kind == "volume":
                        _settle_isosurfaces(item.options, name)
                    if kind in QUALITY_PICKS:
                        _settle_quality(item.options, name, QUALITY_PICKS[kind])
                self._add(item)
        except Exception:       # refused (ValueError, or TypeError for a wrong type)
            for item, model, options, shift in done:   # back as it was
                item.model, item.options, self.level_shift = model, options, shift
                self._add(item)
            raise
        self.draw()
        return self.draw()

    def draw(self) -> float:
        """Draw a frame; return (and keep) its milliseconds."""
        start = time.perf_counter()
        render_image(self.plotter)
        self.last_frame_ms = 1000.0 * (time.perf_counter() - start)
        return self.last_frame_ms

    def reference_error(self, step_voxels: float = 0.1) -> dict:
        """The frame's error against the CPU reference of the scene's volume (slow).

        Returns the image metrics (``mean_abs``, ``psnr``, ``ssim`` ...). Only scenes with
        one volume (and meshes) have a reference here.
        """
        volumes = self._of("volume")
        if len(volumes) != 1 or self._of("voxels") or self._of("surface"):
            raise ValueError("the error against the CPU reference is measured for scenes "
                             "of one volume (and meshes); this one has "
                             f"{len(volumes)} volumes, {len(self._of('voxels'))} voxel "
                             f"grids and {len(self._of('surface'))} surfaces")
        item = volumes[0]
        width, height = self.plotter.window_size
        camera = Camera.from_pyvista(self.plotter.camera)    # where the user has turned to
        color, distance = opaque_layer(self.scene, camera, (width, height))
        technique = get_technique("volume", item.options.get("technique", "vtk"))
        reference = technique.reference(
            item.model, camera, (width, height), step_voxels=step_voxels,
            opaque_depth=distance, opaque_color=color,
            near=camera.clipping_range[0] if camera.clipping_range else None)
        return compare_images(render_image(self.plotter), reference).as_dict()

    def _materials(self) -> tuple:
        """The label ids of the voxel grids (at most :data:`LISTED_MATERIALS`, ascending).

        Ids past 2^53 are listed as strings: a browser's numbers would round them.
        """
        found: set[int] = set()
        for item in self._of("voxels"):
            ids = item.model.ids
            rows = ids.ids if not ids.identity else np.arange(1, item.model.palette.n_materials)
            found.update(int(v) for v in rows[:LISTED_MATERIALS])
        listed = sorted(found)[:LISTED_MATERIALS]
        return tuple(v if abs(v) < 2**53 else str(v) for v in listed)

    def legend(self) -> list[dict]:
        """The listed label ids with their colour as drawn now: the live view's legend.

        One entry per id of :meth:`knobs`' label list (ascending, ids past 2^53 as
        strings), from the first grid holding it: ``{"id", "color": "#rrggbb", "opacity",
        "hidden"}``; ``hidden`` also when its opacity is 0 (drawn as empty).
        """
        entries: dict[int, dict] = {}
        for item in self._of("voxels"):
            for entry in label_legend(item.model, LISTED_MATERIALS):
                entries.setdefault(int(entry["id"]), entry)
        legend = []
        for label in sorted(entries)[:LISTED_MATERIALS]:
            entry = dict(entries[label])
            entry["id"] = label if abs(label) < 2**53 else str(label)
            entry["hidden"] = bool(entry["hidden"] or entry["opacity"] == 0.0)
            legend.append(entry)
        return legend

    def _label_count(self) -> int:
        """How many distinct label ids the voxel grids hold together."""
        every = [item.model.ids.ids if not item.model.ids.identity else
                 np.arange(1, item.model.palette.n_materials) for item in self._of("voxels")]
        if not every:
            return 0
        if len(every) == 1:
            return int(every[0].size)
        return len({int(v) for ids in every for v in ids.tolist()})

    def _show_materials(self, shown: set) -> None:
        """Hide the listed ids taken out of ``shown``, show those put in, in every grid.

        Only the change from the knob's value counts: an id shown in one grid and hidden
        (by its palette) in another stays so until the knob itself moves it.
        """
        shown = {int(m) for m in shown}
        listed = {int(m) for m in self._materials()}
        unknown = shown - listed
        if unknown:
            named = sorted(unknown)   # a few, not all: the message goes back to the page
            raise ValueError(f"{len(named):,} materials ({', '.join(map(str, named[:5]))}"
                             f"{', ...' if len(named) > 5 else ''}) are not in the voxel "
                             f"palettes (listed: {len(listed)} label ids)")
        before = {int(m) for m in self.value("voxels", "materials")}
        for name, item in self.items.items():
            if item.kind != "voxels":
                continue
            binding, loaded, ids = item.binding, self._opacities[name], item.model.ids
            for material in sorted((before - shown) | (shown - before)):
                if not ids.has([material])[0] or material == ids.background:
                    continue
                row = int(ids.rows_of([material])[0])
                if row < len(loaded):     # only the palette's few bytes go to the GPU
                    binding.set_material(material, opacity=(float(loaded[row]) or 1.0)
                                         if material in shown else 0.0)

    def _of(self, kind: str) -> list[TunedItem]:
        return [item for item in self.items.values() if item.kind == kind]

    def _add(self, item: TunedItem) -> None:
        """Add the item again under its name, in its renderer (replacing the old one).

        It keeps the placement its actor has now (PyVista's calls may have moved it since
        it was added: a surface's model is a copy made by ``add_surface``).
        """
        live = getattr(item.binding, "model", None)
        if (live is not None and live is not item.model and hasattr(live, "transform")
                and hasattr(item.model, "transform")
                and not np.array_equal(live.transform, item.model.transform)):
            item.model = replace(item.model, transform=np.array(live.transform, np.float64))
        technique = item.options.get("technique") or DEFAULT_TECHNIQUE[item.kind]
        reader = get_technique(item.kind, technique)
        # options some technique of the kind reads and this one does not are left out
        specific = specific_option_names(item.kind)
        options = {key: value for key, value in item.options.items()
                   if key not in specific or key in reader.option_names}
        if options.get("lights") == "scene" and self.scene.usd_lighting:
            options["lights"] = self.scene.volume_lights()   # as Scene.add_to lights them
        adders = {"volume": add_volume, "voxels": add_voxels, "surface": add_surface}
        active = self._renderer_index(self.plotter.renderer)
        self._make_active(item.renderer)
        try:
            actor = adders[item.kind](self.plotter, item.model, name=item.name, **options)
            item.binding = actor.cubemarch
        finally:
            self._make_active(active)

    def _make_active(self, index: int) -> None:
        """Make renderer ``index`` the plotter's active one (any subplot layout)."""
        self.plotter.subplot(*np.atleast_1d(self.plotter.renderers.index_to_loc(index)))


#: Materials listed by the ``materials`` knob (the first of a larger palette).
LISTED_MATERIALS = 64


def _shown_in(model, label) -> bool:
    """Whether grid ``model`` holds label id ``label`` and draws it."""
    ids, label = model.ids, int(label)
    if label == ids.background or not ids.has([label])[0]:
        return False
    row = int(ids.rows_of([label])[0])
    return row < model.palette.n_materials and bool(model.palette.visible[row])
#: Each kind's default technique.
DEFAULT_TECHNIQUE = {"volume": "vtk", "voxels": "voxels", "surface": "active"}
#: Defaults of knobs that are not fields of a technique's options dataclass.
_OTHER_DEFAULTS = {"lights": "none"}   # as the knob shows it


def adoptable_actors(plotter: pyvista.Plotter) -> list[tuple[str, object, int]]:
    """``(name, actor, renderer index)`` of each of our techniques' actors in ``plotter``.

    Actors a binding draws for another one (the direct half of an ``auto`` volume, a
    world's chunks: their binding's ``actor`` is that other one's) are left out, and label
    grids streamed by bricks and surfaces of several levels (drawn as they are: no knob
    re-adds them yet; the surface knobs tune one level, and would draw only the first).
    """
    return [(name, actor, index) for index, renderer in enumerate(plotter.renderers)
            for name, actor in renderer.actors.items()
            if getattr(getattr(actor, "cubemarch", None), "model", None) is not None
            and not isinstance(actor.cubemarch.model, PagedLabels)
            and len(getattr(actor.cubemarch, "values", None) or ()) < 2
            and getattr(actor.cubemarch, "actor", actor) is actor]


def _fields(options) -> dict:
    """An options dataclass as keyword arguments, unset (``None``) fields left out."""
    return {key: value for key, value in dataclasses.asdict(options).items()
            if value is not None}


#: The settings an error budget chooses, per kind of item.
QUALITY_PICKS = {"volume": VOLUME_PICKED, "surface": SURFACE_PICKED,
                 "voxels": ("traversal", "step_scale", "lod", "lod_bias")}
#: The levels a volume switched to blending='isosurface' gets (three inside its range).
DEFAULT_ISOSURFACES = 5


def _settle_quality(options: dict, changed: str, picked: tuple) -> None:
    """An error budget and the settings it chooses are never set together.

    A quality asked for drops the ``picked`` knobs' values (it chooses them: a volume's
    step, face and samples, a surface's steps and root); one of those moved by hand takes
    the item back from the budget.
    """
    if changed == "quality" and options.get("quality") is not None:
        for name in picked:
            options.pop(name, None)
    elif changed in picked:
        options.pop("quality", None)


def _settle_isosurfaces(options: dict, changed: str) -> None:
    """Keep a volume's blend mode and its levels together as the knobs change either.

    Levels set turn the mode to 'isosurface'; the mode without levels gets
    :data:`DEFAULT_ISOSURFACES`; another mode drops them.
    """
    if changed == "isosurfaces" and options.get("isosurfaces") is not None:
        options["blending"] = "isosurface"
    if options.get("blending") == "isosurface":
        if options.get("isosurfaces") is None:
            options["isosurfaces"] = DEFAULT_ISOSURFACES
    else:
        options.pop("isosurfaces", None)


def _default(kind: str, technique: str | None, name: str):
    """An option's default for a technique (from its options dataclass), or ``None``."""
    if name == "technique":
        return DEFAULT_TECHNIQUE[kind]
    chosen = get_technique(kind, technique or DEFAULT_TECHNIQUE[kind])
    readers = [chosen] + [t for t in techniques(kind) if t is not chosen]
    for reader in readers:      # the chosen technique's default, else a reader's
        defaults = {f.name: f.default for f in dataclasses.fields(reader.options)}
        if name in defaults:
            return defaults[name]
    if name in _OTHER_DEFAULTS:
        return _OTHER_DEFAULTS[name]
    known = {item.name: item.default for item in declared(kind)}
    return known.get(name)
