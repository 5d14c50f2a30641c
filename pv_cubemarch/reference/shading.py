"""The lighting of opaque hits shared by the voxel and surface references (and shaders)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..models.lights import VolumeLight


def blinn_phong(color: np.ndarray, normals: np.ndarray, points: np.ndarray,
                toward_eye: np.ndarray, lights: Sequence[VolumeLight], shading: str,
                ambient: float, specular: float, specular_power: float, *,
                diffuse_weight: float) -> np.ndarray:
    """``color * (ambient + diffuse_weight * sum light * max(n.l, 0))`` (+ the highlight).

    The terms as VTK's lighting of a mesh weighs them (an ambient term added, not mixed).

    ``shading``: ``'unlit'`` (``color`` as is), ``'flat'`` (Lambert) or ``'blinn'`` (plus
    ``specular * sum light * max(n.h, 0) ** specular_power``, ``h`` halfway between the
    light and the eye). Per row: ``(n, 3)`` colours, unit normals, world points and unit
    vectors toward the eye; directional and point lights in world coordinates. Not clipped.
    """
    if shading == "unlit":
        return color
    diffuse = np.zeros_like(color)
    shine = np.zeros_like(color)
    for light in lights:
        if light.kind == "point":
            toward = np.asarray(light.position, dtype=np.float64) - points
        else:
            toward = np.broadcast_to(-np.asarray(light.direction, dtype=np.float64),
                                     points.shape)
        toward = toward / np.linalg.norm(toward, axis=1, keepdims=True)
        diffuse += np.clip(np.sum(normals * toward, axis=1), 0, None)[:, None] \
            * light.radiance
        if shading == "blinn":
            half = toward + toward_eye
            half /= np.maximum(np.linalg.norm(half, axis=1, keepdims=True), 1e-300)
            shine += np.clip(np.sum(normals * half, axis=1), 0, None)[:, None] \
                ** specular_power * light.radiance
    return color * (ambient + diffuse_weight * diffuse) + specular * shine
