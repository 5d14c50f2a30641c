"""Multiscale volumes beyond memory: bricks streamed into a GPU pool, level by footprint.

The volume's levels (:mod:`~pv_cubemarch.models.multiscale`) are cut into bricks. A pool
texture holds as many bricks (each with a one-point apron) as the GPU budget allows and a
page table says, per level and brick, which slot holds it. At each frame the pager walks
the bricks from the coarsest level down, keeping those in view whose nearest point needs
that level or a finer one (the coarsest level whose point spacing fits one pixel there,
shifted by ``lod_bias``), requests the missing ones from the host cache in that order
(coarse first, near first; read in background threads), and uploads what has arrived into
free or least recently used slots: a frame never waits for a read. The shader
(``paged_sample.glsl``) reads each sample from its level's brick, or from the nearest
coarser resident one: the coarsest level is loaded before the first frame and never
evicted, so there is no hole. When nothing wanted is missing the image has converged.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np
import pyvista
import vtk

from ..core.frame_errors import observe
from ..core.gl_limits import MAX_TEXTURE_SIZE
from ..gl.bindings import ShaderBindings
from ..gl.box import bind_camera, box_actor, camera_matrices
from ..gl.sub_upload import sub_image_available
from ..gl.textures import Texture
from ..models.brick_cache import HOST_BYTES, BrickCache, brick_counts, read_brick
from ..models.multiscale import MultiscaleSource
from ..models.transfer import TransferFunction
from ..models.volume import box_world_bounds
from .binding import VolumeSetup, bind_marching, march_defines, world_from_texture
from .clipping import ClipState
from .direct import DirectBinding
from .page_table import PageTable

#: Default GPU budget of the brick pool (bytes).
GPU_BYTES = 256 * 2**20
#: Default points along a brick's edge (its slot holds two more: the apron).
BRICK_POINTS = 32
#: Most brick bytes uploaded in one frame (the rest waits for the next frames).
UPLOAD_BYTES_PER_FRAME = 64 * 2**20


@dataclass(eq=False)
class PagedVolume:
    """A multiscale volume placed in the world with its transfer function; no data held.

    Its index space is the finest level's points; ``transform`` places the physical frame
    of the source's metadata in the world.
    """

    source: MultiscaleSource
    transfer: TransferFunction
    transform: np.ndarray = field(default_factory=lambda: np.eye(4))
    name: str = "volume"
    interpolation: str = "linear"
    #: The streaming keywords it was added with (lod_bias, gpu_bytes, host_bytes,
    #: brick_size), kept when it is added again.
    paging: dict = field(default_factory=dict)
    colors = None
    value_offset = 0

    @property
    def dimensions(self) -> tuple[int, int, int]:
        """Points along x, y, z of the finest level."""
        return self.source.shape

    def dataset_from_index(self) -> np.ndarray:
        """4x4 from finest-level point indices to the source's physical coordinates."""
        return self.source.levels[0].physical_from_index()

    def world_from_index(self) -> np.ndarray:
        """4x4 from finest-level point indices to world coordinates."""
        return np.asarray(self.transform, float) @ self.dataset_from_index()

    def world_bounds(self) -> np.ndarray:
        """World bounds ``(xmin, xmax, ...)`` of the finest level's box."""
        return box_world_bounds(self.world_from_index(), np.asarray(self.dimensions) - 1.0)


def pool_slots(brick: int, gpu_bytes: int, most_bricks: int | None = None
               ) -> tuple[int, int, int]:
    """Slots along x, y, z of the largest pool within ``gpu_bytes`` and one texture.

    No more than ``most_bricks`` (every brick of every level: a small source's pool holds
    all of it and no more).
    """
    side = brick + 2
    budget = int(gpu_bytes) // (side ** 3 * 4)
    most = MAX_TEXTURE_SIZE // side
    if budget < 1:
        raise ValueError(f"gpu_bytes={gpu_bytes} holds no brick of {side ** 3 * 4} bytes "
                         f"({brick}³ points and their apron): give more, or a smaller "
                         "brick_size.")
    want = budget if most_bricks is None else max(1, min(budget, int(most_bricks)))
    # the box of slots holding the most up to ``want`` within the budget, then the fewest
    # slots past ``want`` (a cube's rounding alone left a third of small budgets unused)
    best = (1, 1, 1)
    for x in range(1, min(most, 2 * int(np.ceil(want ** (1 / 3))) + 1) + 1):
        for y in range(1, min(most, 2 * int(np.ceil((want / x) ** 0.5)) + 1) + 1):
            z = min(most, -(-want // (x * y)))
            if x * y * z > budget:
                z = min(most, budget // (x * y))
            if z < 1:
                continue
            count, held = x * y * z, best[0] * best[1] * best[2]
            if min(count, want) > min(held, want) or (min(count, want) == min(held, want)
                                                        and count < held):
                best = (x, y, z)
    return best


class BrickPager:
    """The pool, the page table and the per-frame choice of bricks (module docstring)."""

    def __init__(self, model: PagedVolume, renderer, brick: int = BRICK_POINTS,
                 gpu_bytes: int = GPU_BYTES, host_bytes: int | None = None,
                 threads: int = 4, lod_bias: float = 0.0):
        self.model = model
        self.renderer = renderer
        self.brick = int(brick)
        self.lod_bias = float(lod_bias)
        source = model.source
        self.levels = source.levels
        self.counts = [brick_counts(level.shape, self.brick) for level in self.levels]
        self.slots = pool_slots(self.brick, gpu_bytes,
                                sum(int(np.prod(c)) for c in self.counts))
        self.capacity = int(np.prod(self.slots))
        coarsest = len(self.levels) - 1
        pinned = int(np.prod(self.counts[coarsest]))
        if pinned > self.capacity:
            raise ValueError(f"The coarsest level ({self.levels[coarsest].shape} points) needs "
                             f"{pinned} bricks of {self.brick}³ and gpu_bytes holds "
                             f"{self.capacity}: give more gpu_bytes, or a source with "
                             "coarser levels (pv_cubemarch.build_pyramid).")
        self.cache = BrickCache(source, self.brick,
                                HOST_BYTES if host_bytes is None else host_bytes, threads)
        self.table = PageTable(self.counts, self.capacity)
        side = self.brick + 2
        self.pool = Texture(np.zeros([n * side for n in self.slots], np.float32), kind="3d",
                            interpolate=model.interpolation == "linear",
                            rebuild=self._forget_pool if sub_image_available() else None)
        # Without partial uploads (no window system giving glTexSubImage3D) the pool keeps
        # its host copy: each brick is written there and the whole pool goes up again, so
        # a whole upload never forgets the bricks placed before it.
        self.info = Texture(self._level_info(), kind="2d", interpolate=False)
        self.key_in: list = [None] * self.capacity
        self.slot_of: dict = {}
        self.last_used = np.full(self.capacity, -1, np.int64)
        self._free = list(range(self.capacity - 1, -1, -1))   # popped from the end: 0 first
        self._victims = iter(())   # slots by last use, made when a frame must evict
        self.frame_number = 0
        self.pinned = {(coarsest, *ijk) for ijk in np.ndindex(*self.counts[coarsest])}
        #: Wanted bricks not resident after the last frame (0: converged).
        self.missing = 0
        #: Whether the volume is drawn this frame (its binding says): hidden, it reads nothing.
        self.shown = lambda: True
        #: Whether the last frame wanted more bricks than the pool holds.
        self.over_budget = False
        self.uploaded_bytes = 0
        for key in sorted(self.pinned):   # before the first frame: never a hole
            self._place(key, read_brick(source, key, self.brick))

    def _level_info(self) -> np.ndarray:
        """Per level: (a, world step), (b, 0), (points, 0), (directory origin, 0)."""
        finest = self.levels[0]
        linear = self.model.world_from_index()[:3, :3]
        info = np.zeros((len(self.levels), 4, 4), np.float32)
        for number, level in enumerate(self.levels):
            a = finest.scale / level.scale
            b = (finest.translation - level.translation) / level.scale
            step = float(np.max(np.linalg.norm(linear, axis=0) * level.scale / finest.scale))
            info[number, 0] = (*a, step)
            info[number, 1, :3] = b
            info[number, 2, :3] = level.shape
            info[number, 3, :3] = (self.table.origins[number], 0, 0)
        return info

    def _forget_pool(self) -> np.ndarray:
        """A new window: the pool starts empty (bricks are placed again, the coarsest now)."""
        self.key_in = [None] * self.capacity
        self.slot_of = {}
        self._free = list(range(self.capacity - 1, len(self.pinned) - 1, -1))
        self.missing = max(self.missing, 1)   # decided again at the next frame
        self.table.reset()
        side = self.brick + 2
        pool = np.zeros([n * side for n in self.slots], np.float32)
        for slot, key in enumerate(sorted(self.pinned)):
            self._write_slot(pool, slot, read_brick(self.model.source, key, self.brick))
            self._mark(key, slot)
        return pool

    def _write_slot(self, pool: np.ndarray, slot: int, values: np.ndarray) -> None:
        side = self.brick + 2
        where = self._slot_origin(slot)
        pool[tuple(slice(o, o + side) for o in where)] = values

    def _slot_origin(self, slot: int) -> tuple[int, int, int]:
        x, y, _ = self.slots
        side = self.brick + 2
        return (slot % x * side, slot // x % y * side, slot // (x * y) * side)

    def _mark(self, key, slot: int) -> None:
        self.key_in[slot] = key
        self.slot_of[key] = slot
        self.last_used[slot] = self.frame_number
        self.table.set(key, slot)

    def _place(self, key, values: np.ndarray, keep: set | None = None) -> bool:
        """Put brick ``key`` in a free slot, or the least recently used one not kept.

        The free slots and this frame's eviction order are kept between calls
        (:meth:`_victims`), so placing many bricks costs no scan of the pool per brick.
        """
        if self._free:
            slot = self._free.pop()
        else:
            slot = next((s for s in self._victims if self.key_in[s] is not None
                         and self.key_in[s] not in self.pinned
                         and (keep is None or self.key_in[s] not in keep)), None)
            if slot is None:
                return False
            old = self.key_in[slot]
            del self.slot_of[old]
            self.table.clear(old)
        self.pool.update_region(self._slot_origin(slot), values)
        self.uploaded_bytes += values.nbytes
        self._mark(key, slot)
        return True

    def footprint(self) -> tuple[float, float]:
        """World length one pixel spans at distance d: ``d x + y`` (bias included)."""
        camera = self.renderer.GetActiveCamera()
        height = max(self.renderer.GetSize()[1], 1)
        scale = 2.0 ** self.lod_bias
        if camera.GetParallelProjection():
            return 0.0, 2.0 * camera.GetParallelScale() / height * scale
        return 2.0 * np.tan(np.radians(camera.GetViewAngle()) / 2.0) / height * scale, 0.0

    def wanted(self) -> list:
        """The bricks this view needs, coarse first and near first within a level."""
        levels = self.levels
        info = self.info.array if self.info.array is not None else self._level_info()
        steps = info[:, 0, 3]
        world_from_point = self.model.world_from_index()
        eye_world = np.asarray(self.renderer.GetActiveCamera().GetPosition(), float)
        view, projection = camera_matrices(self.renderer)
        clip_from_point = projection @ view @ world_from_point
        per_distance, constant = self.footprint()
        coarsest = len(levels) - 1
        keys = sorted(self.pinned)
        candidates = np.array(list(np.ndindex(*self.counts[coarsest])), dtype=np.int64)
        for number in range(coarsest, -1, -1):
            if not len(candidates):
                break
            a, b = info[number, 0, :3].astype(float), info[number, 1, :3].astype(float)
            # the bricks' boxes in finest points (one point of margin: the trilinear reads)
            low = (candidates * self.brick - 1.0 - b) / a
            high = ((candidates + 1) * self.brick + 1.0 - b) / a
            shown = _in_view(low, high, clip_from_point)
            candidates, low, high = candidates[shown], low[shown], high[shown]
            nearest = _distance_to_boxes(eye_world, low, high, world_from_point)
            pixel = nearest * per_distance + constant
            # the finest level any sample in the brick may choose
            needed = np.zeros(len(candidates), np.int64)
            for level in range(1, len(levels)):
                needed[steps[level] <= pixel] = level
            keep = needed <= number
            order = np.argsort(nearest[keep], kind="stable")
            if number < coarsest:
                keys += [(number, *map(int, ijk)) for ijk in candidates[keep][order]]
            if number == 0:
                break
            refine = needed < number
            candidates = self._children(number, low[refine], high[refine], info)
        return keys

    def _children(self, number: int, low: np.ndarray, high: np.ndarray, info) -> np.ndarray:
        """The bricks of level ``number - 1`` under boxes (finest points) of level ``number``."""
        finer = number - 1
        a, b = info[finer, 0, :3].astype(float), info[finer, 1, :3].astype(float)
        counts = np.asarray(self.counts[finer])
        first = np.clip(np.floor((low * a + b) / self.brick), 0, counts - 1).astype(np.int64)
        last = np.clip(np.floor((high * a + b) / self.brick), 0, counts - 1).astype(np.int64)
        if not len(first):
            return np.zeros((0, 3), np.int64)
        span = (last - first).max(axis=0) + 1
        offsets = np.stack(np.meshgrid(*(np.arange(n) for n in span), indexing="ij"),
                           -1).reshape(-1, 3)
        children = first[:, None, :] + offsets[None, :, :]
        inside = (children <= last[:, None, :]).all(axis=2)
        return np.unique(children[inside], axis=0)

    def follow_placement(self) -> None:
        """The volume moved: each level's world step (what a pixel is compared with) anew."""
        self.info.set_data(self._level_info())

    def frame(self, *_) -> None:
        """At each frame's start: choose, request, and upload what has arrived.

        Nothing while the volume is hidden (``shown``, set by its binding).
        """
        if not self.shown():
            return
        self.cache.raise_errors()
        self.frame_number += 1
        wanted = self.wanted()
        self.over_budget = len(wanted) > self.capacity
        wanted = wanted[:self.capacity]
        keep = set(wanted)
        for key in wanted:
            slot = self.slot_of.get(key)
            if slot is not None:
                self.last_used[slot] = self.frame_number
        absent = [key for key in wanted if key not in self.slot_of]
        self.cache.request(absent)
        self.cache.arrived()
        self._victims = (int(s) for s in np.argsort(self.last_used, kind="stable"))
        sent = 0
        for key in absent:
            if sent >= UPLOAD_BYTES_PER_FRAME:
                break
            values = self.cache.get(key)
            if values is not None and self._place(key, values, keep):
                sent += values.nbytes
        self.missing = sum(1 for key in wanted if key not in self.slot_of)

    @property
    def converged(self) -> bool:
        """Whether every brick the last frame wanted (within the pool) was resident."""
        return self.missing == 0

    def stats(self) -> dict:
        """Resident and requested bricks and the bytes they hold (for views and scripts)."""
        return {"resident": sum(k is not None for k in self.key_in), "slots": self.capacity,
                "missing": self.missing, "reading": self.cache.pending,
                "over_budget": self.over_budget, "gpu_bytes": self.nbytes,
                "host_bytes": self.cache.nbytes, "bytes_read": self.cache.bytes_read,
                "uploaded_bytes": self.uploaded_bytes}

    @property
    def nbytes(self) -> int:
        """GPU bytes of the pool, the page table and the level table."""
        return self.pool.nbytes + self.table.nbytes + self.info.nbytes

    def release(self) -> None:
        """Stop reading; free the textures."""
        self.cache.close()
        self.table.release()
        for texture in (self.pool, self.info):
            texture.release()


def _corners(low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """The 8 corners ``(n, 8, 3)`` of boxes ``[low, high]`` (``(n, 3)`` each)."""
    return np.stack([np.where(np.array(pick)[None, :] == 0, low, high)
                     for pick in itertools.product((0, 1), repeat=3)], axis=1)


def _distance_to_boxes(eye: np.ndarray, low: np.ndarray, high: np.ndarray,
                       world_from_point: np.ndarray) -> np.ndarray:
    """A lower bound of each box's (finest points) world distance from ``eye``.

    The distance to the world-axis box around its placed corners: exact for a placement
    without rotation, whatever its scales (a bound from the smallest stretch alone asked
    for bricks 2.5x too fine along the longer axes).
    """
    corners = _corners(low, high) @ world_from_point[:3, :3].T + world_from_point[:3, 3]
    lower, upper = corners.min(axis=1), corners.max(axis=1)
    return np.linalg.norm(np.clip(eye, lower, upper) - eye, axis=1)


def _in_view(low: np.ndarray, high: np.ndarray, clip_from_point: np.ndarray) -> np.ndarray:
    """Which boxes (finest points, ``(n, 3)`` corners) are not wholly outside a frustum plane."""
    corners = _corners(low, high)
    clip = np.concatenate([corners, np.ones(corners.shape[:2] + (1,))], axis=2) \
        @ clip_from_point.T
    w = clip[..., 3]
    outside = np.zeros(len(low), bool)
    for axis in range(3):
        outside |= (clip[..., axis] < -w).all(axis=1) | (clip[..., axis] > w).all(axis=1)
    return ~outside


class PagedData:
    """What the marcher's bindings read of a paged volume: its tables, planes and pool."""

    def __init__(self, model: PagedVolume, pager: BrickPager):
        self.model = model
        self.pager = pager
        self.tables = [Texture(model.transfer.table.reshape(1, -1, 4), kind="2d")]
        self.clip = ClipState()
        self.brick_builds = 0

    @property
    def nbytes(self) -> int:
        """GPU bytes of the pool, its tables and the transfer table."""
        return self.pager.nbytes + self.tables[0].nbytes

    def release(self) -> None:
        """The transfer table and the pager's textures and reads."""
        self.tables[0].release()
        self.pager.release()


class PagedBinding(DirectBinding):
    """A paged volume on its box: the direct marcher reading the brick pool."""

    @property
    def pager(self) -> BrickPager:
        """The pool, page table and reads of this volume."""
        return self.data.pager

    @property
    def converged(self) -> bool:
        """Whether the last frame had every brick it wanted."""
        return self.data.pager.converged

    def wait_for_bricks(self, timeout: float) -> bool:
        """Wait until a requested brick arrives (or ``timeout`` s); True if one did."""
        return self.data.pager.cache.wait(timeout)

    def stats(self) -> dict:
        """Resident, missing and read bricks and bytes (:meth:`BrickPager.stats`)."""
        return self.data.pager.stats()

    def place(self, transform) -> None:
        """The box follows, and the levels' world steps (a pixel is compared with them)."""
        super().place(transform)
        self.data.pager.follow_placement()

    def set_interpolation(self, interpolation: str) -> None:
        """Read the bricks ``'linear'`` or ``'nearest'`` from the next frame (no upload)."""
        if interpolation not in ("linear", "nearest"):
            raise ValueError(f"interpolation must be 'linear' or 'nearest', got "
                             f"{interpolation!r}.")
        self.model.interpolation = interpolation
        self.data.pager.pool.set_interpolation(interpolation == "linear")

    def set_values(self, values, member: str | None = None) -> None:
        """Refused: a streamed volume's values are its source's (write to the store)."""
        raise ValueError("A volume streamed from a multiscale source reads its values from "
                         "the source; write them there and add the volume again.")

    def set_opacity_unit_distance(self, length: float) -> None:
        """Refused: add the streamed volume again with ``opacity_unit_distance=``."""
        raise ValueError("A streamed volume's transfer function is set when it is added: "
                         "add it again with opacity_unit_distance=.")

    def set_blending(self, blending: str) -> None:
        """Only 'composite' (what the brick pool's marcher draws)."""
        if blending != "composite":
            raise ValueError(f"blending={blending!r}: a volume streamed from a multiscale "
                             "source is drawn with blending='composite' only.")

    def release_resources(self) -> None:
        """Stop the per-frame choice, then what a direct volume frees (the pager too)."""
        if getattr(self, "_pager_tag", None) is not None:
            self.bindings.renderer.RemoveObserver(self._pager_tag)
            self._pager_tag = None
        super().release_resources()


#: Milliseconds between the redraws of a window whose streamed volume still misses bricks.
REFINE_MS = 100


def refine_while_shown(plotter, binding) -> None:
    """In an interactive window, redraw while bricks arrive: the image refines by itself.

    A repeating timer of the window's interactor (it runs while ``plotter.show()`` does)
    renders again whenever the volume is shown and not converged; offscreen plotters have
    none (``render_image(converge=True)`` waits there).
    """
    interactor = getattr(plotter, "iren", None)
    if interactor is None or getattr(plotter, "off_screen", True):
        return

    def refine(*_):
        if binding.shown and not binding.converged:
            plotter.render()

    tag = interactor.add_observer("TimerEvent", refine)
    timer = interactor.create_timer(REFINE_MS, repeating=True)

    def stop():
        interactor.remove_observer(tag)
        interactor.destroy_timer(timer)

    binding.extra_release.append(stop)


def bind_paged_sampling(target, data: PagedData, step_scale: float,
                        stop_opacity: float) -> dict:
    """Give ``target`` what the marcher reads of a paged volume; returns its switches."""
    model, pager = data.model, data.pager
    bind_marching(target, data, step_scale, stop_opacity)
    target.add_texture("cm_transferTable", data.tables[0])
    target.set_uniform("cm_clim", model.transfer.clim)
    target.add_texture("cm_pool", pager.pool)
    pager.table.bind(target)
    target.add_texture("cm_levelInfo", pager.info)
    target.set_uniform("cm_poolSlots", tuple(float(n) for n in pager.slots))
    target.set_uniform("cm_brickPoints", float(pager.brick))
    target.set_uniform("cm_pagedWorldFromPoint", lambda: model.world_from_index()[:3, :3])

    def eye():
        position = np.append(pager.renderer.GetActiveCamera().GetPosition(), 1.0)
        return tuple((np.linalg.inv(model.world_from_index()) @ position)[:3])

    target.set_uniform("cm_pagedEye", eye)
    target.set_uniform("cm_lodFootprint", pager.footprint)
    return {**march_defines(model, False), **data.clip.defines,
            "CM_PAGED_LEVELS": len(pager.levels)}


def build_paged_actor(plotter, data: PagedData, setup: VolumeSetup) -> PagedBinding:
    """The direct marcher's box actor reading ``data``'s brick pool; returns its binding."""
    options, shading = setup.options, setup.shading
    model = data.model
    renderer = plotter.renderer
    actor = box_actor([n - 1.0 for n in model.dimensions], model.world_from_index())
    step_scale = float(options.step_scale)
    bindings = ShaderBindings(actor.GetMapper(), renderer)
    defines = bind_paged_sampling(bindings, data, step_scale, shading.stop_opacity)
    bind_camera(bindings, renderer, lambda: world_from_texture(model))
    binding = PagedBinding(model, data, bindings, None, step_scale, shading.stop_opacity,
                           window=plotter.ren_win, sampling="paged_sample", defines=defines)
    binding.drawn = [actor]
    binding.renderer = renderer
    binding.follow_multisampling()
    binding._tag = observe(renderer, vtk.vtkCommand.StartEvent,
                           binding.follow_multisampling, 5.0)
    binding._pager_tag = observe(renderer, vtk.vtkCommand.StartEvent, data.pager.frame, 4.0)
    data.pager.shown = lambda: binding.shown
    refine_while_shown(plotter, binding)
    pyvista.set_new_attribute(actor, "cubemarch", binding)
    return binding


def check_paging(given: dict) -> None:
    """Refuse streaming keywords out of their range, naming them (None: the default)."""
    for name, low, high in (("gpu_bytes", 1, None), ("host_bytes", 1, None),
                            ("brick_size", 1, 1024)):
        value = given.get(name)
        if value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low \
                or (high is not None and value > high):
            raise ValueError(f"{name} must be an integer of at least {low}"
                             + (f" and at most {high}" if high else "") + f", got {value!r}.")
    bias = given.get("lod_bias")
    if bias is not None and not (isinstance(bias, (int, float, np.number))
                                 and not isinstance(bias, bool) and -64 <= float(bias) <= 64):
        raise ValueError(f"lod_bias must be a number from -64 to 64 (levels added to the one "
                         f"whose points fit a pixel), got {bias!r}.")


def paged_transfer(source: MultiscaleSource, cmap, opacity, clim, opacity_unit_distance,
                   n_colors, flip_scalars, log_scale) -> TransferFunction:
    """The transfer table for a multiscale source, with defaults it can afford.

    ``clim`` defaults to the coarsest level's range (the finest would mean reading all of
    it); ``opacity_unit_distance`` to PyVista's, the finest level's diagonal over its mean
    number of points less one.
    """
    if clim is None:
        coarsest = source.levels[-1]
        values = coarsest.read(tuple(slice(0, n) for n in coarsest.shape))
        low, high = float(np.nanmin(values)), float(np.nanmax(values))
        clim = (low, high if high > low else low + 1.0)
    if opacity_unit_distance is None:
        finest = source.levels[0]
        diagonal = float(np.linalg.norm((np.asarray(finest.shape) - 1) * finest.scale))
        points = float(np.mean(finest.shape)) - 1.0
        opacity_unit_distance = diagonal / points if points > 0 and diagonal > 0 else float(
            np.mean(finest.scale))
    return TransferFunction.from_colormap(cmap, "linear" if opacity is None else opacity, clim,
                                          opacity_unit_distance, n_colors=n_colors or 256,
                                          flip_scalars=bool(flip_scalars),
                                          log_scale=bool(log_scale))
