"""The light map: transmittance toward each light on ``L^3`` points of a volume.

One RGBA texel holds up to four lights; the pass runs only when a light, the volume's
placement or its data change, and with no light it does not exist.
"""

from __future__ import annotations

import numpy as np

from ..core.errors import SceneChangedError
from ..gl.passes import RenderToTexturePass
from ..gl.shaders import ShaderRecipe
from ..models.lights import DEFAULT_AMBIENT, DEFAULT_LIGHT_MAP_SIZE, LightSource, VolumeLight
from .binding import (
    DECLARATION_SNIPPETS,
    MARCH_SNIPPETS,
    VolumeData,
    bind_sampling,
    world_from_texture,
)


class LightMap:
    """The light-map pass of one volume and what its marching shaders read from it.

    Parameters
    ----------
    renderer : vtkRenderer
        The renderer whose frames run the pass (before any pass that reads it).
    data : VolumeData
        The lit volume (or group) and its GPU copy, shared with the marching shaders.
    source : callable
        This frame's lights (see :func:`light_source`); their number must stay the same.
    size : int
        Light-map points per axis, ``L`` (2 to 128).
    ambient : float
        Share of the emission no light modulates, in [0, 1].
    """

    def __init__(self, renderer, data: VolumeData, source: LightSource,
                 size: int = DEFAULT_LIGHT_MAP_SIZE, ambient: float = DEFAULT_AMBIENT,
                 step_scale: float = 1.0):
        model = data.model
        self.model = model
        self.source = source
        self.size = int(size)
        self.ambient = float(ambient)
        self.count = len(source())
        self._key = None
        self._lights: list[VolumeLight] = []
        self.runs_requested = 0
        self.render_pass = RenderToTexturePass(renderer, None, size=(self.size,
                                               self.size * self.size), run_when=self._changed)
        sampling, defines = bind_sampling(self.render_pass, data, 1.0, 1.0, skip_empty=False)
        self.render_pass.set_recipe(ShaderRecipe(
            standalone=("pass_head", *DECLARATION_SNIPPETS, sampling, *MARCH_SNIPPETS,
                        "light_map_main"),
            defines=dict(defines, CM_LIGHT_COUNT=self.count)))
        self.render_pass.set_uniform("cm_lightMapSize", float(self.size))
        self.render_pass.set_uniform("cm_lightStepScale", float(step_scale))
        self.render_pass.set_uniform("cm_lightVectors", lambda: self._matrix("vectors"))

    @property
    def lights(self) -> list[VolumeLight]:
        """The lights of the last frame."""
        return list(self._lights)

    def _changed(self) -> bool:
        """Whether a light or the volume's placement changed since the last run."""
        lights = self.source()
        if len(lights) != self.count:
            raise SceneChangedError(
                f"Volume {self.model.name!r} was set up for {self.count} light(s) and the scene "
                f"now has {len(lights)} switched-on light(s); a lit volume keeps the number of "
                "lights it was added with: add the volume again (or pass lights=[...] to "
                "add_volume to fix its lights).")
        key = tuple((li.kind, tuple(np.round(li.direction, 12)), tuple(np.round(li.position, 12)))
                    for li in lights) + (self.model.world_from_index().tobytes(),)
        self._lights = lights
        if key == self._key:
            return False
        self._key = key
        self.runs_requested += 1
        return True

    def _matrix(self, what: str) -> np.ndarray:
        matrix = np.zeros((4, 4))
        texture_from_world = np.linalg.inv(world_from_texture(self.model))
        for index, light in enumerate(self._lights or self.source()):
            if what == "vectors":
                matrix[:, index] = light.toward_light(texture_from_world)
            else:
                matrix[:3, index] = light.radiance
        return matrix

    def invalidate(self) -> None:
        """Recompute at the next frame (the data changed)."""
        self.render_pass.invalidate()

    @property
    def defines(self) -> dict:
        """Feature switches of the shaders that read the light map."""
        return {"CM_LIGHTS": True, "CM_LIGHT_COUNT": self.count}

    def bind(self, target) -> None:
        """Give ``target`` (bindings or a pass) the light map and the lights' colours."""
        target.add_texture("cm_lightMap", self.render_pass.output(0))
        target.set_uniform("cm_lightMapSize", float(self.size))
        target.set_uniform("cm_lightColors", lambda: self._matrix("colors"))
        target.set_uniform("cm_ambient", self.ambient)

    @property
    def nbytes(self) -> int:
        """GPU bytes of the light map."""
        return self.render_pass.nbytes

    def release(self) -> None:
        """Free the pass."""
        self.render_pass.release()
