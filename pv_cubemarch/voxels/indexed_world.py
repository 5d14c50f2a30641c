"""A voxel world drawn by one traversal over its chunk index (``world_traversal='index'``).

One box actor around the world's filled voxels; each pixel's ray runs the same Amanatides &
Woo traversal as a single grid, whose labels and occupancy levels are read through the chunk
index (``voxel_chunk_index.glsl``): an empty chunk is one step, a uniform chunk its label,
a stored chunk a slot of the pool texture (:mod:`pv_cubemarch.models.chunk_pool`). A ray
stops at its first hit whatever chunk it is in, so chunks behind the camera or behind
nearer ground cost nothing, and there are no seams, ties or draw order between chunks.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pyvista

from ..core.gl_limits import MAX_TEXTURE_SIZE
from ..gl.bindings import ShaderBindings
from ..gl.box import box_actor, box_polydata
from ..gl.handle import DrawnBinding
from ..gl.textures import Texture
from ..models.chunk_pool import (
    PoolLayout,
    chunk_counts,
    chunk_index,
    chunk_shift,
    pool_layout,
    slot_texels,
    world_filled_bounds,
)
from ..models.voxel_levels import atlas_updates, bounds_in_cells, filled_bounds
from ..models.voxels import palette_texels
from ..models.world import VoxelWorld
from .clipping import ClipPlaneSetting, bind_clip_planes
from .label_state import LabelState, upload_palette_rows
from .layers import LayerHost, TranslucentLayers
from .options import VoxelOptions, drawn_level
from .technique import VoxelBinding, bind_grid, voxel_recipe
from .world_edits import WorldEditing

#: Spare slots a pool gets when an edit needs one more than it has: a quarter more.
POOL_GROWTH = 1.25


def index_levels(world: VoxelWorld, options: VoxelOptions) -> int:
    """The traversal's occupancy levels: every level up to the chunk index by default."""
    shift = chunk_shift(world.chunk_size)
    if options.traversal != "dda":
        return 0
    return shift if options.mip_levels is None else int(options.mip_levels)


def why_not_indexed(world: VoxelWorld, options: VoxelOptions) -> str | None:
    """Why ``world`` cannot be drawn by one traversal with ``options`` (None: it can)."""
    shift = chunk_shift(world.chunk_size)
    if shift is None:
        return (f"its chunk index needs a chunk_size that is a power of two, got "
                f"{world.chunk_size}")
    if options.distance_field:
        return "the distance field is kept per chunk only"
    if options.proxy == "bricks":
        return "brick shells start rays per chunk only"
    counts = chunk_counts(world)
    if max(counts) > MAX_TEXTURE_SIZE:
        return (f"its chunk index would be {counts} texels, over {MAX_TEXTURE_SIZE} on a side: "
                "use a larger chunk_size")
    levels = index_levels(world, options)
    if levels > shift:
        return (f"its levels stop at the chunk index: mip_levels={levels} is over "
                f"log2(chunk_size)={shift}")
    if _layout(world, options, len(world.stored)) is None:
        return (f"its {len(world.stored)} stored chunks do not fit one texture of at most "
                "512 MiB")
    return None


def _layout(world: VoxelWorld, options: VoxelOptions, slots: int) -> PoolLayout | None:
    """The pool for ``slots`` stored chunks of ``world`` with ``options``' levels."""
    shift = chunk_shift(world.chunk_size)
    inside = min(index_levels(world, options), shift - 1)
    return pool_layout(world.chunk_size, inside, slots, world.dtype.itemsize)


class IndexedWorldBinding(LabelState, WorldEditing, ClipPlaneSetting, LayerHost,
                          DrawnBinding):
    """What ``actor.cubemarch`` holds for a world drawn by one traversal.

    Edits, brushes, ``pick`` and ``set_material`` take world voxel indices; an edit uploads
    the touched texels of a stored chunk's slot and, when a chunk changes kind (empty,
    one label, stored), its slot and the small index.
    """

    technique = "voxels"
    needs_single_sample = True   # as a single grid's box (technique.VoxelBinding)
    follows_mapper_planes = True   # as a single grid's (technique.VoxelBinding)
    look_hint = VoxelBinding.look_hint

    def __init__(self, world: VoxelWorld, options: VoxelOptions, renderer):
        self.options = options
        self.layout = _layout(world, options, len(world.stored))
        self.slots = {key: slot for slot, key in enumerate(sorted(world.stored))}
        #: Slots the pool texture has (none when built with no stored chunk: one texel).
        self.capacity = self.layout.capacity if self.slots else 0
        actor = box_actor(np.ones(3), world.world_from_index())
        super().__init__(world, ShaderBindings(actor.GetMapper(), renderer), None)
        self.renderer = renderer
        self.drawn = [actor]
        self.pool = Texture(self._pool_texels(), kind="3d", interpolate=False,
                            rebuild=self._pool_texels)
        self._index_sent = self._index()
        self.index = Texture(self._index_sent, kind="3d", interpolate=False)
        self.palette_texture = Texture(palette_texels(world.palette.rgba), kind="2d",
                                       interpolate=False)
        self._palette_seen = (world.palette, world.palette.version)
        #: Translucent labels composited by a layer actor through the same chunk index
        #: (colour mode, no level of detail); else drawn opaque, as warned.
        self.composites = options.mode == "color" and not options.lod
        self.drawn_bounds = bounds_in_cells(world_filled_bounds(world), drawn_level(options),
                                            world.dimensions)
        self._place_box()

    @property
    def palette(self):
        """The world's :class:`~pv_cubemarch.models.voxels.Palette`."""
        return self.model.palette

    @property
    def nbytes(self) -> int:
        """GPU bytes: the pool of stored chunks, the chunk index and the palette."""
        return (self.pool.nbytes + self.index.nbytes + self.palette_texture.nbytes
                + (self.layers.nbytes if self.layers is not None else 0))

    @property
    def uploaded_bytes(self) -> int:
        """Bytes of the pool (labels and levels) and the chunk index sent so far."""
        return self.pool.uploaded_bytes + self.index.uploaded_bytes

    @property
    def derived_textures(self) -> list[Texture]:
        """The pool, remade from the world's chunks if a new window needs it."""
        return [self.pool]

    def _pool_texels(self) -> np.ndarray:
        """Every stored chunk's level atlas in its slot (one texel when there is none)."""
        layout = self.layout
        if not self.capacity:
            return np.zeros((1, 1, 1), self.model.dtype)
        # x fastest, as the upload wants it: no transposed copy of the whole pool there.
        texels = np.zeros(layout.shape, self.model.dtype, order="F")
        for key, slot in self.slots.items():
            origin = layout.slot_origin(slot)
            texels[tuple(slice(o, o + n) for o, n in zip(origin, layout.slot_shape,
                                                         strict=True))] = self._slot(key)
        return texels

    def _slot(self, key) -> np.ndarray:
        """Stored chunk ``key``'s slot texels (its labels padded, then its levels)."""
        return slot_texels(self.model, key, self.layout, bool(self.options.lod))

    def _index(self) -> np.ndarray:
        """The chunk index for the current slots and palette."""
        return chunk_index(self.model, self.slots, self.model.drawn_labels(), self.layout)

    def _place_box(self) -> None:
        """The box actor around the filled voxels (1 % larger: rays clip to it exactly)."""
        lower, upper = self.drawn_bounds
        margin = 0.01 * max(self.model.dimensions)
        self.set_box_polydata(box_polydata(lower, upper, margin))

    def set_material(self, material: int, color=None, opacity: float | None = None) -> None:
        """Change a material's colour and/or opacity (0 hides it): the palette and index go up.

        The index changes where a chunk of one label is hidden or shown; the pool stays.
        """
        self.model.palette.set_color(self.material_row(material), color, opacity)
        self._follow_palette()

    def follow_palette_rows(self) -> None:
        """Per-label changes: the changed palette entries, and the index if it changed."""
        self._follow_palette(self.model.palette.take_changes())

    def _follow_palette(self, rows: np.ndarray | None = None, whole: bool = False) -> None:
        """Upload the palette (its ``rows``, or whole) and the index if either changed.

        The index changes only where a chunk of one label was hidden or shown. ``whole``:
        the palette as it is now, changed or not (at the start).
        """
        palette = self.model.palette
        if not whole and palette is self._palette_seen[0] and \
                palette.version == self._palette_seen[1]:
            return
        if whole or palette is not self._palette_seen[0]:
            rows = None   # another palette: whole
        self._palette_seen = (palette, palette.version)
        upload_palette_rows(self.palette_texture, self.opaque_entries(palette.rgba), rows)
        self.follow_layers(palette.rgba, rows)
        self.say_drawn_opaque()
        self._send_index()

    def _send_index(self) -> None:
        """The chunk index for the slots and palette now, uploaded if it changed."""
        index = self._index()
        if not np.array_equal(index, self._index_sent):
            self.index.set_data(index)
            self._index_sent = index

    def _write(self, box, values: np.ndarray) -> None:
        """Labels into the world; the touched texels of stored slots, new slots, the index.

        An edit whose chunks no pool within one texture holds raises ``MemoryError`` and
        leaves the world as it was.
        """
        dtype = self.model.dtype
        widening = bool(values.size) and int(values.max()) > 255 and dtype == np.uint8
        needed = len(self.model.stored) + sum(1 for k in self.model.keys_in(box)
                                              if k not in self.model.stored)
        room = not widening and (needed <= self.capacity
                                 or _layout(self.model, self.options, needed) is not None)
        previous = None if room else self.model.labels_in(box)   # to undo a refused edit
        changed = set(self.model.write(box, values))
        try:
            if self.model.dtype != dtype:   # widened to uint16: every slot again
                self._reslot()
            else:
                self._follow_kinds(changed)
        except MemoryError:
            if previous is not None:
                self._undo(box, previous, dtype)
            raise
        if self.model.dtype == dtype:
            for key, inner, _ in self.model.pieces(box):
                if key in self.model.stored and key not in changed:
                    slot = self.slots[key]
                    for origin, block in atlas_updates(
                            self.model.stored[key], inner, self.layout.levels,
                            bool(self.options.lod),
                            lambda level, s=slot: self.layout.level_origin(s, level)):
                        self.pool.update_region(origin, block)
        if changed:
            self._send_index()
        self._follow_palette()   # a palette set on the model directly
        self._grow_box(box, values)

    def _undo(self, box, previous: np.ndarray, dtype) -> None:
        """Put back the labels ``previous`` in ``box`` (and the world's label type)."""
        if self.model.dtype != dtype:
            self.model.label_type = str(np.dtype(dtype))
            for key, kept in self.model.stored.items():
                self.model.stored[key] = kept.astype(dtype)   # the box is written next
        self.model.write(box, previous)

    def _follow_kinds(self, changed: set) -> None:
        """Give chunks that became stored a slot (and their texels), free the others'.

        A pool with too few free slots is made again with room to spare (nothing changes
        when even the chunks alone do not fit: ``MemoryError``).
        """
        kept = {k: s for k, s in self.slots.items() if k in self.model.stored}
        arriving = sorted(k for k in changed if k in self.model.stored and k not in kept)
        free = sorted(set(range(self.capacity)) - set(kept.values()))
        if len(arriving) > len(free):
            self._reslot(growth=POOL_GROWTH)
            return
        self.slots = kept
        for key, slot in zip(arriving, free, strict=False):
            self.slots[key] = slot
            self.pool.update_region(self.layout.slot_origin(slot), self._slot(key))

    def _reslot(self, growth: float = 1.0) -> None:
        """A new pool for every stored chunk, uploaded whole.

        ``growth`` times as many slots if they fit one texture, else exactly as many;
        ``MemoryError`` (nothing changed) when even those do not fit.
        """
        count = len(self.model.stored)
        layout = (_layout(self.model, self.options, max(int(np.ceil(count * growth)), count))
                  or _layout(self.model, self.options, count))
        if layout is None:
            raise MemoryError(f"{count} stored chunks do not fit one texture of at most "
                              "512 MiB: the edit was not made. Draw the world with "
                              "world_traversal='per_chunk' for edits this large.")
        self.layout = layout
        self.slots = {key: slot for slot, key in enumerate(sorted(self.model.stored))}
        self.capacity = layout.capacity if self.slots else 0
        self.pool.set_data(self._pool_texels())
        self._send_index()

    def _grow_box(self, box, values: np.ndarray) -> None:
        """Grow the drawn box to the filled voxels just written (it never shrinks)."""
        low, high = filled_bounds(values)
        if not (high > low).all():
            return
        start = np.array([s.start for s in box], dtype=np.float64)
        lower, upper = self.drawn_bounds
        if not (upper > lower).all():
            lower, upper = np.full(3, np.inf), np.full(3, -np.inf)
        grown = bounds_in_cells((np.minimum(lower, start + low), np.maximum(upper, start + high)),
                                drawn_level(self.options), self.model.dimensions)
        if tuple(np.concatenate(grown)) != tuple(np.concatenate(self.drawn_bounds)):
            self.drawn_bounds = grown
            self._place_box()

    def _recipe(self):
        """The traversal's shaders for the options now (labels through the chunk index)."""
        return voxel_recipe(self.options, None, (self.layout.slab_axis, self.layout.row_axis),
                            chunk_shift=chunk_shift(self.model.chunk_size))

    def follow_clip_planes(self, remake: bool) -> None:
        """Remake the shaders for another number of planes (moved ones: a uniform)."""
        if remake:
            self.recipe = self._recipe()
            self.bindings.install(self.recipe, self.drawn[0])
            if self.layers is not None:
                self.layers.follow_clip_planes(self.options, self)

    @property
    def labels(self) -> Texture:
        """The texture the traversal reads labels from: the chunk pool."""
        return self.pool

    @property
    def level_axes(self) -> tuple[int, int]:
        """The pool's slab and row axes (where each slot's levels sit)."""
        return (self.layout.slab_axis, self.layout.row_axis)

    def make_layers(self) -> TranslucentLayers:
        """The layer actor: the layers' traversal through the same pool and chunk index."""
        return TranslucentLayers(self, self.renderer, bind_grid, chunk_index=self.index,
                                 chunk_shift=chunk_shift(self.model.chunk_size))

    def place(self, transform) -> None:
        """The box and the translucent layers follow the world."""
        super().place(transform)
        if self.layers is not None:
            self.layers.place()

    def follow_anchor(self) -> None:
        """At each frame: the box (placement, planes) and the layers follow the returned actor."""
        super().follow_anchor()
        self.follow_layers_anchor()

    def release_resources(self) -> None:
        """The bindings, and the chunk pool, chunk index and palette textures."""
        super().release_resources()
        self.release_layers()
        for texture in (self.pool, self.index, self.palette_texture):
            texture.release()


def build_indexed_world(plotter, world: VoxelWorld,
                        options: VoxelOptions) -> IndexedWorldBinding:
    """The box actor of ``world`` drawn by one traversal; returns its binding.

    Raises ``ValueError`` saying why when the world or options do not allow it
    (:func:`why_not_indexed`).
    """
    reason = why_not_indexed(world, options)
    if reason is not None:
        raise ValueError(f"world_traversal='index' cannot draw {world.name!r}: {reason}. Use "
                         "world_traversal='per_chunk' (or leave it None to choose).")
    renderer = plotter.renderer
    options = replace(options, mip_levels=index_levels(world, options))
    binding = IndexedWorldBinding(world, options, renderer)
    actor = binding.drawn[0]
    actor.ForceTranslucentOff()
    actor.ForceOpaqueOn()
    actor.GetProperty().LightingOff()
    bindings = binding.bindings
    bindings.add_texture("cm_labels", binding.pool)
    bindings.add_texture("cm_chunkIndex", binding.index)
    bindings.add_texture("cm_palette", binding.palette_texture)
    bind_grid(bindings, renderer, world, options)
    bind_clip_planes(bindings, world, lambda: binding.options.world_planes)
    binding.recipe = binding._recipe()
    bindings.install(binding.recipe, actor)
    binding._follow_palette(whole=True)   # translucent labels: the opaque palette, layers
    pyvista.set_new_attribute(actor, "cubemarch", binding)
    return binding
