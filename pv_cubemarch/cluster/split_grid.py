"""A volume or label grid cut into bricks for sort-last rendering.

Slabs along one axis, or a grid of bricks along all three. A volume's bricks share their
boundary points; a label grid's are cut between voxels. Each brick's values are a NumPy
slice or a lazy slice of a dask array (a zarr store is read through dask), read on the
worker that draws it. What every brick must be drawn with alike
(the whole grid's colour range and opacity unit distance, colours independent of the ids a
brick holds) is settled here, from the whole grid.
"""

from __future__ import annotations

import itertools
import os
from dataclasses import dataclass

import numpy as np

from ..models.label_colors import hashed_colors
from ..models.multiscale import is_zarr_group, multiscale_source
from ..models.zarr_codecs import bounded_array
from ..models.zarr_store import open_zarr
from .partition_march import Partition


@dataclass(frozen=True)
class _LazySlab:
    """A slab of a dask array, read on the worker that draws it (and by no other)."""

    array: object

    def read(self) -> np.ndarray:
        import dask

        return np.asarray(dask.compute(self.array, scheduler="synchronous")[0])


@dataclass(frozen=True)
class SplitVolume:
    """A volume cut into slabs, with what every slab must be drawn with alike.

    ``keywords`` hold the whole volume's ``clim`` and ``opacity_unit_distance`` (by
    default PyVista's, of the whole grid): a slab alone would take its own.
    """

    partitions: tuple[Partition, ...]
    keywords: dict
    token: str


def split_volume(volume, partitions=None, axis: int | None = None, *,
                 scalars: str | None = None, spacing=None, origin=None,
                 keywords: dict | None = None, labels: bool = False) -> SplitVolume:
    """Cut ``volume`` into bricks (see :func:`render_sort_last`).

    ``partitions``: a count of slabs along ``axis``, or bricks per axis ``(nx, ny, nz)``.
    ``labels``: a label grid, one voxel per cell, cut between voxels (no voxel shared).
    """
    from dask.base import tokenize

    values, spacing, origin, coarse = _volume_parts(volume, scalars, spacing, origin, labels)
    shape = tuple(int(n) for n in values.shape)
    counts = _brick_counts(partitions, axis, shape, getattr(values, "chunks", None))
    cells = [n if labels else n - 1 for n in shape]
    for along, (count, available) in enumerate(zip(counts, cells, strict=True)):
        if count > max(available, 1):
            raise ValueError(f"partitions={partitions} is more than the {available} cells "
                             f"along axis {along} (each brick needs one); use at most "
                             f"{max(available, 1)} there, or another axis.")
    # the colour range of an OME-Zarr pyramid's coarsest level, as a streamed volume takes it
    keywords = (_label_look if labels else _volume_look)(
        values if coarse is None else coarse, shape, spacing, dict(keywords or {}))
    cuts = [np.linspace(0, max(n, 0), count + 1).round().astype(int)
            for n, count in zip(cells, counts, strict=True)]
    lazy = not isinstance(values, np.ndarray)
    bricks = []
    # x fastest, as a grid's points are numbered
    for k, j, i in itertools.product(*(range(count) for count in counts[::-1])):
        lower = tuple(int(c[n]) for c, n in zip(cuts, (i, j, k), strict=True))
        upper = tuple(int(c[n + 1]) if m else 0
                      for c, n, m in zip(cuts, (i, j, k), cells, strict=True))
        part = values[tuple(slice(lo, up if labels else up + 1)
                            for lo, up in zip(lower, upper, strict=True))]
        bricks.append(Partition(len(bricks), lower, upper, shape, tuple(spacing),
                                tuple(origin),
                                _LazySlab(part) if lazy else np.ascontiguousarray(part),
                                cells=labels))
    token = tokenize(values, shape, tuple(spacing), tuple(origin), counts, labels)
    return SplitVolume(tuple(bricks), keywords, token)


def _brick_counts(partitions, axis, shape, chunks) -> tuple[int, int, int]:
    """Bricks per axis from ``partitions`` (a count along ``axis``, or one per axis)."""
    def count(value, what: str) -> int:
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise ValueError(f"{what} must be a positive integer, got {value!r}.")
        return int(value)
    if isinstance(partitions, (tuple, list)):
        if axis is not None:
            raise ValueError(f"partitions={tuple(partitions)} gives bricks per axis; leave "
                             f"axis={axis!r} out with it.")
        if len(partitions) != 3:
            raise ValueError(f"partitions as bricks per axis takes three counts (x, y, z), "
                             f"got {tuple(partitions)!r}.")
        return tuple(count(value, "each of partitions") for value in partitions)
    if axis is None:
        axis = int(np.argmax(shape))
    if isinstance(axis, bool) or not isinstance(axis, (int, np.integer)) or \
            axis not in (0, 1, 2):
        raise ValueError(f"axis must be 0, 1 or 2 (x, y, z), got {axis!r}.")
    if partitions is None:
        partitions = len(chunks[axis]) if chunks is not None else 2
    counts = [1, 1, 1]
    counts[axis] = count(partitions, "partitions")
    return tuple(counts)


def _volume_look(values, shape, spacing, keywords: dict) -> dict:
    """What a slab alone would take otherwise, settled from the whole volume.

    Its clim, opacity_unit_distance and number of categories; the theme's colormap (the
    workers have their own theme).
    """
    import pyvista

    if keywords.get("cmap") is None:
        keywords["cmap"] = pyvista.global_theme.cmap
    if keywords.get("nan_policy", "raise") == "raise" and isinstance(values, np.ndarray) \
            and values.dtype.kind == "f" and not np.isfinite(values).all():
        raise ValueError("the volume holds NaN or infinite values; pass nan_policy='zero' "
                         "to draw them as 0, as add_volume takes it.")
    if keywords.get("clim") is None:
        keywords["clim"] = _data_range(values, zero_for_nan=keywords.get("nan_policy")
                                       == "zero")
    if keywords.get("categories") is True:   # as many colours as the whole volume's values
        if isinstance(values, np.ndarray):
            count = np.unique(values).size
        else:
            import dask.array as da

            count = int(da.unique(values.ravel()).size.compute())
        keywords["categories"] = max(int(count), 2)
    if keywords.get("opacity_unit_distance") is None:
        diagonal = float(np.linalg.norm((np.asarray(shape) - 1) * spacing))
        points = float(np.mean(shape)) - 1.0
        keywords["opacity_unit_distance"] = (diagonal / points if points > 0 and diagonal > 0
                                             else float(np.mean(spacing)))
    return keywords


def _label_look(values, shape, spacing, keywords: dict) -> dict:
    """Colours that do not depend on which ids a slab holds.

    By default each id's colour is hashed from it; a colormap spans the whole grid's drawn
    ids unless ``clim`` is given.
    """
    if keywords.get("palette") is None and keywords.get("cmap") is None:
        keywords["palette"] = hashed_color
    elif keywords.get("cmap") is not None and keywords.get("clim") is None:
        keywords["clim"] = _data_range(values, keywords.get("background", 0))
    return keywords


def hashed_color(label) -> tuple[float, float, float]:
    """The colour hashed from ``label`` (a palette function, the same in every slab)."""
    return tuple(float(v) for v in hashed_colors([label])[0, :3])


def _volume_parts(volume, scalars, spacing, origin, cells: bool = False):
    """The (x, y, z) values (NumPy or dask), spacing and origin of a volume input.

    ``cells``: a label grid; an ImageData's cell data (or point data: a voxel centred on
    each point).
    """
    import pyvista

    if isinstance(volume, (str, os.PathLike)) or type(volume).__module__.startswith("zarr"):
        volume = _opened(volume)
        if is_zarr_group(volume):
            return _pyramid_parts(volume, spacing, origin)
        import dask.array as da

        volume = da.from_zarr(bounded_array(volume))
    if isinstance(volume, pyvista.ImageData):
        return (*_image_parts(volume, scalars, spacing, origin, cells), None)
    if scalars is not None:
        raise ValueError("scalars= names an ImageData's array; an array is its own scalars.")
    if not hasattr(volume, "shape") or not hasattr(volume, "dtype"):
        raise TypeError(f"volume must be a NumPy or dask array, a zarr array (or its path) "
                        f"or a pyvista.ImageData, got {type(volume).__name__}.")
    if len(volume.shape) != 3 or min(volume.shape) < 1:
        raise ValueError(f"volume must be a 3-D array of scalars (x, y, z), got shape "
                         f"{tuple(volume.shape)}.")
    kinds = "iu" if cells else "iuf"
    if volume.dtype.kind not in kinds:
        raise ValueError(f"volume must hold {'integer labels' if cells else 'real numbers'},"
                         f" got dtype {volume.dtype}.")
    if type(volume).__module__.split(".")[0] != "dask":
        volume = np.asarray(volume)
    else:   # the zarr arrays it reads (da.from_zarr's), their compression bombs refused
        volume = bounded_array(volume)
    spacing = _triple(spacing, "spacing", (1.0, 1.0, 1.0))
    if not np.all(spacing > 0):
        raise ValueError(f"spacing must be three positive lengths, got {tuple(spacing)}.")
    return volume, spacing, _triple(origin, "origin", (0.0, 0.0, 0.0)), None


def _opened(volume):
    """A zarr array or group from a path (or itself); a clear error for anything else."""
    if not isinstance(volume, (str, os.PathLike)):
        return volume
    try:
        return open_zarr(volume, mode="r")
    except Exception as error:
        raise ValueError(f"volume {os.fspath(volume)!r} is not a zarr array or OME-Zarr image "
                         f"({type(error).__name__}: {error}); give a zarr store's path, a "
                         "NumPy or dask array, or a pyvista.ImageData.") from error


class _LevelArray:
    """A pyramid level as an ``(x, y, z)`` array dask reads box by box.

    Its axes reordered, time and channel fixed, as
    :class:`~pv_cubemarch.models.multiscale.Level` reads.
    """

    def __init__(self, level):
        self.level = level
        self.shape = tuple(int(n) for n in level.shape)
        self.dtype = np.dtype(level.array.dtype)
        self.ndim = 3

    def __getitem__(self, box):
        return self.level.read(tuple(box))


def _pyramid_parts(group, spacing, origin):
    """An OME-Zarr image's finest level (lazy, x y z), its placement, its coarsest level."""
    import dask.array as da

    if spacing is not None or origin is not None:
        raise ValueError("spacing= and origin= place an array; an OME-Zarr image is placed "
                         "by its own metadata: leave them out.")
    try:
        source = multiscale_source(group)
    except Exception as error:
        raise ValueError(f"the zarr group is not an OME-Zarr image ({type(error).__name__}: "
                         f"{error}); give its image group or one of its arrays.") from error
    finest, coarsest = source.levels[0], source.levels[-1]
    chunks = getattr(finest.array, "chunks", None)
    chunks = tuple(chunks[a] for a in finest.axes) if chunks is not None else "auto"
    values = da.from_array(_LevelArray(finest), chunks=chunks, asarray=True)
    coarse = coarsest.read(tuple(slice(0, n) for n in coarsest.shape))
    return (values, np.asarray(finest.scale, float), np.asarray(finest.translation, float),
            coarse)


def _image_parts(volume, scalars, spacing, origin, cells: bool):
    """An ImageData's values (x, y, z), spacing and origin (a label grid's cells' corner)."""
    if spacing is not None or origin is not None:
        raise ValueError("spacing= and origin= place an array; a pyvista.ImageData has "
                         "its own: leave them out.")
    if not np.allclose(volume.direction_matrix, np.eye(3)):
        raise ValueError("a pyvista.ImageData with a direction matrix cannot be split "
                         "yet; resample it onto an axis-aligned grid.")
    data = volume.point_data
    on_cells = cells and (scalars in volume.cell_data if scalars is not None
                          else len(volume.cell_data) > 0)
    if on_cells:
        data = volume.cell_data
    name = scalars or data.active_scalars_name or next(iter(data.keys()), None)
    where = "cell" if on_cells else "point"
    if name is None or name not in data:
        cell_only = "" if cells or not len(volume.cell_data) else (
            f"; its cell arrays {list(volume.cell_data.keys())} are not drawn by a split "
            "volume: move them to the points (ImageData.cell_data_to_point_data())")
        raise ValueError(f"the ImageData has no {where} scalars {name!r} to draw; pass "
                         f"scalars= ({where} arrays: {list(data.keys())}){cell_only}.")
    values = np.asarray(data[name])
    if values.ndim != 1:
        raise ValueError(f"{where} array {name!r} has {values.shape[1]} components; a "
                         f"split grid draws one scalar per {where}.")
    if cells and values.dtype.kind not in "iu":
        raise ValueError(f"{where} array {name!r} holds {values.dtype}, not integer labels.")
    spacing = np.asarray(volume.spacing, float)
    origin = np.asarray(volume.origin, float)
    shape = np.asarray(volume.dimensions) - (1 if on_cells else 0)
    if cells and not on_cells:   # a voxel centred on each point
        origin = origin - 0.5 * spacing
    return values.reshape(tuple(int(n) for n in shape), order="F"), spacing, origin


def _triple(value, name: str, default) -> np.ndarray:
    try:
        triple = np.asarray(default if value is None else value, dtype=float).reshape(3)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be three numbers (x, y, z), got {value!r}.") from None
    if not np.all(np.isfinite(triple)):
        raise ValueError(f"{name} must be finite, got {value!r}.")
    return triple


def _data_range(values, background=None, zero_for_nan: bool = False) -> tuple:
    """The whole grid's finite range (the colour range each slab must share).

    ``background``: a label grid's empty id, left out (its colormap spans the drawn ids).
    ``zero_for_nan``: NaN and infinite values count as 0 (``nan_policy='zero'``).
    """
    if zero_for_nan and values.dtype.kind == "f":
        if isinstance(values, np.ndarray):
            values = np.where(np.isfinite(values), values, 0.0)
        else:
            import dask.array as da

            values = da.where(da.isfinite(values), values, 0.0)
    if isinstance(values, np.ndarray):
        keep = np.isfinite(values) if values.dtype.kind == "f" else np.ones(values.shape, bool)
        if background is not None:
            keep &= values != background
        kept = values[keep]
        low, high = (kept.min(), kept.max()) if kept.size else (np.nan, np.nan)
    else:
        import dask
        import dask.array as da

        if background is not None:
            values = da.where(values == background, np.nan, values.astype(float))
        low, high = dask.compute(da.nanmin(values), da.nanmax(values))
    # integers kept exact (float64 would round ids and counts past 2**53)
    low, high = (v.item() if isinstance(v, np.generic) else v for v in (low, high))
    if not (np.isfinite(float(low)) and np.isfinite(float(high))):
        raise ValueError("the volume holds no finite value to take a colour range from; "
                         "give clim=.")
    return (low, high if high > low else low + 1)
