"""Lit volumes (000 pass 1): lights, the GPU light map and its CPU counterpart.

A sample's emitted colour is scaled by ``ambient + (1 - ambient) * sum_i colour_i *
T_i``, where ``T_i`` is the transmittance from the sample toward light ``i`` through the
volume itself. On the GPU the transmittances live in a light map of ``L^3`` points over the
volume (one RGBA texel holds up to four lights), marched by a pass that runs only when a
light, the volume's placement or its data change; with no light the pass does not exist.
The CPU reference computes the same transmittances on a fine grid (:func:`light_grid`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .gl_resources import RenderToTexturePass
from .reference import ray_box_interval, trilinear
from .shaders import ShaderRecipe
from .volume import VolumeModel

#: One RGBA light map holds the transmittance toward at most this many lights.
MAX_LIGHTS = 4
#: Default share of the emission no light modulates.
DEFAULT_AMBIENT = 0.2
#: Default light-map points per axis.
DEFAULT_LIGHT_MAP_SIZE = 32


@dataclass(frozen=True)
class VolumeLight:
    """A directional or point light as a volume sees it (world coordinates).

    ``direction`` is where a directional light's rays travel; ``position`` is a point
    light's place. ``color`` times ``intensity`` scales the transmitted light.
    """

    kind: str
    direction: tuple[float, float, float] = (0.0, 0.0, -1.0)
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    color: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 1.0

    def __post_init__(self):
        if self.kind not in ("directional", "point"):
            raise ValueError(f"A volume light is 'directional' or 'point', got {self.kind!r}.")
        if self.kind == "directional" and not np.linalg.norm(self.direction) > 0:
            raise ValueError("A directional light needs a non-zero direction.")

    @classmethod
    def from_pyvista(cls, light, camera=None) -> VolumeLight:
        """The light a ``pyvista.Light`` (or ``vtkLight``) casts now.

        Headlights and camera lights follow ``camera`` (a ``vtkCamera``), as VTK places them.
        """
        position = np.array(light.GetPosition(), dtype=np.float64)
        focal = np.array(light.GetFocalPoint(), dtype=np.float64)
        if camera is not None and light.LightTypeIsHeadlight():
            position = np.array(camera.GetPosition(), dtype=np.float64)
            focal = np.array(camera.GetFocalPoint(), dtype=np.float64)
        elif camera is not None and light.LightTypeIsCameraLight():
            matrix = camera.GetCameraLightTransformMatrix()
            position = np.array(matrix.MultiplyPoint((*position, 1.0))[:3])
            focal = np.array(matrix.MultiplyPoint((*focal, 1.0))[:3])
        color = tuple(float(c) for c in light.GetDiffuseColor())
        if light.GetPositional():
            return cls("point", position=tuple(position), color=color,
                       intensity=float(light.GetIntensity()))
        direction = focal - position
        if not np.linalg.norm(direction) > 0:
            direction = np.array([0.0, 0.0, -1.0])
        return cls("directional", direction=tuple(direction), color=color,
                   intensity=float(light.GetIntensity()))

    def toward_light(self, texture_from_world: np.ndarray) -> np.ndarray:
        """The light as the light-map pass reads it, in texture coordinates.

        ``(x, y, z, 0)``: the direction toward a directional light; ``(x, y, z, 1)``: a
        point light's position.
        """
        if self.kind == "point":
            return np.append(texture_from_world[:3, :3] @ self.position
                             + texture_from_world[:3, 3], 1.0)
        toward = -np.asarray(self.direction, dtype=np.float64)
        toward = texture_from_world[:3, :3] @ (toward / np.linalg.norm(toward))
        return np.append(toward, 0.0)

    @property
    def radiance(self) -> np.ndarray:
        """Colour times intensity."""
        return np.asarray(self.color, dtype=np.float64) * float(self.intensity)


LightSource = Callable[[], list[VolumeLight]]


def light_source(lights, renderer) -> LightSource | None:
    """Turn ``add_volume``'s ``lights`` argument into a callable giving this frame's lights.

    ``None`` or an empty list: no lighting (``None`` is returned). ``'scene'``: the
    renderer's switched-on lights, read at every frame. A ``pyvista.Light``, a
    :class:`VolumeLight` or a list of them: those lights (camera lights follow the camera).
    """
    if lights is None:
        return None
    if isinstance(lights, str):
        if lights != "scene":
            raise ValueError(f"lights must be None, 'scene', a light or a list of lights, "
                             f"got {lights!r}.")

        def scene_lights():
            camera = renderer.GetActiveCamera()
            return [VolumeLight.from_pyvista(li, camera) for li in renderer.GetLights()
                    if li.GetSwitch()]

        found = scene_lights()
        if not found:
            return None
        _check_count(len(found), "The plotter has")
        return scene_lights
    items = list(lights) if isinstance(lights, (list, tuple)) else [lights]
    if not items:
        return None
    _check_count(len(items), "lights holds")
    for item in items:
        if not isinstance(item, VolumeLight) and not hasattr(item, "GetTransformedPosition"):
            raise TypeError(f"lights must hold pyvista.Light or VolumeLight objects, got "
                            f"{type(item).__name__}.")
    return lambda: [item if isinstance(item, VolumeLight)
                    else VolumeLight.from_pyvista(item, renderer.GetActiveCamera())
                    for item in items]


def _check_count(count: int, what: str) -> None:
    if count > MAX_LIGHTS:
        raise ValueError(f"{what} {count} lights; a volume is lit by at most {MAX_LIGHTS}. "
                         "Pass lights=[...] with the ones that matter, or make the plotter "
                         "with pyvista.Plotter(lighting='three lights').")


class LightMap:
    """The light-map pass of one volume and what its marching shaders read from it.

    Parameters
    ----------
    renderer : vtkRenderer
        The renderer whose frames run the pass (before any pass that reads it).
    model : VolumeModel
        The lit volume.
    source : callable
        This frame's lights (see :func:`light_source`); their number must stay the same.
    volume_texture : Texture or None
        The volume's data texture (shared with the marching shaders); ``None`` for a
        :class:`~pv_cubemarch.VolumeGroup`, whose members' textures it keeps.
    size : int
        Light-map points per axis, ``L`` (2 to 128).
    ambient : float
        Share of the emission no light modulates, in [0, 1].
    """

    def __init__(self, renderer, model: VolumeModel, source: LightSource, volume_texture,
                 size: int = DEFAULT_LIGHT_MAP_SIZE, ambient: float = DEFAULT_AMBIENT,
                 step_scale: float = 1.0):
        from .emission_absorption import bind_sampling

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
        sampling, defines = bind_sampling(self.render_pass, model, volume_texture, 1.0, 1.0,
                                          skip_empty=False)
        self.render_pass.set_recipe(ShaderRecipe(
            standalone=("pass_head", "ea_declarations", sampling, "ea_march", "light_map_main"),
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
            raise RuntimeError(f"The volume was set up for {self.count} light(s) and the scene "
                               f"now has {len(lights)}; add the volume again.")
        key = tuple((li.kind, tuple(np.round(li.direction, 12)), tuple(np.round(li.position, 12)))
                    for li in lights) + (self.model.world_from_index().tobytes(),)
        self._lights = lights
        if key == self._key:
            return False
        self._key = key
        self.runs_requested += 1
        return True

    def _matrix(self, what: str) -> np.ndarray:
        from .emission_absorption import world_from_texture

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


def check_light_options(light_map_size, ambient) -> None:
    """Clear errors for the lighting parameters of ``add_volume``."""
    if int(light_map_size) != light_map_size or not 2 <= light_map_size <= 128:
        raise ValueError(f"light_map_size must be a whole number from 2 to 128, got "
                         f"{light_map_size}.")
    if not 0.0 <= float(ambient) <= 1.0:
        raise ValueError(f"ambient must be in [0, 1], got {ambient}.")


# ----------------------------------------------------------------------------------------
# CPU counterpart


def transmittance_toward(medium, points_index: np.ndarray, light: VolumeLight,
                         step_voxels: float = 0.25) -> np.ndarray:
    """Transmittance from each point (``medium``'s grid index coordinates) toward ``light``.

    ``medium`` is a :class:`VolumeModel`, or a :class:`~pv_cubemarch.VolumeGroup` whose
    members' extinctions add (index coordinates of its virtual grid). Marched with midpoint
    steps of ``step_voxels`` of the smallest voxel, up to the box or to a point light inside.
    """
    world_from_index = medium.world_from_index()
    index_from_world = np.linalg.inv(world_from_index)
    points = np.asarray(points_index, dtype=np.float64).reshape(-1, 3)
    world = points @ world_from_index[:3, :3].T + world_from_index[:3, 3]
    if light.kind == "point":
        delta = np.asarray(light.position, dtype=np.float64) - world
        distance = np.linalg.norm(delta, axis=1)
        toward = delta / np.maximum(distance, 1e-300)[:, None]
    else:
        direction = -np.asarray(light.direction, dtype=np.float64)
        toward = np.broadcast_to(direction / np.linalg.norm(direction), world.shape)
        distance = np.full(len(world), np.inf)
    toward_index = toward @ index_from_world[:3, :3].T
    upper = np.array(medium.dimensions, dtype=np.float64) - 1.0
    _, t_exit = ray_box_interval(points, toward_index, np.zeros(3), upper)
    t_end = np.clip(np.minimum(t_exit, distance), 0.0, None)
    voxel = np.linalg.norm(world_from_index[:3, :3], axis=0)
    step = float(step_voxels) * float(voxel.min())
    depth = np.zeros(len(points))
    t = np.zeros(len(points))
    active = np.nonzero(t_end > 0)[0]
    while active.size:
        end = np.minimum(t[active] + step, t_end[active])
        middle = 0.5 * (t[active] + end)
        sample = points[active] + toward_index[active] * middle[:, None]
        depth[active] += extinction_at(medium, sample) * (end - t[active])
        t[active] = end
        keep = (end < t_end[active]) & (depth[active] < 30.0)
        active = active[keep]
    return np.exp(-depth)


def extinction_at(medium, points_index: np.ndarray) -> np.ndarray:
    """Extinction of ``medium`` (a volume, or a group: its members' sum) at index points."""
    members = getattr(medium, "members", None)
    if members is None:
        return medium.transfer.lookup(trilinear(medium.values, points_index))[1]
    world_from_group = medium.world_from_index()
    sigma = np.zeros(len(points_index))
    for member in members:
        member_from_group = np.linalg.inv(member.world_from_index()) @ world_from_group
        local = points_index @ member_from_group[:3, :3].T + member_from_group[:3, 3]
        upper = np.array(member.dimensions, dtype=np.float64) - 1.0
        inside = np.all((local >= 0.0) & (local <= upper), axis=1)
        if inside.any():
            sigma[inside] += member.transfer.lookup(trilinear(member.values,
                                                              local[inside]))[1]
    return sigma


def light_grid(volume, lights: Sequence[VolumeLight], spacing_voxels: float = 0.5,
               max_points: int = 96, step_voxels: float = 0.25) -> np.ndarray:
    """Transmittance toward each light on a fine grid over the volume's (or group's) box.

    Returns ``(n_lights, gx, gy, gz)``; grid points span index 0 to ``dims - 1`` per axis,
    ``spacing_voxels`` apart (at most ``max_points`` per axis). The reference interpolates
    it trilinearly; :func:`transmittance_toward` gives exact values to check that against.
    """
    dims = np.array(volume.dimensions)
    counts = np.minimum(np.ceil((dims - 1) / spacing_voxels).astype(int) + 1, max_points)
    counts = np.maximum(counts, 2)
    axes = [np.linspace(0.0, d - 1.0, c) for d, c in zip(dims, counts, strict=True)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    return np.stack([transmittance_toward(volume, grid, li, step_voxels).reshape(counts)
                     for li in lights])


def lit_emission(volume, rgb: np.ndarray, points_index: np.ndarray,
                 lights: Sequence[VolumeLight], grids: np.ndarray, ambient: float) -> np.ndarray:
    """``rgb`` of samples at ``points_index`` scaled by the light reaching them."""
    dims = np.array(volume.dimensions, dtype=np.float64)
    light = np.zeros_like(rgb)
    for light_spec, grid in zip(lights, grids, strict=True):
        scale = (np.array(grid.shape) - 1.0) / np.maximum(dims - 1.0, 1.0)
        transmittance = trilinear(grid, points_index * scale)
        light += transmittance[:, None] * light_spec.radiance
    return rgb * (ambient + (1.0 - ambient) * light)
