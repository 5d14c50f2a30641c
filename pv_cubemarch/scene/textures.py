"""Texture images for VTK's PBR from a material's texture inputs, as UsdUVTexture reads them.

A file is decoded to floats in [0, 1], converted from sRGB to linear when its colour space
says so (``auto``: 8-bit images of three or four channels), scaled and biased, and its
channels chosen; the result is packed for VTK: base colour (sRGB-encoded, alpha from the
opacity), ORM (occlusion, roughness, metallic in R, G, B) and normal maps (linear).
"""

from __future__ import annotations

import io
import os
from functools import lru_cache

import numpy as np
from PIL import Image

from .materials import PrimvarInput, TextureInput

_CHANNELS = {"r": 0, "g": 1, "b": 2, "a": 3}


@lru_cache(maxsize=64)
def _decoded(file: str, data: bytes | None, stamp: int | None) -> tuple[np.ndarray, bool]:
    """RGBA floats (rows top-down, as in the file) and whether the file is 8-bit.

    Single-channel images give (v, v, v, 1), two-channel ones (v, v, v, a). ``stamp``
    (the file's modification time) keys the cache, so an edited file is read again.
    """
    with Image.open(io.BytesIO(data) if data is not None else file) as image:
        image.load()
        mode = image.mode
        if mode in ("I;16", "I;16B", "I;16L", "I"):
            values = np.asarray(image, dtype=np.float64)
            # 'I' holds 16-bit PNGs in some Pillow versions: scale by what the values fill
            values /= 65535.0 if "16" in mode or values.max() <= 65535 else 2.0 ** 31 - 1
            rgba = np.dstack([values] * 3 + [np.ones_like(values)])
            eight_bit = False
        elif mode == "F":
            values = np.asarray(image, dtype=np.float64)
            rgba = np.dstack([values] * 3 + [np.ones_like(values)])
            eight_bit = False
        else:
            # 8-bit colour (palette images included) is sRGB under 'auto'; grey is raw
            eight_bit = mode in ("RGB", "RGBA", "P", "PA", "CMYK", "YCbCr", "RGBX")
            rgba = np.asarray(image.convert("RGBA"), dtype=np.float64) / 255.0
    rgba = np.ascontiguousarray(rgba)
    rgba.setflags(write=False)
    return rgba, eight_bit


def srgb_to_linear(values: np.ndarray) -> np.ndarray:
    """The sRGB transfer function's inverse."""
    return np.where(values <= 0.04045, values / 12.92, ((values + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(values: np.ndarray) -> np.ndarray:
    """The sRGB transfer function."""
    values = np.clip(values, 0.0, 1.0)
    return np.where(values <= 0.0031308, values * 12.92, 1.055 * values ** (1 / 2.4) - 0.055)


def texture_values(texture: TextureInput) -> np.ndarray:
    """The texture's linear values as the material reads them: (h, w, channels), read-only.

    Cached by file (and its modification time), colour space, scale, bias and channels: a
    texture many materials share is decoded and converted once.
    """
    stamp = None if texture.data is not None else os.stat(texture.file).st_mtime_ns
    return _values(texture.file, texture.data, stamp, texture.color_space,
                   tuple(texture.scale), tuple(texture.bias), texture.channels)


@lru_cache(maxsize=64)
def _values(file: str, data: bytes | None, stamp, color_space: str, scale: tuple,
            bias: tuple, channels: str) -> np.ndarray:
    rgba, eight_bit = _decoded(file, data, stamp)
    rgba = rgba.copy()
    if color_space == "sRGB" or color_space == "auto" and eight_bit:
        rgba[..., :3] = srgb_to_linear(rgba[..., :3])
    if scale != (1.0, 1.0, 1.0, 1.0) or bias != (0.0, 0.0, 0.0, 0.0):
        rgba = rgba * np.asarray(scale) + np.asarray(bias)
    if channels in ("rgb", "rgba"):
        out = rgba[..., :len(channels)]
    else:
        out = rgba[..., _CHANNELS[channels]:_CHANNELS[channels] + 1]
    out = np.ascontiguousarray(out)
    out.setflags(write=False)
    return out


def _resized(values: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """``values`` (h, w, c) resampled to ``shape`` (nearest), when the sizes differ."""
    if values.shape[:2] == shape:
        return values
    rows = (np.arange(shape[0]) * values.shape[0] // shape[0])
    cols = (np.arange(shape[1]) * values.shape[1] // shape[1])
    return values[rows][:, cols]


def _channel(value, shape: tuple[int, int]) -> np.ndarray:
    """One channel (h, w) from a constant or a one-channel texture."""
    if isinstance(value, TextureInput):
        return _resized(texture_values(value), shape)[..., 0]
    return np.full(shape, float(value) if not isinstance(value, PrimvarInput) else 1.0)


def base_color_image(color, opacity) -> np.ndarray:
    """The base colour texture: RGB sRGB-encoded, alpha linear, uint8 (h, w, 4)."""
    sources = [v for v in (color, opacity) if isinstance(v, TextureInput)]
    shape = max((texture_values(t).shape[:2] for t in sources), key=lambda s: s[0] * s[1])
    if isinstance(color, TextureInput):
        rgb = _resized(texture_values(color), shape)
        rgb = np.repeat(rgb[..., :1], 3, axis=2) if rgb.shape[2] == 1 else rgb[..., :3]
    else:
        rgb = np.broadcast_to(np.asarray(color, dtype=np.float64)[:3], (*shape, 3))
    alpha = _channel(opacity, shape) if isinstance(opacity, TextureInput) else np.ones(shape)
    image = np.dstack([linear_to_srgb(rgb), np.clip(alpha, 0.0, 1.0)])
    return np.round(image * 255.0).astype(np.uint8)


def orm_image(occlusion, roughness, metallic) -> np.ndarray:
    """The packed occlusion / roughness / metallic texture (linear uint8, h x w x 3)."""
    sources = [v for v in (occlusion, roughness, metallic) if isinstance(v, TextureInput)]
    shape = max((texture_values(t).shape[:2] for t in sources), key=lambda s: s[0] * s[1])
    image = np.dstack([_channel(v, shape) for v in (occlusion, roughness, metallic)])
    return np.round(np.clip(image, 0.0, 1.0) * 255.0).astype(np.uint8)


def normal_image(normal: TextureInput) -> np.ndarray:
    """A tangent-space normal map in VTK's encoding ((n + 1) / 2, linear uint8)."""
    values = texture_values(normal)[..., :3]
    if values.shape[2] < 3:
        values = np.dstack([values[..., :1]] * 3)
    return np.round(np.clip((values + 1.0) / 2.0, 0.0, 1.0) * 255.0).astype(np.uint8)
