"""Label grids beyond memory: the voxel traversal reading a brick pool of a label pyramid.

The levels of a multiscale label source (an OME-Zarr pyramid whose coarse levels keep the
most frequent non-empty id of each block, as ``build_pyramid(method='mode')`` writes) are
cut into bricks streamed into a GPU pool, as a paged volume's
(:mod:`pv_cubemarch.volume.brick_pager`), with two differences: a brick is read without an
apron (labels are read nearest) and turns into rows of the per-label tables as it is read
(ids of any width, up to 2^24 of them, rows given in the order ids are met); a brick of
background alone takes no slot, and the traversal leaves it in one step. The shader
(``voxel_paged.glsl``) draws each voxel with the label of the level its centre chooses, so
the image refines to the exact finest-level one as bricks arrive.
"""

from __future__ import annotations

import threading
import warnings
from dataclasses import dataclass, field

import numpy as np
import pyvista

from ..gl.bindings import ShaderBindings
from ..gl.box import box_actor
from ..gl.handle import DrawnBinding
from ..gl.shaders import ShaderRecipe, box_recipe
from ..gl.textures import Texture
from ..models.brick_cache import read_brick
from ..models.label_colors import colors_by_id, hashed_colors
from ..models.label_ids import MAX_IDS
from ..models.multiscale import MultiscaleSource
from ..models.volume import box_world_bounds
from ..models.voxels import palette_texels
from ..volume.brick_pager import BrickPager, bind_pool
from ..volume.occluded_bricks import opaque_scene_state
from ..volume.paged import FollowsPager, follow_pager
from .clipping import ClipPlaneSetting, bind_clip_planes, clip_count
from .label_state import upload_palette_rows
from .options import VoxelOptions
from .technique import bind_grid


@dataclass(eq=False)
class PagedLabels:
    """A multiscale label grid placed in the world with its colours; no data held.

    Voxel ``i`` of the finest level spans ``[i, i + 1]`` of its index space, centred on the
    point the source's metadata places; ``transform`` places that physical frame in the
    world. ``palette``: ``None`` (a colour hashed from each id), ``{id: colour}`` or
    ``{id: (colour, opacity)}`` (ids left out are hidden), or a function of the id.
    """

    source: MultiscaleSource
    palette: object = None
    transform: np.ndarray = field(default_factory=lambda: np.eye(4))
    name: str = "voxels"
    background: int = 0
    #: The streaming keywords it was added with (lod_bias, gpu_bytes, host_bytes,
    #: brick_size).
    paging: dict = field(default_factory=dict)
    #: Labels are read nearest (the pool's filtering).
    interpolation = "nearest"

    @property
    def dimensions(self) -> tuple[int, int, int]:
        """Voxels along x, y, z of the finest level."""
        return self.source.shape

    def world_from_point(self) -> np.ndarray:
        """4x4 from finest-level voxel indices (their centres) to world coordinates.

        A source of bare arrays has its voxel ``i`` centred at ``i + 1/2``, as a numpy
        array's voxels are placed (``MultiscaleSource.cell_origin``).
        """
        placed = np.asarray(self.transform, float) @ self.source.levels[0].physical_from_index()
        if self.source.cell_origin:
            placed = placed @ _shifted(0.5)
        return placed

    def world_from_index(self) -> np.ndarray:
        """4x4 from the finest level's index space (voxel ``i`` spans ``[i, i + 1]``)."""
        return self.world_from_point() @ _shifted(-0.5)

    @property
    def dtype(self) -> np.dtype:
        """What the pool holds: rows of the per-label tables, float32 (exact to 2^24)."""
        return np.dtype(np.float32)

    def world_bounds(self) -> np.ndarray:
        """World bounds ``(xmin, xmax, ...)`` of the finest level's voxels."""
        return box_world_bounds(self.world_from_index(), np.asarray(self.dimensions, float))

    def frame_bounds(self) -> np.ndarray:
        """Bounds of the finest level's voxels in their own frame, before ``transform``."""
        return box_world_bounds(np.linalg.solve(np.asarray(self.transform, float),
                                                self.world_from_index()),
                                np.asarray(self.dimensions, float))


class LabelPager(BrickPager):
    """The brick pool of a label pyramid: rows of the per-label tables, nearest, no apron.

    Ids become rows as bricks are read (on the reading threads); the palette grows with
    them and goes to the GPU at the frame that first draws them.
    """

    apron = 0
    cull_hidden = True   # drawn opaque: its depth is the surface hit

    def __init__(self, model: PagedLabels, renderer, *args, **kwargs):
        dtype = np.dtype(model.source.dtype)
        if dtype.kind not in "iu":
            raise ValueError(f"Labels streamed from a multiscale source must be integers, got "
                             f"{dtype}: give add_volume the source instead, or its labels.")
        self._lock = threading.Lock()
        self.background = int(model.background)
        if not np.iinfo(dtype).min <= self.background <= np.iinfo(dtype).max:
            raise ValueError(f"background={self.background} is not a {dtype} id: give one "
                             f"from {np.iinfo(dtype).min} to {np.iinfo(dtype).max}.")
        # the ids met so far, sorted (the background first, row 0), and their rows
        self._keys = np.array([self.background], dtype)
        self._key_rows = np.zeros(1, np.float32)
        self._ids = np.zeros(0, dtype)   # the id of each row from 1 on, in the order met
        self.palette = Texture(palette_texels(np.zeros((2, 4), np.float32)), kind="2d",
                               interpolate=False)
        self._rgba = np.zeros((1, 4), np.float32)   # row 0: the background
        self._translucent_said = False
        super().__init__(model, renderer, *args, **kwargs)
        self.follow_ids()

    def read_pinned(self, keys) -> list:
        """The coarsest level's bricks as rows, their new ids registered in one merge.

        Brick by brick, a level of millions of distinct ids would insert into the sorted
        table millions of times over (0.8 s of a first frame).
        """
        bricks = [read_brick(self.model.source, key, self.brick, 0, None) for key in keys]
        found = [np.unique(values, return_inverse=True) for values in bricks]
        every = np.sort(np.concatenate([ids for ids, _ in found])) if found else \
            np.zeros(0, self._keys.dtype)
        every = every[np.append(True, every[1:] != every[:-1])]   # sorted: runs of one id
        self._register(every[every != self.background])
        return [self._rows(ids, inverse, values.shape)
                for (ids, inverse), values in zip(found, bricks, strict=True)]

    def _register(self, ids: np.ndarray) -> None:
        """Give the ids not met yet (sorted, background left out) the next rows."""
        with self._lock:
            at = np.searchsorted(self._keys, ids)
            known = at < self._keys.size
            known[known] = self._keys[at[known]] == ids[known]
            new = ids[~known]
            if not new.size:
                return
            if self._ids.size + new.size > MAX_IDS:
                raise ValueError(f"More than {MAX_IDS} distinct label ids met: rows are "
                                 "read from float32, exact to 2^24.")
            rows = np.arange(self._ids.size + 1, self._ids.size + 1 + new.size,
                             dtype=np.float32)
            place = np.searchsorted(self._keys, new)
            self._keys = np.insert(self._keys, place, new)
            self._key_rows = np.insert(self._key_rows, place, rows)
            self._ids = np.concatenate([self._ids, new])

    def prepare(self, key, values: np.ndarray) -> np.ndarray:
        """A brick of ids as float32 rows; an empty array where all is background.

        Ids met for the first time get the next rows, all at once: the known ids are kept
        sorted with their rows, so a brick of 32³ distinct ids costs a few searches, not a
        Python loop.
        """
        ids, inverse = np.unique(values, return_inverse=True)
        self._register(ids[ids != self.background])
        return self._rows(ids, inverse, values.shape)

    def _rows(self, ids: np.ndarray, inverse: np.ndarray, shape) -> np.ndarray:
        """A brick's rows from its distinct ids (registered) and ``np.unique``'s inverse.

        An empty array where all is background (the brick takes no slot).
        """
        if ids.size == 1 and int(ids[0]) == self.background:
            return np.zeros(0, np.float32)
        with self._lock:
            found = self._key_rows[np.searchsorted(self._keys, ids)]
        return found[inverse.reshape(shape)]

    def follow_ids(self) -> None:
        """Colours for the rows added since the last call; only they go to the GPU."""
        with self._lock:
            ids = self._ids[self.coloured_rows:]
        if not ids.size:
            return
        palette = self.model.palette
        new = hashed_colors(ids) if palette is None else colors_by_id(palette, ids)[1:]
        translucent = (new[:, 3] > 0) & (new[:, 3] < 1)
        if translucent.any() and not self._translucent_said:
            self._translucent_said = True
            warnings.warn(f"Voxels {self.model.name!r}: labels streamed from a multiscale "
                          "source are drawn opaque; translucent ones too.", stacklevel=2)
        new[translucent, 3] = 1.0
        first = len(self._rgba)
        self._rgba = np.vstack([self._rgba, new])
        shape = self.palette.array.shape if self.palette.array is not None else (0, 0)
        if shape[0] * shape[1] < len(self._rgba):   # it grew past the texture: all of it
            self.palette.set_data(palette_texels(self._rgba))
        else:   # only the new entries
            upload_palette_rows(self.palette, self._rgba, np.arange(first, len(self._rgba)))

    def frame(self, *args) -> None:
        """The volume pager's frame, then the colours of ids the new bricks brought."""
        try:
            super().frame(*args)
        finally:   # a read error is raised after this frame's uploads: their colours too
            if self._ids.size > self.coloured_rows:
                self.follow_ids()

    @property
    def ids(self) -> np.ndarray:
        """The id of each row from 1 on, in the order the bricks brought them."""
        with self._lock:
            return self._ids

    @property
    def coloured_rows(self) -> int:
        """Rows (from 1) the palette on the GPU colours."""
        return len(self._rgba) - 1

    @property
    def nbytes(self) -> int:
        """GPU bytes of the pool, page table, level table and palette."""
        return super().nbytes + self.palette.nbytes

    def release(self) -> None:
        """Stop reading; free the textures and the palette."""
        super().release()
        self.palette.release()


def paged_label_recipe(options: VoxelOptions, levels: int) -> ShaderRecipe:
    """The box actor's replacements: the streamed traversal, the mode and the shading."""
    lit = options.mode == "color" and options.shading != "unlit"
    return box_recipe(
        ("camera_declarations", "slab", "pixel_ray", "voxel_declarations",
         *(("clip_planes",) if clip_count(options) else ()), "paged_bricks",
         "voxel_paged", *(("blinn_phong", "voxel_shading") if lit else ())), "voxel_fragment",
        defines={"CM_VOXEL_ID": options.mode == "id", "CM_VOXEL_FACE": options.mode == "face",
                 "CM_LIGHTING": lit, "CM_SPECULAR": lit and options.shading == "blinn",
                 "CM_CLIP_PLANES": clip_count(options), "CM_PAGED_LEVELS": levels})


class PagedLabelsBinding(ClipPlaneSetting, FollowsPager, DrawnBinding):
    """What ``actor.cubemarch`` holds for a streamed label grid: model, pager, bindings."""

    technique = "voxels"
    needs_single_sample = True   # as a grid drawn whole (technique.VoxelBinding)
    follows_mapper_planes = True   # PyVista's mapper planes cut its rays, as clip_planes

    def follow_clip_planes(self, remake: bool) -> None:
        """Remake the shaders for another number of planes (the pager plans again)."""
        if remake:
            self.recipe = paged_label_recipe(self.options, len(self.pager.levels))
            self.bindings.install(self.recipe, self.drawn[0])

    def __init__(self, model: PagedLabels, pager: LabelPager, bindings: ShaderBindings,
                 recipe: ShaderRecipe, options: VoxelOptions):
        super().__init__(model, bindings, recipe)
        self.pager = pager
        self.options = options

    def stats(self) -> dict:
        """Resident, empty, missing and read bricks and bytes, and the ids met so far."""
        return {**super().stats(), "labels": int(self.pager.ids.size)}

    @property
    def label_ids(self) -> np.ndarray:
        """The ids the bricks read so far hold, in the order they were met."""
        return self.pager.ids.copy()

    @property
    def nbytes(self) -> int:
        """GPU bytes of the pool, its tables and the palette."""
        return self.pager.nbytes

    def release_resources(self) -> None:
        """Stop the per-frame choice and the reads; free the pool, tables and palette."""
        super().release_resources()
        self.pager.release()


def build_paged_labels(plotter, model: PagedLabels, options: VoxelOptions,
                       pager: LabelPager) -> PagedLabelsBinding:
    """The opaque box actor of a streamed label grid; returns its binding."""
    renderer = plotter.renderer
    dims = np.asarray(model.dimensions, float)
    actor = box_actor(dims, model.world_from_index(), margin=0.01 * float(dims.max()))
    actor.ForceTranslucentOff()
    actor.ForceOpaqueOn()
    actor.GetProperty().LightingOff()
    bindings = ShaderBindings(actor.GetMapper(), renderer)
    bindings.add_texture("cm_palette", pager.palette)
    bind_pool(bindings, pager, model.world_from_point)
    bind_grid(bindings, renderer, model, options)
    recipe = paged_label_recipe(options, len(pager.levels))
    bindings.install(recipe, actor)
    binding = PagedLabelsBinding(model, pager, bindings, recipe, options)
    binding.drawn = [actor]
    bind_clip_planes(bindings, model, lambda: binding.options.world_planes)
    # the frame's depth holds the other props too, and the planes cut where rays stop: a
    # plan is made again when either changes
    renderer = plotter.renderer   # this one: the plotter's active one may change
    pager.drawn_state = lambda: (opaque_scene_state(renderer, binding.drawn),
                                 binding.options.clip_planes)
    pager.clip_planes = lambda: binding.options.world_planes   # bricks they cut: not read
    binding.renderer = renderer
    follow_pager(plotter, binding, pager)
    pyvista.set_new_attribute(actor, "cubemarch", binding)
    return binding


def _shifted(offset: float) -> np.ndarray:
    """A 4x4 move by ``offset`` along every index axis."""
    shift = np.eye(4)
    shift[:3, 3] = offset
    return shift

