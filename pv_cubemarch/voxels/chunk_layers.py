"""Translucent labels of a world drawn per chunk: a layer actor per chunk that holds one.

Each such chunk's layers read a copy of its labels with one voxel of its neighbours around
them (its apron), so a material going on across a chunk border has no face there and a
face between two chunks is drawn once, by the chunk of the voxel it bounds
(``voxel_layers.glsl``). The chunks' layer actors are drawn far to near (the world orders
them with its chunks), each compositing its part of the ray over what is behind it: the
world's image is the single grid's. Only chunks holding a translucent label get one, and
the opaque actors read the palette with translucent labels hidden.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.parallel import core_pool
from ..core.progress import progress
from ..gl.textures import Texture
from ..models.label_ids import distinct_in_runs
from ..models.voxels import palette_texels
from .label_state import upload_palette_rows
from .layers import TranslucentLayers, translucent_materials
from .technique import bind_grid

#: Chunks from which the search for the rows each holds shows a progress bar.
BAR_CHUNKS = 64


@dataclass
class ChunkRegion:
    """A chunk's whole box as its layers draw it (a uniform chunk is drawn as one voxel).

    ``drawn``: the chunk's model as its opaque actor draws it; the region follows its
    placement.
    """

    drawn: object
    dimensions: tuple[int, int, int]
    dtype: np.dtype

    def world_from_index(self) -> np.ndarray:
        """The chunk's index space (whole voxels, not its stretched single voxel)."""
        scale = np.ones(4)
        scale[:3] = np.asarray(self.drawn.dimensions, float) / np.asarray(self.dimensions)
        return self.drawn.world_from_index() @ np.diag(scale)


@dataclass
class ChunkApron:
    """A chunk's region and the texture of its labels grown by one voxel on every side."""

    key: tuple[int, int, int]
    region: ChunkRegion
    texture: Texture


def apron_labels(world, key) -> np.ndarray:
    """Chunk ``key``'s labels with one voxel of its neighbours around (0 outside the world)."""
    origin, shape = world.chunk_box(key)
    out = np.zeros([n + 2 for n in shape], world.dtype)
    box = tuple(slice(max(o - 1, 0), min(o + n + 1, d))
                for o, n, d in zip(origin, shape, world.dimensions, strict=True))
    at = tuple(slice(s.start - (o - 1), s.stop - (o - 1)) for s, o in zip(box, origin,
                                                                             strict=True))
    out[at] = world.labels_in(box)
    return out


class ChunkLayers:
    """The layer actors of a world's chunks (``binding``: its :class:`WorldBinding`).

    Follows the palette (which chunks need layers, the full palette they read) and edits
    (the aprons of every chunk whose grown box an edit touches).
    """

    def __init__(self, binding):
        self.binding = binding
        self.palette: Texture | None = None
        self._rows: dict[tuple[int, int, int], np.ndarray] = {}
        self._translucent = np.zeros(0, np.int64)   # the rows the layers were placed for

    def rows_in(self, keys) -> dict:
        """Per chunk key, the sorted rows its voxels hold (found once, kept until edited)."""
        world = self.binding.model
        missing = [k for k in keys if k not in self._rows]
        stored = [k for k in missing if k in world.stored]
        for key in missing:
            if key in world.uniform:
                self._rows[key] = np.array([world.uniform[key]])
        if stored:
            def find(key):
                return distinct_in_runs(world.stored[key].ravel())[0]
            with core_pool(len(stored)) as pool:
                found = list(progress(pool.map(find, stored), total=len(stored),
                                      desc=f"{world.name}: translucent chunks",
                                      enabled=None if len(stored) >= BAR_CHUNKS else False))
            self._rows.update(zip(stored, found, strict=True))
        return {k: self._rows[k] for k in keys}

    def follow(self, rgba: np.ndarray, rows: np.ndarray | None) -> None:
        """The palette changed (``rows`` of it, or all): layers made, updated or dropped.

        Which chunks hold layers is decided again only when the translucent labels changed
        (a colour alone sends its entries and nothing more).
        """
        translucent = translucent_materials(rgba)
        if not translucent.size:
            self.release()
            return
        if self.palette is None:
            self.palette = Texture(palette_texels(rgba), kind="2d", interpolate=False)
        else:
            upload_palette_rows(self.palette, rgba, rows)
        if not np.array_equal(translucent, self._translucent):
            self._translucent = translucent
            self.place_layers()

    def place_layers(self, keys=None) -> None:
        """A layer actor for each chunk (of ``keys``, or all) holding a translucent row."""
        chunks = self.binding.chunks
        keys = list(chunks) if keys is None else [k for k in keys if k in chunks]
        table = np.zeros(int(self._translucent.max(initial=0)) + 1, bool)
        table[self._translucent] = True
        held = self.rows_in(keys) if self._translucent.size else {}
        for key in keys:
            chunk = chunks[key]
            rows = held.get(key)
            wanted = rows is not None and bool(table[rows[rows < table.size]].any())
            if wanted and chunk.layers is None:
                chunk.layers = self._make(key, chunk)
                chunk.layers.actor.SetVisibility(chunk.shown)
            elif not wanted and chunk.layers is not None:
                chunk.release_layers()

    def _make(self, key, chunk) -> TranslucentLayers:
        """Chunk ``key``'s layer actor, reading its apron and the world's full palette.

        The apron's host copy goes once uploaded (remade from the world if a new window
        needs it).
        """
        world = self.binding.model
        labels = apron_labels(world, key)
        region = ChunkRegion(chunk.model, tuple(n - 2 for n in labels.shape), labels.dtype)
        apron = ChunkApron(key, region, Texture(labels, kind="3d", interpolate=False,
                                                rebuild=lambda: apron_labels(world, key)))
        return TranslucentLayers(chunk, self.binding.renderer, bind_grid, apron=apron,
                                 palette=self.palette)

    def edited(self, box, rebuilt) -> None:
        """Labels changed in ``box`` (world voxels; chunks ``rebuilt`` have new actors).

        The rows held and the layers are decided again for the chunks the box, grown by
        the one voxel of their aprons, touches; those chunks' aprons take the new labels.
        A world widened to uint16 remakes every apron.
        """
        world = self.binding.model
        grown = tuple(slice(max(s.start - 1, 0), min(s.stop + 1, n))
                      for s, n in zip(box, world.dimensions, strict=True))
        touched = set(world.keys_in(grown)) | set(rebuilt)
        for key in touched:
            self._rows.pop(key, None)
        if self.palette is None:
            return
        if any(c.layers is not None and c.layers.apron.region.dtype != world.dtype
               for c in self.binding.chunks.values()):
            for chunk in self.binding.chunks.values():
                chunk.release_layers()
            self.place_layers()
            return
        for key in touched:
            chunk = self.binding.chunks.get(key)
            if chunk is None or chunk.layers is None:
                continue
            origin, shape = world.chunk_box(key)
            low = [max(s.start, o - 1) for s, o in zip(box, origin, strict=True)]
            high = [min(s.stop, o + n + 1) for s, o, n in zip(box, origin, shape, strict=True)]
            if all(h > lo for lo, h in zip(low, high, strict=True)):
                part = tuple(slice(lo, h) for lo, h in zip(low, high, strict=True))
                chunk.layers.apron.texture.update_region(
                    [lo - o + 1 for lo, o in zip(low, origin, strict=True)],
                    world.labels_in(part))
        self.place_layers(sorted(touched))

    def release(self) -> None:
        """Drop every chunk's layers and the full palette."""
        self._translucent = np.zeros(0, np.int64)
        for chunk in self.binding.chunks.values():
            chunk.release_layers()
        if self.palette is not None:
            self.palette.release()
            self.palette = None
