"""Sort-last rendering of a volume split across a Dask cluster (:func:`render_sort_last`).

The volume is cut into axis-aligned bricks (slabs along one axis, or a grid of bricks)
that share their boundary points; each worker reads only its bricks (a NumPy slice, a dask
array's or a zarr store's part) and marches the whole volume's rays through them
(:mod:`.partition_march`). The client composites the bricks' float images in visibility
order, front-to-back "over" for emission/absorption and the extreme of the extremes for
the intensity projections, as IceT composites ParaView's partitions; for axis-aligned
bricks of one grid that order is exact.
"""

from __future__ import annotations

import time
from collections import OrderedDict
from collections.abc import Sequence

import numpy as np

from ..core.camera import Camera
from ..core.progress import progress
from ..volume.options import DEFAULT_STOP_OPACITY
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
    check_look,
)
from .split_grid import SplitVolume, split_volume

#: Partition views a worker keeps (least recently used closed first).
KEPT_PARTITIONS = 8


def visibility_order(partitions: Sequence[Partition], camera: Camera) -> list[int]:
    """The bricks' indices front to back for ``camera``'s rays.

    Along a ray every coordinate moves away from the camera's, so a brick the ray meets
    later lies no nearer along any axis and farther along the one it crossed into it. The
    bricks sorted by the sum over the axes of their distance from the camera (in cells)
    are therefore in the order of every ray; bricks no common ray meets may fall in any
    order. A parallel projection comes from infinitely far behind: the sum of the bricks'
    lower planes along its direction.
    """
    first = partitions[0]
    origin, spacing = np.asarray(first.origin, float), np.asarray(first.spacing, float)
    if camera.parallel_projection:
        sign = np.sign(np.subtract(camera.focal_point, camera.position))
        return sorted(range(len(partitions)),
                      key=lambda i: float(np.dot(sign, partitions[i].lower)))
    place = (np.asarray(camera.position, float) - origin) / spacing

    def distance(index: int) -> float:
        part = partitions[index]
        lower, upper = np.asarray(part.lower, float), np.asarray(part.upper, float)
        return float(np.maximum(np.maximum(lower - place, place - upper), 0.0).sum())
    return sorted(range(len(partitions)), key=distance)


def _front_to_back(layers: Sequence[tuple], order: Sequence[int], shape: tuple[int, int],
                   stop: float):
    """Walk composite layers front to back as the whole ray would stop.

    Yields ``(index, window, layer, front, crossing, ended)`` per drawn layer: the opacity
    the layers in front leave (from the first pass's layers), the pixels whose whole ray
    passes ``stop`` inside this layer, and those it passed in front of it.
    """
    alpha = np.zeros(shape, np.float64)
    ended = np.zeros(shape, bool)
    for index in order:
        row, col, layer, _ = layers[index]
        if layer is None:
            continue
        window = (slice(row, row + layer.shape[0]), slice(col, col + layer.shape[1]))
        front, before = alpha[window].copy(), ended[window].copy()
        after = front + (1.0 - front) * layer[..., 3]
        crossing = ~before & (after > stop)
        yield index, window, layer, front, crossing, before
        alpha[window] = np.where(before, front, after)
        ended[window] |= crossing


def stop_plan(layers: Sequence[tuple], order: Sequence[int], shape: tuple[int, int],
              stop: float = DEFAULT_STOP_OPACITY) -> dict[int, tuple]:
    """Which composite layers to draw again, with which per-pixel stop opacities.

    The whole volume's march stops at the sample where its opacity passes ``stop``; a slab
    marched alone stops at its own. Where the whole ray stops inside a slab that has
    opacity in front of it, the slab must stop where its own opacity ``a`` gives
    ``front + (1 - front) a > stop``: ``a > (stop - front) / (1 - front)``. (The slabs in
    front of it did not stop early, so ``front`` is exact.) Returns ``{index: (row0, col0,
    stops)}``, ``stops`` a float32 window of the frame, negative where nothing is redrawn.
    """
    plan = {}
    for index, window, _, front, crossing, _ in _front_to_back(layers, order, shape, stop):
        again = crossing & (front > 0.0)
        if not again.any():
            continue
        stops = np.full(again.shape, -1.0, np.float32)
        stops[again] = (stop - front[again]) / (1.0 - front[again])
        plan[index] = (window[0].start, window[1].start, stops)
    return plan


def composite(layers: Sequence[tuple], order: Sequence[int], blending: str,
              shape: tuple[int, int], background, redrawn: dict | None = None,
              stop: float = DEFAULT_STOP_OPACITY, plan: dict | None = None) -> np.ndarray:
    """The frame from the partitions' layers, ``(height, width, 3)`` uint8.

    Each layer is ``(row0, col0, rgba, state)``: a window of premultiplied float RGBA (and
    for the projections the kept value and whether a sample was read). Composite: "over",
    front to back, each pixel ending in the layer where its whole ray passes ``stop``;
    ``redrawn`` maps a layer's index to its second pass (:func:`stop_plan`'s pixels drawn
    again with their own stop opacity, as a layer), which replaces the first there;
    ``plan``: that :func:`stop_plan`, when the caller holds it already.
    Maximum / minimum: per pixel the layer holding the extreme, the first of equals in
    visibility order. The result is drawn over ``background`` (RGB in [0, 1]).
    ``'nearest'``: label slabs' ``(row0, col0, rgb, depth)``, the nearest hit kept.
    """
    height, width = shape
    rgba = np.zeros((height, width, 4), np.float64)
    if blending == "nearest":
        return _nearest([layers[index] for index in order], shape, background)
    if blending == "composite":
        if not redrawn:
            plan = {}
        elif plan is None:
            plan = stop_plan(layers, order, shape, stop)
        for index, window, layer, _, _, ended in _front_to_back(layers, order, shape, stop):
            if index in plan:
                layer = _redrawn_layer(layer, plan[index], redrawn[index])
            under = rgba[window]
            rgba[window] = np.where(ended[..., None], under, under + (1.0 - under[..., 3:])
                                    * layer)
    else:
        held = np.full((height, width), -np.inf)
        sign = -1.0 if blending == "minimum" else 1.0
        for index in order:
            row, col, layer, state = layers[index]
            if layer is None:
                continue
            window = (slice(row, row + layer.shape[0]), slice(col, col + layer.shape[1]))
            value = sign * state[..., 0].astype(np.float64)
            take = (state[..., 1] > 0) & (value > held[window])
            rgba[window][take] = layer[take]
            held[window][take] = value[take]
    color = rgba[..., :3] + (1.0 - rgba[..., 3:]) * np.asarray(background, float)[:3]
    return np.round(np.clip(color, 0.0, 1.0) * 255.0).astype(np.uint8)


def _redrawn_layer(layer, planned, again) -> np.ndarray:
    """``layer`` with the pixels its stop plan drew again taken from the second pass.

    ``planned`` is ``(row0, col0, stops)`` over the layer's window; the second pass sent
    the window of those pixels it reached (inside it), the others it left transparent.
    """
    row, col, stops = planned
    redo = stops >= 0.0
    layer = np.where(redo[..., None], 0.0, layer)
    a_row, a_col, a_rgba, _ = again
    if a_rgba is not None:
        rows = slice(a_row - row, a_row - row + a_rgba.shape[0])
        cols = slice(a_col - col, a_col - col + a_rgba.shape[1])
        layer[rows, cols] = np.where(redo[rows, cols][..., None], a_rgba, layer[rows, cols])
    return layer


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


def worker_addresses(client) -> list[str]:
    """The cluster's workers, asked of the scheduler (waiting for the first to join).

    ``client.scheduler_info()`` is a cache: right after a cluster starts it may list none
    of the workers already there.
    """
    addresses = list(client.nthreads())
    if not addresses:
        client.wait_for_workers(1)
        addresses = list(client.nthreads())
    return addresses


def _placed(workers: list | None) -> dict:
    """``client.submit`` keywords keeping a task on ``workers`` when it can (none: anywhere)."""
    return {} if not workers else {"workers": workers, "allow_other_workers": True}


class SplitRenderer:
    """A split grid placed on a cluster's workers, drawing a frame for any camera.

    Each slab goes to one worker (round robin) and stays there; its plotter is kept per
    look, so later frames only draw. :meth:`submit` asks every slab for its layer at once
    and returns a :class:`SplitFrame` whose ``result()`` composites them.
    """

    def __init__(self, split: SplitVolume, client, size: tuple[int, int], blending: str,
                 background):
        from dask.base import tokenize

        self.split, self.client, self.size = split, client, size
        self.blending, self.background = blending, background
        self.stop = float(split.keywords.get("stop_opacity", DEFAULT_STOP_OPACITY))
        homes = worker_addresses(client)
        self._shared = []
        for part in split.partitions:
            home = _placed([homes[part.index % len(homes)]] if homes else None)
            self._shared.append((client.submit(_same, part, pure=False, **home), home))
        self._look = tokenize(sorted(split.keywords.items(), key=str))   # a view per look
        self.sent = self.composing = 0.0
        #: Frames that needed a second pass (pixels whose whole ray stops in a slab behind
        #: others), and the slabs drawn again in them.
        self.second_passes = self.redrawn_slabs = 0

    def submit(self, camera: Camera) -> SplitFrame:
        """Every slab's layer for ``camera``, asked for now."""
        return SplitFrame(self, camera, self._ask(camera, range(len(self.split.partitions))))

    def _ask(self, camera: Camera, indices, stops: dict | None = None) -> list:
        """Futures of the slabs ``indices``' layers (``stops``: their second pass)."""
        futures = []
        for index in indices:
            part = self.split.partitions[index]
            future, home = self._shared[index]
            # a second pass goes before later frames' first: its frame is being waited for
            extra = {} if stops is None else {"stops": stops[index], "priority": 1}
            futures.append(self.client.submit(
                render_partition, (self.split.token, self._look, part.index, self.size),
                future, camera, self.size, self.split.keywords, pure=False, **home, **extra))
        return futures


class SplitFrame:
    """One frame being drawn by the slabs; ``result()`` waits and composites it.

    Composite frames may take a second round: the slabs where some pixel's whole ray stops
    behind opacity in front draw those pixels again (:func:`stop_plan`), asked for as
    soon as the first layers are all in.
    """

    def __init__(self, renderer: SplitRenderer, camera: Camera, futures: list):
        self.renderer, self.camera, self.futures = renderer, camera, futures
        self.order = visibility_order(renderer.split.partitions, camera)
        self._layers = self._plan = self._again = None

    def _second_round(self) -> None:
        """Once the first layers are in: ask the slabs the stop plan names to draw again."""
        renderer = self.renderer
        self._layers = renderer.client.gather(self.futures)
        self._plan, self._again = {}, []
        if renderer.blending == "composite":
            shape = (renderer.size[1], renderer.size[0])
            self._plan = stop_plan(self._layers, self.order, shape, renderer.stop)
        if self._plan:
            self._again = renderer._ask(self.camera, list(self._plan), self._plan)
            renderer.second_passes += 1
            renderer.redrawn_slabs += len(self._plan)

    def done(self) -> bool:
        """Whether every layer the frame needs has arrived (or one failed)."""
        if self._layers is None:
            if not all(future.done() for future in self.futures):
                return False
            if any(future.status != "finished" for future in self.futures):
                return True   # result() raises the failure
            self._second_round()
        return all(future.done() for future in self._again)

    def outstanding(self) -> list:
        """The futures of the round being waited for that have not arrived."""
        futures = self.futures if self._layers is None else self._again
        return [future for future in futures if not future.done()]

    def cancel(self) -> None:
        """Stop asking for this frame's layers."""
        self.renderer.client.cancel(self.futures + list(self._again or []))

    def result(self) -> np.ndarray:
        """The composited ``(height, width, 3)`` uint8 frame."""
        renderer = self.renderer
        if self._layers is None:
            self._second_round()
        again = dict(zip(self._plan, renderer.client.gather(self._again), strict=True))
        started = time.perf_counter()
        image = composite(self._layers, self.order, renderer.blending,
                          (renderer.size[1], renderer.size[0]), renderer.background,
                          redrawn=again, stop=renderer.stop, plan=self._plan)
        renderer.composing += time.perf_counter() - started
        renderer.sent += sum(a.nbytes + (0 if s is None else s.nbytes)
                             for _, _, a, s in [*self._layers, *again.values()]
                             if a is not None)
        return image


# In each worker process: the partitions it drew, kept for the next frames.
_views: OrderedDict = OrderedDict()
_view_builds = [0]


def worker_view_builds() -> int:
    """Partition views this process built (run on the workers: ``client.run``)."""
    return _view_builds[0]


def render_partition(key: tuple, partition: Partition, camera: Camera, size: tuple[int, int],
                     keywords: dict, stops: tuple | None = None):
    """One partition's layer for one frame, on a worker (its view built at first, then kept).

    Returns ``(row0, col0, rgba, state)`` cropped to the pixels the partition reached
    (``rgba`` None when it reached none), so only those travel. ``stops``: a second pass
    drawing only the pixels of a :func:`stop_plan` window, each with its stop opacity.
    """
    return _gl_thread.submit(_render_kept, key, partition, camera, size, keywords,
                             stops).result()


def _render_kept(key, partition, camera, size, keywords, stops=None):
    view = _views.pop(key, None)
    if view is None:
        view = (LabelView if partition.cells else PartitionView)(partition, size, keywords)
        _view_builds[0] += 1
    try:
        rgba, state = view.render(camera) if stops is None else view.render(camera, stops)
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


def _wait_driving(frames: list, index: int) -> None:
    """Wait for ``frames[index]``, asking later frames' second rounds as their first ends.

    Frames are composited in order; without this, a later frame's second round would be
    asked for only once every frame before it was done.
    """
    from distributed import wait

    while not frames[index].done():
        pending = [future for frame in frames[index:] if frame is not None
                   for future in frame.outstanding()]
        if pending:
            wait(pending, return_when="FIRST_COMPLETED")
        for frame in frames[index + 1:]:
            if frame is not None:
                frame.done()


def prepare_split(volume, *, partitions: int | tuple | None = None, axis: int | None = None,
                  scalars: str | None = None, spacing=None, origin=None,
                  technique: str = "direct", background_color=None, **volume_keywords):
    """The slabs of ``volume`` and how they composite (see :func:`render_sort_last`).

    Returns ``(split, blending, background)``: the :class:`SplitVolume`, the compositing
    rule and the background as RGB in [0, 1]. Every keyword is checked first.
    """
    import pyvista

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
    background = pyvista.Color(background_color if background_color is not None
                               else pyvista.global_theme.background).float_rgb
    check_look(volume_keywords, labels)
    split = split_volume(volume, partitions, axis, scalars=scalars, spacing=spacing,
                         origin=origin, keywords=volume_keywords, labels=labels)
    return split, blending, background


def render_sort_last(volume, cameras, size: tuple[int, int] = (800, 600), *,
                     partitions: int | tuple | None = None, axis: int | None = None,
                     scalars: str | None = None, spacing=None, origin=None,
                     client=None, workers: int | None = None, out=None, fps: float = 24.0,
                     background_color=None, technique: str = "direct",
                     progress_bar: bool | None = None, report: dict | None = None,
                     **volume_keywords):
    """Render a volume or label grid split across a Dask cluster's workers.

    Each worker holds and reads only its slabs of the grid. A volume's slab is marched
    along the whole volume's rays and the client composites the slabs' float images in
    visibility order; the frame equals one plotter's render of the whole volume
    (``add_volume(..., technique='direct')``), also with the camera inside the volume. A
    label grid's slab is drawn voxel by voxel and the client keeps each pixel's nearest
    hit: the same voxels and ids as ``add_voxels`` of the whole grid. By default each
    id's colour is hashed from the id, since no slab knows the whole grid's ids: exactly
    the colours of ``add_voxels(..., palette=split_grid.hashed_color)``.

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
    partitions : int or tuple of int, optional
        Slabs to cut the volume into along ``axis`` (default: a dask array's chunks
        along it, else 2), or bricks per axis ``(nx, ny, nz)`` (``axis`` left out).
        Bricks are spread over the workers and stay there between frames.
    axis : int, optional
        Axis the slabs are cut along (0, 1, 2: x, y, z; default: the one with most
        points).
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
    background_color : color, optional
        What the volume is drawn over (default: PyVista's theme background). (A label
        grid's ``background``, its empty id, is one of the look's keywords.)
    technique : str
        ``'direct'``: a volume, the direct marcher's image; ``'voxels'``: a label grid,
        drawn exactly and opaque, without anti-aliasing.
    progress_bar : bool, optional
        Show a bar as frames finish (default: on a terminal).
    report : dict, optional
        Filled with what the frames cost: ``'bytes'`` sent from the workers per frame,
        ``'composite_s'`` compositing seconds per frame, ``'partitions'``, and the share of
        frames that took a second pass (``'second_passes'``: pixels whose whole ray stops
        inside a slab behind others, drawn again by that slab) with the slabs drawn again
        per frame (``'redrawn_slabs'``).
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
    one = isinstance(cameras, Camera) or hasattr(cameras, "GetPosition") or \
        _is_position(cameras)
    cameras = [as_camera(c, i) for i, c in enumerate([cameras] if one else cameras)]
    if not cameras:
        raise ValueError("cameras is empty: give a camera, or one per frame.")
    if one and out is not None:
        raise ValueError("out= writes a batch of frames; give a list of cameras, or save "
                         "the one image returned.")
    size = _checked_size(size)
    if not float(fps) > 0:
        raise ValueError(f"fps must be positive, got {fps!r}.")
    _checked_workers(client, workers)
    split, blending, background = prepare_split(
        volume, partitions=partitions, axis=axis, scalars=scalars, spacing=spacing,
        origin=origin, technique=technique, background_color=background_color,
        **volume_keywords)
    sink = None
    with local_client(client, workers) as client:
        try:
            sink = _FrameSink(out, len(cameras), float(fps))
            renderer = SplitRenderer(split, client, size, blending, background)
            frames = [renderer.submit(camera) for camera in cameras]
            for index in progress(range(len(cameras)), desc="compositing frames",
                                  enabled=progress_bar):
                try:
                    _wait_driving(frames, index)
                    image = frames[index].result()
                except Exception as error:
                    for frame in frames:
                        frame.cancel()
                    raise FrameError(f"frame {index} (camera at {cameras[index].position}) "
                                     f"failed on the cluster: {type(error).__name__}: "
                                     f"{error}") from error
                sink.put(index, image)
                frames[index] = None
            result, sink = sink.close(), None
        finally:
            if sink is not None:
                sink.abort()
    if report is not None:
        report.update(partitions=len(split.partitions), bytes=renderer.sent / len(cameras),
                      composite_s=renderer.composing / len(cameras),
                      second_passes=renderer.second_passes / len(cameras),
                      redrawn_slabs=renderer.redrawn_slabs / len(cameras))
    return result[0] if one else result
