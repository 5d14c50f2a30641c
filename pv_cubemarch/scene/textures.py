"""Texture images for VTK's PBR from a material's texture inputs, as UsdUVTexture reads them.

A file is decoded as stored (8-bit or 16-bit, reduced to fit the GL limit and a byte
budget), then to float32 in [0, 1], converted from sRGB to linear when its colour space
says so (``auto``: 8-bit images of three or four channels), scaled and biased, and its
channels chosen; the result is packed for VTK: base colour (sRGB-encoded, alpha from the
opacity), ORM (occlusion, roughness, metallic in R, G, B) and normal maps (linear).
"""

from __future__ import annotations

import io
import os
import stat
from functools import lru_cache

import numpy as np
from PIL import Image

from ..core.budgets import budget_from_env
from .materials import PrimvarInput, TextureInput

_CHANNELS = {"r": 0, "g": 1, "b": 2, "a": 3}
#: The most bytes one decoded texture keeps (as 8-bit RGBA: 4096 x 4096 texels); a larger
#: image is reduced by a whole factor, with a note. The environment variable raises it.
TEXTURE_BYTES_ENV = "PV_CUBEMARCH_TEXTURE_MAX_BYTES"
DEFAULT_TEXTURE_BYTES = 64 << 20
#: The widest 2D texture every OpenGL we run on takes (llvmpipe's, most GPUs' least).
MAX_TEXTURE_SIDE = 16384


class TextureError(ValueError):
    """An image that cannot be a texture: not an image, a decompression bomb, too large."""


def texture_budget() -> int:
    """The bytes one decoded texture may keep (``PV_CUBEMARCH_TEXTURE_MAX_BYTES``, 64 MiB)."""
    return max(budget_from_env(TEXTURE_BYTES_ENV, DEFAULT_TEXTURE_BYTES, TextureError), 4)


def _reduction(size: tuple[int, int], texel_bytes: int, budget: int) -> int:
    """The least whole factor that brings an image within the budget and the GL limit."""
    width, height = size
    factor = 1
    while factor < max(width, height) and (
            max(width, height) > MAX_TEXTURE_SIDE * factor
            or -(-width // factor) * -(-height // factor) * texel_bytes > budget):
        factor += 1
    return factor


@lru_cache(maxsize=16)
def _decoded(file: str, data: bytes | None, stamp: int | None, budget: int
             ) -> tuple[np.ndarray, bool, str | None]:
    """The texels as stored (rows top-down), whether 8-bit, and a note if reduced.

    8-bit images come as RGBA uint8 (h, w, 4), 16-bit ones as grey uint16 (h, w, 1), float
    ones as float32 (h, w, 1): never wider than the file. Pillow's decompression-bomb limit
    stays on; an image over ``budget`` bytes (as kept) or over the GL limit is reduced.
    ``stamp`` (the file's modification time) keys the cache, so an edited file is read again.
    A path to anything but a regular file (a device, a pipe) is refused unread.
    """
    if data is None and not stat.S_ISREG(os.stat(file).st_mode):
        raise TextureError(f"{file!r} is not a regular file (a device or a pipe): not read")
    try:
        with Image.open(io.BytesIO(data) if data is not None else file) as image:
            mode = image.mode
            sixteen = mode in ("I;16", "I;16B", "I;16L", "I")
            texel = 2 if sixteen else 4
            factor = _reduction(image.size, texel, budget)
            if factor > 1 and image.format == "JPEG":
                image.draft(image.mode, (image.size[0] // factor, image.size[1] // factor))
            image.load()
            note = None
            if factor > 1:
                original = image.size
                if image.mode in ("P", "PA"):       # reduce() averages colours, not indices
                    image = image.convert("RGBA")
                if max(image.size) > MAX_TEXTURE_SIDE or \
                        image.size[0] * image.size[1] * texel > budget:
                    image = image.reduce(factor) if not sixteen else image.resize(
                        (-(-image.size[0] // factor), -(-image.size[1] // factor)),
                        Image.Resampling.NEAREST)   # 16-bit modes: no reduce()
                note = (f"a {original[0]}x{original[1]} texture is drawn at {image.size[0]}x"
                        f"{image.size[1]} (the GL limit of {MAX_TEXTURE_SIDE} texels a side "
                        f"and {budget} bytes per texture; {TEXTURE_BYTES_ENV} raises the "
                        "latter)")
            if sixteen:
                values = np.asarray(image)
                # 'I' holds 16-bit PNGs in some Pillow versions: kept as 16-bit when it fits
                texels = (values.astype(np.uint16) if values.max(initial=0) <= 65535
                          else (values / (2.0 ** 31 - 1)).astype(np.float32))[..., None]
                eight_bit = False
            elif mode == "F":
                texels = np.asarray(image, dtype=np.float32)[..., None]
                eight_bit = False
            else:
                # 8-bit colour (palette images included) is sRGB under 'auto'; grey is raw
                eight_bit = mode in ("RGB", "RGBA", "P", "PA", "CMYK", "YCbCr", "RGBX")
                texels = np.asarray(image.convert("RGBA"), dtype=np.uint8)
    except Image.DecompressionBombError as exc:
        raise TextureError(f"a decompression bomb ({exc})") from exc
    except MemoryError as exc:
        raise TextureError("decoding it needs more memory than is free") from exc
    texels = np.ascontiguousarray(texels)
    texels.setflags(write=False)
    return texels, eight_bit, note


def unit_rgba(texels: np.ndarray) -> np.ndarray:
    """Stored texels as float32 RGBA in [0, 1] (grey as (v, v, v, 1))."""
    if texels.dtype == np.uint8:
        return texels.astype(np.float32) / np.float32(255.0)
    grey = texels[..., 0].astype(np.float32)
    if texels.dtype == np.uint16:
        grey /= np.float32(65535.0)
    return np.dstack([grey, grey, grey, np.ones_like(grey)])


def _stamp(texture: TextureInput) -> int | None:
    """What keys the caches besides the file name: its modification time (None for bytes)."""
    return None if texture.data is not None else os.stat(texture.file).st_mtime_ns


def _stored(texture: TextureInput) -> tuple[np.ndarray, bool, str | None]:
    return _decoded(texture.file, texture.data, _stamp(texture), texture_budget())


def stored_texels(path: str) -> tuple[np.ndarray, bool, str | None]:
    """An image file's texels as stored, whether 8-bit, and a note (see :func:`_decoded`)."""
    return _decoded(str(path), None, os.stat(path).st_mtime_ns, texture_budget())


def texture_note(texture: TextureInput) -> str | None:
    """What was done to fit the texture (reduced to the GL limit or the budget), if anything."""
    return _stored(texture)[2]


def srgb_to_linear(values: np.ndarray) -> np.ndarray:
    """The sRGB transfer function's inverse."""
    return np.where(values <= 0.04045, values / 12.92, ((values + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(values: np.ndarray) -> np.ndarray:
    """The sRGB transfer function."""
    values = np.clip(values, 0.0, 1.0)
    return np.where(values <= 0.0031308, values * 12.92, 1.055 * values ** (1 / 2.4) - 0.055)


def texture_values(texture: TextureInput) -> np.ndarray:
    """The texture's linear values as the material reads them: (h, w, channels), read-only.

    float32; cached by file (and its modification time), colour space, scale, bias and
    channels: a texture a few materials share is decoded and converted once.
    """
    return _values(texture.file, texture.data, _stamp(texture), texture.color_space,
                   tuple(texture.scale), tuple(texture.bias), texture.channels)


@lru_cache(maxsize=8)
def _values(file: str, data: bytes | None, stamp, color_space: str, scale: tuple,
            bias: tuple, channels: str) -> np.ndarray:
    texels, eight_bit, _note = _decoded(file, data, stamp, texture_budget())
    rgba = unit_rgba(texels)
    if color_space == "sRGB" or color_space == "auto" and eight_bit:
        rgba[..., :3] = srgb_to_linear(rgba[..., :3])
    if scale != (1.0, 1.0, 1.0, 1.0) or bias != (0.0, 0.0, 0.0, 0.0):
        rgba = rgba * np.asarray(scale, np.float32) + np.asarray(bias, np.float32)
    if channels in ("rgb", "rgba"):
        out = rgba[..., :len(channels)]
    else:
        out = rgba[..., _CHANNELS[channels]:_CHANNELS[channels] + 1]
    out = np.ascontiguousarray(out)
    out.setflags(write=False)
    return out


def _srgb_bytes(texture: TextureInput) -> np.ndarray | None:
    """The file's own 8-bit sRGB colour, where the material reads it unchanged; else None."""
    texels, eight_bit, _note = _stored(texture)
    unchanged = (texels.dtype == np.uint8 and eight_bit and texture.channels in ("rgb", "rgba")
                 and texture.color_space in ("sRGB", "auto")
                 and tuple(texture.scale) == (1.0, 1.0, 1.0, 1.0)
                 and tuple(texture.bias) == (0.0, 0.0, 0.0, 0.0))
    return texels[..., :3] if unchanged else None


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
    return np.full(shape, float(value) if not isinstance(value, PrimvarInput) else 1.0,
                   np.float32)


def base_color_image(color, opacity) -> np.ndarray:
    """The base colour texture: RGB sRGB-encoded, alpha linear, uint8 (h, w, 4).

    A plain sRGB file read as it is (the common case) is passed on as its own bytes.
    """
    if isinstance(color, TextureInput) and not isinstance(opacity, TextureInput):
        rgb = _srgb_bytes(color)
        if rgb is not None:
            return np.dstack([rgb, np.full(rgb.shape[:2], 255, np.uint8)])
    sources = [v for v in (color, opacity) if isinstance(v, TextureInput)]
    shape = max((texture_values(t).shape[:2] for t in sources), key=lambda s: s[0] * s[1])
    if isinstance(color, TextureInput):
        rgb = _resized(texture_values(color), shape)
        rgb = np.repeat(rgb[..., :1], 3, axis=2) if rgb.shape[2] == 1 else rgb[..., :3]
    else:
        rgb = np.broadcast_to(np.asarray(color, dtype=np.float32)[:3], (*shape, 3))
    alpha = _channel(opacity, shape) if isinstance(opacity, TextureInput) else \
        np.ones(shape, np.float32)
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
