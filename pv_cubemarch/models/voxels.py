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
from .transfer import unknown_cmap
from .volume import box_world_bounds, check_spacing, checked_transform, first_point

#: Most materials a grid may hold (uint16 labels).
MAX_MATERIALS = 65535
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
        self.rgba = np.ascontiguousarray(rgba)
        self.version = 0   # bumped at each change, so the GPU copy follows

    @classmethod
    def make(cls, palette, n_materials: int) -> Palette:
        """A palette for labels ``1..n_materials - 1`` from what a user may pass.

        ``palette``: ``None`` (a qualitative colormap), a matplotlib colormap name, a list of
        colours (entry ``m`` for material ``m``; entry 0 is ignored), a dict ``{material:
        colour}`` or ``{material: (colour, opacity)}`` (materials left out are hidden), an
        ``(n, 3)`` or ``(n, 4)`` array, or a :class:`Palette`.
        """
        if isinstance(palette, Palette):
            return palette
        n = max(int(n_materials), 2)
        if palette is None or isinstance(palette, str):
            name = palette or ("tab10" if n <= 11 else "tab20" if n <= 21 else "turbo")
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
            rgba = np.zeros((max(n, max(int(k) for k in palette) + 1), 4), np.float32)
            for material, entry in palette.items():
                # (colour, opacity) pairs have two items; a colour has one (a name) or 3-4
                pair = isinstance(entry, (tuple, list)) and len(entry) == 2
                color, opacity = entry if pair else (entry, 1.0)
                rgba[int(material), :3] = _material_color(color, material)
                rgba[int(material), 3] = float(opacity)
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
        if color is not None:
            self.rgba[material, :3] = _material_color(color, material)
        if opacity is not None:
            if not 0.0 <= float(opacity) <= 1.0:
                raise ValueError(f"opacity must be in [0, 1], got {opacity}.")
            self.rgba[material, 3] = float(opacity)
        self.version += 1

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


@dataclass(eq=False)
class VoxelModel(PlacedGrid):
    """A material grid placed in the world, with its palette."""

    labels: np.ndarray
    palette: Palette
    grid_from_index: np.ndarray = field(default_factory=lambda: np.eye(4))
    transform: np.ndarray = field(default_factory=lambda: np.eye(4))
    name: str = "voxels"

    def __post_init__(self):
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
        """The labels' type (uint8 or uint16), as a world's."""
        return self.labels.dtype


def checked_labels(array, name: str = "labels") -> np.ndarray:
    """Integer labels as uint8 (or uint16 above 255), or a clear error naming ``name``."""
    array = np.asarray(array)
    if array.ndim != 3:
        raise VolumeDataError(f"{name} must be a 3D array (x, y, z), got shape {array.shape}.")
    if array.size == 0:
        raise VolumeDataError(f"{name} has no voxels (shape {array.shape}).")
    if array.dtype.kind == "b":
        return array.astype(np.uint8)
    if array.dtype.kind == "f":
        if not np.isfinite(array).all():
            raise VolumeDataError(f"{name} holds NaN or infinite values; material labels are "
                                  "whole numbers (0 = empty).")
        if not np.array_equal(array, np.round(array)):
            raise VolumeDataError(f"{name} holds non-integer values (e.g. "
                                  f"{array[array != np.round(array)].flat[0].item()!r}); material "
                                  "labels are whole numbers: round or label the data first.")
    elif array.dtype.kind not in "iu":
        raise VolumeDataError(f"{name} has dtype {array.dtype}; material labels are integers.")
    low, high = array.min(), array.max()
    if low < 0:
        raise VolumeDataError(f"{name} holds negative labels (down to {low}); labels are "
                              "0 (empty) or positive material ids.")
    if high > MAX_MATERIALS:
        raise VolumeDataError(f"{name} holds labels up to {high}; at most {MAX_MATERIALS} "
                              "materials fit (uint16).")
    dtype = np.uint8 if high <= 255 else np.uint16
    return np.ascontiguousarray(array.astype(dtype))   # a copy: edits leave the input be


def image_samples(data: pyvista.ImageData, scalars: str | None) -> tuple[np.ndarray,
                                                                         np.ndarray]:
    """An ImageData's array as one sample per cell, and the 4x4 placing those cells.

    Cell data: one cell per ImageData cell. Point data: one cell centred on each point, a
    spacing wide. ``scalars``: the array (the first cell, then point array by default).
    Returns ``(values indexed x, y, z, grid_from_index)`` (cell ``(i, j, k)`` spans
    ``[i, i+1]`` per axis of index space).
    """
    names = list(data.cell_data.keys()) + list(data.point_data.keys())
    if scalars is None:
        if not names:
            raise VolumeDataError("The grid has no arrays; add the values to cell_data or "
                                  "point_data.")
        scalars = names[0]
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
                              f"{names}.")
    grid_from_index = np.eye(4)
    grid_from_index[:3, :3] = direction * spacing
    grid_from_index[:3, 3] = start
    return values, grid_from_index


def make_voxels(data, scalars: str | None = None, *, palette=None, transform=None,
                name: str = "voxels", categories: bool = False, cmap=None, clim=None,
                n_colors: int | None = None, flip_scalars: bool = False,
                opacity: float | None = None) -> VoxelModel:
    """Validate a material grid and bundle it with a palette into a :class:`VoxelModel`.

    ``data``: a 3D integer (or bool) numpy array indexed x, y, z (unit voxels from the
    origin), or a ``pyvista.ImageData`` whose cell data (one voxel per cell) or point data
    (one voxel centred on each point, a spacing wide) holds the labels. ``palette``: one
    colour per material number (:meth:`Palette.make`). ``cmap`` (PyVista's name, instead
    of ``palette``): a colormap over the drawn labels' range, as ``threshold`` +
    ``add_mesh(cmap=...)`` colours the cells, with its ``clim``, ``n_colors`` and
    ``flip_scalars`` (:func:`range_palette`). ``categories``: the colormap mapped as
    ``add_mesh(categories=True)`` maps the drawn labels (see :func:`category_palette`).
    ``opacity``: every material's opacity, as ``add_mesh(opacity=)``.
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
        labels = checked_labels(values, scalars or "labels")
    else:
        grid_from_index = np.eye(4)
        labels = checked_labels(data)
    matrix = np.eye(4) if transform is None else checked_transform(transform)
    if abs(np.linalg.det(grid_from_index[:3, :3])) < 1e-300:
        raise VolumeDataError("The grid's spacing must not be zero along any axis.")
    if categories:
        chosen = category_palette(palette if cmap is None else cmap, labels)
    elif cmap is not None:
        chosen = range_palette(cmap, labels, clim, n_colors or 256, flip_scalars)
    else:
        chosen = Palette.make(palette, int(labels.max()) + 1)
    if opacity is not None:
        chosen = chosen.with_opacity(opacity)
    if int(labels.max()) >= chosen.n_materials:
        top = int(labels.max())
        raise VolumeDataError(f"Label {top} has no colour: the palette has "
                              f"{chosen.n_materials} entries (materials 0.."
                              f"{chosen.n_materials - 1}); pass one with at least {top + 1}.")
    return VoxelModel(labels=labels, palette=chosen, grid_from_index=grid_from_index,
                      transform=matrix, name=name)


def range_palette(cmap, labels: np.ndarray, clim=None, n_colors: int = 256,
                  flip_scalars: bool = False) -> Palette:
    """Each drawn label coloured as ``threshold`` + ``add_mesh(cmap=...)`` colours it.

    PyVista maps the cells' values through ``n_colors`` colours of ``cmap`` (reversed with
    ``flip_scalars``) over ``clim``, by default their range: the smallest to the largest
    label above 0 (what ``threshold`` keeps).
    """
    present = np.unique(labels[labels > 0])
    rgba = np.zeros((max(int(labels.max()) + 1, 2), 4), np.float32)
    if present.size:
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
        _colour_labels(rgba, lut, present, None if clim is None else _checked_clim(clim))
    return Palette(rgba)


def _colour_labels(rgba: np.ndarray, lut: pyvista.LookupTable, present: np.ndarray,
                   clim=None) -> None:
    """Row ``v`` of ``rgba``: label ``v``'s colour through ``lut`` over ``clim``, opaque.

    ``clim`` is by default the present labels' range (one unit wide for a single label).
    """
    lo, hi = (float(present[0]), float(present[-1])) if clim is None else clim
    lut.scalar_range = (lo, hi if hi > lo else lo + 1.0)
    for value in present:
        rgba[int(value), :3] = lut.map_value(float(value), opacity=False)
        rgba[int(value), 3] = 1.0


def _checked_clim(clim) -> tuple[float, float]:
    """``clim`` as two finite numbers, low <= high, or a clear error."""
    try:
        low, high = (float(v) for v in clim)
    except (TypeError, ValueError):
        raise VolumeDataError(f"clim must be two numbers (low, high), got {clim!r}.") from None
    if not (np.isfinite(low) and np.isfinite(high) and low <= high):
        raise VolumeDataError(f"clim must be two finite numbers, low <= high, got {clim!r}.")
    return low, high


def category_palette(cmap, labels: np.ndarray) -> Palette:
    """Each drawn label coloured as PyVista's ``add_mesh(categories=True)`` colours it.

    PyVista makes a table of as many colours as the mesh has distinct values over their
    range and maps each value into it: so label ``v`` takes colour ``floor((v - lo) /
    (hi - lo) * n)`` of ``n`` colours of ``cmap`` (``lo``, ``hi``, ``n``: the smallest,
    largest and number of distinct labels above 0, which ``threshold`` keeps).
    """
    if cmap is not None and not isinstance(cmap, (str, list, tuple)):
        raise VolumeDataError("categories=True maps the labels through a colormap: give "
                              "palette= a colormap name or a list of colours.")
    present = np.unique(labels[labels > 0])
    top = int(labels.max())
    rgba = np.zeros((max(top + 1, 2), 4), np.float32)
    if present.size:
        lut = pyvista.LookupTable(list(cmap) if isinstance(cmap, tuple) else (cmap or "tab10"),
                                  n_values=max(int(present.size), 1))
        _colour_labels(rgba, lut, present)
    return Palette(rgba)


def occupancy_levels(labels: np.ndarray, levels: int) -> list[np.ndarray]:
    """Conservative occupancy mipmaps, levels ``1..levels`` (uint8 0/1).

    Level ``L`` marks, per cell of ``2^L`` voxels per axis, whether any voxel under it is
    filled: a cell is empty only if every voxel under it is.
    """
    filled = np.asarray(labels) != 0
    result = []
    for _ in range(int(levels)):
        pad = [(0, n % 2) for n in filled.shape]
        grown = np.pad(filled, pad) if any(p for _, p in pad) else filled
        nx, ny, nz = (n // 2 for n in grown.shape)
        filled = grown.reshape(nx, 2, ny, 2, nz, 2).any(axis=(1, 3, 5))
        result.append(filled.astype(np.uint8))
    return result


def representative_levels(labels: np.ndarray, levels: int) -> list[np.ndarray]:
    """Levels ``1..levels`` holding, per cell, a label that stands for the voxels under it.

    For level of detail: a cell of level ``L`` holds the most frequent non-zero label of its
    8 cells of level ``L - 1`` (the smaller label on a tie; 0 only when all 8 are 0), so it
    is non-zero exactly where :func:`occupancy_levels` marks the cell filled. Labels' dtype.
    """
    grid = np.asarray(labels)
    result = []
    for _ in range(int(levels)):
        pad = [(0, n % 2) for n in grid.shape]
        grown = np.pad(grid, pad) if any(p for _, p in pad) else grid
        nx, ny, nz = (n // 2 for n in grown.shape)
        children = np.sort(grown.reshape(nx, 2, ny, 2, nz, 2).transpose(0, 2, 4, 1, 3, 5)
                           .reshape(-1, 8), axis=1)
        chosen = children[:, 7].copy()   # right where all 8 agree (most cells)
        mixed = np.flatnonzero(children[:, 0] != children[:, 7])
        some = children[mixed]
        counts = (some[:, :, None] == some[:, None, :]).sum(axis=2)
        counts[some == 0] = 0
        best = np.argmax(counts, axis=1)   # sorted: the first of the most frequent is smallest
        chosen[mixed] = some[np.arange(len(some)), best]
        grid = chosen.reshape(nx, ny, nz)
        result.append(grid)
    return result


def atlas_levels(labels: np.ndarray, levels: int, representative: bool) -> list[np.ndarray]:
    """The levels a level atlas holds: representative labels (level of detail) or occupancy."""
    return (representative_levels if representative else occupancy_levels)(labels, levels)


#: Occupancy levels whose bricks' outer faces may start the rays (``proxy='bricks'``),
#: finest first: the first whose shell has at most SHELL_FACE_BUDGET faces is used (finer
#: bricks start rays nearer their hits; scattered content makes too many faces, whose depth
#: pass then costs more than it saves).
SHELL_LEVELS = (1, 2, 3)
SHELL_FACE_BUDGET = 16384
#: How far (voxels) the brick faces stand off the bricks, so rasterisation never drops a
#: pixel whose ray enters a brick near its silhouette (vertex positions are float32).
PROXY_MARGIN = 1.0 / 64.0


def grown_by_one(mask: np.ndarray) -> np.ndarray:
    """``mask`` grown by one cell in all 26 directions (separable, numpy only)."""
    grown = np.asarray(mask, dtype=bool)
    for axis in range(3):
        if grown.shape[axis] < 2:
            continue
        ahead = [slice(None)] * 3
        behind = [slice(None)] * 3
        ahead[axis], behind[axis] = slice(1, None), slice(None, -1)
        spread = grown.copy()
        spread[tuple(behind)] |= grown[tuple(ahead)]
        spread[tuple(ahead)] |= grown[tuple(behind)]
        grown = spread
    return grown


def fits_one_texture(dimensions: Sequence[int], dtype) -> bool:
    """Whether a grid of ``dimensions`` labels of ``dtype`` is drawn whole, not in chunks."""
    voxels = int(np.prod([int(n) for n in dimensions], dtype=np.int64))
    return (max(int(n) for n in dimensions) <= MAX_TEXTURE_SIZE
            and voxels * np.dtype(dtype).itemsize <= MAX_GRID_BYTES)


def level_offset(n: int, level: int) -> int:
    """Where level ``level >= 1`` starts along the atlas's row axis (``n`` voxels long).

    ``n - (n >> (level - 1)) + level - 1``: a formula the shader computes too (no table to
    index per step), leaving each level room for its ``ceil(n / 2^level)`` cells.
    """
    return 0 if level == 0 else n - (n >> (level - 1)) + level - 1


def level_shapes(dimensions: Sequence[int], count: int) -> list[tuple[int, int, int]]:
    """The cell counts of the labels (level 0) and of occupancy levels ``1..count``."""
    dims = tuple(int(n) for n in dimensions)
    return [tuple(-(-n // (1 << level)) for n in dims) for level in range(int(count) + 1)]


def level_origin(dimensions: Sequence[int], level: int, slab_axis: int,
                 row_axis: int) -> tuple[int, int, int]:
    """Where level ``level`` starts in its atlas (the labels, level 0, at the origin)."""
    origin = [0, 0, 0]
    if level:
        origin[row_axis] = level_offset(int(dimensions[row_axis]), level)
        origin[slab_axis] = int(dimensions[slab_axis])
    return tuple(origin)


def atlas_layout(dimensions: Sequence[int], count: int) -> tuple[int, int, tuple] | None:
    """The smallest level atlas within :data:`MAX_TEXTURE_SIZE`: ``(slab, row, shape)``.

    The levels lie in a slab past the labels along the ``slab`` axis, side by side along
    the ``row`` axis; tried with the slab along z, x, y (the first wins a tie). ``None``
    when none fits.
    """
    dims = tuple(int(n) for n in dimensions)
    shapes = level_shapes(dims, count)
    best = None
    for slab in (2, 0, 1):
        for row in (a for a in (0, 1, 2) if a != slab):
            shape = list(dims)
            if count:
                shape[slab] += shapes[1][slab]
                shape[row] = max(dims[row], level_offset(dims[row], count) + shapes[-1][row])
            if max(shape) <= MAX_TEXTURE_SIZE and (best is None
                                                   or np.prod(shape) < np.prod(best[2])):
                best = (slab, row, tuple(shape))
    return best


@dataclass(frozen=True)
class LevelAtlas:
    """The labels and their occupancy levels ``1..n`` in one 3D texture of the labels' type.

    The traversal reads any level with one fetch of one texture (GLSL 1.50 indexes no
    sampler arrays, and llvmpipe runs both sides of a branch: a second texture would be
    read on every step). The labels sit at the origin, so a voxel's label is read where it
    always was; the levels lie in a slab past the labels along ``slab_axis``, side by side
    along ``row_axis`` (:func:`level_origin`). An occupied cell holds 1.
    """

    texels: np.ndarray
    slab_axis: int
    row_axis: int
    shapes: tuple[tuple[int, int, int], ...]

    def origin(self, number: int) -> tuple[int, int, int]:
        """Where level ``number`` starts in the atlas."""
        return level_origin(self.shapes[0], number, self.slab_axis, self.row_axis)

    def level(self, number: int) -> np.ndarray:
        """Level ``number`` (0: the labels; 1..levels: occupancy) cut back out of the atlas."""
        start, shape = self.origin(number), self.shapes[number]
        return self.texels[tuple(slice(o, o + n) for o, n in zip(start, shape, strict=True))]


def level_atlas(labels: np.ndarray, grids: list[np.ndarray]) -> LevelAtlas:
    """``labels`` and their occupancy levels ``grids`` (:func:`occupancy_levels`) packed.

    Raises ``ValueError`` when no layout fits :data:`MAX_TEXTURE_SIZE`.
    """
    labels = np.asarray(labels)
    layout = atlas_layout(labels.shape, len(grids))
    if layout is None:
        raise ValueError(f"A grid of {labels.shape} voxels with {len(grids)} occupancy levels "
                         f"needs a texture over {MAX_TEXTURE_SIZE} texels on a side; use "
                         "mip_levels=0 (or fewer levels), or a smaller grid.")
    slab, row, shape = layout
    atlas = LevelAtlas(np.zeros(shape, labels.dtype), slab, row,
                       tuple(level_shapes(labels.shape, len(grids))))
    atlas.level(0)[...] = labels
    for number, grid in enumerate(grids, start=1):
        atlas.level(number)[...] = grid
    return atlas


def atlas_updates(labels: np.ndarray, box, count: int, representative: bool,
                  origin_of) -> list[tuple[tuple[int, int, int], np.ndarray]]:
    """What a level atlas changes where the labels in ``box`` (three slices) changed.

    Per level ``0..count``: the atlas texel where its changed block starts and the block
    (the labels, then each level's cells over the box, recomputed from the labels under
    them). ``origin_of(level)``: where that level starts in the atlas.
    """
    dims = labels.shape
    lower = [s.start for s in box]
    upper = [s.stop for s in box]
    updates = [(tuple(int(o + a) for o, a in zip(origin_of(0), lower, strict=True)),
                labels[tuple(box)])]
    for level in range(1, int(count) + 1):
        low = [a >> level for a in lower]
        high = [((b - 1) >> level) + 1 for b in upper]
        region = tuple(slice(a << level, min(b << level, n))
                       for a, b, n in zip(low, high, dims, strict=True))
        cells = atlas_levels(labels[region], level, representative)[-1]
        origin = origin_of(level)
        updates.append((tuple(int(o + a) for o, a in zip(origin, low, strict=True)),
                        cells.astype(labels.dtype)))
    return updates


#: A level the traversal climbs to by default must leave at least this share of its cells
#: empty, and at least 3 levels must: on denser grids (a 1 % random fill, a fine
#: checkerboard) climbing and descending cost more than the voxel steps they save.
USEFUL_EMPTY_SHARE = 0.3
USEFUL_FIRST_LEVEL = 3


def useful_levels(grids: list[np.ndarray]) -> int:
    """How many occupancy levels pay off by default (a rule of thumb from the bench).

    The highest level with at least :data:`USEFUL_EMPTY_SHARE` of its cells empty, or 0
    when that is below :data:`USEFUL_FIRST_LEVEL`.
    """
    useful = 0
    for number, grid in enumerate(grids, start=1):
        if 1.0 - float(grid.mean()) >= USEFUL_EMPTY_SHARE:
            useful = number
    return useful if useful >= USEFUL_FIRST_LEVEL else 0


def safe_radii(labels: np.ndarray, radius: int) -> np.ndarray:
    """Per voxel, the largest ``r <= radius`` with an empty ``(2r+1)^3`` cube around it.

    The neighbour distance field (uint8; 0 at filled voxels and next to them): a ray
    in that voxel may leave the whole cube in one step. Voxels outside the grid count as
    empty; any label counts as filled (hidden or not), so the field never changes with the
    palette.
    """
    filled = np.asarray(labels) != 0
    result = np.zeros(filled.shape, np.uint8)
    for _ in range(int(radius)):
        filled = grown_by_one(filled)
        result += ~filled
    return result




def bounds_in_cells(bounds, level: int, dimensions: Sequence[int]) -> tuple[np.ndarray,
                                                                          np.ndarray]:
    """``(lower, upper)`` grown to whole cells of ``2^level`` voxels, within the grid."""
    lower, upper = (np.asarray(b, dtype=np.float64) for b in bounds)
    if level <= 0 or not (upper > lower).all():
        return lower, upper
    cell = float(1 << int(level))
    return (np.floor(lower / cell) * cell,
            np.minimum(np.ceil(upper / cell) * cell, np.asarray(dimensions, np.float64)))


def filled_bounds(labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(lower, upper)`` corners (index space) of the box around the filled voxels.

    Both ``(0, 0, 0)`` for a grid with none.
    """
    filled = np.asarray(labels) != 0
    lower, upper = np.zeros(3), np.zeros(3)
    for axis in range(3):
        along = np.flatnonzero(filled.any(axis=tuple(a for a in range(3) if a != axis)))
        if not len(along):
            return np.zeros(3), np.zeros(3)
        lower[axis], upper[axis] = along[0], along[-1] + 1
    return lower, upper


def occupied_bricks(labels: np.ndarray, brick: int) -> np.ndarray:
    """Per brick of ``brick``³ voxels (the last ones cut by the grid), whether any is filled."""
    filled = np.asarray(labels) != 0
    pad = [(0, -n % brick) for n in filled.shape]
    grown = np.pad(filled, pad) if any(p for _, p in pad) else filled
    nx, ny, nz = (n // brick for n in grown.shape)
    return grown.reshape(nx, brick, ny, brick, nz, brick).any(axis=(1, 3, 5))


def face_rectangles(mask: np.ndarray) -> np.ndarray:
    """Cover the true cells of ``mask`` (``(layers, nu, nv)``) with disjoint rectangles.

    Rows ``(layer, u0, u1, v0, v1)``, ends excluded: runs along ``v``, then runs of equal
    extent in consecutive ``u`` merged. Vectorised (no loop over cells); fewer, larger faces
    draw faster on a rasteriser that shades 4x4 blocks (llvmpipe).
    """
    mask = np.asarray(mask, dtype=bool)
    if mask.ndim == 2:
        mask = mask[None]
    padded = np.pad(mask, ((0, 0), (0, 0), (1, 1)))
    change = np.diff(padded.astype(np.int8), axis=2)
    layer, u, v0 = np.nonzero(change == 1)
    v1 = np.nonzero(change == -1)[2]          # the same runs, in the same order
    if not len(u):
        return np.zeros((0, 5), np.int64)
    order = np.lexsort((u, v1, v0, layer))    # runs of equal (layer, v0, v1) by u
    layer, u, v0, v1 = layer[order], u[order], v0[order], v1[order]
    same = np.zeros(len(u), bool)   # whether a run continues the one before it
    same[1:] = ((layer[1:] == layer[:-1]) & (v0[1:] == v0[:-1]) & (v1[1:] == v1[:-1])
                & (u[1:] == u[:-1] + 1))
    starts = np.flatnonzero(~same)
    ends = np.append(starts[1:], len(u)) - 1
    return np.stack([layer[starts], u[starts], u[ends] + 1, v0[starts], v1[starts]],
                    axis=-1).astype(np.int64).reshape(-1, 5)


def brick_shell(labels: np.ndarray, brick: int, margin: float = PROXY_MARGIN,
                max_faces: int | None = None,
                occupied: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """The outer faces of the filled bricks, as quads facing out: ``(points, quads)``.

    A face is kept where a filled brick meets an empty one or the grid's side, so the
    faces close around every filled voxel and a ray meets one before its first hit;
    coplanar faces are merged into rectangles (:func:`face_rectangles`). Each quad stands
    ``margin`` voxels off its bricks and reaches ``2 margin`` past its edges, beyond the
    planes of the faces it meets, so no seam or edge leaves a crack (seen: a pixel lost
    where two faces met at an edge with different vertices). Faces beyond what is needed
    only start some rays earlier, which changes no hit. Index space; ``points`` is ``(4 n, 3)``
    float64, ``quads`` ``(n, 4)`` indices, counter-clockwise seen from outside. ``None``
    when it would have more than ``max_faces`` faces (given). ``occupied``: the bricks'
    occupancy (:func:`occupied_bricks`), if already made.
    """
    if occupied is None:
        occupied = occupied_bricks(labels, brick)
    return shell_faces(occupied, brick, np.asarray(labels).shape, margin, max_faces)


def shell_faces(occupied: np.ndarray, brick: int, dimensions: Sequence[int],
                margin: float = PROXY_MARGIN,
                max_faces: int | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """The outer faces of the bricks ``occupied`` marks, as :func:`brick_shell` makes them.

    ``dimensions``: the grid's voxels (bricks at its far sides are cut there). A negative
    ``margin`` stands the faces inside the bricks and shrinks them by ``2 |margin|``.
    """
    if max_faces is not None and _exposed_faces(occupied) > 16 * max_faces:
        return None   # merging rarely saves that much: not worth merging to find out
    dims = np.array(dimensions, dtype=np.float64)
    corners = []
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3   # (axis, u, v) right-handed: u x v = axis
        for side in (-1, 1):
            neighbour = np.zeros_like(occupied)
            inner = [slice(None)] * 3
            outer = [slice(None)] * 3
            if side > 0:
                inner[axis], outer[axis] = slice(None, -1), slice(1, None)
            else:
                inner[axis], outer[axis] = slice(1, None), slice(None, -1)
            neighbour[tuple(inner)] = occupied[tuple(outer)]
            exposed = np.transpose(occupied & ~neighbour, (axis, u, v))
            cells = face_rectangles(exposed).astype(np.float64)
            if not len(cells):
                continue
            plane = np.minimum((cells[:, 0] + (side > 0)) * brick, dims[axis]) + side * margin
            reach = 2.0 * margin   # past the perpendicular faces' planes: no gap at edges
            u0 = cells[:, 1] * brick - reach
            u1 = np.minimum(cells[:, 2] * brick, dims[u]) + reach
            v0 = cells[:, 3] * brick - reach
            v1 = np.minimum(cells[:, 4] * brick, dims[v]) + reach
            ring = ((u0, v0), (u1, v0), (u1, v1), (u0, v1))
            if side < 0:
                ring = ring[::-1]
            face = np.empty((len(cells), 4, 3))
            face[:, :, axis] = plane[:, None]
            for k, (cu, cv) in enumerate(ring):
                face[:, k, u] = cu
                face[:, k, v] = cv
            corners.append(face.reshape(-1, 3))
    points = np.concatenate(corners) if corners else np.zeros((0, 3))
    quads = np.arange(len(points)).reshape(-1, 4)
    if max_faces is not None and len(quads) > max_faces:
        return None
    return points, quads


def brick_faces(cells: np.ndarray, brick: int, dimensions: Sequence[int],
                margin: float = PROXY_MARGIN) -> tuple[np.ndarray, np.ndarray]:
    """The six outward faces of each brick ``cells`` (``(n, 3)`` brick indices), unmerged.

    As :func:`brick_shell` draws them (standing ``margin`` off, reaching ``2 margin`` past
    the edges): bricks added to a shell by an edit, faces toward filled neighbours included
    (harmless: a ray meets an outer face first).
    """
    cells = np.asarray(cells, dtype=np.float64).reshape(-1, 3)
    dims = np.asarray(dimensions, dtype=np.float64)
    low = cells * brick
    high = np.minimum((cells + 1) * brick, dims)
    corners = []
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        for side in (-1, 1):
            ring = ((0, 0), (1, 0), (1, 1), (0, 1))
            if side < 0:
                ring = ring[::-1]
            face = np.empty((len(cells), 4, 3))
            face[:, :, axis] = (high[:, axis] + margin if side > 0
                                else low[:, axis] - margin)[:, None]
            for k, (a, b) in enumerate(ring):
                face[:, k, u] = high[:, u] + 2 * margin if a else low[:, u] - 2 * margin
                face[:, k, v] = high[:, v] + 2 * margin if b else low[:, v] - 2 * margin
            corners.append(face.reshape(-1, 3))
    points = np.concatenate(corners) if len(cells) else np.zeros((0, 3))
    return points, np.arange(len(points)).reshape(-1, 4)


def brick_bounds(occupied: np.ndarray, brick: int,
                 dimensions: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """``(lower, upper)`` index-space corners of the filled bricks (zeros when none)."""
    if not occupied.any():
        return np.zeros(3), np.zeros(3)
    where = np.argwhere(occupied)
    lower = where.min(axis=0) * brick
    upper = np.minimum((where.max(axis=0) + 1) * brick, np.asarray(dimensions))
    return lower.astype(np.float64), upper.astype(np.float64)


def _exposed_faces(occupied: np.ndarray) -> int:
    """How many brick faces border an empty brick or the grid's side (before merging)."""
    padded = np.pad(occupied, 1)
    return int(sum((padded & ~np.roll(padded, shift, axis)).sum()
                   for axis in range(3) for shift in (-1, 1)))


@dataclass(frozen=True)
class BrickShell:
    """The outer faces (:func:`brick_shell`) of the filled bricks of occupancy ``level``."""

    level: int
    points: np.ndarray
    quads: np.ndarray
    occupied: np.ndarray   # per brick, whether it holds a filled voxel


def choose_shell(labels: np.ndarray) -> BrickShell | None:
    """The finest shell of :data:`SHELL_LEVELS` within :data:`SHELL_FACE_BUDGET` faces."""
    for level in SHELL_LEVELS:
        occupied = occupied_bricks(labels, 1 << level)
        shell = brick_shell(labels, 1 << level, max_faces=SHELL_FACE_BUDGET,
                            occupied=occupied)
        if shell is not None:
            return BrickShell(level, *shell, occupied)
    return None
