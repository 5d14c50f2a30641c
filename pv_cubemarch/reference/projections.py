"""The blend modes other than composite, on the CPU: the right image of each.

Each pixel's ray is walked in fine steps (sampled as the volume's ``interpolation`` says);
a mode is one small class that takes the samples of every step and leaves each ray's
premultiplied colour, as VTK's volume mapper defines the mode:

- ``maximum`` / ``minimum``: the extreme value along the ray, drawn with the colour and
  the opacity per unit distance that :mod:`.transfer` derives for it (an RGBA volume: the
  extreme alpha, with the colour of the sample that holds it);
- ``average``: the mean over the samples of opacity x value normalised over the data's
  range, an opaque grey level (no sample: the background); with an ``average_range``
  (data units) only the samples whose value lies in it count, as VTK's
  ``AverageIPScalarRange``;
- ``additive``: the sum of opacity x normalised value x step / ``opacity_unit_distance``,
  an opaque grey level clamped to 1;
- ``isosurface``: each level the ray crosses between two samples, with that level's colour
  and opacity, composited front to back.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..core.camera import Camera
from .rays import (
    checked_pixels,
    clip_interval,
    data_per_world,
    index_rays,
    sample,
    sample_colors,
)
from .transfer import medium


def _opacity(volume, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Colour and opacity per unit distance (the opacity curve's own value) of ``values``."""
    rgb, sigma = medium(volume, values)
    return rgb, -np.expm1(-sigma * _unit(volume))


def _unit(volume) -> float:
    """The opacity unit distance the user gave (1 for a bare table)."""
    return volume.transfer.spec.opacity_unit_distance if volume.transfer.spec else 1.0


class _Extreme:
    """``maximum`` / ``minimum``: the extreme value, drawn with its colour and opacity.

    An RGBA volume's value is its alpha; the ray keeps the colour of the sample that holds
    the extreme (the first of equals along the ray, as VTK keeps it).
    """

    def __init__(self, volume, count: int, largest: bool):
        self.volume, self.largest = volume, largest
        self.extreme = np.full(count, -np.inf if largest else np.inf)
        self.colors = np.zeros((count, 3)) if getattr(volume, "colors", None) is not None \
            else None

    def add(self, rays, values, lengths, points=None):
        held = self.extreme[rays]
        beyond = values > held if self.largest else values < held
        self.extreme[rays[beyond]] = values[beyond]
        if self.colors is not None:
            self.colors[rays[beyond]] = sample_colors(self.volume, points[beyond])

    def finish(self):
        hit = np.isfinite(self.extreme)
        rgb, alpha = _opacity(self.volume, np.where(hit, self.extreme, 0.0))
        if self.colors is not None:
            rgb = self.colors
        alpha = np.where(hit, alpha, 0.0)
        return rgb * alpha[:, None], alpha


class _Weighted:
    """``average`` / ``additive``: opacity-weighted values normalised over the data's range."""

    def __init__(self, volume, count: int, additive: bool, kept=None):
        self.volume, self.additive = volume, additive
        offset = float(getattr(volume, "value_offset", 0))   # stored = data - offset
        self.kept = (-np.inf, np.inf) if kept is None else tuple(float(v) - offset
                                                                 for v in kept)
        finite = volume.values[np.isfinite(volume.values)]
        self.low = float(finite.min()) if finite.size else 0.0
        self.width = float(finite.max()) - self.low if finite.size else 0.0
        self.total = np.zeros(count)
        self.samples = np.zeros(count)

    def add(self, rays, values, lengths, points=None):
        inside = (values >= self.kept[0]) & (values <= self.kept[1])
        rays, values, lengths = rays[inside], values[inside], np.broadcast_to(
            lengths, inside.shape)[inside]
        _, alpha = _opacity(self.volume, values)
        level = (values - self.low) / self.width if self.width > 0 else np.zeros_like(values)
        weight = lengths / _unit(self.volume) if self.additive else 1.0
        self.total[rays] += alpha * level * weight
        self.samples[rays] += 1.0

    def finish(self):
        if self.additive:
            grey, drawn = self.total, self.samples > 0
        else:
            grey = self.total / np.maximum(self.samples, 1.0)
            drawn = self.samples > 0
        alpha = drawn.astype(np.float64)
        return np.clip(grey, 0.0, 1.0)[:, None] * alpha[:, None] * np.ones(3), alpha


class _Isosurfaces:
    """``isosurface``: the levels crossed between samples, composited front to back."""

    def __init__(self, volume, count: int, levels: Sequence[float], shade=None,
                 directions=None):
        self.volume = volume
        self.shade, self.directions = shade, directions   # shading, with each ray's way
        self.levels = np.sort(np.asarray(levels, dtype=np.float64))
        self.previous = np.full(count, np.nan)
        self.rgb = np.zeros((count, 3))
        self.alpha = np.zeros(count)
        self.level_rgb, self.level_alpha = _opacity(volume, self.levels)

    def add(self, rays, values, lengths, points=None):
        before = self.previous[rays]
        up, down = values > before, values < before   # False where there is no `before`
        count = len(self.levels)
        for i in range(count):
            for going, index in ((up, i), (down, count - 1 - i)):
                level = self.levels[index]
                if going is up:
                    crossed = up & (before < level) & (level < values)
                else:
                    crossed = down & (level <= before) & (values < level)
                where = rays[crossed]
                weight = (1.0 - self.alpha[where]) * self.level_alpha[index]
                color = np.broadcast_to(self.level_rgb[index], (len(where), 3))
                if self.shade is not None:   # by the gradient at the sample that crossed
                    color = self.shade.apply(self.volume, points[crossed], color,
                                             self.directions[where])
                self.rgb[where] += weight[:, None] * color
                self.alpha[where] += weight
        self.previous[rays] = values

    def finish(self):
        return self.rgb, self.alpha


def blend_accumulator(volume, count: int, blending: str, isosurfaces=(), shade=None,
                      directions=None, average_range=None):
    """The state of ``count`` rays under ``blending`` (``add`` per step, then ``finish``).

    ``shade`` (a :class:`~.volume_shading.ShadeSetup`, with each ray's unit world
    ``directions``) shades the isosurfaces.
    """
    if blending in ("maximum", "minimum"):
        return _Extreme(volume, count, blending == "maximum")
    if blending in ("average", "additive"):
        return _Weighted(volume, count, blending == "additive",
                         average_range if blending == "average" else None)
    if blending == "isosurface":
        if not len(isosurfaces):
            raise ValueError("blending='isosurface' needs its levels: pass isosurfaces=.")
        return _Isosurfaces(volume, count, isosurfaces, shade, directions)
    raise ValueError(f"blending={blending!r} has no reference here; composite is "
                     "render_emission_absorption.")


def render_blended(volume, camera: Camera, size: Sequence[int] = (256, 256),
                   blending: str = "maximum", isosurfaces: Sequence[float] = (),
                   background: Sequence[float] = (0.0, 0.0, 0.0),
                   step_voxels: float = 0.1,
                   near: float | None = None,
                   opaque_depth: np.ndarray | None = None,
                   opaque_color: np.ndarray | None = None,
                   clip_planes: Sequence | None = None, shade=None,
                   average_range: Sequence[float] | None = None,
                   pixels: tuple | None = None) -> np.ndarray:
    """The ``blending`` image of ``volume`` (a VolumeModel): ``(h, w, 3)`` floats.

    ``isosurfaces``: the levels of ``'isosurface'``, in the volume's stored units.
    ``opaque_depth`` / ``opaque_color``: per-pixel distance to opaque meshes and their
    colour; rays stop there, the blend is drawn over that colour. ``clip_planes``: world
    ``(origin, normal)`` pairs cutting the volume (see :func:`.rays.clip_interval`).
    ``shade``: a :class:`~.volume_shading.ShadeSetup` shading the isosurfaces, as VTK's
    ``shade=True`` shades them. ``average_range``: the values (data units) ``'average'``
    takes. ``pixels``: ``(rows, columns)`` of the pixels to trace instead (a sample, rows
    from the top), returned as a ``(1, n, 3)`` image.
    """
    width, height = (int(v) for v in size)
    origins, directions = camera.rays((width, height))
    if pixels is not None:
        rows, columns = checked_pixels(pixels, None, width, height)
        origins, directions = origins[rows, columns][None], directions[rows, columns][None]
        height, width = 1, len(rows)
    origins, directions = origins.reshape(-1, 3), directions.reshape(-1, 3)
    o_idx, d_idx, t0, t1 = index_rays(volume, origins, directions)
    t0 = np.maximum(t0, 0.0)
    if opaque_depth is not None:
        t1 = np.minimum(t1, np.asarray(opaque_depth, dtype=np.float64).reshape(-1))
    if near is not None:
        forward = camera.basis()[2]
        t0 = np.maximum(t0, near / np.maximum(directions @ forward, 1e-12))
    t0, t1 = clip_interval(origins, directions, t0, t1, clip_planes)
    step = float(step_voxels) * float(np.linalg.norm(volume.world_from_index()[:3, :3],
                                                     axis=0).min())
    if shade is not None and blending != "isosurface":
        raise ValueError(f"shade shades blending='isosurface' here; blending={blending!r} "
                         "is drawn unshaded (composite: render_emission_absorption).")
    unit = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    state = blend_accumulator(volume, len(origins), blending, isosurfaces, shade, unit,
                              average_range)
    scale = data_per_world(volume, directions)   # lengths in the data's own units
    active = np.nonzero(t1 > t0)[0]
    t = t0[active].copy()
    while active.size:
        end = np.minimum(t + step, t1[active])
        middle = 0.5 * (t + end)
        points = o_idx[active] + d_idx[active] * middle[:, None]
        state.add(active, sample(volume, points), (end - t) * scale[active], points)
        t = end
        keep = t < t1[active]
        active, t = active[keep], t[keep]
    rgb, alpha = state.finish()
    behind = np.asarray(background, float) if opaque_color is None else np.asarray(
        opaque_color, dtype=np.float64).reshape(-1, 3)
    image = rgb + (1.0 - alpha[:, None]) * behind
    return image.reshape(height, width, 3)
