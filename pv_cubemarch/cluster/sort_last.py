"""Sort-last rendering of a volume split across a Dask cluster (:func:`render_sort_last`).

The volume is cut along one axis into slabs that share their boundary points; each worker
reads only its slab (a NumPy slice, a dask array's or a zarr store's part) and marches the
whole volume's rays through it (:mod:`.partition_march`). The client composites the slabs'
float images in visibility order, front-to-back "over" for emission/absorption and the
extreme of the extremes for the intensity projections, as IceT composites ParaView's
partitions; for slabs along one axis this order is exact.
"""

from __future__ import annotations

import os
import time
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..core.camera import Camera
from ..core.progress import progress
from ..models.label_colors import hashed_colors
from .frames import (
    FrameError,
    _checked_size,
    _checked_workers,
    _FrameSink,
    _gl_thread,
    _is_position,
    _same,
    as_camera,
    local_client,
)
from .partition_march import (
    LABEL_KEYWORDS,
    PARTITION_BLENDING,
    PARTITION_KEYWORDS,
    LabelView,
    Partition,
    PartitionView,
)

#: Partition views a worker keeps (least recently used closed first).
KEPT_PARTITIONS = 8


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


def split_volume(volume, partitions: int | None = None, axis: int | None = None, *,
                 scalars: str | None = None, spacing=None, origin=None,
                 keywords: dict | None = None, labels: bool = False) -> SplitVolume:
    """Cut ``volume`` into ``partitions`` slabs along ``axis`` (see :func:`render_sort_last`).

    ``labels``: a label grid, one voxel per cell, cut between voxels (no voxel shared).
    """
    from dask.base import tokenize

    values, spacing, origin = _volume_parts(volume, scalars, spacing, origin, labels)
    shape = tuple(int(n) for n in values.shape)
    if axis is None:
        axis = int(np.argmax(shape))
    if isinstance(axis, bool) or axis not in (0, 1, 2):
        raise ValueError(f"axis must be 0, 1 or 2 (x, y, z), got {axis!r}.")
    if partitions is None:
        chunks = getattr(values, "chunks", None)
        partitions = len(chunks[axis]) if chunks is not None else 2
    if isinstance(partitions, bool) or not isinstance(partitions, (int, np.integer)) \
            or partitions < 1:
        raise ValueError(f"partitions must be a positive integer, got {partitions!r}.")
    cells = shape[axis] if labels else shape[axis] - 1
    if partitions > max(cells, 1):
        raise ValueError(f"partitions={partitions} is more than the {cells} cells along axis "
                         f"{axis} (each slab needs one); use at most {max(cells, 1)} or "
                         "another axis.")
    keywords = (_label_look if labels else _volume_look)(values, shape, spacing,
                                                         dict(keywords or {}))
    cuts = np.linspace(0, max(cells, 0), partitions + 1).round().astype(int)
    lazy = not isinstance(values, np.ndarray)
    slabs = []
    for index in range(partitions):
        start, stop = int(cuts[index]), int(cuts[index + 1]) if cells else 0
        where = [slice(None)] * 3
        where[axis] = slice(start, stop if labels else stop + 1)
        part = values[tuple(where)]
        slabs.append(Partition(index, axis, start, stop, shape, tuple(spacing), tuple(origin),
                               _LazySlab(part) if lazy else np.ascontiguousarray(part),
                               cells=labels))
    token = tokenize(values if lazy else values.tobytes(), shape, tuple(spacing),
                     tuple(origin), axis, partitions, labels)
    return SplitVolume(tuple(slabs), keywords, token)


def _volume_look(values, shape, spacing, keywords: dict) -> dict:
    """The whole volume's clim and opacity_unit_distance where not given (a slab's differ)."""
    if keywords.get("clim") is None:
        keywords["clim"] = _data_range(values)
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
        import dask.array as da

        try:
            volume = da.from_zarr(os.fspath(volume) if isinstance(volume, os.PathLike)
                                  else volume)
        except Exception as error:
            raise ValueError(f"volume {volume!r} is not a zarr array ({type(error).__name__}: "
                             f"{error}); give a zarr array's path, a NumPy or dask array, "
                             "or a pyvista.ImageData.") from error
    if isinstance(volume, pyvista.ImageData):
        return _image_parts(volume, scalars, spacing, origin, cells)
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
    spacing = _triple(spacing, "spacing", (1.0, 1.0, 1.0))
    if not np.all(spacing > 0):
        raise ValueError(f"spacing must be three positive lengths, got {tuple(spacing)}.")
    return volume, spacing, _triple(origin, "origin", (0.0, 0.0, 0.0))


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
        raise ValueError(f"the ImageData has no {where} scalars {name!r} to draw; pass "
                         f"scalars= ({where} arrays: {list(data.keys())}).")
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


def _data_range(values, background=None) -> tuple[float, float]:
    """The whole grid's finite range (the colour range each slab must share).

    ``background``: a label grid's empty id, left out (its colormap spans the drawn ids).
    """
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
    low, high = float(low), float(high)
    if not (np.isfinite(low) and np.isfinite(high)):
        raise ValueError("the volume holds no finite value to take a colour range from; "
                         "give clim=.")
    return (low, high if high > low else low + 1.0)


def visibility_order(partitions: Sequence[Partition], camera: Camera) -> list[int]:
    """The partitions' indices front to back for ``camera``'s rays.

    Slabs along one axis: the camera's own slab first, then outwards by distance along the
    axis. A ray moves one way along the axis, so slabs on the other side of the camera add
    nothing to its pixel and their order against these does not matter. A parallel
    projection comes from infinitely far behind along its direction.
    """
    first = partitions[0]
    axis, spacing, origin = first.axis, first.spacing[first.axis], first.origin[first.axis]
    if camera.parallel_projection:
        direction = np.subtract(camera.focal_point, camera.position)[axis]
        return sorted(range(len(partitions)),
                      key=lambda i: partitions[i].start * (1 if direction >= 0 else -1))
    place = (camera.position[axis] - origin) / spacing

    def distance(index: int) -> float:
        part = partitions[index]
        return max(part.start - place, place - part.stop, 0.0)
    return sorted(range(len(partitions)), key=distance)


def composite(layers: Sequence[tuple], order: Sequence[int], blending: str,
              shape: tuple[int, int], background) -> np.ndarray:
    """The frame from the partitions' layers, ``(height, width, 3)`` uint8.

    Each layer is ``(row0, col0, rgba, state)``: a window of premultiplied float RGBA (and
    for the projections the kept value and whether a sample was read). Composite: "over",
    front to back; maximum / minimum: per pixel the layer holding the extreme, the first of
    equals in visibility order. The result is drawn over ``background`` (RGB in [0, 1]).
    ``'nearest'``: label slabs' ``(row0, col0, rgb, depth)``, the nearest hit kept.
    """
    height, width = shape
    rgba = np.zeros((height, width, 4), np.float64)
    held = np.full((height, width), -np.inf)
    sign = -1.0 if blending == "minimum" else 1.0
    if blending == "nearest":
        return _nearest([layers[index] for index in order], shape, background)
    for index in order:
        row, col, layer, state = layers[index]
        if layer is None:
            continue
        window = (slice(row, row + layer.shape[0]), slice(col, col + layer.shape[1]))
        if blending == "composite":
            under = rgba[window]
            rgba[window] = under + (1.0 - under[..., 3:]) * layer
            continue
        value = sign * state[..., 0].astype(np.float64)
        take = (state[..., 1] > 0) & (value > held[window])
        rgba[window][take] = layer[take]
        held[window][take] = value[take]
    color = rgba[..., :3] + (1.0 - rgba[..., 3:]) * np.asarray(background, float)[:3]
    return np.round(np.clip(color, 0.0, 1.0) * 255.0).astype(np.uint8)


def _nearest(layers, shape: tuple[int, int], background) -> np.ndarray:
    """Label slabs' frame: at each pixel the colour of the nearest slab's first hit.

    ``layers`` front to back: a hit in a nearer slab keeps its pixel against a farther
    slab's hit at the same depth buffer value (a ray grazing a voxel's side just before the
    cut plane and meeting the next slab's voxel on it: 24 bits cannot tell them apart).
    """
    height, width = shape
    image = np.empty((height, width, 3), np.uint8)
    image[:] = np.round(np.clip(np.asarray(background, float)[:3], 0, 1) * 255.0)
    depth = np.ones((height, width), np.float32)
    for row, col, color, near in layers:
        if color is None:
            continue
        window = (slice(row, row + color.shape[0]), slice(col, col + color.shape[1]))
        take = near < depth[window]
        image[window][take] = color[take]
        depth[window][take] = near[take]
    return image


# In each worker process: the partitions it drew, kept for the next frames.
_views: OrderedDict = OrderedDict()
_view_builds = [0]


def worker_view_builds() -> int:
    """Partition views this process built (run on the workers: ``client.run``)."""
    return _view_builds[0]


def render_partition(key: tuple, partition: Partition, camera: Camera, size: tuple[int, int],
                     keywords: dict):
    """One partition's layer for one frame, on a worker (its view built at first, then kept).

    Returns ``(row0, col0, rgba, state)`` cropped to the pixels the partition reached
    (``rgba`` None when it reached none), so only those travel.
    """
    return _gl_thread.submit(_render_kept, key, partition, camera, size, keywords).result()


def _render_kept(key, partition, camera, size, keywords):
    view = _views.pop(key, None)
    if view is None:
        view = (LabelView if partition.cells else PartitionView)(partition, size, keywords)
        _view_builds[0] += 1
    try:
        rgba, state = view.render(camera)
    except BaseException:
        view.close()
        raise
    _views[key] = view
    while len(_views) > KEPT_PARTITIONS:
        _views.popitem(last=False)[1].close()
    if partition.cells:   # colour and depth of the slab's first hit
        reached = state < 1.0
    else:
        reached = rgba[..., 3] > 0 if state is None else state[..., 1] > 0
    rows, cols = np.flatnonzero(reached.any(axis=1)), np.flatnonzero(reached.any(axis=0))
    if rows.size == 0:
        return 0, 0, None, None
    window = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
    return (int(rows[0]), int(cols[0]), rgba[window].copy(),
            None if state is None else state[window].copy())


def render_sort_last(volume, cameras, size: tuple[int, int] = (800, 600), *,
                     partitions: int | None = None, axis: int | None = None,
                     scalars: str | None = None, spacing=None, origin=None,
                     client=None, workers: int | None = None, out=None, fps: float = 24.0,
                     background=None, technique: str = "direct",
                     progress_bar: bool | None = None, report: dict | None = None,
                     **volume_keywords):
    """Render a volume or label grid split across a Dask cluster's workers.

    Each worker holds and reads only its slabs of the grid. A volume's slab is marched
    along the whole volume's rays and the client composites the slabs' float images in
    visibility order; the frame equals one plotter's render of the whole volume
    (``add_volume(..., technique='direct')``), also with the camera inside the volume. A
    label grid's slab is drawn voxel by voxel and the client keeps each pixel's nearest
    hit: the same voxels, ids and colours as ``add_voxels`` of the whole grid.

    Parameters
    ----------
    volume : numpy.ndarray, dask.array.Array, zarr.Array, str or pyvista.ImageData
        Scalars on the points of a grid ``(x, y, z)`` (with ``technique='voxels'``:
        integer labels, one voxel per array element or ImageData cell); a zarr array or
        its path is read through dask, each worker reading its slab's chunks. A NumPy
        array travels to the workers slab by slab.
    cameras : camera or sequence of cameras
        :class:`pv_cubemarch.Camera`, ``pyvista.Camera`` or camera position; one camera
        gives one frame, a sequence one frame per camera (see :func:`orbit`).
    size : tuple of int
        ``(width, height)`` of every frame.
    partitions : int, optional
        Slabs to cut the volume into (default: a dask array's chunks along ``axis``, else
        2). Slabs are spread over the workers and stay there between frames.
    axis : int, optional
        Axis to cut along (0, 1, 2: x, y, z; default: the one with most points).
    scalars : str, optional
        An ImageData's point array to draw (default: its active scalars).
    spacing, origin : sequence of float, optional
        Where an array's points lie (as ``pyvista.ImageData``'s); default 1 and 0.
    client : dask.distributed.Client, optional
        The cluster; by default a ``LocalCluster`` of ``workers`` processes, closed after.
    workers : int, optional
        Processes of the default ``LocalCluster`` (default 2).
    out : str or os.PathLike, optional
        A folder of PNGs or a movie, as :func:`render_frames` writes them.
    fps : float
        Frames per second of a movie.
    background : color, optional
        What the volume is drawn over (default: PyVista's theme background).
    technique : str
        ``'direct'``: a volume, the direct marcher's image; ``'voxels'``: a label grid,
        drawn exactly and opaque, without anti-aliasing.
    progress_bar : bool, optional
        Show a bar as frames finish (default: on a terminal).
    report : dict, optional
        Filled with what the frames cost: ``'bytes'`` sent from the workers per frame,
        ``'composite_s'`` compositing seconds per frame, ``'partitions'``.
    **volume_keywords
        What :func:`pv_cubemarch.add_volume` takes for the look (``cmap``, ``opacity``,
        ``clim``, ``opacity_unit_distance``, ``blending`` of ``'composite'``,
        ``'maximum'``, ``'minimum'``, ``step_scale`` ...). ``clim`` and
        ``opacity_unit_distance`` default to the whole volume's, as one plotter takes them.
        For labels, what :func:`pv_cubemarch.add_voxels` takes (``palette``, ``cmap``,
        ``shading`` ...); by default each id's colour is hashed from it
        (:func:`pv_cubemarch.hashed_colors`), as no slab knows the whole grid's ids.

    Returns
    -------
    numpy.ndarray, list of numpy.ndarray, list of pathlib.Path or pathlib.Path
        One ``(height, width, 3)`` uint8 frame for one camera; else as
        :func:`render_frames` returns.

    Examples
    --------
    >>> import numpy as np
    >>> import pv_cubemarch
    >>> values = np.random.default_rng(0).random((64, 64, 64))
    >>> camera = [(200, 150, 120), (32, 32, 32), (0, 0, 1)]
    >>> image = pv_cubemarch.render_sort_last(values, camera, (320, 240),
    ...                                       partitions=4)  # doctest: +SKIP
    """
    import pyvista
    from dask.base import tokenize

    one = isinstance(cameras, Camera) or hasattr(cameras, "GetPosition") or \
        _is_position(cameras)
    cameras = [as_camera(c, i) for i, c in enumerate([cameras] if one else cameras)]
    if not cameras:
        raise ValueError("cameras is empty: give a camera, or one per frame.")
    if one and out is not None:
        raise ValueError("out= writes a batch of frames; give a list of cameras, or save "
                         "the one image returned.")
    size = _checked_size(size)
    if technique not in ("direct", "voxels"):
        raise ValueError(f"technique must be 'direct' (a volume) or 'voxels' (a label grid), "
                         f"got {technique!r}.")
    labels = technique == "voxels"
    allowed = LABEL_KEYWORDS if labels else PARTITION_KEYWORDS
    other = sorted(set(volume_keywords) - set(allowed))
    if other:
        raise ValueError(f"{', '.join(other)} cannot be drawn by a split "
                         f"{'label grid' if labels else 'volume'} (only {', '.join(allowed)})"
                         f"; draw it on one machine with "
                         f"{'add_voxels' if labels else 'add_volume'}, or leave them out.")
    blending = "nearest" if labels else volume_keywords.get("blending", "composite")
    if not labels and blending not in PARTITION_BLENDING:
        raise ValueError(f"blending={blending!r} cannot be split across partitions; use one "
                         f"of {PARTITION_BLENDING}.")
    if not float(fps) > 0:
        raise ValueError(f"fps must be positive, got {fps!r}.")
    _checked_workers(client, workers)
    background = pyvista.Color(background if background is not None
                               else pyvista.global_theme.background).float_rgb
    split = split_volume(volume, partitions, axis, scalars=scalars, spacing=spacing,
                         origin=origin, keywords=volume_keywords, labels=labels)
    sink = None
    with local_client(client, workers) as client:
        try:
            sink = _FrameSink(out, len(cameras), float(fps))
            homes = list(client.scheduler_info()["workers"])
            shared = []
            for part in split.partitions:
                home = [homes[part.index % len(homes)]] if homes else None
                shared.append((client.submit(_same, part, pure=False, workers=home,
                                             allow_other_workers=True), home))
            look = tokenize(sorted(split.keywords.items(), key=str))   # a view per look
            frames = []
            for camera in cameras:
                frames.append([client.submit(
                    render_partition, (split.token, look, part.index, size), future, camera, size,
                    split.keywords, workers=home, allow_other_workers=True, pure=False)
                    for part, (future, home) in zip(split.partitions, shared, strict=True)])
            sent = composing = 0.0
            for index in progress(range(len(cameras)), desc="compositing frames",
                                  enabled=progress_bar):
                try:
                    layers = client.gather(frames[index])
                except Exception as error:
                    client.cancel([f for frame in frames for f in frame])
                    raise FrameError(f"frame {index} (camera at {cameras[index].position}) "
                                     f"failed on the cluster: {type(error).__name__}: "
                                     f"{error}") from error
                started = time.perf_counter()
                image = composite(layers, visibility_order(split.partitions, cameras[index]),
                                  blending, (size[1], size[0]), background)
                composing += time.perf_counter() - started
                sent += sum(a.nbytes + (0 if s is None else s.nbytes)
                            for _, _, a, s in layers if a is not None)
                sink.put(index, image)
                frames[index] = None
            result, sink = sink.close(), None
        finally:
            if sink is not None:
                sink.abort()
    if report is not None:
        report.update(partitions=len(split.partitions), bytes=sent / len(cameras),
                      composite_s=composing / len(cameras))
    return result[0] if one else result
