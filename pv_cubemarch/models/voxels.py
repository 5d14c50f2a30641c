"""Material grids: one integer label per voxel (0 = empty), a palette, and a placement.

A voxel ``(i, j, k)`` occupies ``[i, i+1] x [j, j+1] x [k, k+1]`` of the grid's index space;
:meth:`VoxelModel.world_from_index` places that space in the world. Labels are stored as
uint8 (up to 255 materials) or uint16 (up to 65535): one or two bytes per voxel.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pyvista

from ..core.errors import VolumeDataError
from ..core.gl_limits import MAX_GRID_BYTES, MAX_TEXTURE_SIZE
from .label_colors import check_by_id, colors_by_id, hashed_colors, palette_keys
from .label_ids import IDENTITY_MAX, LabelIds, label_rows, sorted_unique
from .transfer import table_range, unknown_cmap
from .volume import (
    box_world_bounds,
    check_geometry,
    check_spacing,
    checked_transform,
    first_point,
)

#: Most materials a grid may hold (uint16 labels).
MAX_MATERIALS = 65535
#: How thick the cells of a 2D image's flat axis are drawn, against its other spacings: a
#: sheet, as PyVista draws the image's cells (a whole spacing was a slab, 18.4 dB off).
FLAT_CELL_THICKNESS = 1e-3

#: Palette entries per row of the palette texture: 65536 entries in one row would be
#: wider than GL's 2D limit (16384 on Mesa), which draws nothing without an error.
PALETTE_WIDTH = 4096

def palette_texels(rgba: np.ndarray) -> np.ndarray:
    """A palette ``(n, 4)`` as the texture the shaders read, wrapped into rows.

    Rows of :data:`PALETTE_WIDTH` entries: material ``m`` at column ``m % width``, row
    ``m // width``; zero past ``n``.
    """
    rgba = np.asarray(rgba, dtype=np.float32)
    width = min(len(rgba), PALETTE_WIDTH)
    rows = -(-len(rgba) // width)
    out = np.zeros((rows * width, 4), np.float32)
    out[:len(rgba)] = rgba
    return out.reshape(rows, width, 4)

def _material_color(color, material) -> tuple:
    """``color`` (anything ``pyvista.Color`` takes) as RGB floats, or an error naming it."""
    try:
        return pyvista.Color(color).float_rgb
    except (ValueError, TypeError):
        raise ValueError(f"color {color!r} of material {material} is not a colour: give a "
                         "name ('tomato'), a hex string ('#ff6347') or an RGB sequence."
                         ) from None

class Palette:
    """Per-material colour and opacity: row ``m`` is material ``m`` (row 0, empty, unused).

    Opacity 0 hides a material (its voxels are traversed as empty); below 1 it is drawn
    translucent, composited front to back. Changing the palette re-uploads only this small
    table, never the labels.
    """

    def __init__(self, rgba: np.ndarray):
        rgba = np.asarray(rgba, dtype=np.float32)
        if rgba.ndim != 2 or rgba.shape[1] != 4 or len(rgba) < 2:
            raise VolumeDataError(f"A palette is an (n, 4) RGBA table with n >= 2, got shape "
                                  f"{rgba.shape}.")
        if not np.isfinite(rgba).all() or rgba.min() < 0 or rgba.max() > 1:
            raise VolumeDataError("Palette colours and opacities must be in [0, 1].")
        #: What is drawn: the colours and opacities below, hidden rows at opacity 0,
        #: highlighted ones in the highlight colour.
        self.rgba = np.ascontiguousarray(rgba)
        self.version = 0   # bumped at each change, so the GPU copy follows
        self._base: np.ndarray | None = None   # the rows' own colours, once some are hidden
        self._hidden: np.ndarray | None = None
        self._highlighted: np.ndarray | None = None
        self._highlight = np.ones(3, np.float32)
        self._changes: list[np.ndarray] | None = []   # rows changed; None: all of them
        #: The table that coloured the labels through a colormap (``cmap=``, ``categories``),
        #: as ``add_mesh`` holds it: the scalar bar shows it. ``None`` for other palettes.
        self.lookup_table: pyvista.LookupTable | None = None

    @classmethod
    def make(cls, palette, n_materials: int, ids: LabelIds | None = None) -> Palette:
        """A palette for labels ``1..n_materials - 1`` from what a user may pass.

        ``palette``: ``None`` (tab10 or tab20 for labels kept as rows up to id 20; beyond
        and for compacted ids, colours hashed from each id,
        :func:`~pv_cubemarch.models.label_colors.hashed_colors`), a
        matplotlib colormap name (its colours in the order of the ids), a list of colours
        (entry ``m`` for material ``m``; entry 0 is ignored), a dict ``{id: colour}`` or
        ``{id: (colour, opacity)}`` (ids left out are hidden), a function of the id
        returning either, an ``(n, 3)`` or ``(n, 4)`` array, or a :class:`Palette`.
        ``ids``: which id each row stands for (compacted labels); lists and arrays are by
        row and need the identity table.
        """
        if isinstance(palette, Palette):
            return palette
        n = max(int(n_materials), 2)
        compacted = ids is not None and not ids.identity
        if compacted:
            check_by_id(palette)
        if (palette is None and (n > 21 or compacted)) or (compacted and (
                isinstance(palette, dict) or callable(palette))):
            labels = ids.ids if ids is not None else np.arange(1, n)
            rgba = np.zeros((max(labels.size + 1, 2), 4), np.float32)
            rgba[1:labels.size + 1] = hashed_colors(labels) if palette is None else \
                colors_by_id(palette, labels)[1:]
            return cls(rgba)
        if callable(palette) and not isinstance(palette, str):
            return cls(colors_by_id(palette, np.arange(1, n)))
        if palette is None or isinstance(palette, str):
            name = palette or ("tab10" if n <= 11 else "tab20")
            try:
                lut = pyvista.LookupTable(name, n_values=max(n - 1, 1))
            except Exception as error:
                raise VolumeDataError(f"palette={palette!r} is not a colormap name: "
                                      f"{error}") from error
            colors = np.asarray(lut.values, dtype=np.float32) / 255.0
            rgba = np.vstack([np.zeros((1, 4), np.float32), colors])
            rgba[1:, 3] = 1.0
            return cls(rgba)
        if isinstance(palette, (dict, list, tuple, np.ndarray)) and len(palette) == 0:
            raise VolumeDataError("palette is empty: give a colour per material (entry 0, "
                                  "empty, is unused), a {material: colour} dict or a "
                                  "colormap name.")
        if isinstance(palette, dict):
            # rows are ids here (0..IDENTITY_MAX): a key past them, or negative, names
            # an id these labels cannot hold (ignored, as colors_by_id ignores ids not met)
            keys = palette_keys(palette)
            rows = [k for k in keys if 0 <= k <= IDENTITY_MAX]
            rgba = np.zeros((max([n, *(k + 1 for k in rows)]), 4), np.float32)
            for material, entry in zip(keys, palette.values(), strict=True):
                if not 0 <= material <= IDENTITY_MAX:
                    continue
                # (colour, opacity) pairs have two items; a colour has one (a name) or 3-4
                pair = isinstance(entry, (tuple, list)) and len(entry) == 2
                color, opacity = entry if pair else (entry, 1.0)
                rgba[material, :3] = _material_color(color, material)
                rgba[material, 3] = float(opacity)
            return cls(rgba)
        array = np.asarray(palette)
        if array.ndim == 2 and array.shape[1] in (3, 4) and array.dtype.kind in "fiu":
            rgba = np.ones((len(array), 4), np.float32)
            rgba[:, :array.shape[1]] = array
            rgba[0, 3] = 0.0
            return cls(rgba)
        colors = [_material_color(c, m) for m, c in enumerate(palette)]
        rgba = np.ones((len(colors), 4), np.float32)
        rgba[:, :3] = colors
        rgba[0, 3] = 0.0
        return cls(rgba)

    @property
    def n_materials(self) -> int:
        """Rows of the table (material ids ``0..n - 1``)."""
        return int(len(self.rgba))

    def set_color(self, material: int, color=None, opacity: float | None = None) -> None:
        """Change one material's colour and/or opacity (0 hides it)."""
        material = int(material)
        if not 0 < material < self.n_materials:
            raise ValueError(f"material must be in 1..{self.n_materials - 1}, got {material}.")
        self.set_rows(np.array([material]), color, opacity)

    def set_rows(self, rows: np.ndarray, color=None, opacity=None) -> None:
        """Change the colour and/or opacity of ``rows`` (0 hides).

        ``color``: one colour for all, or an ``(n, 3)`` array of RGB in [0, 1];
        ``opacity``: one number or one per row.
        """
        rows = np.asarray(rows, dtype=np.int64).ravel()
        own = self.rgba if self._base is None else self._base
        if color is not None:
            array = np.asarray(color) if not isinstance(color, str) else None
            if array is not None and array.ndim == 2:
                if array.shape != (rows.size, 3) or not np.isfinite(array).all() or \
                        array.min() < 0 or array.max() > 1:
                    raise ValueError(f"color must be one colour or an ({rows.size}, 3) array "
                                     f"of RGB in [0, 1], got shape {array.shape}.")
                own[rows, :3] = array
            else:
                own[rows, :3] = _material_color(color, rows[0] if rows.size == 1 else "these")
        if opacity is not None:
            try:
                values = np.asarray(opacity, dtype=np.float64)
            except (TypeError, ValueError):
                raise ValueError(f"opacity must be a number in [0, 1] or one per label, got "
                                 f"{opacity!r}.") from None
            if values.ndim > 1 or (values.ndim == 1 and values.size != rows.size) or \
                    not np.isfinite(values).all() or values.min() < 0 or values.max() > 1:
                raise ValueError(f"opacity must be in [0, 1], one value or one per label, got "
                                 f"{opacity!r}.")
            own[rows, 3] = values
        self._redraw(rows)

    def set_hidden(self, rows: np.ndarray, hidden: bool = True) -> None:
        """Hide ``rows`` (traversed as empty) or show them again with their own opacity."""
        self._keep_state()
        self._hidden[np.asarray(rows, dtype=np.int64)] = bool(hidden)
        self._redraw(rows)

    def set_highlighted(self, rows: np.ndarray, highlighted: bool = True, color=None) -> None:
        """Draw ``rows`` in the highlight colour (``color``, white by default), or not."""
        self._keep_state()
        if color is not None:
            self._highlight = np.asarray(_material_color(color, "highlight"), np.float32)
            rows = np.union1d(np.asarray(rows, dtype=np.int64), np.flatnonzero(
                self._highlighted))   # those already highlighted take the new colour too
        self._highlighted[np.asarray(rows, dtype=np.int64)] = bool(highlighted)
        self._redraw(rows)

    @property
    def hidden(self) -> np.ndarray:
        """Per row: hidden by :meth:`set_hidden` (its own opacity kept)."""
        if self._hidden is None:
            return np.zeros(self.n_materials, bool)
        return self._hidden.copy()

    @property
    def highlighted(self) -> np.ndarray:
        """Per row: highlighted by :meth:`set_highlighted`."""
        if self._highlighted is None:
            return np.zeros(self.n_materials, bool)
        return self._highlighted.copy()

    def _keep_state(self) -> None:
        """From the first hide or highlight on, keep the rows' own colours beside."""
        if self._base is None:
            self._base = self.rgba.copy()
            self._hidden = np.zeros(self.n_materials, bool)
            self._highlighted = np.zeros(self.n_materials, bool)

    def _redraw(self, rows) -> None:
        """What ``rows`` draw, from their own colour, hidden and highlighted states."""
        rows = np.asarray(rows, dtype=np.int64).ravel()
        if self._base is not None:
            drawn = self._base[rows].copy()
            drawn[self._highlighted[rows], :3] = self._highlight
            drawn[self._hidden[rows], 3] = 0.0
            self.rgba[rows] = drawn
        self.rgba[0] = 0.0
        if self._changes is not None:
            self._changes.append(rows)
            if sum(r.size for r in self._changes) > self.n_materials:
                self._changes = None   # more than a whole table: send it whole
        self.version += 1

    def take_changes(self) -> np.ndarray | None:
        """The rows changed since the last call (sorted, unique); ``None``: all of them."""
        changes, self._changes = self._changes, []
        if changes is None:
            return None
        return sorted_unique(np.concatenate(changes)) if changes else np.zeros(0, np.int64)

    def with_opacity(self, opacity) -> Palette:
        """A copy with every material's opacity scaled by ``opacity`` (0-1).

        As ``add_mesh(opacity=)`` makes a whole mesh translucent.
        """
        try:
            value = float(opacity)
        except (TypeError, ValueError):
            raise ValueError(f"opacity must be a number in [0, 1], got {opacity!r}.") from None
        if isinstance(opacity, (bool, str)) or not 0.0 <= value <= 1.0:
            raise ValueError(f"opacity must be a number in [0, 1], got {opacity!r} (per "
                             "material: palette={label: (colour, opacity)}).")
        rgba = self.rgba.copy()
        rgba[1:, 3] *= value
        return Palette(rgba)

    @property
    def visible(self) -> np.ndarray:
        """Per material: drawn (opacity above 0) or hidden; material 0 never."""
        shown = self.rgba[:, 3] > 0
        shown[0] = False
        return shown

class PlacedGrid:
    """A label grid's placement: ``transform @ grid_from_index`` maps its index space."""

    def world_from_index(self) -> np.ndarray:
        """4x4 from index space (voxel ``(i, j, k)`` spans ``[i, i+1]`` per axis) to world."""
        return np.asarray(self.transform, dtype=np.float64) @ self.grid_from_index

    def world_bounds(self) -> np.ndarray:
        """Axis-aligned world bounds ``(xmin, xmax, ymin, ymax, zmin, zmax)`` of the grid."""
        return box_world_bounds(self.world_from_index(), self.dimensions)

    def frame_bounds(self) -> np.ndarray:
        """Bounds of the grid in its own frame, before ``transform`` (as ``world_bounds``)."""
        return box_world_bounds(self.grid_from_index, self.dimensions)


@dataclass(eq=False)
class VoxelModel(PlacedGrid):
    """A material grid placed in the world, with its palette."""

    labels: np.ndarray
    palette: Palette
    grid_from_index: np.ndarray = field(default_factory=lambda: np.eye(4))
    transform: np.ndarray = field(default_factory=lambda: np.eye(4))
    name: str = "voxels"
    #: Which label id each row of ``labels`` and of the palette stands for (by default the
    #: identity: rows are the ids).
    ids: LabelIds | None = None

    def __post_init__(self):
        if self.ids is None:
            self.ids = LabelIds(None, 0, self.labels.dtype, n_rows=self.palette.n_materials)
        check_spacing(np.linalg.norm(np.asarray(self.grid_from_index)[:3, :3], axis=0),
                      "the grid's spacing")

    @property
    def dimensions(self) -> tuple[int, int, int]:
        """Voxels along x, y, z."""
        return tuple(int(n) for n in self.labels.shape)

    @property
    def nbytes(self) -> int:
        """Bytes of the labels (one or two per voxel)."""
        return int(self.labels.nbytes)

    @property
    def dtype(self) -> np.dtype:
        """The rows' type (uint8, uint16, or uint32 beyond 65536 labels), as a world's."""
        return self.labels.dtype

    @property
    def n_labels(self) -> int:
        """Label ids other than the background the grid's tables hold."""
        return self.ids.n_labels if not self.ids.identity else self.palette.n_materials - 1

def label_values(array, name: str = "labels") -> np.ndarray:
    """Integer labels as an integer array (bools as uint8), or a clear error naming ``name``."""
    array = np.asarray(array)
    if array.ndim != 3:
        raise VolumeDataError(f"{name} must be a 3D array (x, y, z), got shape {array.shape}.")
    if array.size == 0:
        raise VolumeDataError(f"{name} has no voxels (shape {array.shape}).")
    if array.dtype.kind == "b":
        return array.astype(np.uint8)
    if array.dtype.kind == "f":
        if not np.isfinite(array).all():
            raise VolumeDataError(f"{name} holds NaN or infinite values; labels are whole "
                                  "numbers (0 = empty).")
        if not np.array_equal(array, np.round(array)):
            raise VolumeDataError(f"{name} holds non-integer values (e.g. "
                                  f"{array[array != np.round(array)].flat[0].item()!r}); labels "
                                  "are whole numbers: round or label the data first.")
        if float(np.abs(array).max()) >= 2**53:   # (as a Python float: float16 has no 2**53)
            raise VolumeDataError(f"{name} holds float labels beyond 2^53, where floats skip "
                                  "whole numbers: store the ids as int64 or uint64.")
        return array.astype(np.int64)
    if array.dtype.kind not in "iu":
        raise VolumeDataError(f"{name} has dtype {array.dtype}; labels are integers.")
    return array


def checked_labels(array, name: str = "labels") -> np.ndarray:
    """Material labels 0..65535 as uint8 (or uint16 above 255), or a clear error.

    For what keeps its ids as rows (a world's chunks); :func:`make_voxels` takes any ids.
    """
    array = label_values(array, name)
    low, high = array.min(), array.max()
    if low < 0:
        raise VolumeDataError(f"{name} holds negative labels (down to {low}); a world's "
                              "labels are 0 (empty) or positive material ids.")
    if high > MAX_MATERIALS:
        raise VolumeDataError(f"{name} holds labels up to {high}; a world's chunks hold at "
                              f"most {MAX_MATERIALS} materials (uint16).")
    dtype = np.uint8 if high <= 255 else np.uint16
    return np.ascontiguousarray(array.astype(dtype))   # a copy: edits leave the input be


def _chosen_array(data: pyvista.ImageData) -> str:
    """The array :func:`image_samples` takes when ``scalars`` is not given."""
    names = list(data.cell_data.keys()) + list(data.point_data.keys())
    active = data.active_scalars_name
    return active if active in names else names[0]


def image_samples(data: pyvista.ImageData, scalars: str | None) -> tuple[np.ndarray,
                                                                         np.ndarray]:
    """An ImageData's array as one sample per cell, and the 4x4 placing those cells.

    Cell data: one cell per ImageData cell. Point data: one cell centred on each point, a
    spacing wide. ``scalars``: the array (the first cell, then point array by default).
    Returns ``(values indexed x, y, z, grid_from_index)`` (cell ``(i, j, k)`` spans
    ``[i, i+1]`` per axis of index space).
    """
    scalars = image_array_name(data, scalars)
    check_geometry(data)
    direction = np.asarray(data.direction_matrix, dtype=np.float64)
    spacing = np.asarray(data.spacing, dtype=np.float64)
    origin = first_point(data)
    if scalars in data.cell_data:
        shape = tuple(max(int(n) - 1, 1) for n in data.dimensions)
        values = np.asarray(data.cell_data[scalars]).reshape(shape, order="F")
        start = origin
    elif scalars in data.point_data:
        shape = tuple(int(n) for n in data.dimensions)
        values = np.asarray(data.point_data[scalars]).reshape(shape, order="F")
        start = origin - direction @ (spacing / 2.0)
    else:
        raise VolumeDataError(f"scalars={scalars!r} is not an array of the grid; it has "
                              f"{list(data.cell_data.keys()) + list(data.point_data.keys())}.")
    grid_from_index = np.eye(4)
    grid_from_index[:3, :3] = direction * spacing
    grid_from_index[:3, 3] = start
    # a 2D image is flat: a sheet, as PyVista draws its cells, a thousandth of a cell thick
    # and centred on the image's plane (point data: its cells centred on the points in it)
    flat = [axis for axis, n in enumerate(data.dimensions) if int(n) == 1]
    across = [spacing[axis] for axis in range(3) if axis not in flat]
    for axis in flat:
        thin = FLAT_CELL_THICKNESS * (min(across) if across else spacing[axis])
        grid_from_index[:3, axis] = direction[:, axis] * thin
        grid_from_index[:3, 3] = start + direction[:, axis] * (
            (spacing[axis] / 2.0 if scalars in data.point_data else 0.0) - thin / 2.0)
        start = grid_from_index[:3, 3].copy()
    return values, grid_from_index


def image_array_name(data: pyvista.ImageData, scalars: str | None) -> str:
    """The name of the array drawn: ``scalars``, else PyVista's active one, else the first."""
    names = list(data.cell_data.keys()) + list(data.point_data.keys())
    if scalars is None:
        if not names:
            raise VolumeDataError("The grid has no arrays; add the values to cell_data or "
                                  "point_data.")
        active = data.active_scalars_name   # PyVista's choice, as add_mesh makes it
        scalars = active if active in names else names[0]
    return scalars


def samples_at_points(data: pyvista.ImageData, scalars: str | None) -> bool:
    """Whether :func:`image_samples` reads point data (cells centred on the points)."""
    name = image_array_name(data, scalars)
    return name not in data.cell_data and name in data.point_data


def make_voxels(data, scalars: str | None = None, *, palette=None, transform=None,
                name: str = "voxels", categories: bool = False, cmap=None, clim=None,
                n_colors: int | None = None, flip_scalars: bool = False,
                opacity: float | None = None, background: int = 0) -> VoxelModel:
    """Validate a material grid and bundle it with a palette into a :class:`VoxelModel`.

    ``data``: a 3D integer (or bool) numpy array indexed x, y, z (unit voxels from the
    origin), or a ``pyvista.ImageData`` whose cell data (one voxel per cell) or point data
    (one voxel centred on each point, a spacing wide) holds the labels. ``palette``: one
    colour per material number (:meth:`Palette.make`). ``cmap`` (PyVista's name, instead
    of ``palette``): a colormap over the drawn labels' range, as ``threshold`` +
    ``add_mesh(cmap=...)`` colours the cells, with its ``clim``, ``n_colors`` and
    ``flip_scalars`` (:func:`range_palette`). ``categories``: the colormap mapped as
    ``add_mesh(categories=True)`` maps the drawn labels (see :func:`category_palette`).
    ``opacity``: every material's opacity, as ``add_mesh(opacity=)``. ``background``: the
    id drawn as empty (0). Ids of any integer type and value are taken: non-negative ones up
    to 65535 with background 0 are stored as they are, others compacted to dense rows
    (:mod:`~pv_cubemarch.models.label_ids`).
    """
    if cmap is not None and palette is not None:
        raise ValueError("give palette= or cmap= (PyVista's name), not both.")
    mapping = [key for key, value in dict(clim=clim, n_colors=n_colors,
                                          flip_scalars=flip_scalars or None).items()
               if value is not None]
    if mapping and (cmap is None or categories):
        raise ValueError(f"{', '.join(mapping)} shape how cmap= spans the drawn labels; give "
                         "cmap= (without categories=True), or colour each material with "
                         "palette=.")
    if isinstance(data, pyvista.ImageData):
        values, grid_from_index = image_samples(data, scalars)
        shown = scalars or _chosen_array(data)
        labels, ids = label_rows(label_values(values, f"array {shown!r}"), background,
                                 f"array {shown!r}")
    else:
        grid_from_index = np.eye(4)
        labels, ids = label_rows(label_values(data), background)
    matrix = np.eye(4) if transform is None else checked_transform(transform)
    if abs(np.linalg.det(grid_from_index[:3, :3])) < 1e-300:
        raise VolumeDataError("The grid's spacing must not be zero along any axis.")
    if categories:
        chosen = category_palette(palette if cmap is None else cmap, labels, ids)
    elif cmap is not None:
        chosen = range_palette(cmap, labels, clim, n_colors or 256, flip_scalars, ids)
    else:
        chosen = Palette.make(palette, int(labels.max()) + 1, ids)
    if opacity is not None:
        chosen = chosen.with_opacity(opacity)
    if int(labels.max()) >= chosen.n_materials:
        top = int(labels.max())
        raise VolumeDataError(f"Label {top} has no colour: the palette has "
                              f"{chosen.n_materials} entries (materials 0.."
                              f"{chosen.n_materials - 1}); pass one with at least {top + 1}.")
    if ids.identity:
        ids.identity_rows = chosen.n_materials
    return VoxelModel(labels=labels, palette=chosen, grid_from_index=grid_from_index,
                      transform=matrix, name=name, ids=ids)

def _present(labels: np.ndarray, ids: LabelIds | None) -> tuple[np.ndarray, np.ndarray]:
    """The drawn labels' rows and ids (what ``threshold`` keeps), ids ascending."""
    if ids is None or ids.identity:
        rows = np.unique(labels[labels > 0])
        return rows, rows
    order = np.argsort(ids.ids, kind="stable")
    return order + 1, ids.ids[order]


def _table(labels: np.ndarray, ids: LabelIds | None) -> np.ndarray:
    """An empty RGBA table with a row per row of ``labels``' tables."""
    if ids is None or ids.identity:
        return np.zeros((max(int(labels.max()) + 1, 2), 4), np.float32)
    return np.zeros((max(ids.n_rows, 2), 4), np.float32)


def range_palette(cmap, labels: np.ndarray, clim=None, n_colors: int = 256,
                  flip_scalars: bool = False, ids: LabelIds | None = None) -> Palette:
    """Each drawn label coloured as ``threshold`` + ``add_mesh(cmap=...)`` colours it.

    PyVista maps the cells' values through ``n_colors`` colours of ``cmap`` (reversed with
    ``flip_scalars``) over ``clim``, by default their range: the smallest to the largest
    drawn label id (what ``threshold`` keeps). ``ids``: the id of each row. A
    ``pyvista.LookupTable`` is used as it is, over its own range whatever ``clim`` says
    (``n_colors`` and ``flip_scalars`` are its own), as ``add_mesh`` uses one.
    """
    rows, present = _present(labels, ids)
    rgba = _table(labels, ids)
    if present.size and isinstance(cmap, pyvista.LookupTable):
        lut = pyvista.LookupTable()
        lut.DeepCopy(cmap)   # the caller's table keeps its range
        span = table_range(cmap, clim, "add_mesh")
        if ids is None or ids.identity:
            rows = present = np.arange(1, len(rgba))
        _colour_labels(rgba, lut, rows, present, span)
    elif present.size:
        from pyvista.plotting.colors import get_cmap_safe

        try:
            colormap = get_cmap_safe(list(cmap) if isinstance(cmap, tuple) else cmap)
        except (ValueError, TypeError) as error:
            raise VolumeDataError(unknown_cmap(cmap, error)) from error
        try:
            count = int(n_colors)
            if count < 1 or count != n_colors:
                raise ValueError(f"n_colors must be a whole number >= 1, got {n_colors!r}")
            lut = pyvista.LookupTable()
            lut.apply_cmap(colormap.reversed() if flip_scalars else colormap, count)
        except (ValueError, TypeError) as error:
            raise VolumeDataError(f"cmap={cmap!r}, n_colors={n_colors!r}: {error}") from error
        span = (float(present[0]), float(present[-1])) if clim is None else _checked_clim(clim)
        if ids is None or ids.identity:   # every id a row holds: an edit may paint any of
            rows = present = np.arange(1, len(rgba))   # them, coloured as PyVista would
        _colour_labels(rgba, lut, rows, present, span)
    palette = Palette(rgba)
    palette.lookup_table = lut if present.size else None
    return palette

def _colour_labels(rgba: np.ndarray, lut: pyvista.LookupTable, rows: np.ndarray,
                   present: np.ndarray, clim=None) -> None:
    """Row ``rows[k]`` of ``rgba``: id ``present[k]``'s colour through ``lut``, opaque.

    ``clim`` is by default the present ids' range (one unit wide for a single id). VTK maps
    the values (as doubles, as it maps a mesh's cell data) to the 8-bit colours it draws.
    """
    from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy

    lo, hi = (float(present[0]), float(present[-1])) if clim is None else clim
    lut.scalar_range = (lo, hi if hi > lo else lo + 1.0)
    values = numpy_to_vtk(np.asarray(present, dtype=np.float64), deep=True)
    mapped = vtk_to_numpy(lut.MapScalars(values, 0, -1)).reshape(-1, 4)
    rgba[rows, :3] = mapped[:, :3].astype(np.float32) / 255.0
    rgba[rows, 3] = 1.0

def _checked_clim(clim) -> tuple[float, float]:
    """``clim`` as two finite numbers, low <= high, or a clear error."""
    try:
        low, high = (float(v) for v in clim)
    except (TypeError, ValueError):
        raise VolumeDataError(f"clim must be two numbers (low, high), got {clim!r}.") from None
    if not (np.isfinite(low) and np.isfinite(high) and low <= high):
        raise VolumeDataError(f"clim must be two finite numbers, low <= high, got {clim!r}.")
    return low, high

def category_palette(cmap, labels: np.ndarray, ids: LabelIds | None = None) -> Palette:
    """Each drawn label coloured as PyVista's ``add_mesh(categories=True)`` colours it.

    PyVista makes a table of as many colours as the mesh has distinct values over their
    range and maps each value into it: so id ``v`` takes colour ``floor((v - lo) /
    (hi - lo) * n)`` of ``n`` colours of ``cmap`` (``lo``, ``hi``, ``n``: the smallest,
    largest and number of distinct drawn ids, which ``threshold`` keeps).
    """
    if cmap is not None and not isinstance(cmap, (str, list, tuple)):
        raise VolumeDataError("categories=True maps the labels through a colormap: give "
                              "palette= a colormap name or a list of colours.")
    rows, present = _present(labels, ids)
    rgba = _table(labels, ids)
    if present.size:
        lut = pyvista.LookupTable(list(cmap) if isinstance(cmap, tuple) else (cmap or "tab10"),
                                  n_values=max(int(present.size), 1))
        _colour_labels(rgba, lut, rows, present)
    palette = Palette(rgba)
    palette.lookup_table = lut if present.size else None
    return palette

def fits_one_texture(dimensions: Sequence[int], dtype) -> bool:
    """Whether a grid of ``dimensions`` labels of ``dtype`` is drawn whole, not in chunks."""
    voxels = int(np.prod([int(n) for n in dimensions], dtype=np.int64))
    return (max(int(n) for n in dimensions) <= MAX_TEXTURE_SIZE
            and voxels * np.dtype(dtype).itemsize <= MAX_GRID_BYTES)


def listed_rows(model) -> np.ndarray:
    """The rows a grid's legend lists: the labels present in a grid kept as rows, else all."""
    if model.ids.identity and hasattr(model, "labels") and model.labels.dtype.itemsize <= 2:
        labels = model.labels.reshape(-1, model.labels.shape[-1])   # counted by slabs
        counts = np.zeros(1 << (8 * labels.dtype.itemsize), np.int64)
        for start in range(0, labels.shape[1], 8):   # a few MB of int64 at a time
            counts += np.bincount(labels[:, start:start + 8].ravel(), minlength=counts.size)
        return np.flatnonzero(counts[1:]) + 1
    if model.ids.identity and hasattr(model, "labels"):
        present = np.unique(model.labels)
        return present[present > 0].astype(np.int64)
    return np.arange(1, model.n_labels + 1)


def label_legend(model, limit: int = 10) -> list[dict]:
    """The first ``limit`` label ids of a grid or world with their colour and opacity.

    Each entry: ``{"id": int, "color": "#rrggbb", "opacity": float, "hidden": bool}``, in
    the order of the grid's rows (ascending ids).
    """
    ids, palette = model.ids, model.palette
    hidden = palette.hidden
    legend = []
    for row in listed_rows(model)[:max(int(limit), 0)]:
        if row >= palette.n_materials:
            break
        rgb = np.clip(np.round(palette.rgba[row, :3] * 255), 0, 255).astype(int)
        legend.append({"id": ids.id_of(row), "color": "#{:02x}{:02x}{:02x}".format(*rgb),
                       "opacity": round(float(palette.rgba[row, 3]), 6),
                       "hidden": bool(hidden[row])})
    return legend


def count_labels(model) -> int:
    """Label ids other than the background a grid holds (a world kept as rows: its palette's)."""
    return int(listed_rows(model).size)


def describe_labels(model) -> str:
    """One line on a grid's label ids: how many, their range and type, bytes per voxel."""
    ids = model.ids
    count = count_labels(model)
    if ids.identity:
        return f"{count} labels, {np.dtype(model.dtype).itemsize} byte(s) a voxel"
    values = ids.ids
    low, high = (int(values.min()), int(values.max())) if values.size else (0, 0)
    return (f"{count} label ids {low}..{high} ({ids.dtype}), background "
            f"{int(ids.background)}, stored as {np.dtype(model.dtype).itemsize} "
            "byte(s) a voxel")
