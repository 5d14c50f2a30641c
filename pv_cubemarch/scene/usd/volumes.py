"""Volume prims: emission/absorption volumes, voxel grids and implicit surfaces from fields.

See :mod:`pv_cubemarch.scene.usd` for the ``cubemarch:*`` attributes each technique reads.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyvista
from pxr import UsdVol

from ...api import voxel_options
from ...core.errors import SceneLoadError, VolumeDataError
from ...core.registry import get_technique, specific_option_names
from ...models.channels import make_data_model
from ...models.field_sources import make_field
from ...models.voxels import Palette, make_voxels
from ...volume.options import CommonVolumeOptions
from ...voxels.options import CALL_ONLY as VOXEL_CALL_ONLY
from ..grids import placement, read_grid
from ..voxel_worlds import ChunkPrim
from .attributes import (
    MODEL_ATTRIBUTES,
    SURFACE_OPTIONS,
    VOLUME_ONLY,
    VOLUME_OPTIONS,
    VOXEL_OPTIONS,
    attr,
    authored,
    converted,
    options_error,
)
from .context import StageContext


def read_volume(ctx: StageContext, prim, name: str) -> None:
    """Add the Volume prim to the scene as the technique ``cubemarch:technique`` chooses.

    Of several fields, ``density`` is drawn (``labels`` first for voxels); the others are
    listed in the report.
    """
    fields = UsdVol.Volume(prim).GetFieldPaths()
    if not fields:
        ctx.report(name, "Volume has no field relationship")
        return
    voxels = ctx.as_voxels or attr(prim, "cubemarch:technique") == "voxels"
    surface = not ctx.as_voxels and attr(prim, "cubemarch:technique") == "surface"
    preferred = ("labels", "density") if voxels else ("density",)
    field_name = next((f for f in preferred if f in fields), sorted(fields)[0])
    others = sorted(set(fields) - {field_name})
    if others:
        ctx.report(name, f"fields {', '.join(others)} not drawn (field:{field_name} is)",
                   warn=False)
    field_prim = ctx.stage.GetPrimAtPath(fields[field_name])
    if not field_prim:
        raise SceneLoadError(f"Volume {name}: field:{field_name} targets missing prim "
                             f"{fields[field_name]}.")
    grid = _read_field(ctx, field_prim, cells=voxels, margin=1 if surface else 0)
    if voxels:
        _voxels(ctx, prim, name, field_prim, grid)
        return
    if surface:
        _surface(ctx, prim, name, field_prim, grid)
        return
    transfer = _model_attributes(prim, name)
    found = authored(prim, name, VOLUME_OPTIONS)
    options = {option: value for option, value in found.values()}
    _check_volume_options(name, found, options)
    if options.get("lights") == "none":
        options["lights"] = None
    data = {key: transfer.pop(key, None) for key in ("independent_components",
                                                      "channel_blending")}
    try:
        volume = make_data_model(
            grid, None, data["independent_components"], data["channel_blending"], transfer,
            transform=placement(grid, ctx.world_matrix(prim)), name=name)
    except VolumeDataError as exc:
        raise VolumeDataError(f"Volume {name} (field {field_prim.GetPath()}): {exc}") from exc
    ctx.scene.volumes.append(volume)
    if options:
        ctx.scene.volume_options[name] = options

def _model_attributes(prim, name: str) -> dict:
    """The volume model's authored attributes as ``make_volume`` keywords, each checked."""
    found = {}
    for key, declaration in MODEL_ATTRIBUTES.items():
        value = attr(prim, f"cubemarch:{key}")
        if value is None:
            continue
        try:
            if declaration.type is tuple:
                if isinstance(value, str):   # each character read as a number before
                    raise TypeError("numbers are wanted, not a string")
                value = tuple(float(v) for v in value)
            elif declaration.name == "opacity" and not isinstance(value, str):
                value = float(value) if np.ndim(value) == 0 else [float(v) for v in value]
            elif declaration.type in (int, float, bool):
                value = declaration.type(value)
            declaration.check(value)
        except (ValueError, TypeError) as exc:
            raise SceneLoadError(f"Volume {name}: cubemarch:{key} = {value!r}: {exc}") from exc
        found[declaration.name] = value
    return found


def _voxels(ctx: StageContext, prim, name: str, field_prim, grid) -> None:
    """A material grid from an integer field, with its palette and checked options."""
    where = f"Volume {name} (field {field_prim.GetPath()})"
    if not ctx.as_voxels:
        other = [f"cubemarch:{key}" for key in VOLUME_ONLY
                 if attr(prim, f"cubemarch:{key}") is not None]
        if other:
            raise SceneLoadError(
                f"Volume {name}: {', '.join(other)} "
                f"{'does' if len(other) == 1 else 'do'} not apply to "
                'cubemarch:technique = "voxels" (volume options); remove '
                f"{'it' if len(other) == 1 else 'them'}, or choose a volume technique.")
    found = authored(prim, name, VOXEL_OPTIONS)
    options = {option: value for option, value in found.values()}
    try:
        voxel_options(**{k: v for k, v in options.items() if k not in VOXEL_CALL_ONLY})
    except ValueError as exc:
        raise options_error(name, found, "voxel", exc) from exc
    if not isinstance(grid, pyvista.ImageData):
        raise VolumeDataError(f"{where}: the file holds a {type(grid).__name__}; material "
                              "labels come on an ImageData (cell or point data).")
    scalars = _field_array(field_prim, grid)
    try:
        model = make_voxels(grid, scalars, transform=placement(grid, ctx.world_matrix(prim)),
                            name=name)
    except VolumeDataError as exc:
        why = "as_voxels=True loads every Volume" if ctx.as_voxels else \
            'cubemarch:technique = "voxels" draws'
        raise VolumeDataError(f"{where}: {exc} ({why} as integer material labels, "
                              "0 = empty.)") from exc
    if model.ids.identity:
        model.palette = _palette(prim, name, where, int(model.labels.max()))
    else:
        model.palette = _id_palette(prim, name, model)
    world = attr(prim, "cubemarch:world")
    if world is not None:
        key = attr(prim, "cubemarch:chunk")
        if key is None or len(key) != 3 or not all(
                np.isfinite(float(k)) and float(k).is_integer() and k >= 0 for k in key):
            raise SceneLoadError(f"Volume {name}: cubemarch:world = {str(world)!r} needs "
                                 "cubemarch:chunk, an int3 of whole numbers >= 0 (the "
                                 "chunk's place in the world).")
        size = attr(prim, "cubemarch:chunkSize")
        ctx.world_chunks.setdefault(str(world), []).append(ChunkPrim(
            tuple(int(k) for k in key), model, options, str(prim.GetPath()),
            None if size is None else int(size),
            lambda top, prim=prim: _palette(prim, name, where, top)))
        return
    ctx.scene.voxels.append(model)
    size = attr(prim, "cubemarch:chunkSize")
    if size is not None:
        options["chunk_size"] = int(size)
    if options:
        ctx.scene.voxel_options[name] = options


def _surface(ctx: StageContext, prim, name: str, field_prim, grid) -> None:
    """A spline field from sampled data and ``cubemarch:isovalue``, options checked."""
    where = f"Volume {name} (field {field_prim.GetPath()})"
    found = authored(prim, name, SURFACE_OPTIONS)
    options = {option: value for option, value in found.values()}
    try:
        get_technique("surface", options.get("technique", "active")).make_options(
            {k: v for k, v in options.items() if k in specific_option_names("surface")})
    except ValueError as exc:
        raise options_error(name, found, "surface", exc) from exc
    isovalue = attr(prim, "cubemarch:isovalue")
    if isovalue is None:
        raise SceneLoadError(f"Volume {name}: cubemarch:technique = \"surface\" needs "
                             "cubemarch:isovalue (the level of the field to draw).")
    scalars = _field_array(field_prim, grid)
    spline = attr(prim, "cubemarch:spline")
    try:
        surface = make_field(grid, float(converted(name, "isovalue", isovalue, float)),
                             scalars, transform=placement(grid, ctx.world_matrix(prim)),
                             name=name, spline="interpolating" if spline is None else
                             str(converted(name, "spline", spline, str)))
    except VolumeDataError as exc:
        raise VolumeDataError(f"{where}: {exc}") from exc
    ctx.scene.surfaces.append(surface)
    if options:
        ctx.scene.surface_options[name] = options




def _check_volume_options(name: str, found: dict, options: dict) -> None:
    """Refuse, when the stage loads, volume options ``add_volume`` would refuse when drawn."""
    try:
        technique = get_technique("volume", options.get("technique", "vtk"))
        technique.make_options({k: v for k, v in options.items()
                                if k in specific_option_names("volume")})
        common = ("stop_opacity", "skip_empty", "light_map_size", "light_map_ambient", "blending")
        CommonVolumeOptions(**{k: options[k] for k in common if k in options},
                            isosurfaces=(0.0,) if options.get("isosurfaces") else ()).check()
    except ValueError as exc:
        raise options_error(name, found, "volume", exc) from exc
    if options.get("lights", "scene") not in ("scene", "none"):
        raise options_error(name, found, "volume", ValueError(
            f"lights must be 'scene' or 'none', got {options['lights']!r}"))


def _field_array(field_prim, grid) -> str | None:
    """The grid's array the field prim's ``fieldName`` names, if the grid has it."""
    field_name = attr(field_prim, "fieldName")
    return str(field_name) if field_name and str(field_name) in grid.array_names else None


def is_field(prim) -> bool:
    """A field prim (anything with a ``filePath``, e.g. ``OpenVDBAsset``)."""
    return bool(prim.GetAttribute("filePath"))


def _id_palette(prim, name: str, model) -> Palette:
    """The palette of a grid whose ids were compacted: hashed, or a colormap over the ids.

    ``cubemarch:palette`` and ``cubemarch:paletteOpacity`` give one entry per label number
    and cannot reach ids past 65535 or negative ones: refused, saying what to use.
    """
    by_row = [key for key in ("cubemarch:palette", "cubemarch:paletteOpacity")
              if attr(prim, key) is not None]
    if by_row:
        raise SceneLoadError(f"Volume {name}: {', '.join(by_row)} give one entry per label "
                             f"number, but its {model.n_labels} ids reach past 0..65535 (or "
                             "are negative): use cubemarch:cmap (a colormap over the ids) or "
                             "leave it out (colours hashed from each id).")
    cmap = attr(prim, "cubemarch:cmap")
    if cmap is not None and not isinstance(cmap, str):
        raise SceneLoadError(f"Volume {name}: cubemarch:cmap must be a colormap name "
                             f"(string or token), got {cmap!r}.")
    try:
        return Palette.make(None if cmap is None else str(cmap), model.ids.n_rows, model.ids)
    except VolumeDataError as exc:
        raise SceneLoadError(f"Volume {name}: cubemarch:cmap = {cmap!r}: {exc}") from exc


def _palette(prim, name: str, where: str, top: int) -> Palette:
    """The palette a voxels Volume prim asks for, covering labels ``0..top``."""
    colors = attr(prim, "cubemarch:palette")
    opacity = attr(prim, "cubemarch:paletteOpacity")
    cmap = attr(prim, "cubemarch:cmap")
    if colors is not None and cmap is not None:
        raise SceneLoadError(f"Volume {name} sets both cubemarch:palette (a colour per "
                             "material) and cubemarch:cmap (a colormap name); keep one.")
    if opacity is not None:
        authored = opacity
        try:
            opacity = np.asarray(opacity, dtype=np.float64)
        except (TypeError, ValueError):
            opacity = np.zeros(())
        if opacity.ndim != 1:
            raise SceneLoadError(f"Volume {name}: cubemarch:paletteOpacity must be a float[] "
                                 f"(one opacity per palette entry), got {authored!r}.")
    if colors is not None:
        rgb = np.asarray(colors)
        if rgb.ndim != 2 or rgb.shape[1] not in (3, 4) or rgb.dtype.kind not in "fiu":
            raise SceneLoadError(f"Volume {name}: cubemarch:palette must be a color3f[] (or "
                                 "color4f[]) array, one colour per material (entry 0 unused), "
                                 f"got {colors!r}.")
        if len(rgb) <= top:
            raise VolumeDataError(f"{where}: cubemarch:palette has {len(rgb)} entries "
                                  f"(materials 0..{len(rgb) - 1}) but the labels go up to "
                                  f"{top}; give at least {top + 1} colours (entry 0, empty, "
                                  "is unused).")
        rgba = np.ones((len(rgb), 4))
        rgba[:, :rgb.shape[1]] = rgb
        source = "cubemarch:palette"
    else:
        if cmap is not None and not isinstance(cmap, str):
            raise SceneLoadError(f"Volume {name}: cubemarch:cmap must be a colormap name "
                                 f"(string or token), got {cmap!r}.")
        rows = max(top + 1, 0 if opacity is None else len(opacity))
        try:
            rgba = Palette.make(cmap, rows).rgba.astype(np.float64)
        except VolumeDataError as exc:
            raise SceneLoadError(f"Volume {name}: cubemarch:cmap = {cmap!r}: {exc}") from exc
        source = "cubemarch:cmap" if cmap is not None else "the default palette"
    if opacity is not None:
        if len(opacity) != len(rgba):
            raise SceneLoadError(f"Volume {name}: cubemarch:paletteOpacity has {len(opacity)} "
                                 f"values and {source} {len(rgba)} entries; give one opacity "
                                 "per entry (entry 0 unused, 0 hides a material).")
        rgba[1:, 3] = opacity[1:]
    rgba[0, 3] = 0.0
    try:
        return Palette(rgba)
    except VolumeDataError as exc:
        attrs = "cubemarch:palette" if colors is not None else ""
        attrs += (" / " if attrs and opacity is not None else "") + \
            ("cubemarch:paletteOpacity" if opacity is not None else "")
        raise SceneLoadError(f"Volume {name}: {attrs or source}: {exc}") from exc



def _read_field(ctx: StageContext, field_prim, cells: bool = False,
                margin: int = 0) -> pyvista.ImageData:
    """Load the grid a field prim's ``filePath`` names (.vti/.vtk/.npy/.npz/.vdb).

    The file path is read at the stage time (a sequence of files animates a volume);
    ``fieldName`` and ``fieldIndex`` choose the grid of a ``.vdb``. ``cells``: the values
    fill voxels (material labels) instead of sitting on points (see
    :mod:`pv_cubemarch.scene.grids`).
    """
    asset = field_prim.GetAttribute("filePath").Get(ctx.time)
    where = f"field prim {field_prim.GetPath()}"
    if asset is None or not asset.path:
        raise SceneLoadError(f"{where} has no filePath.")
    resolved = asset.resolvedPath
    if not resolved:
        layer_dir = Path(field_prim.GetStage().GetRootLayer().realPath).parent
        raise SceneLoadError(f"{where}: volume file {asset.path!r} was not found "
                             f"(looked relative to {layer_dir}).")
    field_name = attr(field_prim, "fieldName")
    field_index = attr(field_prim, "fieldIndex")
    origin, spacing = (_three_numbers(field_prim, name, positive) for name, positive in (
        ("cubemarch:origin", False), ("cubemarch:spacing", True)))
    return read_grid(resolved, where, asset.path, str(field_name) if field_name else None,
                     origin, spacing,
                     cells=cells, field_index=None if field_index is None else int(field_index),
                     margin=margin)




def _three_numbers(prim, name: str, positive: bool):
    """Attribute ``name`` of ``prim`` as three finite numbers (positive ones), or None."""
    value = attr(prim, name)
    if value is None:
        return None
    try:
        numbers = [float(v) for v in value]
    except (TypeError, ValueError):
        numbers = []
    if len(numbers) != 3 or not all(np.isfinite(numbers)) or (
            positive and min(numbers) <= 0):
        raise SceneLoadError(f"{prim.GetPath()}: {name} must be a float3 of "
                             f"{'positive' if positive else 'finite'} numbers (x, y, z), got "
                             f"{value!r}.")
    return numbers
