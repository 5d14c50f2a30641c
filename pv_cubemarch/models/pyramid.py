"""Writing an OME-Zarr pyramid for data that has none, out of core, with dask.

Each level halves the one before along x, y and z (odd sides padded with their last
plane): the mean of each 2³ block for intensities (rounded back to integer types), or for
labels the most frequent non-zero id of the block (the smaller on a tie, 0 only where all
eight are), so that a coarse hit is a real label. Each level is read back from the store
to make the next, so memory holds a few chunks whatever the data's size. The metadata is
written by ``ome-zarr-models`` (OME-Zarr 0.5, zarr format 3).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..core.progress import progress
from .multiscale import Level, multiscale_source, needs
from .voxel_levels import representative_levels

#: Ways a level is made from the one before.
METHODS = ("mean", "mode")


class _Points:
    """A level read by ``(x, y, z)`` boxes, as ``dask.array.from_array`` takes it."""

    def __init__(self, level: Level):
        self.level = level
        self.shape = level.shape
        self.dtype = np.dtype(level.array.dtype)
        self.ndim = 3

    def __getitem__(self, box):
        box = tuple(slice(*s.indices(n)) for s, n in zip(box, self.shape, strict=True))
        return self.level.read(box)


def _halve(level, method: str, dtype: np.dtype):
    """The next level of a dask array ``(x, y, z)`` with even chunks: half on each side."""
    import dask.array as da

    pad = [(0, n % 2) for n in level.shape]
    if any(p for _, p in pad):
        # da.pad adds the plane as a chunk of its own (1 wide): even chunks again, or a block
        # of 'mode' would be cut between two (seen: the last coarse plane of labels all 0)
        even = tuple(max(2, c[0] - c[0] % 2) for c in level.chunks)
        level = da.pad(level, pad, mode="edge").rechunk(even)
    if method == "mode":
        return level.map_blocks(lambda block: representative_levels(block, 1)[0],
                                chunks=tuple(tuple(c // 2 for c in axis)
                                             for axis in level.chunks), dtype=dtype)
    mean = da.coarsen(np.mean, level.astype(np.float64), {0: 2, 1: 2, 2: 2})
    if dtype.kind in "iu":
        info = np.iinfo(dtype)
        mean = da.clip(da.round(mean), info.min, info.max)
    return mean.astype(dtype)


def pyramid_shapes(shape: Sequence[int], levels: int | None, chunk_size: int) -> list[tuple]:
    """Each level's points along x, y, z: halved (rounded up) from the one before.

    ``levels=None``: until the coarsest fits one chunk.
    """
    shapes = [tuple(int(n) for n in shape)]
    while (len(shapes) < levels if levels is not None
           else max(shapes[-1]) > chunk_size and max(shapes[-1]) > 1):
        shapes.append(tuple(-(-n // 2) for n in shapes[-1]))
    return shapes


def build_pyramid(source, store, *, levels: int | None = None, chunk_size: int = 64,
                  method: str = "mean", scale: Sequence[float] = (1.0, 1.0, 1.0),
                  translation: Sequence[float] = (0.0, 0.0, 0.0), name: str = "volume",
                  overwrite: bool = False, progress_bar: bool | None = None):
    """Write ``source`` and its coarser levels to ``store`` as an OME-Zarr image.

    Parameters
    ----------
    source : array-like or MultiscaleSource
        The finest level, indexed ``(x, y, z)`` (a numpy, zarr or dask array, or anything
        with ``shape``, ``dtype`` and slicing), or a multiscale source whose finest level
        is used. Read a chunk at a time.
    store : str, pathlib.Path or zarr store
        Where the image goes: a directory path makes a local store, a URL
        (``s3://...``, ``memory://...``) an fsspec store.
    levels : int, optional
        Levels written, the finest included. Default: until the coarsest fits one chunk.
    chunk_size : int
        Edge of the stored chunks (even).
    method : str
        ``'mean'`` (intensities) or ``'mode'`` (labels: the most frequent non-zero id).
    scale, translation : sequence of float
        The finest level's spacing and the position of its first point, along x, y, z.
    name : str
        The multiscale's name in the metadata.
    overwrite : bool
        Replace what ``store`` holds; otherwise an existing image there is an error.
    progress_bar : bool, optional
        Show the writing's progress (``None``: on a terminal).

    Returns
    -------
    zarr.Group
        The image group (open it again with :func:`~pv_cubemarch.multiscale_source`).

    Examples
    --------
    >>> import numpy as np, pv_cubemarch as cm
    >>> image = cm.build_pyramid(np.random.rand(96, 80, 64).astype("float32"),
    ...                          "/tmp/example.ome.zarr", chunk_size=32, overwrite=True)
    >>> [image[str(k)].shape for k in range(3)]   # stored z, y, x
    [(64, 80, 96), (32, 40, 48), (16, 20, 24)]
    """
    needs("dask")
    needs("ome_zarr_models")
    import dask.array as da
    import zarr
    from ome_zarr_models.v05.axes import Axis
    from ome_zarr_models.v05.image import Image
    from pydantic_zarr.v3 import ArraySpec

    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}.")
    if not (isinstance(chunk_size, (int, np.integer)) and chunk_size >= 2
            and chunk_size % 2 == 0):
        raise ValueError(f"chunk_size must be an even integer of at least 2, got {chunk_size!r}.")
    if levels is not None and (not isinstance(levels, (int, np.integer)) or levels < 1):
        raise ValueError(f"levels must be a positive integer or None, got {levels!r}.")
    base_scale = np.asarray(scale, float)
    base_translation = np.asarray(translation, float)
    if base_scale.shape != (3,) or not (np.isfinite(base_scale).all() and (base_scale > 0).all()):
        raise ValueError(f"scale must be three finite positive numbers, got {scale!r}.")
    if base_translation.shape != (3,) or not np.isfinite(base_translation).all():
        raise ValueError(f"translation must be three finite numbers, got {translation!r}.")
    finest = multiscale_source(source).levels[0]
    dtype = np.dtype(finest.array.dtype)
    if method == "mode" and dtype.kind not in "iu":
        raise ValueError(f"method='mode' keeps label ids, which are integers; got {dtype}.")
    shapes = pyramid_shapes(finest.shape, levels, int(chunk_size))
    factors = [2.0 ** k for k in range(len(shapes))]
    specs = [ArraySpec(
        shape=tuple(reversed(shape)), data_type=dtype.name,
        chunk_grid={"name": "regular", "configuration": {"chunk_shape": [chunk_size] * 3}},
        chunk_key_encoding={"name": "default", "configuration": {"separator": "/"}},
        fill_value=0, attributes={}, dimension_names=["z", "y", "x"],
        codecs=[{"name": "bytes", "configuration": {"endian": "little"}},
                {"name": "zstd", "configuration": {"level": 3, "checksum": False}}])
        for shape in shapes]
    image = Image.new(
        array_specs=specs, paths=[str(k) for k in range(len(shapes))],
        axes=[Axis(name=axis, type="space", unit=None) for axis in "zyx"],
        scales=[list(reversed(base_scale * f)) for f in factors],
        translations=[list(reversed(base_translation + (f - 1.0) / 2.0 * base_scale))
                      for f in factors],
        name=name, multiscale_type=f"{method} of 2x2x2 blocks")
    if isinstance(store, str) and "://" in store:   # fsspec: s3://, gs://, memory://, ...
        store = zarr.storage.FsspecStore.from_url(store, read_only=False)
    elif isinstance(store, str) or hasattr(store, "__fspath__"):
        store = zarr.storage.LocalStore(str(store))
    group = image.to_zarr(store, path="", overwrite=overwrite)
    level = da.from_array(_Points(finest), chunks=(chunk_size,) * 3)
    for number in range(len(shapes)):
        if number:
            previous = da.from_zarr(group[str(number - 1)]).transpose(2, 1, 0)
            level = _halve(previous, method, dtype).rechunk((chunk_size,) * 3)
        with _dask_bar(f"{name}: pyramid level {number} of {len(shapes) - 1}", progress_bar):
            da.store(level.transpose(2, 1, 0), group[str(number)], lock=False)
    return group


def _dask_bar(desc: str, enabled: bool | None):
    """A progress bar over a dask computation's tasks (dask's callbacks, tqdm's bar)."""
    from dask.callbacks import Callback

    class Bar(Callback):
        def _start_state(self, dsk, state):
            self.bar = progress(desc=desc, total=sum(len(state[k]) for k in (
                "ready", "waiting")), enabled=enabled)

        def _posttask(self, key, result, dsk, state, worker_id):
            self.bar.update(1)

        def _finish(self, dsk, state, errored):
            self.bar.close()

    return Bar()
