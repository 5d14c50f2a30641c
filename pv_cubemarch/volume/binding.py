"""What every emission/absorption technique shares.

The GPU copy of the data, the marcher's bindings and feature switches, and the per-volume
state behind ``actor.cubemarch``.

A technique builds its actor and passes; this module gives each of them the same uniforms
and textures (one upload per volume, however many passes read it), so the four techniques
differ only in how a ray is set up and where its result goes.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..core import vtk_classes as vtk
from ..core.rendering import needs_open_plotter
from ..core.user_warnings import warn_user
from ..gl.bindings import FloatArray, ShaderBindings
from ..gl.box import place_box
from ..gl.handle import DrawnBinding
from ..gl.shaders import ShaderRecipe
from ..gl.textures import Texture
from ..models.group import VolumeGroup
from ..models.volume import INTERPOLATIONS, VolumeModel, checked_values
from .clipping import ClipState, data_transform
from .pyvista_keywords import DIRECT_COLOR_BLENDING
from .skipping import DEFAULT_BRICK_SIZE, brick_extinction
from .stand_in import place_stand_in

#: The marcher's loops (ea_march.glsl): blocks of STEP_BLOCK steps, at most STEP_BLOCKS
#: blocks, so a ray (a piece of one in a joint group) takes up to MAX_STEPS steps while every
#: GLSL loop keeps a constant bound; the options refuse settings that need more.
STEP_BLOCK = 4096
STEP_BLOCKS = 4096
MAX_STEPS = STEP_BLOCK * STEP_BLOCKS
#: The widest average range a float32 uniform holds (VTK's unset range is +-1e38).
FLOAT_LIMIT = 1e38
#: What every marching shader declares first: the transfer lookup, the one slab test, the
#: clipping planes (compiled in only with ``CM_CLIP_PLANES``).
DECLARATION_SNIPPETS = ("ea_declarations", "slab", "clip_planes")
#: Blend modes (PyVista's ``blending=``, and VTK's ``'isosurface'``) and their GLSL: each
#: mode is one snippet defining how a sample enters the ray's state and what the ray leaves
#: (blend_*.glsl), with one CPU reference (:mod:`pv_cubemarch.reference.projections`); the
#: modes other than composite share the opacity per unit distance, the projections how
#: their one value is drawn, average and additive their weighted grey level.
BLEND_SNIPPETS = {"composite": ("blend_composite",),
                  "maximum": ("blend_opacity", "blend_projection", "blend_maximum"),
                  "minimum": ("blend_opacity", "blend_projection", "blend_minimum"),
                  "average": ("blend_opacity", "blend_intensity", "blend_average"),
                  "additive": ("blend_opacity", "blend_intensity", "blend_additive"),
                  "isosurface": ("blend_opacity", "blend_isosurface")}
BLEND_MODES = tuple(BLEND_SNIPPETS)
#: Most levels ``blending='isosurface'`` draws at once (a uniform array of the marcher).
MAX_ISOSURFACES = 32


@dataclass(frozen=True)
class Blend:
    """How samples along a ray make its colour: mode, isosurface levels, gradient shading.

    ``isosurfaces`` are in the volume's stored units (data less its ``value_offset``);
    ``shade`` is a :class:`~pv_cubemarch.volume.gradient_shading.GradientShading`, or None.
    """

    mode: str = "composite"
    isosurfaces: tuple[float, ...] = ()
    shade: object = None


@dataclass(frozen=True)
class VolumeSetup:
    """What a volume technique's builder takes with the plotter and the volume's data.

    Every kind's builder is ``build(plotter, model, options)``; a volume's ``model`` is its
    :class:`VolumeData` and its ``options`` this: the technique's options, the shading
    every technique reads (:class:`~pv_cubemarch.volume.options.CommonVolumeOptions`) and the light
    map, if any.
    """

    options: object
    shading: object
    light_map: object = None

    def with_options(self, options) -> VolumeSetup:
        """The same set-up with another technique's options (``'auto'`` builds two)."""
        return replace(self, options=options)


def march_snippets(blending: str = "composite", defines: dict | None = None) -> tuple[str, ...]:
    """The marcher with its blend mode, and the gradient shading where the switches ask.

    They come after the sampling and ray set-up snippets.
    """
    defines = defines or {}
    shaded = ("gradient_shading",) if defines.get("CM_SHADE") else ()
    blend = BLEND_SNIPPETS[blending]
    if defines.get("CM_CHANNELS_ADDITIVE"):   # a channel volume's additive channels
        blend = ("blend_channels_additive",)
    return (*blend, "ea_march", *shaded)


#: The marcher as the light map (and every composite pass) includes it.
MARCH_SNIPPETS = march_snippets("composite")
#: What a screen-space ray set-up declares: the camera, then the frame's opaque depth.
SCREEN_DECLARATIONS = ("camera_declarations", "ea_direct_declarations")


def world_from_texture(model: VolumeModel | VolumeGroup) -> np.ndarray:
    """4x4 from texture coordinates (texel centres on the grid points) to world."""
    dims = np.array(model.dimensions, dtype=np.float64)
    index_from_texture = np.eye(4)
    index_from_texture[:3, :3] = np.diag(dims)
    index_from_texture[:3, 3] = -0.5
    return model.world_from_index() @ index_from_texture


def medium_from_texture(model: VolumeModel | VolumeGroup) -> np.ndarray:
    """4x4 from texture coordinates to the frame the medium's lengths are measured in.

    A volume's own grid frame, before its placement (``transform`` / ``user_matrix``), as
    VTK measures ``opacity_unit_distance`` in the data's coordinates; a group whose members
    share one placement (a channel volume) is measured before it, one whose members are
    placed apart in the world.
    """
    transform = model.shared_transform() if isinstance(model, VolumeGroup) else \
        np.asarray(model.transform, dtype=np.float64)
    if transform is None:
        return world_from_texture(model)
    return np.linalg.inv(transform) @ world_from_texture(model)


class VolumeData:
    """The GPU copies of a volume's data (or of each member of a group), uploaded once.

    Every pass and actor of the volume binds these same textures; :meth:`set_values`
    replaces the data and the empty-space bricks in one place.
    """

    def __init__(self, model: VolumeModel | VolumeGroup):
        self.model = model
        self.members = model.members if isinstance(model, VolumeGroup) else [model]
        # An RGBA volume's texture is its uint8 colours, the opacity's value in alpha.
        self.values = [Texture(m.values if getattr(m, "colors", None) is None else m.colors,
                               kind="3d", interpolate=m.interpolation == "linear")
                       for m in self.members]
        self.tables = [Texture(m.transfer.table.reshape(1, -1, 4), kind="2d")
                       for m in self.members]
        self._bricks: Texture | None = None
        self._none_empty = False   # bricks were built and none was empty
        self.brick_builds = 0
        self.clip = ClipState()    # the clipping planes every pass of the volume reads
        self.range_source = None   # the mapper whose AverageIPScalarRange 'average' reads

    def bricks(self) -> Texture | None:
        """Per-brick largest extinction, built on first use; ``None`` when no brick is empty.

        Groups are not skipped (their members' bricks do not share a grid).
        """
        if isinstance(self.model, VolumeGroup):
            return None
        if self._bricks is None and not self._none_empty:
            bricks = brick_extinction(self.model.values, self.model.transfer, DEFAULT_BRICK_SIZE)
            self.brick_builds += 1
            if (bricks <= 0).any():
                self._bricks = Texture(bricks, kind="3d", interpolate=False)
            else:
                self._none_empty = True
        return self._bricks

    def set_values(self, values, member: str | None = None) -> None:
        """Replace the data of the volume (or of the group's ``member``), same shape."""
        if isinstance(self.model, VolumeGroup):
            index = self.model.set_member_values(member, values)
            self.values[index].set_data(self.members[index].values)
            return
        if member is not None:
            raise ValueError(f"member is for volumes marched jointly; {self.model.name!r} is "
                             "a single volume.")
        if self.model.colors is not None:
            self._set_colors(values)
        else:
            values, _ = checked_values(values, self.model.name, "raise",
                                       offset=self.model.value_offset)
            if values.shape != self.model.values.shape:
                raise ValueError(f"values must keep the volume's shape "
                                 f"{self.model.values.shape}, got {values.shape}.")
            self.model.values = np.ascontiguousarray(values, dtype=np.float32)
            self.values[0].set_data(self.model.values)
        if self._bricks is not None:
            rebuilt = brick_extinction(self.model.values, self.model.transfer,
                                       DEFAULT_BRICK_SIZE)
            self.brick_builds += 1
            self._bricks.set_data(rebuilt)

    def _set_colors(self, rgba) -> None:
        """Replace an RGBA volume's colours (uint8, its shape with 4 components)."""
        rgba = np.asarray(rgba)
        if rgba.shape != self.model.colors.shape or rgba.dtype != np.uint8:
            raise ValueError(f"An RGBA volume's new values must be uint8 of shape "
                             f"{self.model.colors.shape} (x, y, z, RGBA), got {rgba.dtype} "
                             f"{rgba.shape}.")
        self.model.colors = np.ascontiguousarray(rgba)
        self.model.values = self.model.colors[..., 3].astype(np.float32)
        self.values[0].set_data(self.model.colors)

    def set_transfer(self, transfer) -> None:
        """Draw one volume with another transfer function; its empty bricks found again.

        A volume with none empty at add stays unskipped (exact, if slower). Refused for
        joint and RGBA volumes (their colours are their members' and data).
        """
        if isinstance(self.model, VolumeGroup) or self.model.colors is not None:
            raise ValueError("Volumes marched jointly and RGBA volumes take their colours "
                             "from their members and data; add them again to colour "
                             "them otherwise.")
        bricks = None if self._bricks is None else brick_extinction(   # before any change
            self.model.values, transfer, DEFAULT_BRICK_SIZE)
        self.model.transfer = transfer
        self.tables[0].set_data(transfer.table.reshape(1, -1, 4))
        if bricks is not None:
            self.brick_builds += 1
            self._bricks.set_data(bricks)

    def set_opacity_unit_distance(self, length: float) -> None:
        """Draw one volume with its opacities over another length (the table goes up again).

        The empty-space bricks stay: the marchers only ask whether a brick's extinction is
        zero, and a zero extinction stays zero over any length.
        """
        if isinstance(self.model, VolumeGroup):
            raise ValueError("Volumes marched jointly keep each member's "
                             "opacity_unit_distance; add them again with new ones.")
        self.model.transfer = self.model.transfer.with_unit_distance(length)
        self.tables[0].set_data(self.model.transfer.table.reshape(1, -1, 4))

    @property
    def average_range(self) -> tuple[float, float]:
        """The values (stored units) 'average' takes: the returned mapper's range, as VTK's.

        ``vol.mapper.SetAverageIPScalarRange(low, high)`` in data units (``add_volume(...,
        average_range=)`` sets it); read at every draw. Unset: every value (VTK's default).
        """
        if self.range_source is None:
            return -FLOAT_LIMIT, FLOAT_LIMIT
        low, high = sorted(self.range_source.GetAverageIPScalarRange())
        offset = float(getattr(self.model, "value_offset", 0))
        return (max(low - offset, -FLOAT_LIMIT), min(high - offset, FLOAT_LIMIT))

    @property
    def value_range(self) -> tuple[float, float]:
        """The smallest and largest finite value of the data (stored units), as VTK's range.

        'average' and 'additive' normalise each sample over it; read at every draw, so it
        follows :meth:`set_values`.
        """
        values = self.model.values
        finite = values[np.isfinite(values)] if not np.isfinite(values).all() else values
        if finite.size == 0:
            return 0.0, 0.0
        return float(finite.min()), float(finite.max())

    @property
    def nbytes(self) -> int:
        """GPU bytes of the data, tables and bricks."""
        textures = self.values + self.tables + ([self._bricks] if self._bricks else [])
        return sum(t.nbytes for t in textures)

    def release(self) -> None:
        """Free every texture."""
        for texture in self.values + self.tables + ([self._bricks] if self._bricks else []):
            texture.release()


def vtk_scalars(model: VolumeModel):
    """The point array VTK's mapper uploads: the values, or an RGBA volume's 4 components."""
    if model.colors is not None:
        return model.colors.reshape(-1, 4, order="F")
    return model.values.ravel(order="F")


def most_texels(model) -> int:
    """Most texels a ray can cross along its dominant axis in one piece of its march.

    One volume: its longest axis. A joint group steps each piece of a ray on the finest grid
    over it (its virtual grid or a member's own), so: the longest axis of any of them.
    """
    grids = [model, *(model.members if isinstance(model, VolumeGroup) else [])]
    return max(max(max(grid.dimensions) - 1, 1) for grid in grids)


def march_defines(model, skipping: bool) -> dict:
    """The feature switches every marching shader of ``model`` needs."""
    defines = {"CM_TABLE_SIZE": model.transfer.n_colors, "CM_STEP_BLOCK": STEP_BLOCK,
               "CM_STEP_BLOCKS": STEP_BLOCKS, "CM_SKIP_EMPTY": bool(skipping),
               "CM_DIRECT_COLOR": getattr(model, "colors", None) is not None}
    if isinstance(model, VolumeGroup):
        direct = sum(1 << i for i, m in enumerate(model.members)
                     if getattr(m, "colors", None) is not None)
        defines.update(CM_JOINT=True, CM_VOLUME_COUNT=len(model.members),
                       CM_CHANNELS_ADDITIVE=model.channel_mix == "additive",
                       CM_DIRECT_MEMBERS=direct or None)
    return defines


def bind_blend(target, data: VolumeData, blend: Blend) -> dict:
    """Give ``target`` what its blend mode reads; returns the mode's feature switches.

    The modes other than composite read the opacity per unit distance; 'average' and
    'additive' the data's range, 'isosurface' its levels.
    """
    model = data.model
    if blend.mode != "composite":
        target.set_uniform("cm_opacityUnit", lambda: getattr(
            getattr(model.transfer, "spec", None), "opacity_unit_distance", 1.0))
    if blend.mode in ("average", "additive"):
        target.set_uniform("cm_dataRange", lambda: data.value_range)
    if blend.mode == "average":
        target.set_uniform("cm_averageRange", lambda: data.average_range)
    if blend.mode == "isosurface":
        target.set_uniform("cm_isoValues", FloatArray(sorted(blend.isosurfaces)))
        return {"CM_ISO_COUNT": len(blend.isosurfaces)}
    return {}


def swap_blend(recipe: ShaderRecipe, old: str, new: str) -> ShaderRecipe:
    """``recipe`` with blend mode ``old``'s snippets replaced by ``new``'s."""
    before, after = BLEND_SNIPPETS[old], BLEND_SNIPPETS[new]

    def swapped(snippet):
        names = (snippet,) if isinstance(snippet, str) else tuple(snippet)
        for start in range(len(names) - len(before) + 1):
            if names[start:start + len(before)] == before:
                return (*names[:start], *after, *names[start + len(before):])
        return snippet

    return replace(recipe, standalone=None if recipe.standalone is None else swapped(
        recipe.standalone), replacements=[replace(r, snippet=swapped(r.snippet))
                                          for r in recipe.replacements])


def with_gradient_shading(recipe: ShaderRecipe, shaded: bool) -> ShaderRecipe:
    """``recipe`` with the gradient shading snippet after the marcher, or without it."""
    def edited(snippet):
        names = (snippet,) if isinstance(snippet, str) else tuple(snippet)
        if "ea_march" not in names:
            return snippet
        names = tuple(name for name in names if name != "gradient_shading")
        if shaded:
            at = names.index("ea_march") + 1
            names = (*names[:at], "gradient_shading", *names[at:])
        return names

    return replace(recipe, standalone=None if recipe.standalone is None else edited(
        recipe.standalone), replacements=[replace(r, snippet=edited(r.snippet))
                                          for r in recipe.replacements])


def bind_marching(target, data, step_scale: float, stop_opacity: float) -> None:
    """What the marcher reads of any volume: termination, grid, step, placement, planes."""
    model = data.model
    target.set_uniform("cm_stopOpacity", stop_opacity)
    target.set_uniform("cm_dims", tuple(float(n) for n in model.dimensions))
    target.set_uniform("cm_stepScale", step_scale)
    target.set_uniform("cm_worldFromTexture", lambda: world_from_texture(model))
    target.set_uniform("cm_mediumFromTexture", lambda: medium_from_texture(model))
    target.set_uniform("cm_clipPlanes", lambda: data.clip.uniform(world_from_texture(model)))


def bind_sampling(target, data: VolumeData, step_scale: float, stop_opacity: float,
                  skip_empty: bool, sample_data: bool = True,
                  blend: Blend = Blend()) -> tuple[str, dict]:
    """Give ``target`` (bindings or a pass) what the shared marcher reads.

    Returns the GLSL snippet that samples the medium (``volume_sample`` for one volume,
    ``joint_sample`` for a group) and the feature switches. Skipping is compiled in only
    when asked for and some brick is empty. ``sample_data=False`` leaves the data texture
    out (VTK's mapper samples its own copy). A blend mode other than ``'composite'`` reads
    every sample (a skipped brick may hold the ray's extreme, or a level's crossing) and
    the opacity per unit distance; 'average' and 'additive' the data's range,
    'isosurface' its levels.
    """
    model = data.model
    extra = bind_blend(target, data, blend)
    if blend.mode != "composite":
        skip_empty = False
    if blend.shade is not None:
        blend.shade.bind(target)
        extra.update(blend.shade.defines)
    bind_marching(target, data, step_scale, stop_opacity)
    extra.update(data.clip.defines)
    if isinstance(model, VolumeGroup):
        # the table size of the group; each member's own table is bound below
        target.add_texture("cm_transferTable", data.tables[0])
        target.set_uniform("cm_clim", model.transfer.clim)
        group_to_world = lambda: world_from_texture(model)  # noqa: E731
        for index, member in enumerate(model.members):
            target.add_texture(f"cm_member{index}", data.values[index])
            target.add_texture(f"cm_memberTable{index}", data.tables[index])
            target.set_uniform(f"cm_memberClim{index}", member.transfer.clim)
            target.set_uniform(f"cm_memberFromGroup{index}", lambda m=member: np.linalg.inv(
                world_from_texture(m)) @ group_to_world())
            target.set_uniform(f"cm_memberDims{index}",
                               tuple(float(n) for n in member.dimensions))
        return "joint_sample", {**march_defines(model, False), **extra}
    target.add_texture("cm_transferTable", data.tables[0])
    target.set_uniform("cm_clim", lambda: model.transfer.clim)   # follows set_transfer
    if sample_data:
        target.add_texture("cm_volume", data.values[0])
    bricks = data.bricks() if skip_empty else None
    if bricks is not None:
        target.add_texture("cm_brickExtinction", bricks)
        target.set_uniform("cm_brickCount", tuple(float(n) for n in bricks.array.shape))
        target.set_uniform("cm_brickSize", float(DEFAULT_BRICK_SIZE))
    return "volume_sample", {**march_defines(model, bricks is not None), **extra}


class VolumeBinding(DrawnBinding):
    """What ``actor.cubemarch`` holds for a volume: model, data, bindings, settings.

    The technique's builder fills it; :meth:`set_values`, :meth:`set_transform` and
    :meth:`release` are the same for every technique.
    """

    technique = "volume"

    def __init__(self, model, data: VolumeData, bindings: ShaderBindings,
                 recipe: ShaderRecipe, step_scale: float, stop_opacity: float):
        super().__init__(model, bindings, recipe)
        self.data = data
        self.step_scale = step_scale
        self.stop_opacity = stop_opacity
        self.vtk_input = None      # VTK's mapper path: the ImageData it reads
        self.targets: list = [bindings]
        self.downsample = 1
        self.blending = "composite"
        self.clip_source = None    # the mapper whose clipping planes cut the volume
        self.returned_property = None   # follows the returned volume's property
        self._recolour_said = False

    @property
    def skips_empty(self) -> bool:
        """Whether the marching shaders step over empty bricks (compiled with skipping)."""
        return any(t.recipe is not None and bool(t.recipe.defines.get("CM_SKIP_EMPTY"))
                   for t in self.targets)

    @property
    def brick_builds(self) -> int:
        """How many times the empty-space bricks were built (once at add, once per data change)."""
        return self.data.brick_builds

    @property
    def nbytes(self) -> int:
        """GPU bytes we added (VTK owns the volume texture of its mapper path)."""
        data = self.data.nbytes if self.vtk_input is None else \
            sum(t.nbytes for t in self.bindings.textures.values())
        return data + (self.light_map.nbytes if self.light_map else 0)

    def release_resources(self) -> None:
        """The bindings, the light map and the data's textures."""
        super().release_resources()
        if self.light_map is not None:
            self.light_map.release()
        self.data.release()

    def put_back_prop(self) -> None:
        """The stand-in where the volume is (after a move refused)."""
        if self.bounds_proxy is not None:
            place_stand_in(self.bounds_proxy, self.model)

    def check_movable(self) -> None:
        """Volumes marched jointly cannot move one by one."""
        if isinstance(self.model, VolumeGroup):
            raise ValueError("Volumes marched jointly cannot move one by one; add them again "
                             "with their new transforms (pv_cubemarch.add_volumes).")

    def place(self, transform) -> None:
        """The boxes follow (the light map is marched again at the next frame)."""
        for actor in self.drawn:
            # VTK's input grid and the boxes all span index space; a mirroring placement
            # turns a box inside out, so its culling is chosen again.
            place_box(actor, self.model.world_from_index(), culling=self.vtk_input is None)
        follow_placement(self)

    @needs_open_plotter
    def set_values(self, values, member: str | None = None) -> None:
        """Replace the volume's data (same shape); its GPU copy and skip bricks follow.

        The empty-space bricks are rebuilt here, once per change of the data, never per frame.
        For volumes marched jointly (a :class:`~pv_cubemarch.VolumeGroup`), ``member`` names
        the one whose data changes.
        """
        self.data.set_values(values, member)
        if getattr(self, "picker_data", None) is not None:   # VTK's pickers read them
            self.picker_data.follow(self.model)
        if self.vtk_input is not None:
            self.vtk_input.point_data["scalars"] = vtk_scalars(self.model)
            self.vtk_input.Modified()
        if self.light_map is not None:
            self.light_map.invalidate()

    def follow_anchor(self) -> None:
        """At each frame: visibility, then what was set on the returned volume."""
        super().follow_anchor()
        self.follow_returned_volume()

    def follow_returned_volume(self) -> None:
        """At each frame: what PyVista's calls set on the returned volume is drawn.

        Its mapper's clipping planes, its property (see
        :mod:`~pv_cubemarch.volume.returned_property`), and its placement (``user_matrix``,
        ``position``, ``orientation``, ``scale``), which moves the volume as
        :meth:`set_transform` does.
        """
        if self.bounds_proxy is not None:   # first: the crop box is placed with the volume
            self.follow_prop_placement(self.bounds_proxy)
        self.follow_clipping()
        if self.returned_property is not None:
            self.returned_property.follow()

    def set_interpolation(self, interpolation: str) -> None:
        """Read the data ``'linear'`` or ``'nearest'`` from the next frame (no upload)."""
        if interpolation not in INTERPOLATIONS:
            raise ValueError(f"interpolation must be one of {INTERPOLATIONS}, got "
                             f"{interpolation!r}.")
        for member in self.data.members:
            member.interpolation = interpolation
        for texture in self.data.values:
            texture.set_interpolation(interpolation == "linear")
        for actor in self.drawn:   # VTK's mapper samples its own copy of the data
            if isinstance(actor, vtk.vtkVolume):
                actor.GetProperty().SetInterpolationType(
                    vtk.VTK_LINEAR_INTERPOLATION if interpolation == "linear"
                    else vtk.VTK_NEAREST_INTERPOLATION)
        if self.light_map is not None:
            self.light_map.invalidate()

    def set_transfer(self, transfer) -> None:
        """Colour the volume by ``transfer`` (a TransferFunction) from the next frame.

        Compiled again only for a table of another size; ``quality=`` says once that its
        choice was for the first colours.
        """
        rows = self.__dict__.get("table_rows", self.data.model.transfer.n_colors)
        self.data.set_transfer(transfer)
        if transfer.n_colors != rows:   # the size compiled, kept until a compile succeeds
            self.set_march_defines({"CM_TABLE_SIZE": transfer.n_colors})
        self.table_rows = transfer.n_colors
        if self.light_map is not None:
            self.light_map.invalidate()
        if getattr(self, "quality", None) is not None and not self._recolour_said:
            self._recolour_said = True
            warn_user(f"{self.model.name!r}: its colours changed after add_volume(quality="
                      f"{self.quality.target.name!r}), whose settings were chosen for the "
                      "colours it was added with; call actor.cubemarch.recalibrate() to "
                      "choose again for these.")

    def set_opacity_unit_distance(self, length: float) -> None:
        """Opacities over another world length from the next frame (see VolumeData)."""
        self.data.set_opacity_unit_distance(length)
        if self.light_map is not None:
            self.light_map.invalidate()

    def follow_clipping(self) -> None:
        """At each frame: take the clipping planes of the returned volume's mapper.

        The marchers are compiled again only when the number of planes changes; the light
        map is marched again when a plane moves.
        """
        count_changed, changed = self.data.clip.follow(
            self.clip_source, data_transform(self.model))
        if count_changed:
            self.set_march_defines(self.data.clip.defines)
        if changed and self.light_map is not None:
            self.light_map.invalidate()

    def set_march_defines(self, changes: dict) -> None:
        """Compile the marchers (and the light map) again with these feature switches."""
        def changed(target, recipe):
            if all(recipe.defines.get(key) == value for key, value in changes.items()):
                return None
            return replace(recipe, defines={**recipe.defines, **changes})
        self.recompile_marchers(changed)

    def set_blending(self, blending: str) -> None:
        """Composite the samples by another blend mode from the next frame (no upload).

        The marchers are compiled again with the mode's snippets and read its uniforms;
        empty-space skipping (composite only) comes back with composite where it was on.
        Volumes with lights or gradient shading, volumes marched jointly and
        ``'isosurface'`` (which needs its levels) are refused: add the volume again.
        """
        old = self.blending
        if blending == old:
            return
        if blending not in BLEND_MODES or blending == "isosurface" or old == "isosurface":
            raise ValueError(f"blending={blending!r} cannot replace blending={old!r} on a "
                             "drawn volume; add the volume again with add_volume(..., "
                             "blending=..., isosurfaces=...).")
        why = ("it is lit" if self.light_map is not None else "it is shaded"
               if getattr(self.returned_property, "shade", None) is not None else
               "it is marched jointly" if isinstance(self.model, VolumeGroup) else
               "it is an RGBA volume (VTK draws its red component alone, in grey)"
               if self.model.colors is not None and blending not in DIRECT_COLOR_BLENDING
               else None)
        if why is not None and blending != "composite":
            raise ValueError(f"blending={blending!r} reads the samples without attenuating "
                             f"them, and {why}: add the volume again without lights, shade "
                             "or joint volumes to use it.")
        mode = Blend(blending)

        def swapped(target, recipe):
            bind_blend(target, self.data, mode)
            skip = blending == "composite" and "cm_brickExtinction" in target.textures
            recipe = swap_blend(recipe, old, blending)
            return replace(recipe, defines={**recipe.defines, "CM_SKIP_EMPTY": skip})
        self.recompile_marchers(swapped, light_map=False)
        self.blending = blending

    def set_shade(self, shading) -> None:
        """Shade by ``shading`` from the next frame, or not (None), as ``add_volume(shade=)``.

        ``shading``: a :class:`~pv_cubemarch.volume.gradient_shading.GradientShading`, the
        renderer's lights on the gradient.

        Refused, as ``add_volume`` refuses it, for lit volumes (the light map), blend modes
        other than composite and volumes marched jointly.
        """
        if shading is not None:
            why = ("it is lit by lights= (the light map)" if self.light_map is not None else
                   f"it is drawn with blending={self.blending!r}"
                   if self.blending not in ("composite", "isosurface") else "it is marched jointly"
                   if isinstance(self.model, VolumeGroup) else "it is an RGBA volume "
                   "(no scalar has a gradient)" if self.model.colors is not None else None)
            if why is not None:
                raise ValueError(f"shade=True shades one composite volume by the renderer's "
                                 f"lights, and {why}: add the volume again to shade it.")

        def shaded(target, recipe):
            if shading is not None:
                shading.bind(target)
            switches = dict.fromkeys(("CM_SHADE", "CM_SHADE_LIGHTS", "CM_SHADE_FLOATS"))
            defines = {**recipe.defines, **switches,
                       **(shading.defines if shading is not None else {})}
            return replace(with_gradient_shading(recipe, shading is not None),
                           defines=defines)
        self.recompile_marchers(shaded, light_map=False)

    def recompile_marchers(self, change, light_map: bool = True) -> None:
        """Compile every marcher again with ``change(target, recipe)`` (None: unchanged).

        ``light_map``: the light map's pass too.
        """
        passes = list(self.targets) + (
            [self.light_map.render_pass] if self.light_map and light_map else [])
        for target in passes:
            recipe = target.recipe
            if recipe is None or "clip_planes" not in recipe.snippet_names:
                continue
            recipe = change(target, recipe)
            if recipe is None:
                continue
            if hasattr(target, "set_recipe"):
                target.set_recipe(recipe)
                continue
            if target is self.bindings:
                self.recipe = recipe
            target.install(recipe, *(actor for actor in self.drawn
                                     if actor.GetMapper() is target.mapper))


def follow_placement(binding) -> None:
    """After a volume moved: its stand-in (unless it is what moved it).

    The camera's clipping range is left as it is, as PyVista leaves it when a prop moves
    (the user may have set it; ``reset_camera_clipping_range`` or the mouse resets it).
    """
    if binding.bounds_proxy is not None and not binding._following_prop:
        place_stand_in(binding.bounds_proxy, binding.model)
