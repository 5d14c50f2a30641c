"""Translucent materials of a material grid: a second box actor, in the translucent pass.

The grid's opaque actor draws its opaque materials (and writes their depth) with the
translucent ones hidden; this actor then marches every pixel's ray from the box or the near
plane to the frame's opaque depth and composites, front to back, the faces of the
translucent materials it crosses (``voxel_layers.glsl``), each material a closed surface
as PyVista draws ``threshold`` + ``add_mesh(opacity=...)`` per label. It exists only while
some drawn material is translucent.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..gl.bindings import ShaderBindings
from ..gl.box import box_actor, place_box
from ..gl.frame_inputs import frame_inputs
from ..gl.handle import keep_placed_by_matrix
from ..gl.reduced_draw import ReducedDraw
from ..gl.shaders import ShaderRecipe, box_recipe
from ..gl.textures import Texture
from ..models.voxels import palette_texels
from .clipping import bind_clip_planes, clip_count
from .label_state import upload_palette_rows


def translucent_materials(rgba: np.ndarray) -> np.ndarray:
    """The materials (ids above 0) whose opacity is strictly between 0 and 1."""
    alpha = np.asarray(rgba)[1:, 3]
    return np.nonzero((alpha > 0.0) & (alpha < 1.0))[0] + 1


def opaque_palette(rgba: np.ndarray) -> np.ndarray:
    """The palette the opaque actor draws: translucent materials hidden (opacity 0)."""
    out = np.array(rgba, dtype=np.float32, copy=True)
    alpha = out[:, 3]
    alpha[(alpha > 0.0) & (alpha < 1.0)] = 0.0
    return out


def layers_recipe(options, level_axes: tuple[int, int], chunk_shift: int | None = None,
                  apron: bool = False) -> ShaderRecipe:
    """The layer actor's replacements: the grid's declarations, lights, and the layers.

    ``chunk_shift``: a world drawn by one traversal, its labels read through its chunk
    index (chunks of ``2^chunk_shift`` voxels). ``apron``: a chunk of a world drawn per
    chunk, its labels read from a copy with one voxel of its neighbours around them.
    """
    lit = options.shading != "unlit"
    levels = options.mip_levels if not apron else None
    return box_recipe(
        ("camera_declarations", "slab", "pixel_ray", "voxel_declarations",
         *(("clip_planes",) if clip_count(options) else ()),
         *(("voxel_chunk_index",) if chunk_shift else ()),
         *(("blinn_phong", "voxel_shading") if lit else ()), "voxel_layer_declarations"),
        "voxel_layers",
        defines={"CM_LIGHTING": lit, "CM_SPECULAR": lit and options.shading == "blinn",
                 "CM_CLIP_PLANES": clip_count(options), "CM_CHUNK_INDEX": chunk_shift,
                 "CM_LABEL_APRON": apron or None, "CM_MIP_LEVELS": levels or None,
                 "CM_LEVEL_SLAB_AXIS": level_axes[0] if levels else None,
                 "CM_LEVEL_ROW_AXIS": level_axes[1] if levels else None}, layers=True)


class TranslucentLayers:
    """The layer actor of one grid (or world): bindings, full palette, the frame's depth.

    ``chunk_index``: a world drawn by one traversal, whose labels (``binding.labels``, its
    pool) are read through this index of chunks of ``2^chunk_shift`` voxels. ``apron``: a
    chunk of a world drawn per chunk (:class:`~.chunk_layers.ChunkApron`: its box and its
    labels with one voxel of its neighbours), reading ``palette``, the world's full palette.
    """

    def __init__(self, binding, renderer, bind_grid, chunk_index: Texture | None = None,
                 chunk_shift: int | None = None, apron=None, palette: Texture | None = None):
        options = binding.options
        self.model = binding.model if apron is None else apron.region
        self.chunk_shift = chunk_shift
        self.apron = apron
        model = self.model
        self.actor = box_actor(list(model.dimensions), model.world_from_index(),
                               margin=0.01 * max(model.dimensions))
        self.actor.GetProperty().LightingOff()
        self.actor.PickableOff()
        self.renderer = renderer
        self.owns_palette = palette is None
        self.palette = palette or Texture(palette_texels(binding.model.palette.rgba),
                                          kind="2d", interpolate=False)
        bindings = ShaderBindings(self.actor.GetMapper(), renderer)
        # the opaque actor's labels, shared; a chunk's copy with its apron, its own
        bindings.add_texture("cm_labels", binding.labels if apron is None else apron.texture,
                             owned=apron is not None)
        if chunk_index is not None:
            bindings.add_texture("cm_chunkIndex", chunk_index)
        bindings.add_texture("cm_palette", self.palette, owned=self.owns_palette)
        bindings.add_texture("cm_sceneDepth", frame_inputs(renderer).depth)
        bind_grid(bindings, renderer, model, replace(options, show_edges=False, lod=False,
                                                     ambient_occlusion=False))
        self.bindings = bindings
        self.reduced: ReducedDraw | None = None
        self.follow_clip_planes(options, binding)
        renderer.AddActor(self.actor)
        self.actor.UseBoundsOff()   # the grid's returned actor frames it

    def reduce_as(self, opaque: ReducedDraw) -> None:
        """Draw the layers at the reduction of the grid's opaque draw (a frame budget's).

        Drawn after the scene's opaque props, at the overlay's start; its stand-in
        composites them over the frame from the overlay (:class:`ReducedDraw`).
        """
        if self.reduced is None:
            self.reduced = ReducedDraw(self.renderer, self.actor, follows=opaque)

    @property
    def nbytes(self) -> int:
        """GPU bytes of its own, its reduced draw's targets included.

        The labels are the opaque actor's, but a chunk's apron.
        """
        return (self.palette.nbytes if self.owns_palette else 0) + (
            self.apron.texture.nbytes if self.apron is not None else 0) + (
            self.reduced.nbytes if self.reduced is not None else 0)

    def set_palette(self, rgba: np.ndarray, rows: np.ndarray | None = None) -> None:
        """The palette changed (``rows`` of it, or all): the layers read the new entries."""
        if self.owns_palette:
            upload_palette_rows(self.palette, rgba, rows)

    def follow_clip_planes(self, options, binding) -> None:
        """The grid's clip planes changed in number: the layers' shaders are (re)made."""
        self.bindings.install(layers_recipe(options, binding.level_axes, self.chunk_shift,
                                            apron=self.apron is not None), self.actor)
        bind_clip_planes(self.bindings, self.model, lambda: binding.options.world_planes)

    def place(self) -> None:
        """The grid moved: the box follows it."""
        place_box(self.actor, self.model.world_from_index())

    def release(self) -> None:
        """Leave the renderer and free the palette, observers and any reduced draw."""
        if self.reduced is not None:
            self.reduced.release()
            self.reduced = None
        self.renderer.RemoveActor(self.actor)
        self.bindings.release()


class LayerHost:
    """Translucent labels of a binding that draws them (a grid, or a world of one traversal).

    Its opaque actor reads the palette with them hidden, and a layer actor
    (:class:`TranslucentLayers`) exists while one is translucent. ``composites``: whether
    it draws them so (else they are drawn opaque, as warned). The binding gives
    ``make_layers()``, its layer actor.
    """

    layers: TranslucentLayers | None = None
    composites = False

    def opaque_entries(self, rgba: np.ndarray) -> np.ndarray:
        """The palette the opaque actor reads (translucent labels hidden where composited)."""
        return opaque_palette(rgba) if self.composites else rgba

    def follow_layers(self, rgba: np.ndarray, rows: np.ndarray | None) -> bool:
        """Make, update or drop the layer actor for the palette ``rgba``; True if made now.

        ``rows``: the entries that changed (``None``: all).
        """
        if not self.composites:
            return False
        wanted = translucent_materials(rgba).size > 0
        if wanted and self.layers is None:
            self.layers = self.make_layers()
            self.layers.actor.SetVisibility(self.shown)
            if getattr(self, "reduced", None) is not None:   # under a frame budget
                self.layers.reduce_as(self.reduced)
            return True
        if self.layers is not None and not wanted:
            self.release_layers()
        elif self.layers is not None:
            self.layers.set_palette(rgba, rows)
        return False

    @property
    def blends_in_main_renderer(self) -> bool:
        """Whether its translucent layers draw in the renderer's translucent pass.

        VTK's order-independent translucency, which moves the viewport, stays off there.
        """
        return self.layers is not None

    def follow_layers_anchor(self) -> None:
        """At each frame: the layers follow the returned actor's visibility.

        They keep no placement of their own (PyVista's ``set_scale`` scales them too).
        """
        if self.layers is not None:
            self.layers.actor.SetVisibility(self.shown)
            keep_placed_by_matrix(self.layers.actor)

    def look_bindings(self) -> list:
        """The grid's bindings and its translucent layers': a term set shades both."""
        return [self.bindings, *([self.layers.bindings] if self.layers is not None else [])]

    def release_layers(self) -> None:
        """Drop the layer actor, if any."""
        if self.layers is not None:
            self.layers.release()
            self.layers = None
