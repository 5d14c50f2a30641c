"""Frames of one scene rendered on a Dask cluster (:func:`render_frames`).

Each worker process builds the scene once in an offscreen plotter and keeps it, keyed by
the scene and the frame size, so a batch loads the data once per worker, not once per
frame. Frames come back in camera order whatever order they finish in. A worker that dies
costs only the frames it held, which the scheduler runs again on another worker.
"""

from __future__ import annotations

import hashlib
import os
import warnings
from collections import OrderedDict
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyvista

from ..core.camera import Camera
from ..core.errors import CubemarchError
from ..core.progress import progress
from ..core.rendering import offscreen_plotter, render_image, tracked_bindings
from ..scene.io import load_scene
from ..scene.model import Scene

#: Plotters a worker keeps (least recently used dropped first): one per scene and size.
KEPT_PLOTTERS = 2
#: Movies render_frames writes (``out``; imageio-ffmpeg, GIF by imageio); else a folder.
MOVIE_SUFFIXES = (".mp4", ".mov", ".mkv", ".avi", ".webm", ".gif")
#: Suffixes of one image: refused as ``out`` (a folder of frames would be made by that name).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")


class FrameError(CubemarchError, RuntimeError):
    """A frame the cluster could not render right (its error, or an image not converged)."""


class SceneBuildError(FrameError):
    """The scene could not be built on a worker (every frame would fail alike)."""


@dataclass(frozen=True)
class SceneSource:
    """What a worker builds its plotter from, and the key its plotter is kept under."""

    key: str
    path: str | None = None
    builder: Callable | None = None

    @classmethod
    def of(cls, scene) -> SceneSource:
        """A scene file's path, a :class:`~pv_cubemarch.Scene`, or ``build(plotter)``."""
        if isinstance(scene, (str, os.PathLike)):
            path = Path(scene).expanduser().resolve()
            if not path.is_file():
                raise FileNotFoundError(f"scene {str(scene)!r} is not a file: give a scene "
                                        "file, a pv_cubemarch.Scene or a function that adds "
                                        "what it draws to the plotter it is given.")
            stat = path.stat()
            return cls(f"{path}:{stat.st_mtime_ns}:{stat.st_size}", path=str(path))
        if isinstance(scene, Scene) or callable(scene):
            import cloudpickle  # what Dask ships functions with: the key is their bytes

            try:
                data = cloudpickle.dumps(scene)
            except Exception as error:
                raise TypeError(f"scene cannot be sent to the workers ({type(error).__name__}: "
                                f"{error}): a build function must be picklable (no open "
                                "files, locks or plotters in what it uses).") from error
            builder = _SceneAdder(scene) if isinstance(scene, Scene) else scene
            return cls(hashlib.sha256(data).hexdigest(), builder=builder)
        raise TypeError(f"scene must be a scene file's path, a pv_cubemarch.Scene or a "
                        f"function build(plotter), got {type(scene).__name__}.")

    def build(self, size: tuple[int, int]):
        """An offscreen plotter of ``size`` holding the scene."""
        plotter = offscreen_plotter(size)
        try:
            if self.path is not None:
                load_scene(self.path, progress_bar=False).add_to(plotter, progress_bar=False)
            else:
                self.builder(plotter)
        except BaseException:
            plotter.close()
            raise
        return plotter


@dataclass(frozen=True)
class _SceneAdder:
    """``build(plotter)`` for a loaded Scene (picklable, unlike a lambda's closure name)."""

    scene: object

    def __call__(self, plotter) -> None:
        self.scene.add_to(plotter, progress_bar=False)


# In each worker process: its plotters, how many times it built one, and the one thread
# every frame is drawn on (a GL context is current on one thread; a worker may run its
# tasks on several).
_kept: OrderedDict = OrderedDict()
_builds = [0]
_gl_thread = ThreadPoolExecutor(1, thread_name_prefix="pv-cubemarch-gl")


def render_one(source: SceneSource, camera: Camera, size: tuple[int, int]) -> np.ndarray:
    """One frame, on a worker: its kept plotter for the scene (built at first), converged."""
    return _gl_thread.submit(_render_kept, source, camera, size).result()


def _render_kept(source: SceneSource, camera: Camera, size: tuple[int, int]) -> np.ndarray:
    key = (source.key, size)
    plotter = _kept.pop(key, None)
    if plotter is None:
        try:
            plotter = source.build(size)
        except Exception as error:
            raise SceneBuildError(f"building the scene failed on a worker: "
                                  f"{type(error).__name__}: {error}") from error
        _builds[0] += 1
    try:
        camera.apply_to(plotter.camera)
        if camera.clipping_range is None:
            plotter.renderer.ResetCameraClippingRange()
        with warnings.catch_warnings():   # not converged in time: an error, not a frame
            warnings.filterwarnings("error", message=r"render_image\(converge=True\)")
            image = render_image(plotter, converge=True)
        _check_streamed(plotter)
    except BaseException:
        plotter.close()   # a later try builds it again: bricks failed here are read anew
        raise
    _kept[key] = plotter
    while len(_kept) > KEPT_PLOTTERS:
        _kept.popitem(last=False)[1].close()
    return image


def _check_streamed(plotter) -> None:
    """Raise if a streamed source of the plotter drew a brick from a coarser level."""
    for binding in tracked_bindings(plotter):
        pager = getattr(binding, "pager", None)
        failed = len(pager.cache.failed) if pager is not None else 0
        if failed:
            raise FrameError(f"{failed} bricks of {binding.model.name!r} could not be read; "
                             "the frame would draw them from a coarser level.")


def _same(value):
    """The value itself (a task whose result the scheduler can make again)."""
    return value


def worker_builds() -> int:
    """How many plotters this process built (run on the workers: ``client.run``)."""
    return _builds[0]


def as_camera(camera, index: int = 0) -> Camera:
    """A :class:`Camera`, a ``pyvista.Camera`` or a camera position (3 points).

    Refused, naming ``cameras[index]``, when it makes no view (a value not finite, the
    position on the focal point, view up along the view): such a frame drew black.
    """
    if hasattr(camera, "GetPosition") and not isinstance(camera, Camera):
        camera = Camera.from_pyvista(camera)
    elif not isinstance(camera, Camera):
        try:
            position, focal, up = (tuple(float(v) for v in point) for point in camera)
            if not all(len(p) == 3 for p in (position, focal, up)):
                raise ValueError
        except (TypeError, ValueError):
            raise ValueError(f"cameras[{index}] must be a pv_cubemarch.Camera, a "
                             f"pyvista.Camera or a camera position [(x, y, z), focal point, "
                             f"view up], got {camera!r}.") from None
        camera = Camera(position, focal, up)
    if not np.all(np.isfinite([*camera.position, *camera.focal_point, *camera.view_up])):
        raise ValueError(f"cameras[{index}] holds a value that is not finite: {camera}.")
    try:
        camera.basis()   # a view direction and view up that make a view
    except ValueError as error:
        raise ValueError(f"cameras[{index}]: {error}") from None
    return camera


def orbit(camera, frames: int) -> list[Camera]:
    """``frames`` cameras turning once around ``camera``'s focal point, about its view up.

    Each keeps the camera's clipping range (its distance to the focal point is the same);
    a camera without one has its range fitted to the scene at each frame.

    Examples
    --------
    >>> import pv_cubemarch
    >>> cameras = pv_cubemarch.orbit([(10, 0, 0), (0, 0, 0), (0, 0, 1)], 4)
    >>> [tuple(round(v, 6) for v in c.position) for c in cameras][:2]
    [(10.0, 0.0, 0.0), (0.0, 10.0, 0.0)]
    """
    camera = as_camera(camera)
    if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or frames < 1:
        raise ValueError(f"frames must be a positive integer, got {frames!r}.")
    focal = np.asarray(camera.focal_point, float)
    axis = np.asarray(camera.view_up, float)
    axis /= max(np.linalg.norm(axis), 1e-300)
    offset = np.asarray(camera.position, float) - focal
    cameras = []
    for k in range(int(frames)):
        angle = 2.0 * np.pi * k / frames
        turned = (offset * np.cos(angle) + np.cross(axis, offset) * np.sin(angle)
                  + axis * np.dot(axis, offset) * (1.0 - np.cos(angle)))
        cameras.append(Camera(tuple(map(float, focal + turned)), camera.focal_point,
                              camera.view_up, camera.view_angle, camera.clipping_range,
                              camera.parallel_projection, camera.parallel_scale))
    return cameras


class _FrameSink:
    """Where finished frames go: a list, PNG files in a folder, or a movie, in order."""

    def __init__(self, out, count: int, fps: float):
        self.count = count
        self.images: list = [None] * count
        self.folder = self.movie = None
        if out is not None:
            out = Path(out)
            if out.suffix.lower() in MOVIE_SUFFIXES:
                import imageio.v2 as imageio

                out.parent.mkdir(parents=True, exist_ok=True)
                # a GIF plays in a loop; a video keeps the frames' size (no macro blocks)
                timing = {"loop": 0, "duration": 1000.0 / fps} \
                    if out.suffix.lower() == ".gif" else {"fps": fps, "macro_block_size": 1}
                self.movie = imageio.get_writer(str(out), **timing)
                self.path = out
            elif out.suffix.lower() in IMAGE_SUFFIXES:
                raise ValueError(f"out={str(out)!r} names one image; give a folder for the "
                                 f"frames' PNGs or a movie ({', '.join(MOVIE_SUFFIXES)}).")
            else:
                out.mkdir(parents=True, exist_ok=True)
                self.folder = out
        self.next = 0   # the movie's next frame: later ones wait in images

    def put(self, index: int, image: np.ndarray):
        if self.folder is not None:
            from PIL import Image

            path = self.folder / f"frame_{index:05d}.png"
            Image.fromarray(image).save(str(path))
            self.images[index] = path
            return
        self.images[index] = image
        while self.movie is not None and self.next < self.count \
                and self.images[self.next] is not None:
            self.movie.append_data(self.images[self.next])
            self.images[self.next] = True   # written: not kept
            self.next += 1

    def close(self):
        if self.movie is not None:
            self.movie.close()
            return self.path
        return self.images

    def abort(self) -> None:
        """After an error: the movie closed and removed (a partial one would mislead)."""
        if self.movie is not None:
            self.movie.close()
            self.path.unlink(missing_ok=True)


def render_frames(scene, cameras: Sequence, size: tuple[int, int] = (800, 600), *,
                  client=None, workers: int | None = None, out=None, fps: float = 24.0,
                  retries: int = 1, progress_bar: bool | None = None):
    """Render one frame of ``scene`` per camera on a Dask cluster, in camera order.

    Each worker builds the scene once in an offscreen plotter and keeps it for every frame
    it renders (streamed sources converge at each frame). A worker that dies costs only
    its frames: the scheduler runs them again elsewhere. The frames equal the ones one
    plotter would render in a loop.

    Parameters
    ----------
    scene : str, os.PathLike, pv_cubemarch.Scene or callable
        A scene file (what :func:`pv_cubemarch.load_scene` reads), a loaded scene, or a
        picklable function ``build(plotter)`` adding what it draws to the offscreen
        plotter it is given.
    cameras : sequence
        One per frame: :class:`pv_cubemarch.Camera`, ``pyvista.Camera`` or camera
        positions ``[(x, y, z), focal_point, view_up]`` (see :func:`orbit`).
    size : tuple of int
        ``(width, height)`` of every frame.
    client : dask.distributed.Client, optional
        The cluster to use (any: local, SSH, Kubernetes, Slurm). By default a
        ``LocalCluster`` of ``workers`` processes is started and closed again.
    workers : int, optional
        Processes of the default ``LocalCluster`` (default: 2, at most the cores).
    out : str or os.PathLike, optional
        A folder (frames written as ``frame_00000.png`` ...) or a movie (``.mp4``,
        ``.mov``, ``.mkv``, ``.avi``, ``.webm`` through imageio-ffmpeg, or ``.gif``). By
        default the frames are returned.
    fps : float
        Frames per second of a movie.
    retries : int
        Times a frame whose rendering raised is tried again before its error is raised
        (:class:`FrameError`, also for a streamed source not converged in time or with
        bricks it could not read: never a frame drawn coarser in silence).
    progress_bar : bool, optional
        Show a bar as frames finish (default: on a terminal).

    Returns
    -------
    list of numpy.ndarray, list of pathlib.Path or pathlib.Path
        The ``(height, width, 3)`` uint8 frames, the PNG files, or the movie.

    Examples
    --------
    >>> import pyvista as pv
    >>> import pv_cubemarch
    >>> def build(plotter):
    ...     plotter.add_mesh(pv.Sphere())
    >>> cameras = pv_cubemarch.orbit([(4, 0, 0), (0, 0, 0), (0, 0, 1)], 8)
    >>> frames = pv_cubemarch.render_frames(build, cameras, (320, 240))  # doctest: +SKIP
    """
    from distributed import as_completed

    if isinstance(cameras, Camera) or hasattr(cameras, "GetPosition") or _is_position(cameras):
        raise ValueError("cameras is one camera; give a list of them, one per frame "
                         "(pv_cubemarch.orbit(camera, n) makes an orbit).")
    cameras = [as_camera(camera, i) for i, camera in enumerate(cameras)]
    if not cameras:
        raise ValueError("cameras is empty: give one camera per frame (pv_cubemarch.orbit("
                         "camera, n) makes an orbit).")
    size = _checked_size(size)
    if isinstance(retries, bool) or not isinstance(retries, (int, np.integer)) or retries < 0:
        raise ValueError(f"retries must be a non-negative integer, got {retries!r}.")
    _checked_workers(client, workers)
    if not float(fps) > 0:
        raise ValueError(f"fps must be positive, got {fps!r}.")
    source = SceneSource.of(scene)
    sink = None
    with local_client(client, workers) as client:
        try:
            sink = _FrameSink(out, len(cameras), float(fps))
            # the workers pickle as this process does: the scene held by one worker is
            # copied to the others in that format (PyVista's legacy one rounds spacings)
            client.run(pyvista.set_pickle_format, pyvista.PICKLE_FORMAT)
            # a task, not scattered data: if the worker holding it dies, it is made again
            shared = client.submit(_same, source, pure=False)
            futures = [client.submit(render_one, shared, camera, size, retries=int(retries),
                                     pure=False) for camera in cameras]
            index_of = {future.key: i for i, future in enumerate(futures)}
            for future in progress(as_completed(futures), desc="rendering frames",
                                   total=len(futures), enabled=progress_bar):
                index = index_of[future.key]
                try:
                    image = future.result()
                except SceneBuildError:
                    client.cancel(futures)
                    raise
                except Exception as error:
                    client.cancel(futures)
                    raise FrameError(f"frame {index} (camera at {cameras[index].position}) "
                                     f"failed on the cluster: {type(error).__name__}: "
                                     f"{error}") from error
                sink.put(index, image)
                future.release()
            result, sink = sink.close(), None
        finally:
            if sink is not None:
                sink.abort()
    return result


def _checked_workers(client, workers) -> int:
    """The LocalCluster's process count (default 2, at most the cores), checked."""
    if client is not None and workers is not None:
        raise ValueError("workers= sizes the LocalCluster started for you; a client brings "
                         "its own workers: leave workers out.")
    count = workers if workers is not None else min(2, os.cpu_count() or 1)
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
        raise ValueError(f"workers must be a positive integer, got {workers!r}.")
    return int(count)


@contextmanager
def local_client(client=None, workers: int | None = None):
    """``client``, or a ``LocalCluster`` of ``workers`` processes closed on leaving."""
    count = _checked_workers(client, workers)
    if client is not None:
        yield client
        return
    try:
        from distributed import Client, LocalCluster
    except ImportError as error:
        raise ImportError("Rendering on a cluster needs Dask distributed: pip install "
                          "'pv_cubemarch[cluster]'.") from error

    with LocalCluster(n_workers=count, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster, Client(cluster) as started:
        yield started


def _is_position(value) -> bool:
    """Whether ``value`` is one camera position: three points of three numbers."""
    try:
        return len(value) == 3 and all(len(p) == 3 and all(
            isinstance(v, (int, float, np.number)) for v in p) for p in value)
    except TypeError:
        return False


def _checked_size(size) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in size)
        if width < 1 or height < 1 or width != float(size[0]) or height != float(size[1]):
            raise ValueError
    except (TypeError, ValueError):
        raise ValueError(f"size must be (width, height) in pixels, got {size!r}.") from None
    return width, height
