"""Calibration on a probe: candidate settings drawn on a second plotter, against the CPU reference.

Each candidate is drawn alone at the plotter's window size, with its background, from the
camera the plotter will have once the prop is added; the technique's CPU reference traces
a sample of the same frame's pixels. A technique's calibration says what its ladders are,
what its choice depends on (the cache key), how its reference traces and how a choice is
applied to a drawn binding; the search, the cache and following the view are shared.
"""

from __future__ import annotations

import math
import re
import warnings
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pyvista
from vtkmodules.vtkCommonCore import vtkCommand
from vtkmodules.vtkRenderingCore import vtkCamera

from ..core.camera import Camera
from ..core.frame_errors import observe
from ..core.rendering import offscreen_plotter, read_pixels, render_frame
from ..core.user_warnings import warn_user
from ..models.lights import VolumeLight
from ..models.volume import box_world_bounds
from .cache import choice_key, lookup, store
from .calibration import SAMPLES, QualityChoice, calibrate
from .interaction import MOVING_RATE
from .ladders import Rung
from .targets import QualityTarget


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


def renderer_name(plotter) -> str:
    """The GL renderer's name (a choice is kept per GPU)."""
    found = re.search(r"OpenGL renderer string:\s*(.+)", plotter.ren_win.ReportCapabilities()
                      or "")
    return found.group(1).strip() if found else "unknown"


def stored_choice(stored: dict, tracks, target: QualityTarget, size) -> QualityChoice | None:
    """A cached entry as a choice, if it names one of these rungs with a PSNR (not NaN, -inf).

    The file is untrusted: another version's ladder, or an edited file, calibrates again.
    An infinite PSNR (a drawing equal to the reference, as voxels are) is a measurement.
    The setting drawn is the ladder's own rung (not the file's copy of it), and whether
    the target is met is worked out again from the PSNR, not read.
    """
    rungs = [rung.setting for track in tracks for rung in track]

    def rung_of(setting) -> dict | None:
        return next((dict(r) for r in rungs if r == setting and all(
            type(r[k]) is type(setting[k]) for k in r)), None)

    def number(value) -> float | None:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return None
        try:
            value = float(value)
        except OverflowError:
            return None
        return None if math.isnan(value) else value

    setting = rung_of(stored.get("setting"))
    psnr = number(stored.get("psnr"))
    measured = stored.get("measured", [])
    if setting is None or psnr is None or psnr == -math.inf \
            or not isinstance(measured, list) or not all(
                isinstance(m, dict) and rung_of(m.get("setting")) is not None
                and number(m.get("psnr")) is not None for m in measured):
        return None
    measured = [{"setting": rung_of(m["setting"]), "psnr": number(m["psnr"]),
                 "cost": number(m.get("cost")) or 0.0} for m in measured]
    return QualityChoice(target, setting, psnr, psnr >= target.psnr, measured, 0.0, size, 0,
                         cached=True)


def drawn_box_bounds(model, lower, upper) -> np.ndarray:
    """World bounds of the index-space box ``[lower, upper]`` of ``model``, placed."""
    shift = np.eye(4)
    shift[:3, 3] = lower
    return box_world_bounds(np.asarray(model.world_from_index()) @ shift,
                            np.subtract(upper, lower))


def view_key(camera: Camera) -> tuple:
    """The camera's fields rounded to 9 significant digits (a key, not a measurement)."""
    return tuple(float(f"{v:.9g}") for value in (camera.position, camera.focal_point,
                                                   camera.view_up) for v in value) + (
        float(f"{camera.view_angle:.9g}"), camera.parallel_projection,
        float(f"{camera.parallel_scale:.9g}"))


def same_view(a: tuple, b: tuple | None) -> bool:
    """Whether two views (camera key, size, background) are one, up to float32 rounding.

    A prop's bounds are float32, so a camera framed on them may differ from the predicted
    one in the 7th digit.
    """
    if b is None or a[1:] != b[1:]:
        return False
    camera_a = np.array([float(v) for v in a[0]])
    camera_b = np.array([float(v) for v in b[0]])
    scale = max(float(np.abs(camera_a[:6]).max()), float(np.abs(camera_b[:6]).max()), 1e-30)
    return bool(np.allclose(camera_a, camera_b, rtol=1e-6, atol=1e-6 * scale))


#: The least estimated PSNR of a frame that draws its reference exactly (8-bit rounding
#: alone is about 59 dB; a grid drawn exactly with edges and clip planes measures 45-90).
EXACT_FLOOR_DB = 45.0


@dataclass
class ProbeCalibration(ABC):
    """What ``quality=`` needs to calibrate a prop, now and again when the view moves.

    ``add(plotter, model, technique=, name=, **setting, **keep)`` draws a candidate (the
    package's ``add_*``); ``reference`` is the technique's CPU reference. Subclasses give
    the ladders, the key, the trace and how a choice is applied.
    """

    model: object
    technique: str
    target: QualityTarget
    keep: dict
    add: Callable
    reference: Callable
    view: tuple | None = None
    warned: bool = False
    probe: object = None
    #: The ``add_*`` the prop comes from (messages and the cache's key).
    kind = "volume"
    #: About how many pixels of the footprint the reference traces.
    samples = SAMPLES

    @abstractmethod
    def tracks(self) -> list[list[Rung]]:
        """The ladders searched, each cheapest first."""

    @abstractmethod
    def key_parts(self) -> tuple:
        """What the choice depends on besides the view, the GL renderer and the target."""

    @abstractmethod
    def trace(self, camera: Camera, size, background, near: float, pixels) -> np.ndarray:
        """The reference's colours of ``pixels`` (``(1, n, 3)`` floats in [0, 1])."""

    @abstractmethod
    def apply(self, binding, setting: dict) -> None:
        """Draw ``setting`` from the next frame, nothing rebuilt."""

    def start(self, tracks) -> int | None:
        """The rung each track's search starts from (None: its middle)."""
        return None

    def bounds(self) -> np.ndarray:
        """World bounds of the prop as drawn (what PyVista frames the camera on)."""
        return np.asarray(self.model.world_bounds(), dtype=np.float64)

    def shading(self) -> str:
        """How the candidates are shaded: anything lit is lit by one headlight."""
        return "unlit"

    def light_probe(self, probe) -> None:
        """Light a lit look by one headlight on the probe (placed as VTK places it)."""
        self.probe = probe
        if self.shading() != "unlit":
            probe.remove_all_lights()
            probe.add_light(pyvista.Light(light_type="headlight"))

    def probe_lights(self) -> list:
        """The probe's lights as the references take them, placed for its camera now."""
        return [VolumeLight.from_pyvista(light, self.probe.camera)
                for light in self.probe.renderer.GetLights()]

    def settle(self, choice: QualityChoice) -> QualityChoice:
        """The choice as reported; ``'exact'`` is met only when measured so.

        The reference drawn, 8-bit rounding and a few grazing pixels apart: at least
        :data:`EXACT_FLOOR_DB`.
        """
        if self.target.exact:
            choice.met = choice.psnr >= EXACT_FLOOR_DB
        return choice

    def run(self, plotter, reset_camera: bool | None) -> QualityChoice:
        """Choose the rung for the view the plotter will have (cached per view)."""
        camera = camera_once_added(plotter, self.bounds(), reset_camera)
        size = tuple(int(v) for v in plotter.window_size)
        background = tuple(float(c) for c in plotter.background_color.float_rgb)
        self.view = (view_key(camera), size, background)
        return self._choose(camera, size, background)

    def _choose(self, camera: Camera, size, background) -> QualityChoice:
        tracks = self.tracks()
        probe = offscreen_plotter(size)
        try:
            probe.ren_win.SetMultiSamples(0)
            probe.set_background(background)
            self.light_probe(probe)

            def draw(setting: dict) -> None:
                self.add(probe, self.model, technique=self.technique, name="calibration",
                         reset_camera=False, render=False, **setting, **self.keep)
                camera.apply_to(probe.camera)
                probe.renderer.ResetCameraClippingRange()

            with warnings.catch_warnings():   # the candidates' own (said once by the add)
                warnings.simplefilter("ignore")
                draw(tracks[0][0].setting)
            render_frame(probe)
            near = float(probe.camera.clipping_range[0])
            key = choice_key(self.kind, self.technique, *self.key_parts(), view_key(camera),
                             size, background, renderer_name(probe), self.target.psnr,
                             self.target.name)
            stored = lookup(key)
            found = None if stored is None else stored_choice(stored, tracks, self.target,
                                                              size)
            if found is not None:
                return self.settle(found)

            def render(setting: dict) -> np.ndarray:
                draw(setting)
                render_frame(probe)
                return read_pixels(probe)

            with warnings.catch_warnings():   # the candidates' own (said once by the add)
                warnings.simplefilter("ignore")
                choice = calibrate(tracks, render,
                                   lambda pixels: self.trace(camera, size, background, near,
                                                             pixels),
                                   camera, size, self.bounds(), self.target,
                                   self.start(tracks), self.samples)
        finally:
            probe.close()
        store(key, choice.as_dict())
        choice = self.settle(choice)
        if not choice.met:
            warn_user(f"{choice}: no {self.technique!r} setting reaches {self.target.name} on "
                      f"this {self.kind} and view; ask for less, or try another technique.")
        return choice

    def follow(self, binding, plotter) -> None:
        """Warn once when a still frame is drawn from another view than the calibrated one.

        The binding gets ``recalibrate()``: the choice for the view the plotter has now.
        """
        window = plotter.ren_win

        def check(*_) -> None:
            if self.warned or window.GetDesiredUpdateRate() >= MOVING_RATE:
                return
            if not same_view(self.current_view(plotter), self.view):
                self.warned = True
                warn_user(
                    f"quality {self.target.name} was calibrated for the view at add_"
                    f"{self.kind}; the camera, window size or background has changed since, "
                    "so the error may differ: call actor.cubemarch.recalibrate() (or set the "
                    f"view before add_{self.kind}).")

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
        return (view_key(Camera.from_pyvista(plotter.renderer.camera)),
                tuple(int(v) for v in plotter.window_size),
                tuple(float(c) for c in plotter.background_color.float_rgb))

    def follow_binding(self, binding) -> None:  # noqa: B027  (most calibrations keep none)
        """What was set on the drawing since it was added, before choosing again (none)."""

    def recalibrate(self, binding, plotter) -> QualityChoice:
        """Choose again for the plotter's view now, and draw with the new choice."""
        self.follow_binding(binding)
        camera = Camera.from_pyvista(plotter.renderer.camera)
        view = self.current_view(plotter)
        choice = self._choose(camera, view[1], view[2])
        self.view, self.warned = view, False
        self.apply(binding, choice.setting)
        binding.quality = choice
        budget = getattr(binding, "frame_budget", None)
        if budget is not None:   # its still value and its estimates: this view's now
            knob = budget.knob.name
            if knob in choice.setting:
                budget.still = budget.value = float(choice.setting[knob])
            budget.errors = {float(m["setting"][knob]): m["psnr"] for m in choice.measured
                             if knob in m["setting"]}
        return choice
