"""Multi-channel volumes (microscopy): 2 to 4 components, each with its own transfer function.

A channel volume is a :class:`~pv_cubemarch.models.group.VolumeGroup` of co-located members,
one per component, so every marcher of joint groups draws it: ``'composite'`` mixes the
channels as one medium (their extinctions add, the emission is their extinction-weighted
mean: the continuous form of VTK's independent components), ``'additive'`` draws each
channel as if alone and adds their light (napari's additive channels). Numpy only.
"""

from __future__ import annotations

import numpy as np
import pyvista

from ..core.errors import VolumeDataError
from .group import MAX_GROUP_MEMBERS, VolumeGroup
from .volume import is_rgba, make_volume, with_transfer

#: How the channels of one volume mix (``channel_blending=``).
CHANNEL_MIXES = ("composite", "additive")
#: Each channel's colour when no cmap is given: a ramp from black (napari's first four).
CHANNEL_COLOURS = ("green", "magenta", "cyan", "yellow")
#: The per-channel keywords: each takes one value for every channel, or a list of one each.
CHANNEL_KEYWORDS = ("cmap", "opacity", "clim", "opacity_unit_distance", "n_colors",
                    "flip_scalars", "log_scale")   # n_colors: one for all (one table size)


def channel_count(grid, scalars: str | None, independent_components: bool | None) -> int:
    """How many independent channels ``grid``'s array ``scalars`` draws as (0: one scalar).

    2 to 4 components are channels, except 4 uint8 components, which are RGBA (as PyVista
    draws them) unless ``independent_components=True``. ``False`` asks for RGBA and is
    refused for any other array.
    """
    if not isinstance(grid, pyvista.DataSet):
        if isinstance(grid, np.ndarray) and independent_components:
            raise VolumeDataError(
                "independent_components=True draws each component of a grid's array as a "
                "channel; a numpy volume is one scalar (x, y, z) or RGBA (x, y, z, 4 uint8): "
                "give the channels as a pyvista.ImageData point array of 2 to 4 components.")
        if isinstance(grid, np.ndarray) or grid is None:
            return 0
        grid = pyvista.wrap(grid)
    name = scalars if scalars is not None else grid.active_scalars_name
    if name is None or (name not in grid.point_data and name not in grid.cell_data):
        return 0
    array = np.asarray(grid.point_data[name] if name in grid.point_data
                       else grid.cell_data[name])
    if array.ndim != 2:
        if independent_components:
            raise VolumeDataError(f"independent_components=True draws each component of "
                                  f"{name!r} as a channel; it has one component.")
        return 0
    count = int(array.shape[1])
    if independent_components is False:
        if not is_rgba(array):
            raise VolumeDataError(f"independent_components=False draws 4 uint8 components as "
                                  f"RGBA; {name!r} has {count} components of {array.dtype}.")
        return 0
    if is_rgba(array) and not independent_components:
        return 0
    if not 2 <= count <= MAX_GROUP_MEMBERS:
        raise VolumeDataError(f"Array {name!r} has {count} components; a volume draws 1, 2 "
                              f"to {MAX_GROUP_MEMBERS} channels, or 4 uint8 (RGBA): pick "
                              "components, e.g. scalars=grid[name][:, :4].")
    return count


def per_channel(keyword: str, value, count: int) -> list:
    """``value`` for each of ``count`` channels: a list of ``count`` items is one each.

    Except where a list of plain numbers is itself one value: a ``clim`` pair (with two
    channels), an ``opacity`` curve and an RGB ``cmap`` colour are the same for every
    channel. An array is its list (``clim`` as a ``(count, 2)`` array: one pair each).
    """
    if isinstance(value, np.ndarray) and value.ndim >= 1:   # a (count, 2) clim array...
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) != count:
        return [value] * count
    numbers = all(isinstance(v, (int, float, np.number)) for v in value)
    if numbers and (keyword in ("opacity", "cmap") or (keyword == "clim" and count == 2)):
        return [value] * count   # one curve, one pair, one RGB colour
    return list(value)


def channel_cmap(cmap):
    """One channel's colormap: a colour ramps from black to it.

    The colour is a name that is no colormap, or an RGB(A) tuple of 0-1 floats.
    """
    import matplotlib
    from matplotlib.colors import LinearSegmentedColormap, is_color_like

    if isinstance(cmap, str):
        if cmap in matplotlib.colormaps or not is_color_like(cmap):
            return cmap
    elif not (isinstance(cmap, (tuple, list)) and len(cmap) in (3, 4)
              and all(isinstance(v, (int, float, np.number)) for v in cmap)
              and is_color_like(tuple(cmap))):
        return cmap
    return LinearSegmentedColormap.from_list(f"black-{cmap}", ["black", cmap])


def make_channels(grid, scalars: str, count: int, make_member, channel_mix: str = "composite",
                  name: str = "volume", **keywords) -> VolumeGroup:
    """A channel volume: one member per component of ``grid[scalars]``, co-located.

    ``make_member(member_grid, member_scalars, name=..., **channel_keywords)`` makes each
    member (:func:`pv_cubemarch.make_volume`); ``keywords`` are the transfer keywords, each
    one value or one per channel (:func:`per_channel`), and the others, the same for all.
    """
    _check_mix(channel_mix)
    if not isinstance(grid, pyvista.DataSet):
        grid = pyvista.wrap(grid)
    if scalars not in grid.point_data:
        grid = grid.cell_data_to_point_data(pass_cell_data=False)
    array = np.asarray(grid.point_data[scalars])
    if keywords.get("categories"):
        raise ValueError("categories= sizes one volume's colours by its distinct values; the "
                         "channels of a volume share one table size: give n_colors= (one "
                         "number for every channel) instead.")
    channels = {key: per_channel(key, keywords.pop(key), count)
                for key in CHANNEL_KEYWORDS if key in keywords}
    if len(set(channels.get("n_colors", [None]))) > 1:
        raise ValueError(f"n_colors={channels['n_colors']}: the channels of a volume share "
                         "one table size (one marcher reads them all); give one number.")
    given = channels.get("cmap", [None] * count)
    channels["cmap"] = [channel_cmap(CHANNEL_COLOURS[i] if c is None else c)
                        for i, c in enumerate(given)]
    members = []
    for index in range(count):
        member_grid = grid.copy(deep=False)
        member_grid.clear_data()
        label = f"{scalars}[{index}]"
        member_grid.point_data[label] = np.ascontiguousarray(array[:, index])
        mine = {key: values[index] for key, values in channels.items()}
        members.append(make_member(member_grid, label, name=label,
                                   **mine, **keywords))
    return VolumeGroup(members, name=name, channel_mix=channel_mix)


def is_channels(model) -> bool:
    """Whether ``model`` is a channel volume (a group of co-located channels)."""
    return isinstance(model, VolumeGroup) and model.channel_mix is not None


def make_data_model(volume, scalars, independent_components, channel_blending,
                    transfer: dict, **placement):
    """The model of raw data: one volume, an RGBA volume, or a channel volume (a group).

    ``transfer`` holds add_volume's transfer keywords as given (``None``: the default);
    ``placement``: ``make_volume``'s other keywords (``transform``, ``name`` ...).
    """
    defaults = dict(opacity="linear", n_colors=256, categories=False)
    keywords = dict(transfer, **{key: default if transfer.get(key) is None else
                                 transfer[key] for key, default in defaults.items()})
    for key in ("cmap", "clim", "opacity_unit_distance", "flip_scalars", "log_scale"):
        keywords.setdefault(key, None)
    count = channel_count(volume, scalars, independent_components)
    if count:
        for flag in ("flip_scalars", "log_scale"):   # one each, or one for all
            if not isinstance(keywords[flag], (list, tuple)):
                keywords[flag] = bool(keywords[flag])
        return make_channels(volume, scalars or volume.active_scalars_name, count,
                             make_volume, channel_mix=channel_blending or "composite",
                             **keywords, **placement)
    if channel_blending is not None:
        raise ValueError("channel_blending mixes the channels of a volume with 2 to 4 "
                         "components; this one has a single component.")
    keywords.update(flip_scalars=bool(keywords["flip_scalars"]),
                    log_scale=bool(keywords["log_scale"]))
    return make_volume(volume, scalars, **keywords, **placement)


def with_channel_transfer(group: VolumeGroup, **changes) -> VolumeGroup:
    """A channel volume with some transfer keywords changed.

    Each keyword is one value for every channel, or a list of one each (as
    :func:`make_channels` takes them).
    """
    count = len(group.members)
    if len(set(per_channel("n_colors", changes.get("n_colors"), count))) > 1:
        raise ValueError(f"n_colors={changes['n_colors']}: the channels of a volume share "
                         "one table size (one marcher reads them all); give one number.")
    each = {key: per_channel(key, value, count) for key, value in changes.items()}
    if "cmap" in each:
        each["cmap"] = [channel_cmap(c) for c in each["cmap"]]
    members = [with_transfer(member, **{key: values[index] for key, values in each.items()})
               for index, member in enumerate(group.members)]
    return VolumeGroup(members, name=group.name, channel_mix=group.channel_mix)


def _check_mix(channel_mix: str) -> None:
    if channel_mix not in CHANNEL_MIXES:
        raise ValueError(f"channel_blending must be one of {CHANNEL_MIXES}, got "
                         f"{channel_mix!r}.")


def with_channel_mix(model, channel_mix: str) -> VolumeGroup:
    """A channel volume mixing its channels as ``channel_mix`` says (refused for others)."""
    _check_mix(channel_mix)
    if not is_channels(model):
        raise ValueError("channel_blending mixes the channels of a volume with 2 to 4 "
                         f"components; {model.name!r} is not such a volume.")
    return VolumeGroup(model.members, name=model.name, channel_mix=channel_mix)


def channel_grid(group: VolumeGroup) -> pyvista.ImageData:
    """A channel volume's grid with its channels as one array of components, as read."""
    first = group.members[0]
    grid = first.grid.copy(deep=False)
    grid.clear_data()
    name = first.name.rsplit("[", 1)[0]
    grid.point_data[name] = np.column_stack([np.asarray(m.grid.point_data[m.name])
                                             for m in group.members])
    return grid
