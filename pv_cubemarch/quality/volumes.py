"""``add_volume(..., quality=)``: calibrate an emission/absorption technique on the view.

The volume is drawn alone, unlit, over black, at the plotter's window size from the
camera the plotter will have once the volume is added, on a second offscreen plotter; the
CPU reference (the technique's own) traces a sample of the same frame's pixels. The choice
is kept per data, transfer function, placement, camera, window size, GL renderer and
target.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Callable

import numpy as np
from vtkmodules.vtkRenderingCore import vtkCamera

from ..core.camera import Camera
from ..core.rendering import offscreen_plotter, read_pixels, render_frame
from .cache import choice_key, lookup, store
from .calibration import QualityChoice, calibrate
from .ladders import volume_tracks
from .targets import QualityTarget, parse_quality

#: The knobs a ladder sets: giving one with ``quality=`` is a contradiction.
PICKED = ("step_scale", "face_size", "max_samples", "sample_factor")
#: Step of the CPU reference, in voxels (as the speed/accuracy benches).
REFERENCE_STEP = 0.1


def check_quality_request(quality, given: dict, blending: str, shade: bool, lights,
                          single_unlit_volume: bool) -> QualityTarget:
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


def calibrate_volume(plotter, model, technique: str, target: QualityTarget, keep: dict,
                     reset_camera: bool | None, add: Callable, reference: Callable
                     ) -> QualityChoice:
    """Choose ``technique``'s rung for ``model`` in ``plotter``'s view (cached).

    ``add(plotter, model, technique=, name=, **setting, **keep)`` draws a candidate (the
    package's ``add_volume``); ``reference`` is the technique's CPU reference.
    """
    tracks = volume_tracks(technique, model.dimensions)
    size = tuple(int(v) for v in plotter.window_size)
    camera = camera_once_added(plotter, model.world_bounds(), reset_camera)
    probe = offscreen_plotter(size)
    try:
        probe.ren_win.SetMultiSamples(0)
        probe.set_background("black")

        def draw(setting: dict) -> None:
            add(probe, model, technique=technique, name="calibration", reset_camera=False,
                render=False, **setting, **keep)
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
                         dataclass_tuple(camera), size, _renderer_name(probe), target.psnr,
                         sorted(keep.items()))
        stored = lookup(key)
        if stored is not None:
            return QualityChoice(target, dict(stored["setting"]), float(stored["psnr"]),
                                 bool(stored["met"]), list(stored.get("measured", [])),
                                 0.0, size, 0, cached=True)

        def render(setting: dict) -> np.ndarray:
            draw(setting)
            render_frame(probe)
            return read_pixels(probe)

        def traced(pixels) -> np.ndarray:
            return reference(model, camera, size, step_voxels=REFERENCE_STEP, near=near,
                             pixels=pixels)

        start = next((i for i, rung in enumerate(tracks[0])
                      if rung.setting.get("step_scale") == 1.0), None)
        choice = calibrate(tracks, render, traced, camera, size, model.world_bounds(),
                           target, start)
    finally:
        probe.close()
    store(key, choice.as_dict())
    if not choice.met:
        warnings.warn(f"{choice}: no {technique!r} setting reaches {target.name} on this "
                      "volume and view; ask for less, or try another technique.", stacklevel=3)
    return choice


def dataclass_tuple(camera: Camera) -> tuple:
    """The camera's fields rounded to 9 significant digits (a key, not a measurement)."""
    return tuple(float(f"{v:.9g}") for value in (camera.position, camera.focal_point,
                                                   camera.view_up) for v in value) + (
        float(f"{camera.view_angle:.9g}"), camera.parallel_projection,
        float(f"{camera.parallel_scale:.9g}"))
