"""Editing a drawn material grid: labels changed in place, only what they touch uploaded.

An edit writes the labels, then refreshes the box of voxels it touched: that box of the
labels, the occupancy cells above it at each level and the distance field around it go up as
sub-texture uploads (:meth:`pv_cubemarch.gl.textures.Texture.update_region`); the brick
shell and the box around the filled voxels are rebuilt from the labels. Every edit is
exact: the next frame equals a grid built from the edited labels.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..core.errors import VolumeDataError
from ..gl.box import box_polydata
from ..models.procedural import sphere
from ..models.voxel_levels import (
    atlas_updates,
    bounds_in_cells,
    filled_bounds,
    level_origin,
    safe_radii,
)
from .options import drawn_level

Box = tuple[slice, slice, slice]
#: Edits touching more than this share of the grid upload it whole.
WHOLE_UPLOAD_SHARE = 0.5


def checked_material(binding, material) -> int:
    """``material`` as the row the grid's labels and palette hold, or a clear error.

    A grid whose ids were compacted takes its own ids (the background empties); an id it
    does not hold is refused, as its rows are fixed when the grid is made.
    """
    ids = binding.model.ids
    if not ids.identity:
        return int(compacted_rows(ids, material, "material")[0])
    return check_material(material, binding.model.labels.dtype, binding.model.palette)


def compacted_rows(ids, values, name: str) -> np.ndarray:
    """Rows of label ids of a compacted grid, or an error saying what can be written."""
    try:
        return ids.rows_of(values, name)
    except ValueError as error:
        raise ValueError(f"{error} This grid's ids were compacted when it was made: edits "
                         f"write its own ids or the background ({ids.background}); make the "
                         "grid again (add_voxels) to add new ids.") from None


def check_material(material, dtype, palette) -> int:
    """``material`` as an int labels of ``dtype`` and ``palette`` hold, or a clear error."""
    if isinstance(material, (bool, np.bool_)) or not float(material).is_integer():
        raise ValueError(f"material must be a whole number, got {material!r}.")
    value = int(material)
    top = int(np.iinfo(dtype).max)
    if not 0 <= value <= top:
        raise ValueError(f"material must be in 0..{top} for this grid's {np.dtype(dtype)} "
                         f"labels, got {value}.")
    if value >= palette.n_materials:
        raise ValueError(f"Material {value} has no colour: the grid's tables hold the ids "
                         f"0..{palette.n_materials - 1} it was added with (their colours "
                         "from palette= or cmap=). Add it with every id it will hold: with "
                         "cmap=, a grid whose largest id is at least this one (clim= keeps "
                         "the colours), or a palette= with more entries; or use a smaller "
                         "label.")
    return value


def checked_labels_for(binding, values: np.ndarray) -> np.ndarray:
    """The rows to write for ``values``; labels the grid cannot hold are refused."""
    ids = binding.model.ids
    if not ids.identity:
        return compacted_rows(ids, values, "values").reshape(values.shape).astype(
            binding.model.labels.dtype)
    check_labels(values, binding.model.labels.dtype, binding.model.palette)
    return values


def check_labels(values: np.ndarray, dtype, palette) -> None:
    """Refuse labels ``palette`` has no colour for, or labels of ``dtype`` cannot hold."""
    top = min(palette.n_materials, int(np.iinfo(dtype).max) + 1) - 1
    if values.size and (not np.issubdtype(values.dtype, np.integer) or values.min() < 0
                        or values.max() > top):
        raise VolumeDataError(f"Labels must be whole numbers in 0..{top} (the palette's "
                              f"materials that the grid's {np.dtype(dtype)} labels hold).")


def box_of(where, dimensions: Sequence[int]) -> tuple[Box, np.ndarray | None]:
    """The box an index, a tuple of slices or a boolean mask of the grid touches.

    Returns the box and, for a mask, the mask cut to it (``None`` otherwise).
    """
    dims = tuple(int(n) for n in dimensions)
    if isinstance(where, np.ndarray) and where.dtype == bool:
        if where.shape != dims:
            raise ValueError(f"A mask must have the grid's shape {dims}, got {where.shape}.")
        if not where.any():
            return (slice(0, 0),) * 3, where[:0, :0, :0]
        box = tuple(slice(int(np.flatnonzero(where.any(axis=tuple(a for a in range(3)
                                                                    if a != axis)))[0]),
                          int(np.flatnonzero(where.any(axis=tuple(a for a in range(3)
                                                                  if a != axis)))[-1]) + 1)
                    for axis in range(3))
        return box, where[box]
    if not isinstance(where, tuple) or len(where) != 3:
        raise ValueError("where must be an (i, j, k) index, a tuple of three slices or of "
                         "three index arrays, or a boolean mask of the grid's shape, got "
                         f"{where!r}.")
    if any(np.ndim(item) > 0 for item in where):   # numpy's (i's, j's, k's) index arrays
        mask = np.zeros(dims, bool)
        try:
            mask[tuple(np.asarray(item, dtype=np.int64) for item in where)] = True
        except (IndexError, ValueError, TypeError) as exc:
            raise IndexError(f"where as index arrays (i's, j's, k's) must be integers of one "
                             f"length inside the grid's shape {dims}: {exc}") from exc
        return box_of(mask, dims)
    box = []
    for axis, (item, n) in enumerate(zip(where, dims, strict=True)):
        if isinstance(item, slice):
            start, stop, step = item.indices(n)
            if step != 1:
                raise ValueError("slices of an edit must have step 1.")
            box.append(slice(start, max(start, stop)))
        else:
            index = int(item)
            if not -n <= index < n:
                raise IndexError(f"index {index} is outside axis {axis} of size {n}.")
            index %= n
            box.append(slice(index, index + 1))
    return tuple(box), None


def set_voxels(binding, where, material) -> None:
    """Set the voxels ``where`` (index, slices or boolean mask) to ``material``."""
    value = checked_material(binding, material)
    box, mask = box_of(where, binding.model.dimensions)
    if any(s.stop <= s.start for s in box):
        return
    if mask is None:
        binding.model.labels[box] = value
    else:
        binding.model.labels[box][mask] = value
    refresh(binding, box)


def fill_sphere(binding, center: Sequence[float], radius: float, material) -> None:
    """Set the voxels whose centre lies within ``radius`` of ``center`` (index space)."""
    value = checked_material(binding, material)
    box, local = sphere_region(center, radius, binding.model.dimensions)
    if local is None:
        return
    binding.model.labels[box][local] = value
    refresh(binding, box)


def sphere_region(center: Sequence[float], radius: float,
                  dimensions: Sequence[int]) -> tuple[Box, np.ndarray | None]:
    """The box of voxels whose centre is within ``radius`` of ``center``, and their mask.

    The mask is ``None`` when the sphere misses the grid.
    """
    if not float(radius) >= 0:
        raise ValueError(f"radius must be at least 0, got {radius!r}.")
    if len(center) != 3:
        raise ValueError(f"center must be three coordinates, got {center!r}.")
    center = np.asarray(center, dtype=np.float64)
    box = tuple(slice(max(0, int(np.floor(c - radius))), min(n, int(np.ceil(c + radius)) + 1))
                for c, n in zip(center, dimensions, strict=True))
    if any(s.stop <= s.start for s in box):
        return box, None
    shape = tuple(s.stop - s.start for s in box)
    return box, sphere(center - [s.start for s in box], float(radius)).voxels(shape) > 0


def fill_box(binding, lower: Sequence[int], upper: Sequence[int], material) -> None:
    """Set the voxels ``lower <= (i, j, k) < upper`` to ``material``."""
    set_voxels(binding, clipped_box(lower, upper, binding.model.dimensions), material)


def clipped_box(lower: Sequence[int], upper: Sequence[int], dimensions: Sequence[int]) -> Box:
    """The voxels ``lower <= (i, j, k) < upper``, clipped to the grid, as three slices."""
    if len(lower) != 3 or len(upper) != 3:
        raise ValueError("lower and upper must be three voxel indices each.")
    return tuple(slice(min(max(int(a), 0), n), min(max(int(b), 0), n))
                 for a, b, n in zip(lower, upper, dimensions, strict=True))


def set_block(binding, where: tuple, values: np.ndarray) -> None:
    """Write ``values`` into the box ``where`` (a tuple of three slices, step 1)."""
    box, mask = box_of(where, binding.model.dimensions)
    values = np.asarray(values)
    shape = tuple(s.stop - s.start for s in box)
    if mask is not None or values.shape != shape:
        raise ValueError(f"set_block needs a tuple of slices and values of its shape {shape}, "
                         f"got values of {values.shape}.")
    values = checked_labels_for(binding, values)
    if not values.size:
        return
    binding.model.labels[box] = values
    refresh(binding, box)


def set_values(binding, labels: np.ndarray) -> None:
    """Replace every label (same shape); uploaded whole."""
    labels = np.asarray(labels)
    model = binding.model
    if labels.shape != model.labels.shape:
        raise ValueError(f"set_values needs labels of the grid's shape {model.labels.shape}, "
                         f"got {labels.shape}.")
    labels = checked_labels_for(binding, labels)
    model.labels[...] = labels
    refresh(binding, tuple(slice(0, n) for n in model.labels.shape))


def refresh(binding, box: Box) -> None:
    """Send what the labels in ``box`` change to the GPU at the next frame."""
    labels = binding.model.labels
    dims = labels.shape
    lower = [s.start for s in box]
    upper = [s.stop for s in box]
    share = np.prod([b - a for a, b in zip(lower, upper, strict=True)]) / labels.size
    textures = [binding.labels, *binding.skipping]
    whole = share > WHOLE_UPLOAD_SHARE
    if whole:
        for texture in textures:
            texture.invalidate()
    else:
        for origin, block in atlas_updates(
                labels, box, binding.options.mip_levels or 0, binding.options.lod,
                lambda level: level_origin(dims, level, *binding.level_axes)):
            binding.labels.update_region(origin, block)   # the labels, then their levels
        radius = binding.options.distance_field
        if radius:
            outer = [slice(max(0, a - 2 * radius), min(n, b + 2 * radius))
                     for a, b, n in zip(lower, upper, dims, strict=True)]
            inner = [slice(max(0, a - radius), min(n, b + radius))
                     for a, b, n in zip(lower, upper, dims, strict=True)]
            radii = safe_radii(labels[tuple(outer)], radius)
            cut = tuple(slice(i.start - o.start, i.stop - o.start)
                        for i, o in zip(inner, outer, strict=True))
            binding.skipping[0].update_region([s.start for s in inner], radii[cut])
    shell = binding.shell
    if not binding.box_follows_voxels:
        return   # the whole grid's box is drawn
    before = tuple(np.concatenate(binding.drawn_bounds))
    if shell is not None and (shell.enabled or whole):
        if whole:
            shell.rebuild()
        else:
            shell.edit(box)
        # the filled voxels' box, as drawn when added: grown by an edit, shrunk where it
        # emptied the box's faces, found anew by a whole one
        after = filled_bounds(labels) if whole or not shell.enabled else _grown(
            _shrunk(binding.drawn_bounds, labels, box), labels, box)
    else:   # no shell fits: the box around the labels
        after = filled_bounds(labels) if whole else _grown(
            _shrunk(binding.drawn_bounds, labels, box), labels, box)
        after = bounds_in_cells(after, drawn_level(binding.options), dims)
    if tuple(np.concatenate(after)) != before:
        binding.drawn_bounds = after
        binding.set_box_polydata(box_polydata(*after, 0.01 * max(dims)))
        # the camera's clipping range stays as it is, as PyVista's after a mesh's edit


def _shrunk(bounds, labels: np.ndarray, box: Box) -> tuple[np.ndarray, np.ndarray]:
    """``bounds`` moved in past the faces an edit in ``box`` emptied (an erase at a face).

    Only a face the edit reaches is looked at, a plane at a time inward up to the first
    filled voxel: an edit inside the box costs nothing. No voxel left: both corners 0, as
    :func:`filled_bounds` says.
    """
    lower, upper = (np.asarray(b, dtype=np.float64).copy() for b in bounds)
    if not (upper > lower).all():
        return lower, upper
    reaches = [(box[a].start <= lower[a], box[a].stop >= upper[a]) for a in range(3)]
    for axis in range(3):
        for side in (0, 1):
            while reaches[axis][side] and lower[axis] < upper[axis]:
                plane = int(lower[axis]) if side == 0 else int(upper[axis]) - 1
                window = [slice(int(a), int(b)) for a, b in zip(lower, upper, strict=True)]
                window[axis] = slice(plane, plane + 1)
                if np.any(labels[tuple(window)]):
                    break
                if side == 0:
                    lower[axis] += 1
                else:
                    upper[axis] -= 1
            if not lower[axis] < upper[axis]:
                return np.zeros(3), np.zeros(3)
    return lower, upper


def _grown(bounds, labels: np.ndarray, box: Box) -> tuple[np.ndarray, np.ndarray]:
    """``bounds`` grown to the filled voxels in ``box`` (:func:`_shrunk` moves them in)."""
    lower, upper = (np.asarray(b, dtype=np.float64) for b in bounds)
    inside, _ = box_of(labels[box] != 0, labels[box].shape)
    if any(s.stop <= s.start for s in inside):
        return lower, upper
    if not (upper > lower).all():   # nothing was filled before
        lower, upper = np.full(3, np.inf), np.full(3, -np.inf)
    start = np.array([b.start + s.start for b, s in zip(box, inside, strict=True)], float)
    stop = np.array([b.start + s.stop for b, s in zip(box, inside, strict=True)], float)
    return np.minimum(lower, start), np.maximum(upper, stop)
