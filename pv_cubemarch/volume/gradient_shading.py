"""Gradient shading (``shade=True``): the renderer's lights on the data's gradient, as VTK.

:class:`GradientShading` gives the marching shaders (``gradient_shading.glsl``) the
material and, at every draw, the renderer's switched-on lights and the normal transform
VTK's volume mapper uses, so a volume shades as ``pl.add_volume(..., shade=True)`` does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.declared import option
from ..core.errors import VolumeDataWarning
from ..core.user_warnings import warn_user
from ..gl.bindings import FloatArray
from ..gl.lights import is_headlight
from ..models.lights import light_placement

#: Most lights a shaded volume reads (VTK's light kit has five).
MAX_SHADE_LIGHTS = 8
#: Floats per light in ``cm_shadeLights`` (gradient_shading.glsl says which).
SHADE_FLOATS = 18


@dataclass(frozen=True)
class ShadeMaterial:
    """VTK's volume property terms (their defaults are the options' declared ones)."""

    ambient: float
    diffuse: float
    specular: float
    specular_power: float


def _switched_on(renderer) -> list:
    lights = renderer.GetLights()
    lights.InitTraversal()
    found = []
    for _ in range(lights.GetNumberOfItems()):
        light = lights.GetNextItem()
        if light.GetSwitch():
            found.append(light)
    return found


def _travel(light, camera) -> np.ndarray:
    """The unit direction a light's rays travel in the world.

    A positional light's too: toward its focal point.
    """
    position, focal = light_placement(light, camera)
    direction = focal - position
    length = float(np.linalg.norm(direction))
    return direction / length if length > 0 else np.array([0.0, 0.0, -1.0])


class GradientShading:
    """The shading of one volume: its material, and the renderer whose lights it reads."""

    def __init__(self, renderer, model, material: ShadeMaterial):
        self.renderer = renderer
        self.model = model
        self.material = material

    @property
    def defines(self) -> dict:
        """The shader's switches."""
        return {"CM_SHADE": True, "CM_SHADE_LIGHTS": MAX_SHADE_LIGHTS,
                "CM_SHADE_FLOATS": SHADE_FLOATS}

    def lights(self) -> list:
        """The renderer's switched-on lights (at most :data:`MAX_SHADE_LIGHTS`).

        Positional (point and spot) lights included.
        """
        return _switched_on(self.renderer)[:MAX_SHADE_LIGHTS]

    def headlight_path(self) -> bool:
        """Whether VTK takes its single-headlight path: one light, a headlight, intensity 1."""
        lights = self.lights()
        return len(lights) == 1 and is_headlight(lights[0]) and \
            float(lights[0].GetIntensity()) == 1.0

    def packed_lights(self) -> FloatArray:
        """Per light: its direction of travel, diffuse and specular colour x intensity.

        And a positional light's world position, attenuation, cone angle and exponent.
        """
        camera = self.renderer.GetActiveCamera()
        packed = np.zeros((MAX_SHADE_LIGHTS, SHADE_FLOATS))
        for index, light in enumerate(self.lights()):
            intensity = float(light.GetIntensity())
            packed[index, :3] = _travel(light, camera)
            packed[index, 3:6] = np.asarray(light.GetDiffuseColor()) * intensity
            packed[index, 6:9] = np.asarray(light.GetSpecularColor()) * intensity
            if light.GetPositional():
                packed[index, 9:12] = light_placement(light, camera)[0]
                packed[index, 12:15] = light.GetAttenuationValues()
                packed[index, 15:] = (light.GetConeAngle(), light.GetExponent(), 1.0)
        return FloatArray(packed.ravel())

    def ambient_light(self) -> tuple:
        """The lights' ambient colours times their intensities, summed."""
        total = np.zeros(3)
        for light in self.lights():
            total += np.asarray(light.GetAmbientColor()) * float(light.GetIntensity())
        return tuple(total)

    def normal_matrix(self) -> np.ndarray:
        """What VTK's multi-light path turns the gradient into its normal by, in the world.

        VTK multiplies the gradient (per texture axis, over the spacing) by its
        texture-to-eye matrix as uploaded (the transpose of the geometric one): in view
        space ``(world_from_index diag(points - 1))^T R g``, ``R`` the camera's rotation;
        here turned back to the world by ``R^T``. For a cube of equal sides it is the
        gradient's own direction.
        """
        view = self.renderer.GetActiveCamera().GetViewTransformMatrix()
        rotation = np.array([[view.GetElement(i, j) for j in range(3)] for i in range(3)])
        scale = np.diag([max(int(n) - 1, 1) for n in self.model.dimensions])
        extent = self.model.world_from_index()[:3, :3] @ scale
        return rotation.T @ extent.T @ rotation

    def bind(self, target) -> None:
        """Give ``target`` (bindings or a pass) the material and, per draw, the lights."""
        target.set_uniform("cm_shadeMaterial", lambda: (
            self.material.ambient, self.material.diffuse, self.material.specular,
            self.material.specular_power))   # read per draw: vol.prop.ambient = ... follows
        target.set_uniform("cm_spacing", tuple(float(v) for v in np.linalg.norm(
            self.model.world_from_index()[:3, :3], axis=0)))
        target.set_uniform("cm_shadeLights", self.packed_lights)
        target.set_uniform("cm_shadeAmbient", self.ambient_light)
        target.set_uniform("cm_shadeLightCount", lambda: len(self.lights()))
        target.set_uniform("cm_shadeHeadlight", lambda: int(self.headlight_path()))
        target.set_uniform("cm_twoSided", lambda: int(self.renderer.GetTwoSidedLighting()))
        target.set_uniform("cm_shadeNormal", self.normal_matrix)


#: The blend modes gradient shading lights (VTK shades these two).
SHADED_BLENDS = ("composite", "isosurface")


def gradient_shading(plotter, model, shade: bool, lights, blending: str,
                     terms: dict) -> GradientShading | None:
    """The shading ``add_volume(shade=...)`` asks for, its terms checked; None unshaded.

    ``terms``: ``ambient``, ``diffuse``, ``specular``, ``specular_power`` as given (None:
    VTK's default).
    """
    given = {name: value for name, value in terms.items() if value is not None}
    for name, value in given.items():   # checked before anything is built, shaded or not
        option("volume", name).check(value)
    if not shade:
        if given:   # as PyVista draws them: set, and unused (its property's, shade off)
            warn_user(f"{', '.join(given)} shade{'s' if len(given) == 1 else ''} the volume "
                      "with shade=True only; without it the volume is drawn unshaded, as "
                      "PyVista draws it: pass shade=True, or leave "
                      f"{'it' if len(given) == 1 else 'them'} out.", VolumeDataWarning)
        return None
    if lights is not None:
        raise ValueError("shade=True lights each sample by the renderer's lights on the "
                         "data's gradient; lights= is the light map's shadowed lighting. "
                         "Use one of the two.")
    if blending not in SHADED_BLENDS:
        raise ValueError(f"shade=True shades composite and isosurface blending; "
                         f"blending={blending!r} draws unshaded values. Leave shade out, or "
                         "use 'composite' or 'isosurface'.")
    if isinstance(getattr(model, "members", None), list):
        raise ValueError("shade=True shades one volume; volumes marched jointly are not "
                         "shaded (add them one by one).")
    material = ShadeMaterial(**{name: float(given.get(name, option("volume", name).default))
                                for name in terms})
    shading = GradientShading(plotter.renderer, model, material)
    return shading
