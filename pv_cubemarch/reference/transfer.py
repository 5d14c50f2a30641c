"""The colour and extinction a scalar should get, derived on its own from matplotlib.

This is the CPU reference's transfer function. It reads what the user asked for (the
``spec`` a :class:`~pv_cubemarch.TransferFunction` keeps: colormap, opacity, ``clim`` in
data units less the volume's offset, ``n_colors``, ``flip_scalars``, ``log_scale``) and
derives colours from matplotlib's colormap on the normalised scalar, following what VTK
does with the transfer functions PyVista's ``add_volume`` gives it: ``n_colors`` points
evenly spaced over ``clim``, each with the lookup-table colour of its value, the opacity
curve's value capped at 0.998, both linear in between and clamped outside; an opacity
``a`` over the unit distance ``u`` is the extinction ``-ln(1 - a) / u``.

It imports nothing of pv_cubemarch (a test checks that), so the renderer's table is never
its own oracle.
"""

from __future__ import annotations

import matplotlib
import matplotlib.colors
import numpy as np
import pyvista  # PyVista's own opacity presets are the definition of their names

#: PyVista's ``to_opacity_tf(max_clip=0.998)``.
OPACITY_CLIP = 0.998


def colormap_samples(cmap, n: int, flip: bool) -> np.ndarray:
    """``(n, 3)`` colours: a matplotlib colormap at ``n`` evenly spaced points of [0, 1]."""
    if isinstance(cmap, np.ndarray) and cmap.ndim == 2:      # a lookup table's own colours
        return np.asarray(cmap, dtype=np.float64)[:, :3]
    if isinstance(cmap, str):
        colormap = matplotlib.colormaps[cmap]
    elif isinstance(cmap, matplotlib.colors.Colormap):
        colormap = cmap
    else:
        colormap = matplotlib.colors.ListedColormap(matplotlib.colors.to_rgba_array(list(cmap)))
    if flip:
        colormap = colormap.reversed()
    return np.asarray(colormap(np.linspace(0.0, 1.0, n)), dtype=np.float64)[:, :3]


def opacity_samples(opacity, n: int) -> np.ndarray:
    """``(n,)`` opacities in [0, 1] at ``n`` evenly spaced points over ``clim``."""
    if isinstance(opacity, str):
        return np.asarray(pyvista.opacity_transfer_function(opacity, n), np.float64) / 255.0
    values = np.atleast_1d(np.asarray(opacity, dtype=np.float64))
    if values.max() > 1:   # a curve of bytes, as PyVista reads one above 1
        values = values / 255.0
    if values.size == 1:
        return np.full(n, float(values[0]))
    if values.size == n:
        return values
    # a curve of another length is resampled as PyVista's add_volume resamples it
    lut = pyvista.LookupTable(n_values=n)
    lut.apply_opacity(values)
    return np.asarray(lut.values[:, 3], np.float64) / 255.0


def point_colors(spec) -> np.ndarray:
    """The colour of each of the ``n_colors`` points over ``clim`` (VTK's lookup-table index)."""
    n = int(spec.n_colors)
    samples = colormap_samples(spec.cmap, n, spec.flip_scalars)
    lo, hi = (float(v) for v in spec.clim)
    positions = np.linspace(lo, hi, n)
    if spec.log_scale:   # of the data's own values
        offset = float(spec.value_offset)
        lo, hi, positions = lo + offset, hi + offset, positions + offset
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (np.log10(positions) - np.log10(lo)) / (np.log10(hi) - np.log10(lo))
    else:
        t = (positions - lo) / (hi - lo)
    index = np.clip(np.floor(np.nan_to_num(t) * n), 0, n - 1).astype(np.int64)
    return samples[index]


def point_values(spec) -> tuple[np.ndarray, np.ndarray]:
    """The colour and capped opacity of each of the ``n_colors`` points over ``clim``.

    Derived once per spec (the references ask at every step of every ray).
    """
    cached = _POINTS.get(id(spec))
    if cached is None or cached[0] is not spec:
        alphas = np.minimum(opacity_samples(spec.opacity, int(spec.n_colors)), OPACITY_CLIP)
        cached = (spec, point_colors(spec), alphas)
        if len(_POINTS) > 64:
            _POINTS.clear()
        _POINTS[id(spec)] = cached
    return cached[1], cached[2]


#: ``id(spec) -> (spec, colours, opacities)``; the spec is kept so an id is never reused.
_POINTS: dict = {}


def colors_and_extinction(spec, data: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(rgb, sigma)`` of scalars ``data`` (``spec.clim``'s units): what should be drawn."""
    n = int(spec.n_colors)
    lo, hi = (float(v) for v in spec.clim)
    data = np.asarray(data, dtype=np.float64)
    colors, alphas = point_values(spec)
    if n == 1:   # one point: its colour and opacity everywhere
        rgb = np.broadcast_to(colors[0], data.shape + (3,))
        return rgb, np.full(data.shape, -np.log1p(-alphas[0]) / float(spec.opacity_unit_distance))
    x = np.clip((data - lo) / (hi - lo), 0.0, 1.0) * (n - 1)
    below = np.minimum(np.floor(x).astype(np.int64), n - 2)
    w = x - below
    rgb = colors[below] * (1.0 - w)[..., None] + colors[below + 1] * w[..., None]
    alpha = alphas[below] * (1.0 - w) + alphas[below + 1] * w
    sigma = -np.log1p(-alpha) / float(spec.opacity_unit_distance)
    return rgb, sigma


def extinction_of(spec, data: np.ndarray) -> np.ndarray:
    """``sigma`` of scalars ``data``: :func:`colors_and_extinction`'s without the colours.

    What a light's march through the medium reads at every step, at a third of the cost.
    """
    n = int(spec.n_colors)
    _, alphas = point_values(spec)
    if n == 1:
        return np.full(np.shape(data), -np.log1p(-alphas[0]) / float(spec.opacity_unit_distance))
    lo, hi = (float(v) for v in spec.clim)
    x = np.clip((np.asarray(data, dtype=np.float64) - lo) / (hi - lo), 0.0, 1.0) * (n - 1)
    alpha = np.interp(x, np.arange(n, dtype=np.float64), alphas)
    return -np.log1p(-alpha) / float(spec.opacity_unit_distance)


def table_lookup(table: np.ndarray, clim, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(rgb, sigma)`` from a table given as is (rows evenly over ``clim``, linear between)."""
    table = np.asarray(table, dtype=np.float64)
    n = table.shape[0]
    lo, hi = (float(v) for v in clim)
    x = np.clip((np.asarray(values, dtype=np.float64) - lo) / (hi - lo), 0.0, 1.0) * (n - 1)
    below = np.minimum(np.floor(x).astype(np.int64), n - 2)
    w = (x - below)[..., None]
    rows = table[below] * (1.0 - w) + table[below + 1] * w
    return rows[..., :3], rows[..., 3]


def medium(volume, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(rgb, sigma)`` of a volume's stored ``values`` (its data minus ``value_offset``).

    From what the user asked for when the volume keeps it; a table the user gave as is
    is its own definition.
    """
    transfer = volume.transfer
    if transfer.spec is None:
        return table_lookup(transfer.table, transfer.clim, values)
    return colors_and_extinction(transfer.spec, values)


def extinction(volume, values: np.ndarray) -> np.ndarray:
    """``sigma`` of a volume's stored ``values``: :func:`medium`'s without the colours."""
    transfer = volume.transfer
    if transfer.spec is None:
        return table_lookup(transfer.table, transfer.clim, values)[1]
    return extinction_of(transfer.spec, values)
