"""Gradient shading of volume samples on the CPU, as VTK's volume mapper defines it.

A sample's colour ``c`` becomes ``clamp(ka * ambient_light + kd * diffuse * c + ks *
specular)`` over the lights (or, for VTK's one-headlight case, ``ka * c + ...`` lit from
the eye); the normal is the data's central-difference gradient, each axis one texture step
``1 / (points - 1)`` either side, over the spacing. Written from VTK's documented shader
behaviour, not from our GLSL.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .rays import sample


@dataclass(frozen=True)
class ShadeSetup:
    """What gradient shading needs: the material, the lights, the camera's rotation.

    ``lights``: per switched-on light, ``(direction of travel, diffuse colour x intensity,
    specular colour x intensity)`` in world coordinates, and for a positional light also
    ``(position, attenuation (a, b, c), cone angle in degrees, exponent)``: its light
    travels from the position to the sample, scaled by ``1 / (a + b d + c d^2)`` and, for
    a cone up to 90 degrees, by ``cos ** exponent`` inside the cone (nothing outside), its
    highlight two-sided too, as VTK shades it. ``view_rotation``: the camera's
    world-to-view 3x3. ``headlight``: VTK's path for one headlight of intensity 1.
    """

    ambient: float = 0.1
    diffuse: float = 0.7
    specular: float = 0.2
    specular_power: float = 10.0
    lights: Sequence = ()
    ambient_light: Sequence[float] = (0.0, 0.0, 0.0)
    two_sided: bool = True
    headlight: bool = False
    view_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))

    def gradient(self, volume, points: np.ndarray) -> np.ndarray:
        """Central differences over ``points - 1`` steps of the texture, over the spacing."""
        dims = np.asarray(volume.dimensions, dtype=np.float64)
        reach = dims / np.maximum(dims - 1.0, 1.0)        # one texture step, in points
        spacing = np.linalg.norm(volume.world_from_index()[:3, :3], axis=0)
        grad = np.zeros_like(points)
        for axis in range(3):
            offset = np.zeros(3)
            offset[axis] = reach[axis]
            ahead = np.clip(points + offset, 0.0, dims - 1.0)
            behind = np.clip(points - offset, 0.0, dims - 1.0)
            grad[:, axis] = (sample(volume, ahead) - sample(volume, behind)) / spacing[axis]
        return grad

    def apply(self, volume, points: np.ndarray, rgb: np.ndarray,
              directions: np.ndarray) -> np.ndarray:
        """The shaded colours of samples at ``points`` (index space), rays ``directions``.

        ``directions``: each sample's ray, unit, in the world.
        """
        grad = self.gradient(volume, points)
        if self.headlight:
            return self._headlight(grad, rgb, directions)
        extent = volume.world_from_index()[:3, :3] @ np.diag(
            np.maximum(np.asarray(volume.dimensions, dtype=np.float64) - 1.0, 1.0))
        # VTK's normal: its texture-to-eye matrix, as uploaded (transposed), on the
        # gradient; in view space, then back to the world (dot products are the same).
        to_normal = self.view_rotation.T @ extent.T @ self.view_rotation
        normal = grad @ to_normal.T
        length = np.linalg.norm(normal, axis=1, keepdims=True)
        lit = length[:, 0] > 0
        normal = np.where(lit[:, None], normal / np.where(length > 0, length, 1.0), 0.0)
        diffuse = np.zeros_like(rgb)
        shine = np.zeros_like(rgb)
        world = points @ volume.world_from_index()[:3, :3].T + volume.world_from_index()[:3, 3]
        for light in self.lights:
            travel, light_diffuse, light_specular = (np.asarray(v, dtype=np.float64)
                                                     for v in light[:3])
            travel = np.broadcast_to(travel, normal.shape)
            weight = np.ones(len(normal))
            positional = len(light) > 3
            if positional:
                travel, weight = _point_light(world, travel[0], *light[3:])
            facing = np.sum(normal * travel, axis=1)
            if self.two_sided:
                facing = np.abs(facing)
            on = lit & (facing > 0)
            diffuse[on] += np.maximum(weight[on] * facing[on], 0.0)[:, None] * light_diffuse
            mirror = 2.0 * facing[:, None] * normal - travel
            mirror /= np.maximum(np.linalg.norm(mirror, axis=1, keepdims=True), 1e-300)
            rho = np.sum(directions * mirror, axis=1)
            if positional and self.two_sided:
                rho = np.abs(rho)
            glint = on & (rho > 0)
            shine[glint] += (weight[glint] * rho[glint] ** self.specular_power)[:, None] \
                * light_specular
        shaded = self.ambient * np.asarray(self.ambient_light) + self.diffuse * diffuse * rgb \
            + self.specular * shine
        return np.clip(shaded, 0.0, 1.0)

    def _headlight(self, grad, rgb, directions):
        """VTK's one-headlight path: lit from the eye, the normal the gradient's own."""
        _, light_diffuse, light_specular = self.lights[0]
        length = np.linalg.norm(grad, axis=1, keepdims=True)
        normal = np.where(length > 0, grad / np.where(length > 0, length, 1.0), 0.0)
        facing = np.sum(normal * directions, axis=1)
        mirror = 2.0 * facing[:, None] * normal - directions
        mirror /= np.maximum(np.linalg.norm(mirror, axis=1, keepdims=True), 1e-300)
        rho = np.sum(mirror * directions, axis=1)
        if self.two_sided:
            facing = np.abs(facing)
        shaded = self.ambient * rgb
        on = facing > 0
        shaded[on] += self.diffuse * facing[on, None] * np.asarray(light_diffuse) * rgb[on] \
            + self.specular * (np.maximum(rho[on], 0.0) ** self.specular_power)[:, None] \
            * np.asarray(light_specular)
        return np.clip(shaded, 0.0, 1.0)


def _point_light(world: np.ndarray, axis: np.ndarray, position, attenuation, cone: float,
                 exponent: float) -> tuple[np.ndarray, np.ndarray]:
    """A positional light's unit travel to each sample and its weight there (VTK's)."""
    away = world - np.asarray(position, dtype=np.float64)
    distance = np.linalg.norm(away, axis=1)
    travel = np.where(distance[:, None] > 0, away / np.maximum(distance, 1e-300)[:, None],
                      axis)
    a, b, c = (float(v) for v in attenuation)
    weight = 1.0 / (a + b * distance + c * distance**2)
    if cone <= 90.0:
        along = travel @ np.asarray(axis, dtype=np.float64)
        inside = along >= np.cos(np.radians(cone))
        weight = np.where(inside, weight * np.abs(along) ** exponent, 0.0)
    return travel, weight
