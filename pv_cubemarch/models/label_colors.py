"""Colours for label ids: hashed from the id, from a dict or a function of the id.

A hashed colour depends on the id alone (splitmix64 of its 64-bit pattern), so it is the
same across runs, chunks and grids, and neighbouring ids (cells 41 and 42) differ: what
napari's and neuroglancer's segmentation colours do.
"""

from __future__ import annotations

import numbers
from collections.abc import Callable

import numpy as np
import pyvista

from ..core.errors import VolumeDataError

_MASK = np.uint64(0xFFFFFFFFFFFFFFFF)


def _splitmix64(bits: np.ndarray) -> np.ndarray:
    """The splitmix64 finaliser of each 64-bit word (wrapping arithmetic)."""
    with np.errstate(over="ignore"):
        z = (bits + np.uint64(0x9E3779B97F4A7C15)) & _MASK
        z = ((z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)) & _MASK
        z = ((z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)) & _MASK
        return z ^ (z >> np.uint64(31))


def hashed_colors(ids, seed: int = 0) -> np.ndarray:
    """An opaque RGBA colour per id, ``(n, 4)`` float32, hashed from the id and ``seed``.

    Hue from 16 bits of the hash, saturation in [0.55, 1] and value in [0.7, 1] from others,
    so no id is drawn near-black or grey. Signed ids hash their two's complement pattern.

    Examples
    --------
    >>> hashed_colors([1, 2, 2**40 + 7]).shape
    (3, 4)
    """
    values = np.atleast_1d(np.asarray(ids))
    if values.dtype.kind not in "iu":
        values = np.asarray([int(v) & 0xFFFFFFFFFFFFFFFF for v in values.ravel()], np.uint64)
    bits = values.astype(np.int64 if values.dtype.kind == "i" else np.uint64).ravel()
    bits = bits.view(np.uint64) ^ _splitmix64(np.array([int(seed) & 0xFFFFFFFFFFFFFFFF],
                                                        np.uint64))
    h = _splitmix64(bits)
    hue = (h & np.uint64(0xFFFF)).astype(np.float64) / 65536.0
    sat = 0.55 + 0.45 * ((h >> np.uint64(16)) & np.uint64(0xFF)).astype(np.float64) / 255.0
    val = 0.7 + 0.3 * ((h >> np.uint64(24)) & np.uint64(0xFF)).astype(np.float64) / 255.0
    rgba = np.ones((bits.size, 4), np.float32)
    rgba[:, :3] = _hsv_to_rgb(hue, sat, val)
    return rgba


def _hsv_to_rgb(hue: np.ndarray, sat: np.ndarray, val: np.ndarray) -> np.ndarray:
    """HSV in [0, 1] to RGB ``(n, 3)``."""
    sector = np.floor(hue * 6.0)
    f = hue * 6.0 - sector
    p, q, t = val * (1 - sat), val * (1 - sat * f), val * (1 - sat * (1 - f))
    choices = [(val, t, p), (q, val, p), (p, val, t), (p, q, val), (t, p, val), (val, p, q)]
    index = sector.astype(np.int64) % 6
    rgb = np.empty((hue.size, 3))
    for k, (r, g, b) in enumerate(choices):
        at = index == k
        rgb[at] = np.stack([r[at], g[at], b[at]], axis=-1)
    return rgb


def _rgba_entry(entry, label) -> tuple[tuple[float, float, float], float]:
    """A dict value: a colour, or ``(colour, opacity)``; an error naming the label."""
    pair = isinstance(entry, (tuple, list)) and len(entry) == 2
    color, opacity = entry if pair else (entry, 1.0)
    try:
        rgb = pyvista.Color(color).float_rgb
    except (ValueError, TypeError):
        raise ValueError(f"color {color!r} of label {label} is not a colour: give a name "
                         "('tomato'), a hex string ('#ff6347') or an RGB sequence.") from None
    try:
        opacity = float(opacity)
    except (TypeError, ValueError):
        raise ValueError(f"opacity {opacity!r} of label {label} is not a number.") from None
    if not 0.0 <= opacity <= 1.0:
        raise ValueError(f"opacity of label {label} must be in [0, 1], got {opacity}.")
    return rgb, opacity


def colors_by_id(palette, ids: np.ndarray) -> np.ndarray:
    """Rows ``1..n`` of a table over ``ids`` from a dict or a function of the id.

    ``palette``: ``{id: colour}`` or ``{id: (colour, opacity)}`` (ids left out are hidden;
    keys the grid does not hold are ignored, so one dict serves many grids), or a callable
    ``f(id) -> colour | (colour, opacity)`` called once per id.
    """
    rgba = np.zeros((ids.size + 1, 4), np.float32)
    if isinstance(palette, dict):
        keys = palette_keys(palette)
        lookup = {int(v): row for row, v in enumerate(ids.tolist(), start=1)}
        for key, entry in zip(keys, palette.values(), strict=True):
            row = lookup.get(key)
            if row is not None:
                rgb, opacity = _rgba_entry(entry, key)
                rgba[row, :3], rgba[row, 3] = rgb, opacity
        return rgba
    function: Callable = palette
    for row, value in enumerate(ids.tolist(), start=1):
        rgb, opacity = _rgba_entry(function(value), value)
        rgba[row, :3], rgba[row, 3] = rgb, opacity
    return rgba


def palette_keys(palette: dict) -> list[int]:
    """The ids a ``{id: colour}`` palette names, refusing a key that is not an integer.

    A float (``3.7``) or a string (``"3"``) would be read as another id in silence.
    """
    keys = []
    for key in palette:
        if isinstance(key, (bool, np.bool_)) or not isinstance(key, numbers.Integral):
            raise VolumeDataError(f"palette key {key!r} is not an integer label id: key the "
                                  "dict by the ids in the labels ({3: 'red'}).")
        keys.append(int(key))
    return keys


def check_by_id(palette) -> None:
    """Refuse a palette that is read by row (a list, an array) where rows are not ids."""
    if not (palette is None or isinstance(palette, (str, dict)) or callable(palette)):
        raise VolumeDataError("These labels are compacted (ids beyond 0..65535, negative, or "
                              "another background), so a list or array of colours has no "
                              "row per id: give palette= a {id: colour} dict, a function "
                              "of the id, or a colormap name.")
