"""The CPU reference of a channel volume whose channels add their light.

Each channel is rendered alone, as the emission/absorption reference renders one volume,
over black and over white: the first is its light, the difference its transmittance. The
image is their light summed (clamped to white) plus what lies behind seen through every
channel. Numpy only.
"""

from __future__ import annotations

import numpy as np


def render_additive_channels(group, render_emission_absorption, camera, size,
                             background=(0.0, 0.0, 0.0), opaque_color=None,
                             **options) -> np.ndarray:
    """``(h, w, 3)`` image of ``group``'s channels added (``channel_blending='additive'``).

    ``render_emission_absorption`` renders one channel (the reference of one volume) with
    ``options``, the same for every channel.
    """
    light, transmittance = None, None
    for member in group.members:
        black = render_emission_absorption(member, camera, size, background=(0, 0, 0),
                                           opaque_color=_filled(opaque_color, 0.0), **options)
        white = render_emission_absorption(member, camera, size, background=(1, 1, 1),
                                           opaque_color=_filled(opaque_color, 1.0), **options)
        seen = (white - black)[..., :1]
        light = black if light is None else light + black
        transmittance = seen if transmittance is None else transmittance * seen
    behind = np.broadcast_to(np.asarray(background, dtype=np.float64), light.shape) \
        if opaque_color is None else np.asarray(opaque_color, dtype=np.float64).reshape(
            light.shape)
    return np.minimum(light, 1.0) + transmittance * behind


def _filled(opaque_color, level: float):
    """An opaque colour of one grey level where opaque geometry is given, else None."""
    return None if opaque_color is None else np.full(np.shape(opaque_color), level)
