"""The brick pool of a multiscale volume and the per-frame choice of its bricks.

The pool is one 3D texture of brick slots within a GPU budget; the page table
(:mod:`.page_table`) says which slot holds each brick. At each frame the pager walks the
bricks from the coarsest level down, keeping those in view whose nearest point needs that
level or a finer one, requests the missing ones from the host cache (coarse first, near
first) and uploads what has arrived into free or least recently used slots: a frame never
waits for a read, and the coarsest level, loaded before the first frame, is never evicted.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable

import numpy as np

from ..core.errors import VolumeDataError
from ..core.gl_limits import MAX_TEXTURE_SIZE
from ..gl.box import camera_matrices
from ..gl.sub_upload import sub_image_available
from ..gl.textures import Texture
from ..models.brick_cache import HOST_BYTES, BrickCache, brick_counts, read_brick
from .clipping import texture_planes
from .occluded_bricks import DepthPyramid, hidden_boxes
from .page_table import BLOCK, PageTable
from .skipping import range_extinction, transparent_value

#: Default GPU budget of the brick pool (bytes).
GPU_BYTES = 256 * 2**20
#: Default points along a brick's edge (its slot holds two more: the apron).
BRICK_POINTS = 32
#: Page-table blocks kept beyond the slots' for bricks marked empty (1 KiB each).
EMPTY_BLOCKS = 1024
#: Most brick bytes uploaded in one frame (the rest waits for the next frames).
UPLOAD_BYTES_PER_FRAME = 64 * 2**20
#: A frame plans at most this many times the pool's slots (plus the bricks known empty),
#: the nearest first: beyond that, bricks could not be resident anyway.
PLAN_SLOTS_FACTOR = 16


def pool_slots(brick: int, gpu_bytes: int, most_bricks: int | None = None,
               apron: int = 1) -> tuple[int, int, int]:
    """Slots along x, y, z of the largest pool within ``gpu_bytes`` and one texture.

    No more than ``most_bricks`` (every brick of every level: a small source's pool holds
    all of it and no more). A slot holds ``brick + 2 apron`` values a side.
    """
    side = brick + 2 * apron
    budget = int(gpu_bytes) // (side ** 3 * 4)
    most = MAX_TEXTURE_SIZE // side
    if budget < 1:
        raise ValueError(f"gpu_bytes={gpu_bytes} holds no brick of {side ** 3 * 4} bytes "
                         f"({side}³ values): give more, or a smaller brick_size.")
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


def coarsest_fits(source, brick: int, gpu_bytes: int, apron: int = 1) -> tuple[int, int, int]:
    """The pool's slots, once the coarsest level's bricks (always resident) fit in it.

    Raises ``ValueError`` otherwise, before anything of the source is read (its default
    ``clim`` reads the coarsest level whole).
    """
    counts = [brick_counts(level.shape, brick) for level in source.levels]
    # products of Python ints: a level claiming 2^40 points a side wraps int64 to 0
    slots = pool_slots(brick, gpu_bytes, sum(math.prod(c) for c in counts), apron)
    capacity, pinned = math.prod(slots), math.prod(counts[-1])
    if pinned > capacity:
        raise ValueError(f"The coarsest level ({source.levels[-1].shape} points) needs "
                         f"{pinned} bricks of {brick}³ and gpu_bytes holds {capacity}: give "
                         "more gpu_bytes, or a source with coarser levels "
                         "(pv_cubemarch.build_pyramid).")
    return slots


#: The largest float32: finite values of a wider source beyond it are drawn at it.
FLOAT32_MAX = float(np.finfo(np.float32).max)


class FiniteBricks:
    """A read brick as float32, its NaN and infinite values refused or drawn as 0.

    ``policy``: ``add_volume``'s ``nan_policy`` (``'raise'``: a brick holding one raises,
    naming it, at the frame that reads it, as an in-memory volume raises when added;
    ``'zero'``: they are drawn as 0).
    """

    def __init__(self, policy: str, name: str):
        self.policy, self.name = policy, name

    def __call__(self, key, values: np.ndarray) -> np.ndarray:
        values = np.asarray(values)
        if values.dtype.itemsize > 4:   # finite values past float32's range: saturated
            values = np.clip(values, -FLOAT32_MAX, FLOAT32_MAX)
        values = values.astype(np.float32, copy=False)
        bad = ~np.isfinite(values)
        if bad.any():
            if self.policy == "raise":
                raise VolumeDataError(
                    f"{self.name!r}: the brick {tuple(key[1:])} of level {key[0]} holds "
                    f"{int(bad.sum())} NaN or infinite values; clean the source, or pass "
                    "nan_policy='zero' to draw them as 0.")
            values = np.where(bad, np.float32(0.0), values)
        return values


class BrickPager:
    """The pool, the page table and the per-frame choice of bricks (module docstring).

    ``model``: the :class:`~.paged.PagedVolume` drawn (its source, placement, interpolation).
    A subclass changes what a slot holds: ``apron`` (points of the neighbours around a
    brick), ``prepare`` (a read brick to what is uploaded, on the reading thread; an empty
    array marks a brick with nothing to draw, which takes no slot) and ``page_blocks``.
    """

    #: Points of the neighbours around each brick in its slot (trilinear reads need 1).
    apron = 1
    #: A read brick to its slot's values (None: float32 values as read).
    prepare = None
    #: Whether bricks behind what the last frame of the same view drew are left out: for
    #: sources drawn opaque, whose depth is the surface hit (:mod:`.occluded_bricks`).
    cull_hidden = False

    def __init__(self, model, renderer, brick: int = BRICK_POINTS,
                 gpu_bytes: int = GPU_BYTES, host_bytes: int | None = None,
                 threads: int = 4, lod_bias: float = 0.0, skip_empty: bool = True):
        self.model = model
        self.renderer = renderer
        self.brick = int(brick)
        self.lod_bias = float(lod_bias)
        source = model.source
        self.levels = source.levels
        self.counts = [brick_counts(level.shape, self.brick) for level in self.levels]
        self.slots = coarsest_fits(source, self.brick, gpu_bytes, self.apron)
        self.capacity = int(np.prod(self.slots))
        coarsest = len(self.levels) - 1
        policy = getattr(model, "nan_policy", None)
        if self.prepare is None and policy and np.dtype(source.dtype).kind == "f":
            self.prepare = FiniteBricks(policy, model.name)
        self.cache = BrickCache(source, self.brick,
                                HOST_BYTES if host_bytes is None else host_bytes, threads,
                                self.apron, self.prepare)
        self.table = PageTable(self.counts, self.capacity, self.page_blocks())
        transfer = getattr(model, "transfer", None)
        #: A value read as "nothing here" (zero extinction), when the transfer function has
        #: one: bricks whose values all map to zero extinction then take no slot, and the
        #: marcher leaves them in one step.
        self.skip_empty = bool(skip_empty)
        self.empty_value = None if transfer is None or not skip_empty \
            else transparent_value(transfer)
        side = self.brick + 2 * self.apron
        self.pool = Texture(np.zeros([n * side for n in self.slots], np.float32, order="F"),
                            kind="3d",
                            interpolate=model.interpolation == "linear",
                            rebuild=self._forget_pool if sub_image_available() else None)
        # x fastest (Fortran order), as the upload wants it: no copy of the whole pool.
        # Without partial uploads (no window system giving glTexSubImage3D) the pool keeps
        # its host copy: each brick is written there and the whole pool goes up again, so
        # a whole upload never forgets the bricks placed before it.
        self.info = Texture(self._level_info(), kind="2d", interpolate=False)
        self.key_in: list = [None] * self.capacity
        self.slot_of: dict = {}
        #: Bricks with nothing to draw (``prepare`` gave an empty array): no slot, a mark in
        #: the page table.
        self.empty: set = set()
        #: Empty bricks of this frame the page table had no block left to mark (drawn from
        #: a coarser level; not counted missing, asked for again at the next choice).
        self.unmarked: set = set()
        #: The last frame's depth pyramid and the view it was drawn for (cull_hidden).
        self.depth: tuple | None = None
        #: The depth the frame just drawn leaves (a DepthPyramid; None: none), kept after
        #: each frame that planned; or, where it is set, the depth of what the pool holds
        #: seen from this view, made before each plan (a volume's: where its rays stop).
        self.read_depth = lambda: DepthPyramid.read(self.renderer)
        self.depth_before_plan: Callable[[], DepthPyramid | None] | None = None
        #: What else than the view the depth depends on (a volume's clipping planes): a
        #: change plans again.
        self.drawn_state = lambda: ()
        #: The world planes (``(origin, normal)`` pairs) that cut what it draws: a brick
        #: wholly on a side they cut away is not read (``drawn_state`` says when they move).
        self.clip_planes = lambda: ()
        self._view_now = None
        self.last_used = np.full(self.capacity, -1, np.int64)
        self._free = list(range(self.capacity - 1, -1, -1))   # popped from the end: 0 first
        self._victims = iter(())   # slots by last use, made when a frame must evict
        self.frame_number = 0
        self.pinned = {(coarsest, *ijk) for ijk in np.ndindex(*self.counts[coarsest])}
        #: Wanted bricks not resident after the last frame (0: converged).
        self.missing = 0
        #: Whether the volume is drawn this frame (its binding says): hidden, it reads nothing.
        self.shown = lambda: True
        self._planned_for = None   # the view the last choice of bricks was made for
        #: Whether the last frame wanted more bricks than the pool holds.
        self.over_budget = False
        self.plan_cut = False   # whether the last plan left bricks out (see wanted)
        self.uploaded_bytes = 0
        #: Bricks the last plan left out as hidden behind the depth.
        self.hidden_bricks = 0
        self._fruitless = None   # the view whose depth pass stopped no ray
        pinned = sorted(self.pinned)   # before the first frame: never a hole
        for key, values in zip(pinned, self.read_pinned(pinned), strict=True):
            self._place(key, values)

    @classmethod
    def from_paging(cls, model, renderer, **options) -> BrickPager:
        """A pager for ``model`` with the streaming keywords it was added with.

        ``model.paging``: brick_size, gpu_bytes, host_bytes, lod_bias (None: the defaults).
        """
        paging = model.paging

        def given(key, default):
            value = paging.get(key)
            return default if value is None else value

        return cls(model, renderer, given("brick_size", BRICK_POINTS),
                   given("gpu_bytes", GPU_BYTES), paging.get("host_bytes"),
                   lod_bias=float(given("lod_bias", 0.0)), **options)

    def nothing_drawn(self, values: np.ndarray) -> bool:
        """Whether a read brick draws nothing: empty, or all zero extinction.

        Every value, apron included, mapped through the volume's transfer function.
        """
        if not values.size:
            return True
        if self.empty_value is None:
            return False
        low, high = float(values.min()), float(values.max())
        return bool(np.isfinite(low) and np.isfinite(high)
                    and range_extinction(low, high, self.model.transfer) <= 0.0)

    def recolour(self) -> bool:
        """The volume's transfer function changed: which bricks draw nothing is found again.

        Every brick but the coarsest level's is forgotten (read again from the host cache
        when wanted, so one that now draws nothing gives its slot to one that draws); the
        coarsest level's marked empty are placed again at once, so the pool keeps no hole.
        Returns whether empty bricks are still told apart (a value of zero extinction).
        """
        transfer = getattr(self.model, "transfer", None)
        self.empty_value = transparent_value(transfer) \
            if self.skip_empty and transfer is not None else None
        forgotten = sorted(self.empty | self.unmarked)
        for key in self.empty:
            self.table.clear(key)
        self.empty, self.unmarked = set(), set()
        for slot, key in enumerate(self.key_in):
            if key is not None and key not in self.pinned:
                self.table.clear(key)
                del self.slot_of[key]
                self.key_in[slot] = None
                self._free.append(slot)
        self._victims = iter(())
        pinned = [key for key in forgotten if key in self.pinned]
        for key, values in zip(pinned, self.read_pinned(pinned), strict=True):
            self._place(key, values)
        self.missing = max(self.missing, 1)
        self._planned_for = None
        return self.empty_value is not None

    def page_blocks(self) -> int:
        """Blocks the page table holds: the slots', the coarsest level's and a reserve.

        The coarsest level's bricks may all be empty, marked without a slot; the reserve,
        :data:`EMPTY_BLOCKS`, holds other empty marks.
        """
        return self.capacity + int(np.prod([-(-n // BLOCK) for n in self.counts[-1]])) \
            + EMPTY_BLOCKS

    def read_pinned(self, keys) -> list:
        """The coarsest level's bricks, read on this thread before the first frame."""
        return [self.read_now(key) for key in keys]

    def read_now(self, key) -> np.ndarray:
        """Brick ``key`` read on this thread, as the cache would keep it."""
        if self.prepare is None:
            return read_brick(self.model.source, key, self.brick, self.apron)
        return self.prepare(key, read_brick(self.model.source, key, self.brick, self.apron,
                                            None))

    def world_from_point(self) -> np.ndarray:
        """4x4 from finest-level point indices to world coordinates."""
        return self.model.world_from_point()

    def _level_info(self) -> np.ndarray:
        """Per level: (a, world step), (b, 0), (points, 0), (directory origin, 0)."""
        finest = self.levels[0]
        linear = self.world_from_point()[:3, :3]
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
        self.empty = set()
        self.missing = max(self.missing, 1)   # decided again at the next frame
        self.table.reset()
        side = self.brick + 2 * self.apron
        pool = np.zeros([n * side for n in self.slots], np.float32, order="F")
        slot = 0
        pinned = sorted(self.pinned)
        for key, values in zip(pinned, self.read_pinned(pinned), strict=True):
            if not self.nothing_drawn(values):
                self._write_slot(pool, slot, values)
                self._mark(key, slot)
                slot += 1
            else:
                self._mark_empty(key)
        self._free = list(range(self.capacity - 1, slot - 1, -1))
        return pool

    def _write_slot(self, pool: np.ndarray, slot: int, values: np.ndarray) -> None:
        side = self.brick + 2 * self.apron
        where = self._slot_origin(slot)
        pool[tuple(slice(o, o + side) for o in where)] = values

    def _slot_origin(self, slot: int) -> tuple[int, int, int]:
        x, y, _ = self.slots
        side = self.brick + 2 * self.apron
        return (slot % x * side, slot // x % y * side, slot // (x * y) * side)

    def _mark(self, key, slot: int, keep: set | None = None) -> None:
        self.key_in[slot] = key
        self.slot_of[key] = slot
        self.last_used[slot] = self.frame_number
        if not self._make_room(key, keep) and not self._make_room(key):
            raise RuntimeError(f"The page table has no block left for brick {key} "
                               f"({self.table.block_capacity} blocks).")
        self.table.set(key, slot)

    def _mark_empty(self, key, keep: set | None = None) -> bool:
        """Brick ``key`` has nothing to draw: its entry says so (slot ``capacity``), no slot."""
        if not self._make_room(key, keep):
            self.unmarked.add(key)
            return False
        self.empty.add(key)
        self.table.set(key, self.capacity)
        return True

    def _make_room(self, key, keep: set | None = None) -> bool:
        """A page-table block for ``key``: empty bricks' marks not kept give theirs back."""
        if self.table.has_room(key):
            return True
        for old in [k for k in self.empty if k not in self.pinned
                    and (keep is None or k not in keep)]:
            self.empty.discard(old)
            self.table.clear(old)
            if self.table.has_room(key):
                return True
        return False

    def _place(self, key, values: np.ndarray, keep: set | None = None) -> bool:
        """Put brick ``key`` in a free slot, or the least recently used one not kept.

        The free slots and this frame's eviction order are kept between calls
        (:meth:`_victims`), so placing many bricks costs no scan of the pool per brick.
        A brick that draws nothing (:meth:`nothing_drawn`) takes no slot.
        """
        if self.nothing_drawn(values):
            return self._mark_empty(key, keep)
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
        self._mark(key, slot, keep)
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
        world_from_point = self.world_from_point()
        eye_world = np.asarray(self.renderer.GetActiveCamera().GetPosition(), float)
        view, projection = camera_matrices(self.renderer)
        clip_from_point = projection @ view @ world_from_point
        point_planes = texture_planes(self.clip_planes(), world_from_point)
        per_distance, constant = self.footprint()
        coarsest = len(levels) - 1
        keys = sorted(self.pinned)
        self.hidden_bricks = 0
        self.plan_cut = False
        # at most this many keys are planned (the pool's slots, many times over, and the
        # bricks known empty, which take none): a view that wants the finest level of a
        # huge grid everywhere listed millions of bricks, out of memory within a frame
        limit = PLAN_SLOTS_FACTOR * self.capacity + len(self.empty)
        candidates = np.array(list(np.ndindex(*self.counts[coarsest])), dtype=np.int64)
        for number in range(coarsest, -1, -1):
            if not len(candidates):
                break
            a, b = info[number, 0, :3].astype(float), info[number, 1, :3].astype(float)
            # the bricks' boxes in finest points (the apron's margin: the trilinear reads;
            # without one, half a point: a nearest read's cell)
            below, above = (1.0, 1.0) if self.apron else (0.5, -0.5)
            low = (candidates * self.brick - below - b) / a
            high = ((candidates + 1) * self.brick + above - b) / a
            shown = _in_view(low, high, clip_from_point) & _kept_by(point_planes, low, high)
            hidden = self._hidden(low[shown], high[shown], clip_from_point)
            self.hidden_bricks += int(hidden.sum())
            shown[shown] = ~hidden
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
            candidates = self._children(number, low[refine], high[refine], info,
                                        nearest[refine], limit - len(keys))
        return keys

    def _hidden(self, low: np.ndarray, high: np.ndarray, clip_from_point) -> np.ndarray:
        """Which boxes lie behind the last frame's depth (none without one for this view)."""
        if not self.cull_hidden or self.depth is None or self.depth[0] != self._view_now \
                or not len(low):
            return np.zeros(len(low), bool)
        corners = _corners(low, high)
        clip = np.concatenate([corners, np.ones(corners.shape[:2] + (1,))], axis=2) \
            @ clip_from_point.T
        pyramid = self.depth[1]   # its pixels are the ones the clip space maps onto
        return hidden_boxes(pyramid, clip, pyramid.levels[0].shape[::-1])

    def wants_depth(self) -> bool:
        """Whether the frame now drawn leaves a depth to keep.

        It does when the source culls hidden bricks, is shown, and the frame planned anew
        or is not converged.
        """
        return (self.cull_hidden and self._planned_for is not None and self.shown()
                and (not self.converged or self.depth is None
                     or self.depth[0] != self._planned_for))

    def keep_depth(self, *_) -> None:
        """After a frame that planned or uploaded: its depth, for the next frame's culling."""
        if self.wants_depth():
            pyramid = self.read_depth()
            self.depth = None if pyramid is None else (self._planned_for, pyramid)

    def _children(self, number: int, low: np.ndarray, high: np.ndarray, info,
                  nearest: np.ndarray, room: int) -> np.ndarray:
        """The bricks of level ``number - 1`` under boxes (finest points) of level ``number``.

        At most about ``room`` of them: the nearest boxes' first (``plan_cut`` says when
        some were left out).
        """
        finer = number - 1
        a, b = info[finer, 0, :3].astype(float), info[finer, 1, :3].astype(float)
        counts = np.asarray(self.counts[finer])
        half = 0.0 if self.apron else 0.5   # no apron: a point reads its nearest cell
        first = np.clip(np.floor((low * a + b + half) / self.brick), 0,
                        counts - 1).astype(np.int64)
        last = np.clip(np.floor((high * a + b + half) / self.brick), 0,
                       counts - 1).astype(np.int64)
        if not len(first):
            return np.zeros((0, 3), np.int64)
        under = np.prod(last - first + 1, axis=1, dtype=np.int64)
        if int(under.sum()) > room:   # the nearest boxes whose children fit the room
            order = np.argsort(nearest, kind="stable")
            taken = order[np.cumsum(under[order]) <= max(room, 0)]
            self.plan_cut = True
            first, last = first[taken], last[taken]
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

        Nothing while the volume is hidden (``shown``, set by its binding), nor once
        converged for a view that has not changed since (other props' redraws).
        """
        if not self.shown():
            return
        try:
            self._choose_and_upload()
        finally:
            self.cache.raise_errors()   # after this frame's work: raised once, not each frame

    def _choose_and_upload(self) -> None:
        camera = self.renderer.GetActiveCamera()
        view = (camera.GetMTime(), tuple(self.renderer.GetSize()), self.lod_bias,
                self.world_from_point().tobytes(), self.drawn_state())
        if view == self._planned_for and self.converged:
            return
        # The first frame draws the coarsest level at once; a pager that culls hidden
        # bricks asks for nothing then: the next frame asks, knowing where the rays stop
        # (asked blind, the reads started would be spent on hidden bricks).
        defer = self._planned_for is None and self.cull_hidden
        if self.cull_hidden and self.depth_before_plan is not None:
            # before the uploads; a view where no ray stopped runs no more of them (culling
            # less is never wrong; the pass costs a march of every pixel)
            pyramid = None if defer or view == self._fruitless else self.depth_before_plan()
            self.depth = None if pyramid is None else (view, pyramid)
        self._planned_for = self._view_now = view
        self.frame_number += 1
        self.unmarked = set()
        wanted = self.wanted()
        if self.depth_before_plan is not None and self.depth is not None \
                and self.depth[1].levels[0].min() >= 1.0:
            self._fruitless = view
        failed = self.cache.failed
        # within the pool's slots (bricks known to be empty, or unreadable, take none)
        taking = np.cumsum([key not in self.empty and key not in failed for key in wanted])
        self.over_budget = self.plan_cut or (
            bool(len(wanted)) and int(taking[-1]) > self.capacity)
        wanted = wanted[:int(np.searchsorted(taking, self.capacity, side="right"))]
        keep = set(wanted)
        for key in wanted:
            slot = self.slot_of.get(key)
            if slot is not None:
                self.last_used[slot] = self.frame_number
        absent = [key for key in wanted if key not in self.slot_of and key not in self.empty
                  and key not in failed]
        marked = len(self.empty)
        self.cache.request([] if defer else absent)
        self.cache.arrived()
        self._victims = (int(s) for s in np.argsort(self.last_used, kind="stable"))
        sent = 0
        for key in absent:
            if sent >= UPLOAD_BYTES_PER_FRAME:
                break
            values = self.cache.get(key)
            if values is not None and self._place(key, values, keep):
                sent += values.nbytes
        self.missing = sum(1 for key in wanted if key not in self.slot_of
                           and key not in self.empty and key not in failed
                           and key not in self.unmarked)
        if self.cull_hidden and sent and self.hidden_bricks:
            # what was drawn coarse may hide what the new bricks uncover: plan again with
            # the depth of the frame that draws them (nothing hidden: nothing to uncover)
            self.missing = max(self.missing, 1)
        if self.over_budget and (len(self.empty) != marked or self.unmarked):
            # bricks cut from this frame's list may fit now that some turned out empty
            self.missing = max(self.missing, 1)

    def retry(self) -> None:
        """Ask again, from the next frame, for the bricks whose read failed."""
        self.cache.retry()
        self._planned_for = None

    @property
    def converged(self) -> bool:
        """Whether every brick the last frame wanted (within the pool) was resident."""
        return self.missing == 0

    def stats(self) -> dict:
        """Resident and requested bricks and the bytes they hold (for views and scripts)."""
        return {"resident": sum(k is not None for k in self.key_in), "slots": self.capacity,
                "empty": len(self.empty), "failed": len(self.cache.failed),
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


def bind_pool(target, pager: BrickPager, world_from_point) -> None:
    """What ``paged_bricks.glsl`` reads: the pool, page table, levels and the eye."""
    target.add_texture("cm_pool", pager.pool)
    pager.table.bind(target)
    target.add_texture("cm_levelInfo", pager.info)
    target.set_uniform("cm_poolSlots", tuple(float(n) for n in pager.slots))
    target.set_uniform("cm_brickPoints", float(pager.brick))
    target.set_uniform("cm_pagedWorldFromPoint", lambda: world_from_point()[:3, :3])

    def eye():
        position = np.append(pager.renderer.GetActiveCamera().GetPosition(), 1.0)
        return tuple((np.linalg.inv(world_from_point()) @ position)[:3])

    target.set_uniform("cm_pagedEye", eye)
    target.set_uniform("cm_lodFootprint", pager.footprint)
    # read at each draw: a new transfer function finds another (recolour)
    target.set_uniform("cm_pagedEmptyValue", lambda: float(
        pager.empty_value if pager.empty_value is not None else 0.0))



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


def _kept_by(planes: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Which boxes (finest points) are not wholly on a side one of ``planes`` cuts away.

    ``planes``: ``(m, 4)`` unit-normal planes of point space keeping ``plane . (p, 1) >= 0``;
    a box is cut only where every corner lies a millionth of a point past a plane.
    """
    if not len(planes) or not len(low):
        return np.ones(len(low), bool)
    kept = _corners(low, high) @ planes[:, :3].T + planes[:, 3]   # (boxes, corners, planes)
    return ~(kept < -1e-6).all(axis=1).any(axis=1)


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
