"""Voxel worlds drawn per chunk (``world_traversal='per_chunk'``): a box actor per chunk.

The other drawing, one traversal over a chunk index, is :mod:`.indexed`; this one serves
worlds it cannot draw (chunk sizes that are no power of two, distance fields, brick shells,
pools over one texture).

Each chunk is drawn as a grid of its own (:func:`build_voxel_actor`), so frustum culling,
levels and editing work per chunk; a chunk of one label is a single stretched voxel, and
empty chunks draw nothing. Every chunk's rays end at the world's solid faces
(:class:`~.occluders.WorldOccluders`), so chunks hidden behind nearer terrain cost one
texture read per pixel. With ``proxy='bricks'`` the chunks' brick shells are drawn by one
depth pass: the nearest shell face over all chunks is a safe start for every chunk's rays.
The world stands in the plotter as one invisible bounds actor; the chunks' actors follow its
visibility and leave with it. Edits, picks and palette changes go through the world
(:class:`WorldBinding`): an edit reaching an empty or uniform chunk gives it its own labels
and actor. Translucent labels are composited by the layers of the chunks holding them
(:mod:`.chunk_layers`).
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pyvista

from ..core import vtk_classes as vtk
from ..core.frame_errors import observe
from ..core.rendering import needs_open_plotter
from ..gl.box import camera_matrices
from ..gl.face_depth import FaceDepthPass
from ..gl.handle import DrawnBinding, Placement
from ..gl.look import ReturnedLook
from ..gl.overlay import bounds_proxy
from ..gl.reduced_group import ReducedGroup
from ..gl.textures import Texture
from ..models.voxel_shell import occupied_bricks
from ..models.voxels import palette_texels
from ..models.world import VoxelWorld
from . import editing
from .chunk_layers import ChunkLayers
from .clipping import ClipPlaneSetting
from .label_state import LabelState, upload_palette_rows
from .layers import opaque_palette
from .occluders import WorldOccluders
from .options import VoxelOptions
from .technique import VoxelBinding, build_voxel_actor
from .world_edits import WorldEditing


class WorldBinding(LabelState, WorldEditing, ClipPlaneSetting, Placement):
    """What ``actor.cubemarch`` holds for a world: the world, its chunks, their passes.

    Edits take world voxel indices, as a single grid's do (:class:`VoxelBinding`).
    """

    technique = "voxels"
    #: What a frame budget that fewer pixels cannot hold says would help.
    budget_hint = ("A world drawn by a box per chunk costs per chunk too, whatever the "
                   "pixels: world_traversal='index' (a power-of-two chunk_size, no "
                   "distance_field, proxy='box') draws it by one traversal.")

    def __init__(self, plotter, world: VoxelWorld, options: VoxelOptions, anchor):
        self.plotter = plotter
        self.model = world
        self.options = options
        self.anchor = anchor
        renderer = plotter.renderer
        self.renderer = renderer
        self.chunks: dict[tuple[int, int, int], VoxelBinding] = {}
        #: Whether translucent labels are composited (by each chunk's layers), else opaque.
        self.composites = options.mode == "color" and not options.lod
        self.chunk_layers = ChunkLayers(self)
        #: One palette for every chunk: a change sends its entries once, not per chunk
        #: (translucent labels hidden where composited).
        world.palette.take_changes()
        self.palette_texture = Texture(palette_texels(self._opaque_entries()), kind="2d",
                                       interpolate=False)
        self._palette_seen = world.palette
        self._shown_seen = self._solid_labels()   # what the occluders were made for
        self._parts = vtk.vtkAssembly()
        self.depth = (FaceDepthPass(renderer, self._parts, self._shells_used)
                      if options.proxy == "bricks" else None)
        self.occluders = WorldOccluders(world, renderer, opaque_only=self.composites)
        self.occluders.shown = lambda: bool(anchor.GetVisibility())
        # a clip plane may cut the solid faces away: rays must not end at them then
        self.occluders.clipped = lambda: bool(self.options.world_planes)
        self.occluders.depth.read_back = True
        self.occluders.depth.on_frame = self._hide_hidden_chunks
        self._blocks: dict = {}   # per chunk key, its filled blocks (index-space boxes)
        self._culled_for = None
        self._corners_for = None
        self._hidden: list[VoxelBinding] = []
        self._ordered_for = None
        #: A frame budget's draw of the chunks at fewer pixels (made at its first need),
        #: and of their translucent layers, following it.
        self.reduced: ReducedGroup | None = None
        self._reduced_layers: ReducedGroup | None = None
        self._order_tag = observe(renderer, vtk.vtkCommand.StartEvent, self._order_chunks)
        try:
            for key in sorted(set(world.stored) | set(world.uniform)):
                self._build_chunk(key)
            if self.composites:
                self.chunk_layers.follow(world.palette.rgba, None)
        except BaseException:
            self.discard()
            raise

    def discard(self) -> None:
        """Take back what a failed build made: chunks, passes, the ordering observer."""
        for chunk in self.chunks.values():
            self.plotter.cubemarch.untrack(chunk)
        self.chunks = {}
        self.release_passes()

    def release_passes(self) -> None:
        """Free the shared passes and stop ordering (the chunks are freed on their own)."""
        self.renderer.RemoveObserver(self._order_tag)
        for reduced in (self.reduced, self._reduced_layers):
            if reduced is not None:
                reduced.release()
        self.reduced = self._reduced_layers = None
        self.chunk_layers.release()
        if self.depth is not None:
            self.depth.release()
        self.occluders.release()
        self.palette_texture.release()

    def release_resources(self) -> None:
        """What goes when the world leaves (its passes; hooks such as a calibration's wrap it)."""
        self.release_passes()

    def follow_clip_planes(self, remake: bool) -> None:
        """Every chunk cut by the world's planes (chunks made later take them too)."""
        for chunk in self.chunks.values():
            chunk.options = replace(chunk.options, clip_planes=self.options.clip_planes)
            chunk.follow_clip_planes(remake)

    def make_reduced_draw(self) -> ReducedGroup:
        """The chunks drawn at fewer pixels as one (a frame budget's), freed with the world.

        Their translucent layers, where composited, follow its reduction; the chunks' rays
        start at their boxes then, and do not end at the occluders' faces (both drawn at
        the full viewport).
        """
        self.reduced = ReducedGroup(self.renderer, self.anchor,
                                    lambda: [c.drawn[0] for c in self.chunks.values()])
        if self.composites:
            self._reduced_layers = ReducedGroup(
                self.renderer, self.anchor, lambda: [c.layers.actor for c in self.chunks.values()
                                                     if c.layers is not None],
                follows=self.reduced, translucent=True)
        return self.reduced

    @property
    def reduced_bytes(self) -> int:
        """GPU bytes of the reduced draws' targets."""
        return sum(r.nbytes for r in (self.reduced, self._reduced_layers) if r is not None)

    def _opaque_entries(self) -> np.ndarray:
        """The palette the chunks' opaque actors read (translucent hidden if composited)."""
        rgba = self.model.palette.rgba
        return opaque_palette(rgba) if self.composites else rgba

    def _solid_labels(self) -> np.ndarray:
        """Per row, whether it stops rays (shown; and opaque, where others are composited)."""
        shown = self.model.palette.visible
        return shown & (self.model.palette.rgba[:, 3] >= 1.0) if self.composites else shown

    def _shells_used(self) -> bool:
        """Each shell decides for its chunk; the shared pass draws if any uses it."""
        return any([c.shell.used() for c in self.chunks.values() if c.shell is not None])

    def _build_chunk(self, key) -> None:
        """Draw chunk ``key`` (replacing its actor, if any) or nothing when it is empty."""
        self._blocks.pop(key, None)
        old = self.chunks.pop(key, None)
        if old is not None:
            if old.shell is not None:
                self._parts.RemovePart(old.shell.actor)
            self.plotter.cubemarch.untrack(old)
        if key not in self.model.stored and key not in self.model.uniform:
            return
        if self.model.palette is not self._palette_seen:   # a palette set on the model
            self.follow_palette_rows()
        model = self.model.chunk_model(key)
        self.options.check_model(model)
        binding = build_voxel_actor(self.plotter, model, self.options, shared_depth=self.depth,
                                    occluders=self.occluders,
                                    palette_texture=self.palette_texture)
        self.renderer.AddActor(binding.drawn[0])
        binding.main_renderer = self.renderer
        binding.actor = self.anchor   # the chunk follows its visibility, leaves with it
        if binding.shell is not None:
            binding.shell.shared = True   # the world's passes are freed with the world
            self._parts.AddPart(binding.shell.actor)
        self.plotter.cubemarch.track(binding)
        self.chunks[key] = binding

    def _order_chunks(self, *_) -> None:
        """Draw the chunks far to near, so that the nearer chunk wins a depth tie.

        Two hits in adjacent chunks along a ray may lie closer than the depth buffer
        resolves (seen: 10 pixels of a 100-chunk terrain showing the farther chunk's face,
        0.03 voxel behind, at a depth 2000 voxels away); the depth test passes on equal
        depths (``GL_LEQUAL``), so the chunk drawn last wins. Adjacent cells of a grid are in
        visibility order by their centres' distance from the eye in index space (along the
        view direction under a parallel projection), whatever the placement: a shear or a
        stretch after a rotation keeps which side of each border the eye is on. Reordered
        when the camera or the chunks change.
        """
        camera = self.renderer.GetActiveCamera()
        key = (camera.GetMTime(), self.model.world_from_index().tobytes(),
               tuple((id(c), id(c.layers)) for c in self.chunks.values()))
        if key == self._ordered_for or len(self.chunks) < 2:
            return
        self._ordered_for = key
        size = self.model.chunk_size
        centers = (np.array(list(self.chunks), dtype=np.float64) + 0.5) * size
        # in index space, where the chunks are a grid of cubes (a sheared placement keeps
        # which side of each border the eye is on, not the distances between centres)
        index_from_world = np.linalg.inv(self.model.world_from_index())
        if camera.GetParallelProjection():
            direction = index_from_world[:3, :3] @ np.asarray(camera.GetDirectionOfProjection())
            distance = centers @ direction
        else:
            eye = (index_from_world @ np.append(camera.GetPosition(), 1.0))[:3]
            distance = np.linalg.norm(centers - eye, axis=1)
        props = self.renderer.GetViewProps()   # moved in the list: nothing released
        chunks = list(self.chunks.values())
        for index in np.argsort(-distance, kind="stable"):
            # the layers too: each composites over the farther chunks' (the translucent
            # pass draws in this order)
            layers = chunks[index].layers
            for actor in (chunks[index].drawn[0],
                          *((layers.actor,) if layers is not None else ())):
                props.RemoveItem(actor)
                props.AddItem(actor)

    def _hide_hidden_chunks(self) -> None:
        """Leave out of this frame the chunks whose every pixel ends before its voxels.

        Each chunk's filled blocks of :data:`CULL_BLOCK`³ voxels are tested: where the
        occluders' depth over a block's screen rectangle is everywhere nearer than the
        block's nearest corner, every ray that could meet a voxel of the block has ended
        before it (its fragments would discard there). A chunk all of whose blocks are so
        hidden is not drawn at all: chunks behind nearer terrain cost nothing. Decided again
        when the occluders were drawn again or the chunks changed; the plotter shows every
        chunk at each frame's start, this runs after.
        """
        depths = self.occluders.depth.depths
        key = (self.occluders.depth.runs, tuple(id(c) for c in self.chunks.values()))
        if key != self._culled_for:
            self._culled_for = key
            self._hidden = [] if depths is None else self._hidden_by(depths)
        for chunk in self._hidden:
            chunk.drawn[0].SetVisibility(False)

    def _block_corners(self) -> tuple[list[VoxelBinding], np.ndarray]:
        """Every chunk's filled blocks as world-space corners ``(blocks, 8, 4)``, and owners.

        Kept until the chunks, their labels (an edit forgets it) or the placement change.
        """
        key = (tuple(id(c) for c in self.chunks.values()),
               self.model.world_from_index().tobytes())
        if self._corners_for is not None and self._corners_for[0] == key:
            return self._corners_for[1]
        pick = np.array(list(itertools.product((0, 1), repeat=3)))
        chunks, corners = [], []
        for chunk_key, chunk in self.chunks.items():
            blocks = self._blocks.get(chunk_key)
            if blocks is None:
                blocks = self._blocks[chunk_key] = _filled_blocks(chunk.model.labels)
            to_world = chunk.model.world_from_index()
            for low, high in blocks:
                box = np.where(pick == 0, low, high)
                corners.append(np.c_[box, np.ones(8)] @ to_world.T)
                chunks.append(chunk)
        found = (chunks, np.array(corners).reshape(-1, 8, 4))
        self._corners_for = (key, found)
        return found

    def _hidden_by(self, depths: np.ndarray) -> list[VoxelBinding]:
        """The chunks whose filled blocks all lie behind ``depths`` (the occluders')."""
        view, projection = camera_matrices(self.renderer)
        height, width = depths.shape
        chunks, world_corners = self._block_corners()
        if not chunks:
            return []
        corners = world_corners @ np.asarray(view).T       # (blocks, 8, 4), view space
        depth = -corners[..., 2]                          # the pixel rays' parameter
        clip = corners @ np.asarray(projection).T
        with np.errstate(divide="ignore", invalid="ignore"):
            ndc = np.nan_to_num(clip[..., :2] / clip[..., 3:4])   # blocks the eye's plane
        x = (ndc[..., 0] + 1.0) * 0.5 * width - 0.5      # cuts are kept below, whatever it is
        y = (ndc[..., 1] + 1.0) * 0.5 * height - 0.5
        i0 = np.clip(np.floor(x.min(axis=1)) - 1, 0, width).astype(int)
        i1 = np.clip(np.ceil(x.max(axis=1)) + 1, 0, width).astype(int)
        j0 = np.clip(np.floor(y.min(axis=1)) - 1, 0, height).astype(int)
        j1 = np.clip(np.ceil(y.max(axis=1)) + 1, 0, height).astype(int)
        ahead = (depth > 0).all(axis=1)   # else the eye's plane cuts the block
        on_screen = (i1 > i0) & (j1 > j0)
        nearest = depth.min(axis=1)
        # The pyramid proves most hidden blocks hidden at once; those it cannot (its texels
        # reach past their rectangles) are read exactly, a chunk's reading stopping at its
        # first block found in sight.
        maybe = on_screen & ahead & ~(nearest > _rectangle_max(depths, i0, i1, j0, j1,
                                                                on_screen & ahead))
        # One pixel at or past the block's nearest corner shows it in sight: the centre's
        # is read first for all blocks at once.
        middle = depths[np.minimum((j0 + j1) // 2, height - 1),
                        np.minimum((i0 + i1) // 2, width - 1)]
        shown = {id(chunks[index]) for index in np.flatnonzero(~ahead | (maybe & (
            middle >= nearest)))}
        for index in np.flatnonzero(maybe):
            if id(chunks[index]) not in shown and not nearest[index] > depths[
                    j0[index]:j1[index], i0[index]:i1[index]].max():
                shown.add(id(chunks[index]))
        return [c for c in self.chunks.values() if id(c) not in shown]

    @property
    def hidden_chunks(self) -> int:
        """How many chunks the last frame left out as hidden behind the occluders."""
        if not self.anchor.GetVisibility():
            return 0
        return sum(1 for c in self.chunks.values() if not c.drawn[0].GetVisibility())

    @property
    def palette(self):
        """The world's :class:`~pv_cubemarch.models.voxels.Palette` (shared by its chunks)."""
        return self.model.palette

    @property
    def nbytes(self) -> int:
        """GPU bytes of every chunk and the occluders, the shared depth pass counted once."""
        full = self.chunk_layers.palette   # the layers' palette, shared
        total = (sum(c.nbytes for c in self.chunks.values()) + self.occluders.nbytes
                 + self.palette_texture.nbytes + (full.nbytes if full is not None else 0)
                 + self.reduced_bytes)
        shells = sum(1 for c in self.chunks.values() if c.shell is not None)
        return total - max(shells - 1, 0) * (self.depth.nbytes if self.depth else 0)

    @property
    def uploaded_bytes(self) -> int:
        """Bytes of every chunk's labels, levels and distance field sent so far."""
        return sum(c.uploaded_bytes for c in self.chunks.values())

    @needs_open_plotter
    def set_material(self, material: int, color=None, opacity: float | None = None) -> None:
        """Change a material's colour and/or opacity (0 hides it) in every chunk."""
        self.model.palette.set_color(self.material_row(material), color, opacity)
        self.follow_palette_rows()

    def follow_palette_rows(self) -> None:
        """Changed entries go to the chunks' one palette; the occluders follow what is shown."""
        rows = self.model.palette.take_changes()
        if self.model.palette is not self._palette_seen:
            self._palette_seen, rows = self.model.palette, None   # another palette: whole
        upload_palette_rows(self.palette_texture, self._opaque_entries(), rows)
        if self.composites:
            self.chunk_layers.follow(self.model.palette.rgba, rows)
        self.say_drawn_opaque()
        shown = self._solid_labels()
        if not np.array_equal(shown, self._shown_seen):   # not for a colour: a full scan
            self._shown_seen = shown
            self.occluders.rebuild()   # which bricks are solid depends on what is shown

    def _write(self, box, values: np.ndarray) -> None:
        """Labels into the world; chunks that changed kind get new actors, others edits."""
        stored_before = set(self.model.stored)
        rebuilt = set(self.model.write(box, values))
        for key, inner, _ in self.model.pieces(box):
            if key in rebuilt:
                self._build_chunk(key)
            elif key in stored_before and key in self.chunks:
                editing.refresh(self.chunks[key], inner)
                self._blocks.pop(key, None)
                self._corners_for = None
        for key in rebuilt - {key for key, _, _ in self.model.pieces(box)}:
            self._build_chunk(key)   # a chunk outside the box whose labels widened
        self._culled_for = None
        self.occluders.edit(box)
        self.chunk_layers.edited(box, rebuilt)

    @property
    def bounds_proxy(self):
        """The prop standing for the world (placed again when the world moves)."""
        return self.anchor

    def place(self, transform) -> None:
        """Every chunk follows the world, with the solid faces that end its rays."""
        for chunk in self.chunks.values():
            chunk.set_transform(transform)
        self.occluders.place()


#: Edge (voxels) of the blocks whose screen rectangles decide if a chunk is hidden: finer
#: blocks hide more chunks whose boxes show above nearer terrain but whose voxels do not
#: (bench's inside view: 51 of 100 chunks with 64, 28 with whole chunk boxes; 32 and 16
#: found 54 for 2x and 5x the work).
CULL_BLOCK = 64


def _rectangle_max(image: np.ndarray, i0, i1, j0, j1, which: np.ndarray) -> np.ndarray:
    """Per rectangle ``[j0, j1) x [i0, i1)`` of ``image`` (where ``which``), at least its max.

    From a max pyramid: each rectangle is read at the level where it spans at most two
    texels a side, so at most 3 x 3 texels that cover it (and a little around it: the
    result may be larger than the exact max, never smaller). ``-inf`` where not ``which``.
    """
    levels = [image]
    while max(levels[-1].shape) > 1:
        last = levels[-1]
        padded = np.pad(last, [(0, n % 2) for n in last.shape], constant_values=-np.inf)
        levels.append(np.maximum(np.maximum(padded[0::2, 0::2], padded[1::2, 0::2]),
                                 np.maximum(padded[0::2, 1::2], padded[1::2, 1::2])))
    result = np.full(len(which), -np.inf)
    span = np.maximum(i1 - i0, j1 - j0)
    level = np.maximum(np.ceil(np.log2(np.maximum(span, 1))).astype(int) - 1, 0)
    for number in np.unique(level[which]):
        rows = np.flatnonzero(which & (level == number))
        grid = levels[min(number, len(levels) - 1)]
        top_i, top_j = grid.shape[1] - 1, grid.shape[0] - 1
        for di in range(3):
            for dj in range(3):
                ci = np.minimum((i0[rows] >> number) + di, np.minimum((i1[rows] - 1) >> number,
                                                                      top_i))
                cj = np.minimum((j0[rows] >> number) + dj, np.minimum((j1[rows] - 1) >> number,
                                                                      top_j))
                result[rows] = np.maximum(result[rows], grid[cj, ci])
    return result


def _filled_blocks(labels: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Index-space ``(low, high)`` corners of the :data:`CULL_BLOCK` blocks holding voxels."""
    occupied = occupied_bricks(labels, CULL_BLOCK)
    dims = np.asarray(labels.shape)
    return [(cell * CULL_BLOCK, np.minimum((cell + 1) * CULL_BLOCK, dims))
            for cell in np.argwhere(occupied)]


class WorldPasses(DrawnBinding):
    """The world's shared passes as the plotter tracks them: freed when the world leaves.

    At each frame it also has the world follow what PyVista's calls set on the returned
    prop: its placement and its mapper's clipping planes (the chunks hold the prop, not a
    box of their own, so they do not).
    """

    follows_mapper_planes = True
    look_hint = VoxelBinding.look_hint

    def __init__(self, world: WorldBinding):
        super().__init__(world.model, world.occluders.bindings, None)
        self.world = world
        self.actor = self.bounds_proxy = world.anchor
        self.main_renderer = self.renderer = world.renderer
        self.look = ReturnedLook(self)   # what is set on the prop from now: drawn or said

    def look_bindings(self) -> list:
        """The chunks' bindings: a term set on the world's prop shades every chunk."""
        return [bindings for chunk in self.world.chunks.values()
                for bindings in chunk.look_bindings()]

    def check_movable(self) -> None:
        """As the world."""
        self.world.check_movable()

    def place(self, transform) -> None:
        """The world follows (the prop is placed again by ``set_transform``)."""
        self.world.place(transform)

    def follow_mapper_planes(self, actor) -> None:
        """The world is cut by the prop's mapper's planes (see the class)."""
        self.world.follow_mapper_planes(actor)

    @property
    def name(self) -> str:
        """The world's name, for the plotter's memory report."""
        return f"{self.model.name} passes"

    @property
    def nbytes(self) -> int:
        """GPU bytes of its passes: occluders, shells, layers' palette, reduced targets."""
        full = self.world.chunk_layers.palette
        return self.world.occluders.nbytes + (self.world.depth.nbytes if self.world.depth
                                              else 0) + (full.nbytes if full is not None
                                                         else 0) + self.world.reduced_bytes

    def release_resources(self) -> None:
        """The world's shared passes (the chunks are tracked and freed on their own)."""
        self.world.release_resources()


def build_world(plotter, world: VoxelWorld, options: VoxelOptions,
                name: str | None = None) -> pyvista.Actor:
    """Draw ``world``'s chunks in ``plotter``; returns the actor that stands for them.

    That actor is in the plotter (as ``name``, by default the world's) before any chunk
    is tracked: a tracked chunk whose anchor is not in the renderer counts as removed.
    """
    proxy = bounds_proxy(world)
    plotter.add_actor(proxy, name=name or world.name, reset_camera=False, render=False)
    try:
        binding = WorldBinding(plotter, world, options, proxy)
    except BaseException:
        plotter.remove_actor(proxy, reset_camera=False)   # the binding took back its parts
        raise
    plotter.cubemarch.track(WorldPasses(binding))
    pyvista.set_new_attribute(proxy, "cubemarch", binding)
    return proxy

