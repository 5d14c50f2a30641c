"""``pyvista.Plotter.add_volume``'s keywords, taken with PyVista's meaning.

Its aliases (``rng``, ``colormap``), its data arguments (``scalars`` as an array, a numpy
volume's ``resolution``), its scalar bar, and a clear refusal, naming what to use, of the
keywords no technique here draws yet.
"""

from __future__ import annotations

import warnings

import numpy as np
import pyvista

from ..core.errors import VolumeDataError
from ..core.options import is_count, level_values, spread_levels
from ..core.scalar_bar import attach_scalar_bar
from ..models.channels import is_channels
from ..models.transfer import pyvista_lookup_table, shift_value

#: PyVista's aliases of add_volume's keywords (``add_mesh``'s ``rng`` and ``colormap``).
ALIASES = {"rng": "clim", "colormap": "cmap"}
#: Keywords PyVista takes that a technique here does not draw, and what to do instead.
REFUSED = {
    "mapper": "pv_cubemarch draws with its own marchers: choose one with technique= "
              "('vtk', 'direct', 'cubemap' or 'auto')",
    "culling": "a volume draws the faces of its box it needs itself; leave culling out",
}


def resolve_aliases(kwargs: dict, given: dict) -> dict:
    """Move PyVista's alias keywords of ``kwargs`` onto their names in ``given``.

    ``given`` maps add_volume's own keywords to their values (``None``: not given). Any
    keyword left over is refused with what to use instead.
    """
    out = dict(given)
    for key in list(kwargs):
        if key in ALIASES:
            target = ALIASES[key]
            if out.get(target) is not None:
                raise TypeError(f"add_volume got both {key}= and {target}= ({key} is "
                                f"PyVista's alias of {target}); pass one.")
            out[target] = kwargs.pop(key)
    for key in list(kwargs):
        if key in REFUSED:
            raise TypeError(f"add_volume does not take {key}=: {REFUSED[key]}.")
    if kwargs:
        raise TypeError(f"add_volume got unexpected keyword argument(s) {sorted(kwargs)}; see "
                        "help(pv_cubemarch.add_volume) for the keywords it takes (PyVista's "
                        "add_volume keywords, and the techniques' options).")
    return out


def volume_input(volume, scalars, resolution, preference: str = "point"):
    """``(volume, scalars name)`` with PyVista's ``scalars`` array and ``resolution`` applied.

    A numpy volume with ``resolution`` becomes an ImageData of that spacing; ``scalars``
    given as an array is attached to a shallow copy of the grid (points, or cells when it
    has one value per cell, or ``preference`` decides when both fit).
    """
    if resolution is not None:
        spacing = np.asarray(resolution, dtype=np.float64)
        if spacing.shape != (3,) or not np.isfinite(spacing).all() or (spacing <= 0).any():
            raise VolumeDataError(f"resolution must be three positive spacings, got "
                                  f"{resolution!r}.")
        if not isinstance(volume, np.ndarray):
            raise VolumeDataError("resolution= sets the spacing of a numpy volume; a grid "
                                  "carries its own (set grid.spacing).")
        if volume.ndim != 3:
            raise VolumeDataError(f"A numpy volume must be 3D (x, y, z), got shape "
                                  f"{volume.shape}.")
        grid = pyvista.ImageData(dimensions=volume.shape, spacing=tuple(spacing))
        grid.point_data["values"] = volume.ravel(order="F")
        volume = grid
        scalars = scalars if scalars is not None else "values"
    if scalars is None or isinstance(scalars, str):
        return volume, scalars
    array = np.asarray(scalars)
    if isinstance(volume, np.ndarray):
        raise VolumeDataError("scalars= as an array needs a grid to sit on; pass the array "
                              "itself as the volume.")
    if not isinstance(volume, pyvista.DataSet):
        volume = pyvista.wrap(volume)
    grid = volume.copy(deep=False)
    fits_points = array.shape[0] == grid.n_points
    fits_cells = array.shape[0] == grid.n_cells
    if not (fits_points or fits_cells):
        raise VolumeDataError(f"scalars has {array.shape[0]} values; the grid has "
                              f"{grid.n_points} points and {grid.n_cells} cells.")
    on_cells = fits_cells and (not fits_points or preference == "cell")   # averaged, said
    (grid.cell_data if on_cells else grid.point_data)["Data"] = array
    return grid, "Data"


#: The modes an RGBA volume is drawn in: by its alpha, each sample with its own colour (the
#: others read one scalar; VTK draws an RGBA volume's red component alone there, in grey).
DIRECT_COLOR_BLENDING = ("composite", "maximum", "minimum")


def check_direct_color(model, blending: str, shade: bool, cmap) -> None:
    """Refuse, by name, what an RGBA (direct-colour) volume cannot draw.

    Its colours are its own, so a ``cmap`` colours nothing (warned, as PyVista ignores it).
    'maximum' and 'minimum' keep the sample of extreme alpha with its colour, as VTK does;
    'average' and 'additive' read one scalar per sample (VTK draws the red component alone,
    in grey), 'isosurface' needs levels of one, and gradient shading one scalar's gradient.
    """
    if getattr(model, "colors", None) is None:
        return
    if blending not in DIRECT_COLOR_BLENDING:
        raise ValueError(f"blending={blending!r} draws one value per sample; an RGBA volume "
                         "(4 uint8 components) has a colour instead (VTK draws its red "
                         "component alone, in grey): use blending='composite', 'maximum' "
                         "or 'minimum', or draw one component as scalars.")
    if shade:
        raise ValueError("shade=True lights the gradient of one scalar; an RGBA volume (4 "
                         "uint8 components) has none: leave shade off (lights= lights it "
                         "through itself).")
    if cmap is not None:
        warnings.warn("cmap colours nothing in an RGBA volume: its first three components "
                      "are its colours (PyVista ignores cmap there too).", stacklevel=3)


def check_channels(model, blending: str, shade: bool, lights) -> None:
    """Refuse, by name, what a channel volume cannot draw.

    Its channels are marched jointly, so composite blending only; channels that add their
    light are each their own medium, which no light map or gradient shading models.
    """
    if not is_channels(model):
        return
    mix = model.channel_mix
    if blending != "composite":
        raise ValueError(f"blending={blending!r} reads one value per sample; a volume of "
                         f"{len(model.members)} channels mixes its channels by "
                         "channel_blending ('composite' or 'additive'): leave blending out.")
    if mix == "additive" and (shade or lights is not None):
        raise ValueError(f"channel_blending='additive' draws each channel as if alone; "
                         f"{'shade' if shade else 'lights'}= lights one medium: use "
                         "channel_blending='composite' to light the channels.")


def scalar_bar_mapper(model) -> pyvista.DataSetMapper:
    """A mapper (never drawn) whose lookup table is the volume's colours over its ``clim``.

    ``plotter.add_scalar_bar`` reads ``plotter.mapper``'s lookup table; this one holds the
    volume's colormap, opacity and range in data units, so a scalar bar added with the
    volume or afterwards shows what is drawn.
    """
    spec = model.transfer.spec
    mapper = pyvista.DataSetMapper()
    given = getattr(model.transfer, "lookup_table", None)
    if isinstance(given, pyvista.LookupTable):   # the user's own (cmap=lut), as PyVista's
        mapper.lookup_table = given
        mapper.scalar_range = given.scalar_range
        return mapper
    if spec is None:   # a table given as is: its rows over its clim
        lut = pyvista.LookupTable()
        table = np.asarray(model.transfer.table, dtype=np.float64)
        alpha = -np.expm1(-table[:, 3])
        lut.values = np.column_stack([table[:, :3], np.clip(alpha, 0, 1)]) * 255.0
        offset = float(model.value_offset) if model.value_offset else 0.0
        lut.scalar_range = tuple(float(v) + offset for v in model.transfer.clim)
    else:
        if isinstance(spec.cmap, np.ndarray):
            lut = pyvista.LookupTable()
            lut.values = np.column_stack([spec.cmap, spec.opacity]) * 255.0
        else:   # the transfer function's own table: the bar fades as the volume is drawn
            lut = pyvista_lookup_table(spec.cmap, spec.opacity, spec.n_colors,
                                       spec.flip_scalars)
        lut.scalar_range = spec.data_clim
        lut.log_scale = spec.log_scale
    mapper.lookup_table = lut
    mapper.scalar_range = lut.scalar_range
    return mapper


def add_scalar_bar(plotter, actor, model, title: str, show: bool | None,
                   args: dict | None, annotations: dict | None):
    """Make the volume ``plotter.mapper`` (for ``add_scalar_bar``) and add its bar if shown.

    The mapper shares the lookup table of ``actor``'s mapper, as PyVista's volume is its
    bar's mapper: ``plotter.update_scalar_bar_range`` then recolours the volume.

    ``show`` ``None`` follows the theme (``pyvista.global_theme.show_scalar_bar``), as
    ``add_volume`` does. Returns that mapper.
    """
    mapper = scalar_bar_mapper(model)
    drawn = getattr(actor.GetMapper(), "lookup_table", None)
    if isinstance(drawn, pyvista.LookupTable):   # one table: the bar's edits recolour it
        mapper.lookup_table = drawn
    if annotations:
        mapper.lookup_table.annotations = dict(annotations)
    if show is None:
        show = bool(plotter.theme.show_scalar_bar)
    attach_scalar_bar(plotter, actor, mapper, title, show, args)
    return mapper


def isosurface_levels(isosurfaces, model) -> tuple[float, ...]:
    """The levels of ``isosurfaces=`` in ``model``'s stored units (data less its offset).

    A sequence of data values, or an int ``n``: ``n`` levels from the data's smallest to
    its largest value, as :meth:`pyvista.DataSetFilters.contour` spreads them.
    """
    if isosurfaces is None:
        return ()
    if is_count(isosurfaces):
        return spread_levels(isosurfaces, model.values)
    levels = level_values(isosurfaces)
    return tuple(shift_value(v, model.value_offset) for v in levels)


def set_average_range(mapper, value, blending: str) -> None:
    """Put ``average_range`` (two numbers, data units) on ``mapper``, as VTK keeps it.

    Only ``blending='average'`` reads it (a warning says so for another mode; it stays on
    the mapper, as in VTK, for a later switch to 'average').
    """
    try:
        low, high = (float(v) for v in np.asarray(value, dtype=np.float64).ravel())
    except (TypeError, ValueError):
        low = high = np.nan
    if not (np.isfinite(low) and np.isfinite(high)) or low > high:
        raise ValueError(f"average_range takes two finite numbers (low, high), low not above "
                         f"high, in the data's units; got {value!r}.")
    if blending != "average":
        warnings.warn(f"average_range is read by blending='average' only; this volume is "
                      f"drawn with blending={blending!r}.", stacklevel=3)
    mapper.SetAverageIPScalarRange(low, high)
