"""Multiscale volumes: the levels of a pyramid, finest first, each read by boxes.

A source is a zarr array, an OME-Zarr multiscale group (its ``multiscales`` metadata,
validated by ``ome-zarr-models``, places each level), a dask array, a list of arrays
finest first (as napari's multiscale data), or any object with ``shape``, ``dtype`` and
slicing. Nothing is read until a box is asked for. Indices are ``(x, y, z)`` as everywhere
in the project; OME-Zarr stores arrays ``(..., z, y, x)``, and a level's other axes (time,
channel) are read at one index.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..core.budgets import host_budget
from ..core.errors import StoreReadError
from .image_files import ARRAY_BYTES_ENV
from .ome_units import unit_factors
from .zarr_codecs import bounded_array
from .zarr_store import open_zarr

#: OME-Zarr's names of the spatial axes, in the project's index order.
SPACE = ("x", "y", "z")


@dataclass(frozen=True)
class Level:
    """One level: its array, where its x, y, z axes lie in it, and its placement.

    ``scale``: the physical step between neighbouring points along x, y, z; ``translation``:
    the physical position of point ``(0, 0, 0)``. ``fixed``: the array's other axes and
    the index each is read at.
    """

    array: object
    shape: tuple[int, int, int]
    scale: np.ndarray
    translation: np.ndarray
    axes: tuple[int, int, int] = (0, 1, 2)
    fixed: dict = field(default_factory=dict)

    def __post_init__(self):
        _check_chunk_bytes(self.array)
        object.__setattr__(self, "array", bounded_array(self.array))   # compression bombs

    def read(self, box) -> np.ndarray:
        """The points in ``box`` (three slices of x, y, z, within the level) as ``(x, y, z)``.

        One read of the array; a copy in the order the project indexes.
        """
        index = [slice(None)] * len(self.array.shape)
        for axis, value in self.fixed.items():
            index[axis] = int(value)
        for spatial, axis in enumerate(self.axes):
            index[axis] = box[spatial]
        try:
            block = np.asarray(self.array[tuple(index)])
        except StoreReadError as error:   # a key refused (a link out of the store, ...)
            raise StoreReadError(f"the points {tuple((s.start, s.stop) for s in box)} were "
                                 f"not read: {error}") from error
        except Exception as error:   # a codec, a chunk cut short, metadata that lies
            where = getattr(self.array, "store_path", None) or type(self.array).__name__
            raise StoreReadError(
                f"{where}: the points {tuple((s.start, s.stop) for s in box)} could not be "
                f"read ({type(error).__name__}: {error}); the store is damaged there, or its "
                "metadata (dtype, chunks, codecs) does not match its chunks.") from error
        kept = [a for a in range(len(index)) if a not in self.fixed]   # in the array's order
        return np.ascontiguousarray(np.transpose(block, [kept.index(a) for a in self.axes]))

    def physical_from_index(self) -> np.ndarray:
        """4x4 from this level's point indices to physical coordinates."""
        matrix = np.eye(4)
        matrix[:3, :3] = np.diag(self.scale)
        matrix[:3, 3] = self.translation
        return matrix


@dataclass
class MultiscaleSource:
    """The levels of a volume, finest first, each with the same dtype."""

    levels: list[Level]
    name: str = "volume"
    #: The axes besides x, y and z (an OME-Zarr image's time and channel), by name: the
    #: index read, the entries there are, and ``'time'`` or ``'channel'``.
    others: dict = field(default_factory=dict)
    #: Arrays with no placement of their own (a list, a zarr or dask array): a label's
    #: finest voxel ``i`` spans ``[i, i + 1]``, as ``add_voxels`` places a numpy array's.
    #: An OME-Zarr image's metadata places the voxels' centres instead.
    cell_origin: bool = False

    def __post_init__(self):
        check_levels(self.levels)

    @property
    def dtype(self) -> np.dtype:
        """The values' type (every level's)."""
        return np.dtype(self.levels[0].array.dtype)

    @property
    def shape(self) -> tuple[int, int, int]:
        """Points along x, y, z of the finest level."""
        return self.levels[0].shape

    @property
    def nbytes(self) -> int:
        """Bytes of the finest level (what reading it whole would take)."""
        return math.prod(int(n) for n in self.shape) * self.dtype.itemsize   # no int64 wrap


def _numbers(values) -> str:
    """``values`` as plain numbers, ``[2, 2, 0.5]`` (not numpy's reprs)."""
    return "[" + ", ".join(f"{float(v):g}" for v in values) + "]"


#: The most levels a pyramid has (each halves the last: 2^40 points a side at most).
MAX_LEVELS = 40


def check_levels(levels: Sequence[Level]) -> None:
    """Refuse levels that do not form a pyramid, saying which and why."""
    if not levels:
        raise ValueError("A multiscale source needs at least one level.")
    if len(levels) > MAX_LEVELS:
        raise ValueError(f"{len(levels):,} levels: a pyramid has at most {MAX_LEVELS} (each "
                         "half the last).")
    dtype = np.dtype(levels[0].array.dtype)
    for number, level in enumerate(levels):
        if np.dtype(level.array.dtype) != dtype:
            raise ValueError(f"Level {number} holds {level.array.dtype}, level 0 {dtype}: every "
                             "level of a pyramid must have the same dtype.")
        if dtype.kind not in "iuf":
            raise ValueError(f"Level {number} holds {dtype}; volumes are numbers (integers or "
                             "floats).")
        if min(level.shape) < 1:
            raise ValueError(f"Level {number} has shape {level.shape} (x, y, z): empty.")
        if not (np.all(np.isfinite(level.scale)) and np.all(level.scale > 0)
                and np.all(np.isfinite(level.translation))):
            raise ValueError(f"Level {number} has scale {_numbers(level.scale)} and translation "
                             f"{_numbers(level.translation)}: scales must be finite and positive, "
                             "translations finite.")
        if number and any(n > m for n, m in zip(level.shape, levels[number - 1].shape,
                                                 strict=True)):
            raise ValueError(f"Level {number} ({level.shape}) is larger than level "
                             f"{number - 1} ({levels[number - 1].shape}) along some axis: "
                             "levels go finest first.")
        if number and np.any(level.scale < levels[number - 1].scale):
            raise ValueError(f"Level {number} has a finer scale ({_numbers(level.scale)}) than "
                             f"level {number - 1} ({_numbers(levels[number - 1].scale)}): levels "
                             "go finest first.")
        if np.any(level.scale < 1e-30) or np.any(level.scale > 1e30) or np.any(
                np.abs(level.translation) / level.scale >= 2.0**53):
            raise ValueError(f"Level {number} has scale {_numbers(level.scale)} and translation "
                             f"{_numbers(level.translation)}: scales from 1e-30 to 1e30 and "
                             "translations under 2^53 voxels are drawn (float32 shaders, "
                             "exact voxel offsets); rescale the metadata.")
        # every level spans the finest one's box, within one of its own voxels (a level
        # of half the points at the same scale covers half the data: drawn as garbage)
        extent = np.asarray(level.shape) * level.scale
        finest = np.asarray(levels[0].shape) * levels[0].scale
        if number and np.any(np.abs(extent - finest) > 1.5 * level.scale + 1e-9 * finest):
            raise ValueError(f"Level {number} spans {_numbers(extent)} ({level.shape} points "
                             f"of {_numbers(level.scale)}), level 0 {_numbers(finest)}: a "
                             "level's shape and scale must cover the same box as the finest "
                             "level's; its metadata says otherwise.")


def _check_chunk_bytes(array) -> None:
    """Refuse a zarr array whose one chunk decodes to more than the memory budget.

    zarr decodes a whole chunk to read any point of it: a 33 KB store of one 1024³ chunk
    took 1.5 GB to read two points. (A chunk whose codec inflates past its own size is
    refused as it is decoded: :mod:`.zarr_codecs`.)
    """
    chunks = getattr(array, "chunks", None)
    if not (isinstance(chunks, tuple) and all(isinstance(n, (int, np.integer)) for n in chunks)):
        return   # not a zarr array (a dask array's chunks are tuples of sizes)
    nbytes = math.prod(int(n) for n in chunks) * np.dtype(array.dtype).itemsize
    budget = host_budget(ARRAY_BYTES_ENV, StoreReadError)
    if budget is not None and nbytes > budget:
        raise StoreReadError(
            f"{getattr(array, 'store_path', 'a zarr array')}: one chunk of {tuple(chunks)} "
            f"takes {nbytes:,} bytes decoded, more than the {budget:,} a read may take "
            f"({ARRAY_BYTES_ENV}); zarr decodes a whole chunk to read any point of it. "
            "Rechunk the store into smaller chunks.")


def needs(module: str):
    """Import an optional dependency of multiscale sources, or say how to install it."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as error:
        raise ImportError(f"{module} is needed for multiscale sources (OME-Zarr, "
                          "build_pyramid): pip install 'pv_cubemarch[multiscale]'.") from error


def _array_level(array, scale=(1.0, 1.0, 1.0), translation=(0.0, 0.0, 0.0)) -> Level:
    """An array indexed ``(x, y, z)`` as a level (no metadata: unit spacing at the origin)."""
    shape = tuple(int(n) for n in np.shape(array))
    if len(shape) != 3:
        raise ValueError(f"A volume array needs 3 axes (x, y, z), got shape {shape}; for "
                         "OME-Zarr data give the multiscale group, whose axes say which is "
                         "which.")
    return Level(array, shape, np.asarray(scale, float), np.asarray(translation, float))


def multiscale_source(source, *, time: int = 0, channel: int = 0,
                      name: str | None = None) -> MultiscaleSource:
    """``source`` as levels, finest first (module docstring); nothing read yet.

    ``time`` and ``channel``: the index read along such axes of OME-Zarr data.
    """
    if isinstance(source, MultiscaleSource):
        return source
    if isinstance(source, str) or hasattr(source, "__fspath__"):
        try:
            source = open_zarr(source, mode="r")
        except Exception as error:   # metadata that is not JSON, a missing codec, ...
            raise ValueError(f"{source}: not a zarr array or group that can be opened "
                             f"({type(error).__name__}: {error}).") from error
    if is_zarr_group(source):
        return _ome_source(source, time, channel, name)
    if isinstance(source, (list, tuple)):
        arrays = list(source)
        if not arrays:
            raise ValueError("A list of levels needs at least one array.")
        base = np.asarray(np.shape(arrays[0]), float)
        levels = []
        for array in arrays:
            shape = np.asarray(np.shape(array), float)
            if shape.size != 3:
                raise ValueError(f"Every level needs 3 axes (x, y, z), got {tuple(shape)}.")
            step = base / shape   # each level spans the finest one's extent, cell centred
            levels.append(_array_level(array, step, (step - 1.0) / 2.0))
        return MultiscaleSource(levels, name or "volume", cell_origin=True)
    if not all(hasattr(source, a) for a in ("shape", "dtype", "__getitem__")):
        raise TypeError(f"A multiscale source is a zarr array or group, a dask or numpy array, "
                        f"a list of arrays finest first, or an object with shape, dtype and "
                        f"slicing; got {type(source).__name__}.")
    return MultiscaleSource([_array_level(source)], name or "volume", cell_origin=True)


def is_zarr_group(value) -> bool:
    """Whether ``value`` is a zarr group (without importing zarr)."""
    return type(value).__module__.startswith("zarr") and type(value).__name__ == "Group"


def _image_error(group) -> str | None:
    """Why ``group`` is not an OME-Zarr image of its version, in a line or three.

    ``open_ome_zarr`` says only that no model validated it (the reason, among every
    model's, is deep in its text); the image model of the group's version says which field
    is wrong. None where that model reads it.
    """
    attributes = dict(group.attrs)
    version = "v05" if "ome" in attributes else "v04"
    scales = _raw_scales(attributes.get("ome", attributes))
    if scales:   # said as it is (the model blames the levels' order for a negative scale)
        return scales
    model = needs(f"ome_zarr_models.{version}.image").Image
    try:
        model.from_zarr(group)
    except Exception as error:   # any: its text is all that is kept
        lines = [re.sub(r"\s*\[type=.*$", "", line).strip()
                 for line in str(error).splitlines()
                 if line.strip() and "errors.pydantic.dev" not in line]
        return "; ".join(line for line in lines[:3] if line) or None
    return None


def _raw_scales(attributes: dict) -> str | None:
    """What is wrong with the first multiscale's scales as written, if one is not positive."""
    try:
        datasets = attributes["multiscales"][0]["datasets"]
        for number, dataset in enumerate(datasets):
            for transform in dataset.get("coordinateTransformations", ()):
                scale = transform.get("scale") if transform.get("type") == "scale" else None
                if scale is not None and not all(
                        isinstance(v, (int, float)) and np.isfinite(v) and v > 0
                        for v in scale):
                    return (f"dataset {number} ({dataset.get('path')!r}) has scale {scale}: "
                            "every entry must be a positive number (a voxel's size along "
                            "its axis); mirror an axis with the transform given to add_*")
    except (KeyError, IndexError, TypeError, AttributeError):
        return None   # the model says what is missing
    return None


def _raw_levels(group) -> None:
    """Refuse more datasets than a pyramid has levels, or one dataset named twice.

    Read from the attributes as written, before the model opens every array (2,000
    datasets naming one array took 71 s and 1.3 GB to be refused for the GPU's pool).
    """
    attributes = dict(group.attrs)
    try:
        datasets = attributes.get("ome", attributes)["multiscales"][0]["datasets"]
        paths = [str(dataset.get("path")) for dataset in datasets]
    except (KeyError, IndexError, TypeError, AttributeError):
        return   # the model says what is missing
    if len(paths) > MAX_LEVELS:
        raise ValueError(f"The zarr group {group.path or group.store!s} lists {len(paths):,} "
                         f"datasets; a pyramid has at most {MAX_LEVELS} levels (each half "
                         "the last): its metadata is damaged or hostile.")
    twice = sorted({p for p in paths if paths.count(p) > 1})
    if twice:
        raise ValueError(f"The zarr group {group.path or group.store!s} lists the dataset(s) "
                         f"{', '.join(map(repr, twice[:3]))} more than once; each level is "
                         "its own array.")


def _ome_source(group, time: int, channel: int, name: str | None) -> MultiscaleSource:
    """An OME-Zarr image group's first multiscale, validated and placed by its metadata."""
    _raw_levels(group)
    ome_zarr_models = needs("ome_zarr_models")
    from pydantic import ValidationError

    try:
        image = ome_zarr_models.open_ome_zarr(group)
    except (ValidationError, ValueError, TypeError, KeyError, RuntimeError) as error:
        raise ValueError(f"The zarr group {group.path or group.store!s} is not a valid OME-Zarr "
                         f"image: {_image_error(group) or str(error).splitlines()[0]}"
                         ) from error
    attributes = getattr(image, "ome_attributes", None) or image.attributes
    multiscales = getattr(attributes, "multiscales", None)
    if not multiscales:
        raise ValueError(f"The zarr group {group.path or group.store!s} holds no multiscales "
                         "metadata (an OME-Zarr image, or give one array).")
    scales = multiscales[0]
    names = [axis.name for axis in scales.axes]
    kinds = [axis.type for axis in scales.axes]
    missing = [s for s in SPACE if s not in names]
    if missing:
        raise ValueError(f"The image's axes are {names}: a volume needs space axes x, y and z "
                         f"({', '.join(missing)} missing).")
    axes = tuple(names.index(s) for s in SPACE)
    units = [None if getattr(axis, "unit", None) is None else str(
        getattr(axis.unit, "value", axis.unit)) for axis in scales.axes]
    factors = np.asarray(unit_factors(names, kinds, units, SPACE))   # into x's unit
    fixed, others = {}, {}
    finest = group[scales.datasets[0].path].shape
    for index, (axis_name, kind) in enumerate(zip(names, kinds, strict=True)):
        if index in axes:
            continue
        along = "channel" if kind == "channel" or axis_name == "c" else "time"
        fixed[index] = channel if along == "channel" else time
        others[axis_name] = (fixed[index], int(finest[index]), along)
    overall = _transforms(getattr(scales, "coordinateTransformations", None), len(names))
    levels = []
    for dataset in scales.datasets:
        array = group[dataset.path]
        for axis, value in fixed.items():
            if not 0 <= value < array.shape[axis]:
                raise ValueError(f"Index {value} along the image's {names[axis]!r} axis is "
                                 f"outside its {array.shape[axis]} entries.")
        scale, translation = _transforms(dataset.coordinateTransformations, len(names))
        scale, translation = scale * overall[0], translation * overall[0] + overall[1]
        levels.append(Level(array, tuple(int(array.shape[a]) for a in axes),
                            scale[list(axes)] * factors, translation[list(axes)] * factors,
                            axes, fixed))
    return MultiscaleSource(levels, name or (scales.name or "volume"), others)


def _transforms(transforms, ndim: int) -> tuple[np.ndarray, np.ndarray]:
    """A scale and a translation per axis from OME-Zarr coordinate transformations."""
    scale, translation = np.ones(ndim), np.zeros(ndim)
    for transform in transforms or ():
        kind = getattr(transform, "type", None)
        if kind == "scale" and getattr(transform, "scale", None) is not None:
            scale = scale * np.asarray(transform.scale, float)
        elif kind == "translation" and getattr(transform, "translation", None) is not None:
            translation = translation + np.asarray(transform.translation, float)
        elif kind != "identity":
            raise ValueError(f"OME-Zarr coordinate transformation {transform!r} is not "
                             "supported (only scale, translation and identity values).")
    return scale, translation
