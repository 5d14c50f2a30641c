"""Implicit surfaces drawn per pixel from their cells' polynomials.

``'active'`` marches only the active cells, drawn one of two ways (``traversal``):

- ``'index'`` (default): the domain's box, each pixel's ray traversing the active cells'
  brick index (``models/surface_bricks.py``) and marching each active cell it meets, in
  order, up to the first root: one fragment a pixel, its cells' coefficients shared.
- ``'cell_boxes'``: the back faces of the active cells' boxes (12 triangles a cell,
  sharing their corners), each fragment marching its ray inside its own cell, found from
  the primitive's number (no per-vertex index: 12 triangles of shared corners, not 36
  vertices of 7 floats per cell); the cells' corners and 27 Bernstein coefficients in one
  texture buffer.

``'full'`` (the baseline): the domain's box, each ray marched through every cell, with
every cell's coefficients. All write the hit's real depth: the depth test keeps the
nearest hit, and meshes and other techniques occlude and are occluded.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pyvista

from ..core import vtk_classes as vtk
from ..core.gl_limits import MAX_TEXTURE_SIZE
from ..core.registry import Technique, register_technique
from ..gl.bindings import FloatArray, ShaderBindings
from ..gl.box import AUTO_SHIFT, GROW, bind_camera, box_actor, place_box
from ..gl.frame_inputs import frame_inputs
from ..gl.handle import DrawnBinding
from ..gl.lights import bind_scene_lights
from ..gl.shaders import ShaderRecipe, box_recipe
from ..gl.textures import Texture
from ..models.surface import SplineField, level_cells
from ..models.surface_bricks import BLOCK_SIZE, BRICK_SIZE, SurfaceBricks, surface_bricks
from ..reference.surfaces import render_surface
from ..voxels.clipping import ClipPlaneSetting, bind_clip_planes, clip_count
from .options import LOOP_BUDGET, SurfaceOptions

#: The 12 triangles of a unit cell, as corners ``x + 2 y + 4 z``, wound outward.
CELL_TRIANGLES = np.array([
    [0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5],      # x = 0, x = 1
    [0, 1, 5], [0, 5, 4], [2, 6, 7], [2, 7, 3],      # y = 0, y = 1
    [0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6],      # z = 0, z = 1
])
CORNERS = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)])
#: How far (cells) the corners on the cell boxes' outer faces are drawn out.
HULL_GROW = 0.01


def drawing(technique: str, options: SurfaceOptions) -> str:
    """How the surface is drawn: ``'index'``, ``'cell_boxes'`` (both active) or ``'full'``."""
    return options.traversal if technique == "active" else "full"


#: Per drawing: the cells' storage and the fragment's main block.
STORAGE = {"index": "surface_bricks", "cell_boxes": "surface_records",
           "full": "surface_records"}
FRAGMENT = {"index": "surface_traverse_fragment", "cell_boxes": "surface_cell_boxes_fragment",
            "full": "surface_full_fragment"}
#: Most crossings a translucent surface's ray composites (the ray also stops once 99.9 % is
#: covered: 256 crossings of opacity 0.027 cover that much; the loop budget still bounds
#: a fragment's traversal).
MAX_LAYERS = 256
#: Most translucent levels one pass draws (each sample tests every level, written out).
MAX_TRANSLUCENT_LEVELS = 8


def surface_recipe(options: SurfaceOptions, technique: str, levels: int = 1,
                   domain_cut: bool = False) -> ShaderRecipe:
    """The replacements of ``technique`` (``'active'`` or ``'full'``) with ``options``.

    ``levels`` above 1: that many translucent level sets of the field in one pass.
    ``domain_cut``: the field is drawn in part of its cells only (``SplineField.domain``),
    which cell boxes cut their rays to (the other drawings start from the domain's box).
    """
    lit = options.shading in ("flat", "blinn")
    how = drawing(technique, options)
    exact = options.root == "exact"
    root = ("surface_exact" if exact else "surface_march",) if how != "full" else ()
    cells = ("surface_dense",) if how == "full" else (
        ("surface_traverse",) if how == "index" else ())
    defines = {"CM_CLIP_PLANES": clip_count(options), "CM_EXACT_ROOT": exact,
               "CM_COLOR_BY_CURVATURE": options.color_by == "curvature",
               "CM_COLOR_VALUES": options.color_by == "field", "CM_LIGHTING": lit,
               "CM_NORMAL_COLORS": options.shading == "normals",
               "CM_SPECULAR": lit and options.shading == "blinn"}
    if how == "cell_boxes":
        defines["CM_DOMAIN_CUT"] = domain_cut
    if how == "index":
        defines["CM_BRICK_SHIFT"] = BRICK_SIZE.bit_length() - 1
        defines["CM_BLOCK_SHIFT"] = BLOCK_SIZE.bit_length() - 1
    else:
        first, floats, values = cell_layout(technique, options)
        defines.update(CM_CELL_FLOATS=floats, CM_FIRST_COEFFICIENT=first,
                       CM_COLOR_VALUES=values)
    layers = options.translucent
    if layers:
        defines["CM_MAX_LAYERS"] = MAX_LAYERS
        defines["CM_LEVELS"] = levels if levels > 1 else None
    body = ("surface_layers_fragment",) if layers else (FRAGMENT[how], "surface_hit")
    return box_recipe(
        ("camera_declarations", "slab", "pixel_ray",
         *(("clip_planes",) if clip_count(options) else ()), "surface_declarations",
         STORAGE[how],
         *root, *cells, *(("blinn_phong",) if lit else ()),
         *(("surface_color",) if options.color_by else ()), "surface_shade_hit",
         *(("surface_layer_declarations",) if layers else ())), body, defines=defines,
        layers=bool(layers))


def cell_layout(technique: str, options: SurfaceOptions) -> tuple[int, int, int | None]:
    """Floats of a cell's record: ``(first coefficient, floats per cell, colour values)``.

    ``'active'`` records start with the cell's corner (3 floats); then 27 coefficients;
    with ``color_by='field'``, 27 more of the second field (their offset, else None).
    """
    first = 3 if technique == "active" else 0
    values = first + 27 if options.color_by == "field" else None
    return first, first + 27 + (27 if values is not None else 0), values


def cell_boxes(cells: np.ndarray, domain=None) -> pyvista.PolyData:
    """The boxes of ``cells`` (``(n, 3)``) as 12 triangles each, in order, corners shared.

    ``domain``: ``(lower, upper)`` corners the boxes are cut to (a cell at the grid's face
    reaches only to the samples' hull), or None.
    """
    cells = np.asarray(cells, dtype=np.int64).reshape(-1, 3)
    corners = (cells[:, None, :] + CORNERS[None, :, :]).reshape(-1, 3)
    points, index = np.unique(corners, axis=0, return_inverse=True)
    triangles = index.reshape(-1, 8)[:, CELL_TRIANGLES].reshape(-1, 3)
    faces = np.hstack([np.full((len(triangles), 1), 3), triangles]).ravel()
    points = points.astype(np.float64)
    if domain is not None:
        points = np.clip(points, domain[0], domain[1])
    boxes = pyvista.PolyData(points, faces=faces)
    # corners on the hull's faces drawn a hair out (box_grow_vertex): a pixel whose ray runs
    # exactly on a face is rasterised, and its cell's fragment decides (inner ones stay)
    lower, upper = (points.min(axis=0), points.max(axis=0)) if len(points) else (0.0, 0.0)
    boxes.point_data[GROW] = HULL_GROW * ((points >= upper).astype(np.float64)
                                          - (points <= lower))
    return boxes


def cell_buffer(field: SplineField, cells: np.ndarray, corners: bool,
                color_values: bool = False) -> np.ndarray:
    """Per cell (float32), as :func:`cell_layout` orders it.

    With ``corners`` its corner (i, j, k), then its 27 coefficients, with ``color_values``
    the second field's 27.
    """
    parts = [field.cell_bernstein(cells).reshape(len(cells), 27)]
    if corners:
        parts.insert(0, np.asarray(cells, dtype=np.float64).reshape(-1, 3))
    if color_values:
        parts.append(field.cell_bernstein(cells, field.color_values).reshape(len(cells), 27))
    return np.hstack(parts).astype(np.float32).ravel()


class SurfaceBinding(ClipPlaneSetting, DrawnBinding):
    """What ``actor.cubemarch`` holds for a surface: the field, its cells, the textures."""

    look_hint = "add_surface(color=..., opacity=...) draws them"

    technique = "surface"
    needs_single_sample = True   # a pixel's hit is one ray's, as for voxels
    follows_mapper_planes = True   # a plane widget's planes cut the rays (ClipPlaneSetting)

    def __init__(self, field: SplineField, bindings: ShaderBindings, recipe: ShaderRecipe,
                 options: SurfaceOptions, cells: np.ndarray | None,
                 bricks: SurfaceBricks | None = None, recipe_args: tuple = ("active", 1, False)):
        super().__init__(field, bindings, recipe)
        self.options = options
        #: The active cells drawn (``'active'``), or None (``'full'``: every cell).
        self.cells = cells
        #: The bricks of active cells (``traversal='index'``), or None.
        self.bricks = bricks
        #: ``surface_recipe``'s technique, level count and domain cut, to remake the shaders.
        self.recipe_args = recipe_args

    def follow_clip_planes(self, remake: bool) -> None:
        """Remake the shaders for another number of planes (moved ones: a uniform)."""
        if remake:
            self.recipe = surface_recipe(self.options, *self.recipe_args)
            self.bindings.install(self.recipe, self.drawn[0])

    @property
    def blends_in_main_renderer(self) -> bool:
        """A translucent surface draws in the renderer's translucent pass (OIT off there)."""
        return self.options.translucent

    @property
    def nbytes(self) -> int:
        """GPU bytes: the textures and the drawn geometry (points, triangles)."""
        polydata = self.drawn[0].GetMapper().GetInput()
        geometry = 4 * 3 * polydata.GetNumberOfPoints() + 4 * 3 * polydata.GetNumberOfCells()
        return self.bindings.nbytes + geometry

    @property
    def dense_bytes(self) -> int:
        """What a dense layout takes: 27 floats per cell of the grid."""
        return 27 * 4 * int(np.prod(self.model.dimensions))


def _domain_actor(field: SplineField, cells: np.ndarray | None = None) -> pyvista.Actor:
    """The back faces of the box holding the active ``cells`` (all: the domain's), in the domain.

    A hair larger: no grazing pixel lost. Every root lies in an active cell, so a pixel
    whose ray meets the surface lies inside their box; a box no larger draws fewer
    fragments, and the returned actor's bounds are the surface's cells' (``reset_camera``
    frames them, not the whole sampled grid).
    """
    dims = np.asarray(field.dimensions, dtype=np.float64)
    lower, upper = field.domain_corners()
    if cells is not None and len(cells):
        lower = np.maximum(lower, np.min(cells, axis=0))
        upper = np.minimum(upper, np.max(cells, axis=0) + 1.0)
    return box_actor(upper, field.world_from_index(), margin=0.01 * float(dims.max()),
                     lower=lower)


def _cell_boxes_actor(field: SplineField, cells: np.ndarray) -> pyvista.Actor:
    """The active cells' boxes as one mesh (12 triangles a cell, in ``cells``' order)."""
    mapper = vtk.vtkOpenGLPolyDataMapper()
    domain = None if field.domain is None else field.domain_corners()
    mapper.SetInputData(cell_boxes(cells, domain) if len(cells) else pyvista.PolyData())
    mapper.MapDataArrayToVertexAttribute(GROW, GROW, vtk.vtkDataObject.FIELD_ASSOCIATION_POINTS,
                                         -1)
    mapper.SetVBOShiftScaleMethod(AUTO_SHIFT)   # shifted, never scaled: the moves are in cells
    actor = pyvista.Actor()
    actor.SetMapper(mapper)
    place_box(actor, field.world_from_index())
    return actor


def _index_bricks(field: SplineField, options: SurfaceOptions,
                  cells: np.ndarray) -> SurfaceBricks | None:
    """The bricks of ``traversal='index'``, or None when this grid is beyond the index.

    Beyond it (with a warning, drawn as cell boxes instead): an index wider than a 3D
    texture, a pool of bricks that fits none, or a grid so long that a ray's traversal
    alone would overrun llvmpipe's loop budget. ``steps`` that overrun it are refused.
    """
    dims = field.dimensions
    need = options.index_iterations(dims)
    traversal = need - options.steps - options.refine_steps   # the cells crossed alone
    why = None
    if max(-(-n // BRICK_SIZE) for n in dims) > MAX_TEXTURE_SIZE:
        why = f"its brick index would be wider than {MAX_TEXTURE_SIZE} texels"
    elif traversal >= LOOP_BUDGET:
        why = (f"a ray could cross {sum(dims):,} cells, more than one fragment's loops may "
               "run on llvmpipe")
    else:
        if need > LOOP_BUDGET:
            raise ValueError(
                f"steps={options.steps} on {dims} cells: a ray of traversal='index' may run "
                f"{need:,} loop iterations, and llvmpipe stops a fragment's loops after about "
                f"32,000: use steps <= {LOOP_BUDGET - traversal - options.refine_steps:,}, "
                "or traversal='cell_boxes'.")
        try:
            return surface_bricks(field, cells, colors=options.color_by == "field")
        except MemoryError as error:
            why = str(error)
    if options.translucent:
        raise ValueError(f"opacity={options.opacity:g}: a translucent surface is drawn by "
                         f"traversal='index', and a grid of {dims} cells is beyond it ({why}). "
                         "Resample the field coarser, or leave opacity out.")
    warnings.warn(f"A grid of {dims} cells is beyond traversal='index' ({why}): drawn with "
                  "traversal='cell_boxes'.", stacklevel=4)
    return None


def _bind_cells(bindings: ShaderBindings, field: SplineField, options: SurfaceOptions,
                how: str, cells: np.ndarray | None,
                bricks: SurfaceBricks | None) -> None:
    """Bind where the cells' coefficients live: the ``bricks`` (``'index'``), or records."""
    colors = options.color_by == "field"
    if how == "index":
        for sampler, array in (("cm_brickIndex", bricks.index),
                               ("cm_brickCoefficients", bricks.coefficients),
                               ("cm_brickCells", bricks.active), ("cm_brickColors", bricks.colors),
                               ("cm_blocks", bricks.blocks)):
            if array is not None:
                bindings.add_texture(sampler, Texture(array, kind="3d", interpolate=False),
                                     owned=True)
        return
    if how == "full":
        cells = np.argwhere(np.ones(field.dimensions[::-1], bool))[:, ::-1]
    buffer = cell_buffer(field, cells, corners=how == "cell_boxes", color_values=colors)
    bindings.add_texture("cm_cells", Texture(buffer if len(buffer) else np.zeros(1, np.float32),
                                             kind="buffer"), owned=True)


def _build(plotter, field: SplineField, options: SurfaceOptions, technique: str,
           offsets: tuple[float, ...] = (0.0,),
           colors: tuple | None = None) -> SurfaceBinding:
    """The actor of ``field``'s surface drawn by ``technique``; returns its binding.

    ``offsets``: the levels of the field drawn (translucent, in one pass, when several),
    ``colors`` one RGB each.
    """
    renderer = plotter.renderer
    how = drawing(technique, options)
    if options.translucent and how != "index":
        used = f"technique={technique!r}" if how == "full" else f"traversal={how!r}"
        raise ValueError(f"opacity={options.opacity:g}: a translucent surface composites every "
                         "crossing along one ray per pixel, as traversal='index' of "
                         f"technique='active' (the defaults) marches it; {used} keeps only "
                         "the nearest hit. Leave it out, or leave opacity out.")
    cells = None if how == "full" else level_cells(field, offsets, options.active_test,
                                                    options.active_samples)
    bricks = _index_bricks(field, options, cells) if how == "index" else None
    if how == "index" and bricks is None:
        options = dataclasses.replace(options, traversal="cell_boxes")
        how = "cell_boxes"
    actor = (_cell_boxes_actor(field, cells) if how == "cell_boxes"
             else _domain_actor(field, cells))
    if not options.translucent:   # else the translucent pass, after every opaque prop
        actor.ForceTranslucentOff()
        actor.ForceOpaqueOn()
    actor.GetProperty().LightingOff()
    mapper = actor.GetMapper()
    mapper.ScalarVisibilityOff()
    bindings = ShaderBindings(mapper, renderer)
    _bind_cells(bindings, field, options, how, cells, bricks)
    dims = field.dimensions
    bindings.set_uniform("cm_gridDims", tuple(float(n) for n in dims))
    lower, upper = field.domain_corners()
    bindings.set_uniform("cm_domainLower", tuple(float(v) for v in lower))
    bindings.set_uniform("cm_domainUpper", tuple(float(v) for v in upper))
    bindings.set_uniform("cm_stepLength", options.step_length(field))
    bindings.set_uniform("cm_refineSteps", int(options.refine_steps))
    bindings.set_uniform("cm_surfaceColor", options.rgb)
    bindings.set_uniform("cm_near", lambda: renderer.GetActiveCamera().GetClippingRange()[0])
    bind_camera(bindings, renderer, field.world_from_index)
    if options.translucent:
        bindings.add_texture("cm_sceneDepth", frame_inputs(renderer).depth)
        bindings.set_uniform("cm_opacity", float(options.opacity))
    if len(offsets) > 1:
        bindings.set_uniform("cm_levels", FloatArray(offsets))
        bindings.set_uniform("cm_levelColors", FloatArray(np.ravel(colors)))
    if options.shading != "unlit":   # the lights, and the normals' map to view space
        bind_scene_lights(bindings, renderer, field.world_from_index)
        bindings.set_uniform("cm_ambient", float(options.ambient))
        bindings.set_uniform("cm_diffuse", float(options.diffuse))
        bindings.set_uniform("cm_specular", float(options.specular))
        bindings.set_uniform("cm_specularPower", float(options.specular_power))
    if options.color_by:
        bindings.add_texture("cm_colormap", Texture(
            options.lookup_table().reshape(1, 256, 3).astype(np.float32), kind="2d",
            interpolate=False), owned=True)
        bindings.set_uniform("cm_colorRange", options.color_range(field))
        bindings.set_uniform("cm_indexFromWorld",
                             lambda: np.linalg.inv(field.world_from_index()[:3, :3]))
    recipe_args = (technique, len(offsets), field.domain is not None)
    recipe = surface_recipe(options, *recipe_args)
    bindings.install(recipe, actor)
    binding = SurfaceBinding(field, bindings, recipe, options, cells, bricks, recipe_args)
    # the planes as the binding holds them now (set_clip_planes and mapper planes move them)
    bind_clip_planes(bindings, field, lambda: binding.options.world_planes)
    binding.drawn = [actor]
    binding.renderer = renderer
    pyvista.set_new_attribute(actor, "cubemarch", binding)
    return binding


def build_active(plotter, field: SplineField, options: SurfaceOptions) -> SurfaceBinding:
    """Only the active cells marched: through their index, or as boxes."""
    return _build(plotter, field, options, "active")


def build_full(plotter, field: SplineField, options: SurfaceOptions) -> SurfaceBinding:
    """The domain's box, each ray marched through the whole grid (the baseline)."""
    if options.traversal != "index":
        raise ValueError(f"traversal={options.traversal!r} chooses how technique='active' "
                         "finds its active cells; technique='full' marches every cell: "
                         "leave traversal out with it.")
    if options.root != "march":
        raise ValueError("root='exact' solves each cell's polynomial along the ray, which "
                         "technique='full' (the march through the whole domain) "
                         "does not: use technique='active' with it.")
    return _build(plotter, field, options, "full")


def build_translucent_levels(plotter, field: SplineField, options: SurfaceOptions,
                             offsets, colors) -> SurfaceBinding:
    """Several translucent levels of ``field`` in one pass.

    ``offsets``: the levels from its zero, ``colors`` one RGB each; every crossing of any
    level is composited along one ray per pixel, in depth order whatever its level.
    """
    if not options.translucent:
        raise ValueError("several levels in one pass are translucent levels: give opacity "
                         "below 1, or draw each level as its own surface.")
    if not 2 <= len(offsets) <= MAX_TRANSLUCENT_LEVELS:
        raise ValueError(f"{len(offsets)} translucent isosurfaces: one pass draws 2 to "
                         f"{MAX_TRANSLUCENT_LEVELS}; give fewer levels.")
    if options.root != "march":
        raise ValueError("root='exact' solves one level's polynomial; several translucent "
                         "isosurfaces are marched (root='march'): leave root out.")
    return _build(plotter, field, options, "active", tuple(float(v) for v in offsets),
                  tuple(tuple(float(c) for c in rgb) for rgb in colors))


register_technique(Technique(
    name="active", kind="surface", options=SurfaceOptions, build=build_active,
    reference=render_surface,
    summary="f = 0 of a quadratic B-spline field, marched only in the cells it crosses"))
register_technique(Technique(
    name="full", kind="surface", options=SurfaceOptions, build=build_full,
    reference=render_surface,
    summary="f = 0 of a quadratic B-spline field, marched through the whole domain (the "
            "baseline)"))
