"""``add_volume(..., quality=)``: calibrate an emission/absorption technique on the view.

The volume is drawn alone, unlit, over black, at the plotter's window size from the
camera the plotter will have once the volume is added, on a second offscreen plotter; the
CPU reference (the technique's own) traces a sample of the same frame's pixels. The choice
is kept per data, transfer function, placement, camera, window size, GL renderer and
target.
"""

from __future__ import annotations

import dataclasses
import math
import re
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from vtkmodules.vtkCommonCore import vtkCommand
from vtkmodules.vtkRenderingCore import vtkCamera

from ..core.camera import Camera
from ..core.frame_errors import observe
from ..core.rendering import offscreen_plotter, read_pixels, render_frame
from ..volume.clipping import clip_plane_list
from .cache import choice_key, lookup, store
from .calibration import QualityChoice, calibrate
from .interaction import KNOBS, MOVING_RATE
from .ladders import volume_tracks
from .targets import QualityTarget, parse_quality

#: The knobs a ladder sets: giving one with ``quality=`` is a contradiction.
PICKED = ("step_scale", "face_size", "max_samples", "sample_factor")
#: Step of the CPU reference, in voxels (as the speed/accuracy benches).
REFERENCE_STEP = 0.1


def check_quality_request(quality, given: dict, blending: str, shade: bool, lights,
                          single_unlit_volume: bool, crop_box=None, average_range=None
                          ) -> QualityTarget:
    """Read ``quality=`` and refuse what calibration cannot measure, by name."""
    target = parse_quality(quality)
    picked = [k for k in PICKED if k in given]
    if picked:
        raise ValueError(f"quality= chooses {', '.join(picked)} itself: give quality= or "
                         "the settings, not both.")
    if blending != "composite" or shade or lights is not None or not single_unlit_volume:
        raise ValueError("quality= measures against the emission/absorption reference of one "
                         "unlit scalar volume: it takes blending='composite', no shade, no "
                         "lights, no RGBA, channel or jointly marched volumes. Give the "
                         "settings (step_scale, face_size ...) for those.")
    if crop_box is not None or average_range is not None:
        raise ValueError("quality= with crop_box (or average_range): the CPU reference has no "
                         "crop box; cut the volume with clip_planes instead, which it traces.")
    return target


def camera_once_added(plotter, bounds, reset_camera: bool | None) -> Camera:
    """The camera the plotter will draw with after adding a prop of ``bounds`` (left as is).

    As PyVista frames it: a camera nobody set turns to the theme's view (isometric) of the
    whole scene at the first frame; one set but not pinned slides along its direction to
    fit the scene (``reset_camera``); a camera the user placed stays.
    """
    renderer = plotter.renderer
    camera = renderer.camera
    fresh = not camera.is_set
    if not (fresh or reset_camera or (reset_camera is None and not renderer.camera_set)):
        return Camera.from_pyvista(camera)
    seen = np.asarray(renderer.ComputeVisiblePropBounds(), dtype=np.float64)
    own = np.asarray(bounds, dtype=np.float64)
    union = own if seen[0] > seen[1] else np.ravel(
        [[min(seen[i], own[i]), max(seen[i + 1], own[i + 1])] for i in (0, 2, 4)])
    saved = vtkCamera()
    saved.DeepCopy(camera)
    try:
        if fresh:
            centre = (union[0::2] + union[1::2]) / 2.0
            theme = renderer._theme.camera
            offset = np.asarray(theme.position, dtype=np.float64) / np.asarray(renderer.scale)
            camera.SetFocalPoint(*centre)
            camera.SetPosition(*(centre + offset))
            camera.SetViewUp(*theme.viewup)
        renderer.ResetCamera(*union)
        return Camera.from_pyvista(camera)
    finally:
        camera.DeepCopy(saved)


def _renderer_name(plotter) -> str:
    found = re.search(r"OpenGL renderer string:\s*(.+)", plotter.ren_win.ReportCapabilities()
                      or "")
    return found.group(1).strip() if found else "unknown"


def _stored_choice(stored: dict, tracks, target: QualityTarget, size) -> QualityChoice | None:
    """A cached entry as a choice, if it names one of these rungs with a finite PSNR.

    The file is untrusted: another version's ladder, or an edited file, calibrates again.
    """
    rungs = [rung.setting for track in tracks for rung in track]
    measured = stored.get("measured", [])
    if (stored.get("setting") not in rungs or not math.isfinite(float(stored["psnr"]))
            or not isinstance(measured, list)
            or not all(isinstance(m, dict) and m.get("setting") in rungs
                       and isinstance(m.get("psnr"), (int, float)) for m in measured)):
        return None
    return QualityChoice(target, dict(stored["setting"]), float(stored["psnr"]),
                         bool(stored["met"]), list(measured), 0.0, size, 0, cached=True)


def plane_pairs(clip_planes) -> list[tuple]:
    """``add_volume``'s clip planes as the reference's ``(origin, normal)`` pairs."""
    return [(tuple(p.GetOrigin()), tuple(p.GetNormal())) for p in clip_plane_list(clip_planes)]


@dataclass
class VolumeCalibration:
    """What ``quality=`` needs to calibrate a volume, now and again when the view moves.

    ``add(plotter, model, technique=, name=, **setting, **keep)`` draws a candidate (the
    package's ``add_volume``); ``reference`` is the technique's CPU reference.
    """

    model: object
    technique: str
    target: QualityTarget
    keep: dict
    add: Callable
    reference: Callable
    view: tuple | None = None
    warned: bool = False

    def run(self, plotter, reset_camera: bool | None) -> QualityChoice:
        """Choose the rung for the view the plotter will have (cached per view)."""
        camera = camera_once_added(plotter, self.model.world_bounds(), reset_camera)
        size = tuple(int(v) for v in plotter.window_size)
        background = tuple(float(c) for c in plotter.background_color.float_rgb)
        self.view = (dataclass_tuple(camera), size, background)
        return self._choose(camera, size, background)

    def _choose(self, camera: Camera, size, background) -> QualityChoice:
        model, technique, target, keep = self.model, self.technique, self.target, self.keep
        tracks = volume_tracks(technique, model.dimensions)
        planes = plane_pairs(keep.get("clip_planes"))
        probe = offscreen_plotter(size)
        try:
            probe.ren_win.SetMultiSamples(0)
            probe.set_background(background)

            def draw(setting: dict) -> None:
                self.add(probe, model, technique=technique, name="calibration",
                         reset_camera=False, render=False, **setting, **keep)
                camera.apply_to(probe.camera)
                probe.renderer.ResetCameraClippingRange()

            draw(tracks[0][0].setting)
            render_frame(probe)
            near = float(probe.camera.clipping_range[0])
            transfer = model.transfer
            key = choice_key("volume", technique, model.values, transfer.table,
                             tuple(transfer.clim), repr(getattr(transfer, "spec", None)),
                             float(getattr(model, "value_offset", 0.0)),
                             np.asarray(model.world_from_index()), model.interpolation,
                             dataclass_tuple(camera), size, background, planes,
                             _renderer_name(probe), target.psnr,
                             sorted((k, v) for k, v in keep.items() if k != "clip_planes"))
            stored = lookup(key)
            found = None if stored is None else _stored_choice(stored, tracks, target, size)
            if found is not None:
                return found

            def render(setting: dict) -> np.ndarray:
                draw(setting)
                render_frame(probe)
                return read_pixels(probe)

            def traced(pixels) -> np.ndarray:
                return self.reference(model, camera, size, background=background,
                                      step_voxels=REFERENCE_STEP, near=near, pixels=pixels,
                                      clip_planes=planes or None)

            start = next((i for i, rung in enumerate(tracks[0])
                          if rung.setting.get("step_scale") == 1.0), None)
            choice = calibrate(tracks, render, traced, camera, size, model.world_bounds(),
                               target, start)
        finally:
            probe.close()
        store(key, choice.as_dict())
        if not choice.met:
            warnings.warn(f"{choice}: no {technique!r} setting reaches {target.name} on this "
                          "volume and view; ask for less, or try another technique.",
                          stacklevel=4)
        return choice

    def follow(self, binding, plotter) -> None:
        """Warn once when a still frame is drawn from another view than the calibrated one.

        The binding gets ``recalibrate()``: the choice for the view the plotter has now.
        """
        window = plotter.ren_win

        def check(*_) -> None:
            if self.warned or window.GetDesiredUpdateRate() >= MOVING_RATE:
                return
            if self.current_view(plotter) != self.view:
                self.warned = True
                warnings.warn(
                    f"quality {self.target.name} was calibrated for the view at add_volume; "
                    "the camera, window size or background has changed since, so the error "
                    "may differ: call actor.cubemarch.recalibrate() (or set the view before "
                    "add_volume).", stacklevel=2)

        tag = observe(window, vtkCommand.StartEvent, check)
        release = binding.release_resources

        def release_and_stop() -> None:
            window.RemoveObserver(tag)
            release()
        binding.release_resources = release_and_stop
        binding.recalibrate = lambda: self.recalibrate(binding, plotter)

    @staticmethod
    def current_view(plotter) -> tuple:
        """The plotter's camera, window size and background, as :meth:`run` keys them."""
        return (dataclass_tuple(Camera.from_pyvista(plotter.renderer.camera)),
                tuple(int(v) for v in plotter.window_size),
                tuple(float(c) for c in plotter.background_color.float_rgb))

    def recalibrate(self, binding, plotter) -> QualityChoice:
        """Choose again for the plotter's view now, and draw with the new choice."""
        camera = Camera.from_pyvista(plotter.renderer.camera)
        view = self.current_view(plotter)
        choice = self._choose(camera, view[1], view[2])
        self.view, self.warned = view, False
        apply_setting(binding, choice.setting)
        binding.quality = choice
        budget = getattr(binding, "frame_budget", None)
        if budget is not None and "step_scale" in choice.setting:
            budget.still = budget.value = float(choice.setting["step_scale"])
        return choice


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
            sample_factor=float(setting.get("sample_factor", 1.0)))


def dataclass_tuple(camera: Camera) -> tuple:
    """The camera's fields rounded to 9 significant digits (a key, not a measurement)."""
    return tuple(float(f"{v:.9g}") for value in (camera.position, camera.focal_point,
                                                   camera.view_up) for v in value) + (
        float(f"{camera.view_angle:.9g}"), camera.parallel_projection,
        float(f"{camera.parallel_scale:.9g}"))
