"""``add_volume(..., quality=)``: calibrate a volume technique on the view.

The volume is drawn alone on a probe plotter (:mod:`.probe`), shaded (``shade=True``) by
one headlight; the CPU reference (emission/absorption, or the projection ``blending``
asks for) traces a sample of the same frame's pixels. The choice is kept per data, transfer
function, placement, clip planes, camera, window size, background, GL renderer and target.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pyvista

from ..core.declared import option
from ..core.registry import get_technique
from ..models.group import VolumeGroup
from ..models.lights import light_source
from ..reference.projections import render_blended
from ..reference.volume_shading import ShadeSetup
from ..volume.clipping import box_planes, clip_plane_list, data_transform
from ..volume.pyvista_keywords import isosurface_levels
from .cache import choice_key
from .calibration import QualityChoice
from .interaction import KNOBS
from .ladders import volume_tracks
from .probe import ProbeCalibration, view_key
from .targets import QualityTarget, parse_quality

#: The knobs a ladder sets: giving one with ``quality=`` is a contradiction.
PICKED = ("step_scale", "face_size", "max_samples", "sample_factor")
#: Step of the CPU reference, in voxels (as the speed/accuracy benches).
REFERENCE_STEP = 0.1
#: The blendings quality= measures (the reference draws each).
QUALITY_BLENDING = ("composite", "maximum", "minimum", "average", "additive", "isosurface")
#: The gradient shading's material terms (``shade=True``).
MATERIAL = ("ambient", "diffuse", "specular", "specular_power")
#: The kept options the reference reads (besides the clip planes, crop box and lights).
REFERENCE_READS = ("blending", "isosurfaces", "shade", *MATERIAL, "light_map_ambient",
                   "average_range")


def check_quality_request(quality, given: dict, blending: str, rgba: bool = False
                          ) -> QualityTarget:
    """Read ``quality=`` and refuse what calibration cannot measure, by name.

    Channel volumes and volumes marched jointly are composited (``add_volume`` refuses
    other blendings for them), which the emission/absorption reference traces.
    """
    target = parse_quality(quality)
    picked = [k for k in PICKED if k in given]
    if picked:
        raise ValueError(f"quality= chooses {', '.join(picked)} itself: give quality= or "
                         "the settings, not both.")
    if blending not in QUALITY_BLENDING or (rgba and blending != "composite"):
        raise ValueError(f"quality= measures against the CPU reference: blending one of "
                         f"{QUALITY_BLENDING} (shade=True with 'composite' or 'isosurface'; "
                         "an RGBA volume composited). Give the settings (step_scale, "
                         "face_size ...) for others.")
    return target


def plane_pairs(clip_planes, crop_box=None, transform=None) -> list[tuple]:
    """``add_volume``'s clip planes and crop box as the reference's ``(origin, normal)`` pairs.

    The crop box is in the data's coordinates, which ``transform`` places.
    """
    pairs = [(tuple(p.GetOrigin()), tuple(p.GetNormal())) for p in clip_plane_list(clip_planes)]
    if crop_box is not None:
        pairs += box_planes(crop_box, np.eye(4) if transform is None else transform)
    return pairs


def light_keys(lights) -> list:
    """``lights=`` as a cache key: a VTK light by what places and colours it, not its id."""
    if lights is None or isinstance(lights, str):
        return [lights]
    keys = []
    for light in lights if isinstance(lights, (list, tuple)) else [lights]:
        if hasattr(light, "GetTransformedPosition"):
            keys.append((light.GetLightType(), light.GetSwitch(), light.GetPosition(),
                         light.GetFocalPoint(), light.GetDiffuseColor(), light.GetIntensity(),
                         light.GetPositional(), light.GetConeAngle(), light.GetExponent(),
                         light.GetAttenuationValues()))
        else:
            keys.append(repr(light))
    return keys


def model_key(model) -> tuple:
    """What a volume draws (data, colours, transfer function, placement) as flat key parts.

    A group's (channels, or volumes marched jointly): how it mixes, then each member's.
    """
    if isinstance(model, VolumeGroup):
        return (model.channel_mix, len(model.members),
                *(part for member in model.members for part in model_key(member)))
    transfer = model.transfer
    return (model.values, model.colors, transfer.table, tuple(transfer.clim),
            repr(getattr(transfer, "spec", None)), float(getattr(model, "value_offset", 0.0)),
            np.asarray(model.world_from_index()), model.interpolation)


@dataclass
class VolumeCalibration(ProbeCalibration):
    """``quality=`` of a volume: its step, or its cube map's face.

    ``keep`` holds its ``blending`` and, shaded, ``shade`` and the material it was given.
    ``traced``: the reference's images of the last samples, shared by the two paths of
    ``'auto'`` (the same sample of the same view: traced once).
    """

    traced: dict | None = None

    def tracks(self) -> list:
        return volume_tracks(self.technique, self.model.dimensions)

    def key_parts(self) -> tuple:
        return (*model_key(self.model),
                self.planes(),
                light_keys(self.keep.get("lights")),
                sorted((k, v) for k, v in self.keep.items()
                       if k not in ("clip_planes", "lights")))

    def planes(self) -> list[tuple]:
        """The clip planes and crop box the volume is drawn with, as world planes."""
        return plane_pairs(self.keep.get("clip_planes"), self.keep.get("crop_box"),
                           data_transform(self.model))

    def shading(self) -> str:
        return "blinn" if self.keep.get("shade") else "unlit"

    def volume_lights(self) -> list | None:
        """``lights=`` (the light map's) as the reference takes them, for the probe's view."""
        source = light_source(self.keep.get("lights"), self.probe.renderer)
        return None if source is None else list(source())

    def shade_setup(self) -> ShadeSetup:
        """The reference's shading: the given material, lit by the probe's one headlight."""
        camera = self.probe.camera
        position, focal = (np.asarray(v, dtype=np.float64) for v in (
            camera.GetPosition(), camera.GetFocalPoint()))
        view = pyvista.array_from_vtkmatrix(camera.GetViewTransformMatrix())[:3, :3]
        material = {name: float(self.keep[name]) if self.keep.get(name) is not None else
                    float(option("volume", name).default) for name in MATERIAL}
        white = np.ones(3)
        return ShadeSetup(**material, lights=[((focal - position) / np.linalg.norm(
            focal - position), white, white)], headlight=True, view_rotation=view,
            two_sided=bool(self.probe.renderer.GetTwoSidedLighting()))

    def trace(self, camera, size, background, near, pixels) -> np.ndarray:
        """The reference's sample, or the one the other path of ``'auto'`` traced."""
        if self.traced is None:
            return self._trace(camera, size, background, near, pixels)
        key = choice_key(*model_key(self.model), self.planes(),
                         light_keys(self.keep.get("lights")),
                         sorted((k, repr(v)) for k, v in self.keep.items()
                                if k in REFERENCE_READS), view_key(camera), size, background,
                         near, *(np.asarray(p) for p in pixels))
        if key not in self.traced:
            self.traced.clear()   # the last sample only
            self.traced[key] = self._trace(camera, size, background, near, pixels)
        return self.traced[key]

    def _trace(self, camera, size, background, near, pixels) -> np.ndarray:
        planes = self.planes() or None
        blending = self.keep.get("blending", "composite")
        shade = self.shade_setup() if self.keep.get("shade") else None
        if blending != "composite":
            return render_blended(self.model, camera, size, blending, background=background,
                                  step_voxels=REFERENCE_STEP, near=near, clip_planes=planes,
                                  pixels=pixels, shade=shade, isosurfaces=isosurface_levels(
                                      self.keep.get("isosurfaces"), self.model),
                                  average_range=self.keep.get("average_range"))
        ambient = self.keep.get("light_map_ambient")
        return self.reference(self.model, camera, size, background=background,
                              step_voxels=REFERENCE_STEP, near=near, pixels=pixels,
                              clip_planes=planes, shade=shade, lights=self.volume_lights(),
                              ambient=float(option("volume", "light_map_ambient").default
                                            if ambient is None else ambient))

    def start(self, tracks) -> int | None:
        return next((i for i, rung in enumerate(tracks[0])
                     if rung.setting.get("step_scale") == 1.0), None)

    def apply(self, binding, setting: dict) -> None:
        apply_setting(binding, setting)


def apply_setting(binding, setting: dict) -> None:
    """Draw a rung's setting from the next frame, nothing rebuilt.

    The step's uniform, or the cube map's face and samples per texel (its level of detail
    reads them at every frame).
    """
    if "step_scale" in setting:
        KNOBS["step"].write(binding, float(setting["step_scale"]))
    else:
        frame = binding.frame
        frame.options = dataclasses.replace(
            frame.options, face_size=int(setting["face_size"]),
            sample_factor=float(setting["sample_factor"]))


@dataclass
class AutoCalibration:
    """``quality=`` of ``technique='auto'``: its two paths calibrated apart.

    Each frame draws the cube map or the direct marcher; each meeting the target on its
    own, whichever a frame draws meets it. The choice reported holds both settings, the
    lower estimate, and what both tried.
    """

    direct: VolumeCalibration
    cubemap: VolumeCalibration

    def run(self, plotter, reset_camera: bool | None) -> QualityChoice:
        """Choose both paths' rungs for the view the plotter will have."""
        return merged(self.direct.run(plotter, reset_camera),
                      self.cubemap.run(plotter, reset_camera))

    def follow(self, binding, plotter) -> None:
        """Warn once when the view changes; ``recalibrate()`` chooses both again."""
        self.direct.follow(binding, plotter)
        binding.recalibrate = lambda: self.recalibrate(binding, plotter)

    def recalibrate(self, binding, plotter) -> QualityChoice:
        """Choose again for the plotter's view now, each path drawing its new rung."""
        choice = merged(self.direct.recalibrate(binding.direct, plotter),
                        self.cubemap.recalibrate(binding.cubemap, plotter))
        self.direct.warned = False
        binding.quality = choice
        return choice


def merged(direct: QualityChoice, cubemap: QualityChoice) -> QualityChoice:
    """One report of both paths' choices."""
    return QualityChoice(direct.target, {**direct.setting, **cubemap.setting},
                         min(direct.psnr, cubemap.psnr), direct.met and cubemap.met,
                         direct.measured + cubemap.measured, direct.seconds + cubemap.seconds,
                         direct.size, direct.traced + cubemap.traced,
                         direct.cached and cubemap.cached)


def volume_calibration(model, technique: str, target: QualityTarget, keep: dict, add
                       ) -> VolumeCalibration | AutoCalibration:
    """The calibration of ``technique`` (both paths of 'auto').

    Each path is drawn with the kept options it reads (the direct marcher no ``upscale``).
    """
    def one(name: str) -> VolumeCalibration:
        reads = set(get_technique("volume", name).option_names) | {
            "stop_opacity", "skip_empty", "clip_planes", "crop_box", "average_range",
            "blending", "isosurfaces", "shade",
            "lights", "light_map_size", "light_map_ambient", *MATERIAL}
        return VolumeCalibration(model, name, target,
                                 {k: v for k, v in keep.items() if k in reads}, add,
                                 get_technique("volume", name).reference)
    if technique == "auto":
        direct, cubemap = one("direct"), one("cubemap")
        direct.traced = cubemap.traced = {}
        return AutoCalibration(direct, cubemap)
    return one(technique)
