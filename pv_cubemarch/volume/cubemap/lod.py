"""Cube-map imposter bookkeeping (visible faces, level of detail), as plain numpy.

The visible-face mask says which interior faces of the volume's cube the eye
can see, so only those are marched; the adaptive LOD turns the cube's projected size into a
cube-map resolution, a sample count and a MIP level, under the user's caps. The passes of
the cube-map technique use these per volume and per frame; they are kept apart here so the
formulas can be checked against hand-computed cases.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Cube-map face order (OpenGL's): +X, -X, +Y, -Y, +Z, -Z.
FACES = ("+x", "-x", "+y", "-y", "+z", "-z")

#: The cube's 12 edges as pairs of corner indices; corner k has coordinates
#: (-1 or +1 by bit 0, bit 1, bit 2 of k) in the cube's local [-1, 1] space.
EDGES = tuple((a, a | bit) for bit in (1, 2, 4) for a in range(8) if not a & bit)


def cube_corners() -> np.ndarray:
    """The 8 corners of the local cube [-1, 1]^3, ordered as :data:`EDGES` expects."""
    return np.array([[1.0 if k & bit else -1.0 for bit in (1, 2, 4)] for k in range(8)])


def visible_face_mask(eye_local) -> int:
    """Bit ``i`` set when interior face ``i`` (order of :data:`FACES`) faces the eye.

    The face at +1 on an axis is seen from its inner side when the eye's
    coordinate is below 1, the face at -1 when it is above -1. An eye inside sees all six.
    """
    eye = np.asarray(eye_local, dtype=np.float64)
    mask = 0
    for face in range(6):
        coordinate = eye[face // 2]
        visible = coordinate > -1.0 if face & 1 else coordinate < 1.0
        mask |= int(visible) << face
    return mask


@dataclass(frozen=True)
class LodChoice:
    """What the LOD step chose for one volume in one frame (inspectable per frame)."""

    ideal_size: float     # S_ideal, texels per face edge the projection asks for
    ideal_samples: float  # N_ideal
    samples: int          # N, after the user's cap
    size: float           # S, the resolution matching N
    level: int            # MIP level of the face texture actually marched
    level_size: int       # texels per face edge at that level


def choose_lod(corners_px, max_samples: int, finest_size: int, upscale: float = 1.0,
               sample_factor: float = 1.0) -> LodChoice:
    """The adaptive LOD: cube-map size, sample count and MIP level from projected corners.

    Parameters
    ----------
    corners_px : array_like
        ``(8, 2)`` window positions of the cube's corners (see :func:`cube_corners`).
    max_samples : int
        ``N_max``, the most samples a ray may take.
    finest_size : int
        ``S_0``, texels per face edge at MIP level 0 (a power of two).
    upscale : float
        ``k_u``: screen pixels per cube-map texel (above 1 marches fewer texels).
    sample_factor : float
        ``k_c``: samples per texel along the cube's diagonal.
    """
    corners = np.asarray(corners_px, dtype=np.float64)
    if corners.shape != (8, 2) or not np.isfinite(corners).all():
        raise ValueError("corners_px must be 8 finite window positions (an (8, 2) array).")
    if max_samples < 1 or finest_size < 1 or finest_size & (finest_size - 1):
        raise ValueError("max_samples must be >= 1 and finest_size a power of two.")
    if upscale <= 0 or sample_factor <= 0:
        raise ValueError("upscale and sample_factor must be positive.")
    longest = max(float(np.linalg.norm(corners[b] - corners[a])) for a, b in EDGES)
    ideal_size = longest / upscale
    ideal_samples = sample_factor * ideal_size / math.sqrt(3.0)
    samples = max(1, min(math.ceil(ideal_samples), int(max_samples)))
    size = math.sqrt(3.0) * min(ideal_samples, samples) / sample_factor
    levels = int(math.log2(finest_size))
    # the coarsest level whose faces still hold S texels per edge
    level = 0 if size <= 0 else int(math.floor(math.log2(finest_size / size)))
    level = min(max(level, 0), levels)
    return LodChoice(ideal_size, ideal_samples, samples, size, level, finest_size >> level)


def project_corners(world_from_local, view_projection, window_size) -> np.ndarray | None:
    """Window positions of the cube's corners, or ``None`` if one lies behind the eye.

    (With a corner behind the eye the projected size is unbounded: use the finest level.)
    """
    corners = np.column_stack([cube_corners(), np.ones(8)])
    clip = corners @ (np.asarray(view_projection) @ np.asarray(world_from_local)).T
    if (clip[:, 3] <= 0).any():
        return None
    ndc = clip[:, :2] / clip[:, 3:4]
    width, height = window_size
    return np.column_stack([(ndc[:, 0] + 1) * 0.5 * width, (ndc[:, 1] + 1) * 0.5 * height])
