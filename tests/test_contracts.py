"""Contracts of the emission/absorption marchers, each checked so that a break shows.

Every GPU test here was seen to fail against a deliberate break of the code, named in its
docstring as "catches: ...", and to pass again once the code was restored. The checks are of
two kinds:

* pixel-wise against a closed form derived by hand in the test (constant media seen along an
  axis, where every central pixel has the same chord), within 2 levels of 255: rounding to
  8 bits is half a level, float32 arithmetic and VTK's proxy box (0.2 % short of the data
  bounds, 0.2 level here) less than one more; measured: at most 1 level;
* against the CPU reference with the project's contract (README, Correctness: PSNR >= 45 dB
  and at most 4/255 per channel), and then the same check is shown to reject what a broken
  renderer would draw (the reference rendered the broken way, and a background-only image),
  so no image without the contract can meet the tolerance.

The cube map resamples its texels on screen: at a sharp feature of the image (the box's
outline, a near-plane cut, a transfer-function edge) bilinear filtering moves the feature by
up to half a texel, so its per-pixel bound against the reference is 12/255 (as in
``test_cubemap.py``; measured up to 11 at the near-plane cut); its PSNR bound is the same
45 dB. On constant media its texels are all equal and it meets the closed forms like the
others. 'auto' draws these small volumes with its direct marcher (its cube map would march
more texels than the volume covers pixels); ``test_set_values_draws_the_new_data`` forces it
onto each path.

Two defects these tests found (both fixed with this file; the tests fail without the fix):

* ``technique='vtk'`` started its rays 0.001 (far - near) beyond the near plane wherever the
  near plane cuts the box: VTK clips its box with the near plane moved that far forward
  (vtkOpenGLGPUVolumeRayCastMapper), and ea_vtk_ray_init.glsl marched from VTK's entry.
  With the far plane 20 away: camera outside 47.9 dB / 7 levels, camera inside 30.5 dB /
  15 levels with 95 % of the pixels more than 8 levels off (at far = 40.6: 24 dB, 30 levels).
* the CPU reference's slab test (``reference.ray_box_interval``) gave a ray parallel to an
  axis and outside that axis' slab an unbounded interval instead of an empty one, so a
  parallel projection along an axis drew the (clamped) grid all over the screen.
"""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv
from conftest import BACKGROUND, VOLUME_TECHNIQUES, blob_grid, set_camera, technique_options

import pv_cubemarch as cm
from pv_cubemarch.image_metrics import compare_images, to_uint8

TECHNIQUES = VOLUME_TECHNIQUES
BG = np.asarray(BACKGROUND, dtype=np.float64)

MIN_PSNR = 45.0
MAX_LEVELS = {"vtk": 4, "direct": 4, "cubemap": 12, "auto": 12}
CLOSED_FORM_LEVELS = 2

# The constant medium of the closed forms: opacity o per opacity_unit_distance u.
OPACITY, UNIT = 0.5, 0.8


def options(model, technique, step_scale=0.5, pixels=30.0):
    """add_volume options for ``technique`` with ``step_scale``'s samples per ray.

    'auto' gets both: ``step_scale`` for its direct marcher and the cube map's sample
    count and sample factor (see ``technique_options``) for its cube map.
    """
    if technique == "auto":
        return dict(technique_options(model, "cubemap", step_scale, pixels),
                    technique="auto", step_scale=step_scale)
    return technique_options(model, technique, step_scale, pixels)


def within_contract(image, reference, technique):
    errors = compare_images(image, reference)
    return errors.psnr >= MIN_PSNR and errors.max_abs <= MAX_LEVELS[technique], errors


def assert_matches(image, reference, technique, wrong=()):
    """``image`` matches ``reference``; the background, and each of ``wrong``, would not."""
    ok, errors = within_contract(image, reference, technique)
    assert ok, (technique, errors)
    background = np.broadcast_to(BG, reference.shape)
    for name, other in [("background only", background), *wrong]:
        accepted, other_errors = within_contract(other, reference, technique)
        assert not accepted, f"the check would accept {name}: {other_errors}"


def assert_closed_form(image, mask, expected, technique):
    expected = to_uint8(np.asarray(expected)).astype(int)
    # the expected colour is far from the background: a background image fails the check
    assert np.abs(expected - to_uint8(BG).astype(int)).max() > 10 * CLOSED_FORM_LEVELS
    diff = np.abs(image[mask].astype(int) - expected)
    assert diff.max() <= CLOSED_FORM_LEVELS, (
        technique, "min", image[mask].min(axis=0), "max", image[mask].max(axis=0),
        "expected", expected)


def constant_slab(shape=(9, 9, 6), spacing=0.25, color="#ff8000"):
    """A constant medium in a box centred on the origin, 2 x 2 x 1.25 (8 x 8 x 5 texels)."""
    origin = tuple(-0.5 * (n - 1) * spacing for n in shape)
    grid = pv.ImageData(dimensions=shape, spacing=(spacing,) * 3, origin=origin)
    grid.point_data["v"] = np.ones(grid.n_points, dtype=np.float32)
    return cm.make_volume(grid, cmap=[color, color], opacity=OPACITY, clim=(0, 1),
                          opacity_unit_distance=UNIT)


def slab_pixel(model, chord):
    """The closed form of a constant medium over the background: c (1 - T) + bg T.

    T = (1 - o) ** (chord / u): a sample of opacity o absorbs the fraction o per
    opacity_unit_distance u, whatever the step.
    """
    color = model.transfer.table[0, :3].astype(np.float64)
    transmittance = (1.0 - OPACITY) ** (chord / UNIT)
    return color * (1.0 - transmittance) + BG * transmittance


def parallel_view(pl, position=(0.0, 0.0, 5.0), scale=1.5):
    """Parallel projection from ``position`` on an axis through the origin."""
    set_camera(pl, position)
    pl.camera.parallel_projection = True
    pl.camera.parallel_scale = scale
    pl.renderer.ResetCameraClippingRange()
    return cm.Camera.from_pyvista(pl.camera)


def central_pixels(size, half_extent, scale, margin=2.0):
    """Pixels of a parallel view whose centres lie ``margin`` pixels inside the box.

    ``half_extent``: the box's half width and half height on screen. (Outline pixels are
    partly covered, and multisampling blends them with the background.)
    """
    width, height = size
    pixel = 2.0 * scale / height
    xs = ((np.arange(width) + 0.5) / width * 2 - 1) * scale * width / height
    ys = ((np.arange(height) + 0.5) / height * 2 - 1) * scale
    inside_x = np.abs(xs) < half_extent[0] - margin * pixel
    inside_y = np.abs(ys) < half_extent[1] - margin * pixel
    return inside_y[:, None] & inside_x[None, :]


def render_slab_down_z(plotter_factory, model, technique, step_scale, size=(48, 48), **extra):
    """The slab from +z in parallel projection: every central chord is 1.25 along z."""
    pl = plotter_factory(size)
    # the box is 2 / (2 * 1.5 / 48) = 32 pixels wide: the cube map's LOD aims at that
    cm.add_volume(pl, model, **options(model, technique, step_scale, pixels=32.0), **extra)
    parallel_view(pl)
    image = cm.render_image(pl)
    mask = central_pixels(size, (1.0, 1.0), 1.5)
    assert mask.sum() > 400
    return image, mask


def blob_model(n=20, unit=0.3):
    return cm.make_volume(blob_grid(n), clim=(0, 1), opacity_unit_distance=unit)


# --- a. the near plane cutting the volume ----------------------------------------------------

@pytest.mark.parametrize("technique", TECHNIQUES)
@pytest.mark.parametrize("position, focal, near, angle", [
    ((0.6, 0.9, 3.6), (0.0, 0.0, 0.0), 3.7, 40.0),
    ((0.2, 0.1, 0.5), (-0.2, -0.1, -0.4), 0.6, 60.0),
], ids=["camera-outside", "camera-inside"])
def test_near_plane_cutting_the_volume(plotter_factory, technique, position, focal, near,
                                       angle):
    """Rays start on the near plane, which here cuts the volume in two.

    The near plane is 3.7 from an eye 3.77 from the blob's centre (the camera outside the
    box), or 0.6 ahead of an eye inside it; the far plane is 20 away, as a scene with other
    props puts it. The reference starts its rays at the same near distance.
    catches: rays started at the eye -- ``nearView = vec3(0.0)`` in ea_screen_ray.glsl
    (direct, cubemap, auto: seen to fail, 25.6 dB / 130 levels outside, 15.1 dB / 139
    inside); for vtk, the entry taken where the ray enters the box, ignoring the near plane
    (seen to fail, 25.6 dB / 129 levels outside, 17.8 dB / 100 inside). The reference with
    rays from the eye is rejected by the same check (25.6 dB outside, 15.1 dB inside).
    Before the fix of ea_vtk_ray_init.glsl, vtk failed here (see the module docstring).
    Measured: >= 50.7 dB, at most 3 levels (cube map: 11, at the cut outside).
    """
    model = blob_model()
    size = (48, 48)
    pl = plotter_factory(size)
    cm.add_volume(pl, model, **options(model, technique, pixels=29.0))
    set_camera(pl, position, focal=focal, angle=angle)
    pl.camera.clipping_range = (near, 20.0)  # after add_volume, which resets it
    camera = cm.Camera.from_pyvista(pl.camera)
    image = cm.render_image(pl)
    assert pl.camera.clipping_range == (near, 20.0)
    reference = cm.render_emission_absorption(model, camera, size, background=BACKGROUND,
                                              near=near)
    from_the_eye = cm.render_emission_absorption(model, camera, size, background=BACKGROUND)
    assert_matches(image, reference, technique, wrong=[("rays from the eye", from_the_eye)])


# --- b. set_values ---------------------------------------------------------------------------

def asymmetric_values(n=16):
    """A blob off every axis plus a ramp along x: transposing x and z moves both."""
    axis = np.linspace(-1.0, 1.0, n)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    blob = np.exp(-8 * ((x - 0.45) ** 2 + (y + 0.2) ** 2 + (z + 0.1) ** 2))
    return (0.9 * blob + 0.25 * (x + 1) / 2 * np.exp(-2 * (y**2 + z**2))).astype(np.float32)


@pytest.mark.parametrize("technique", TECHNIQUES)
def test_set_values_draws_the_new_data(plotter_factory, technique):
    """After set_values the image is the reference of the new data, not of its transpose.

    The first data (the symmetric blob) is drawn first, so the new data replaces an upload;
    'auto' is then drawn forced onto each of its two paths.
    catches: the new data uploaded transposed -- ``values.transpose(2, 1, 0)`` given to
    ``texture.set_data`` in VolumeBinding.set_values and VTK's input raveled in C order
    (seen to fail, every technique: 18.6 dB, 158 levels); the same transpose inside
    Texture.set_data (seen to fail for direct, cubemap, auto; VTK uploads its own texture).
    The reference of the transposed data is rejected by the same check (18.6 dB).
    Measured: >= 52.2 dB, at most 2 levels (cube map: 7).
    """
    n = 16
    grid = blob_grid(n)
    first = cm.make_volume(grid, clim=(0, 1), opacity_unit_distance=0.2)
    new = asymmetric_values(n)
    size = (48, 48)
    pl = plotter_factory(size)
    actor = cm.add_volume(pl, first, **options(first, technique, pixels=26.0))
    camera = set_camera(pl, (3.0, 2.0, 4.0))
    cm.render_image(pl)                     # the old data is on the GPU
    actor.cubemarch.set_values(new)
    image = cm.render_image(pl)

    def reference_of(values):
        changed = grid.copy()
        changed.point_data["density"] = values.ravel(order="F")
        model = cm.make_volume(changed, clim=(0, 1), opacity_unit_distance=0.2)
        return cm.render_emission_absorption(model, camera, size, background=BACKGROUND,
                                             near=pl.camera.clipping_range[0])

    reference = reference_of(new)
    transposed = reference_of(np.ascontiguousarray(new.transpose(2, 1, 0)))
    wrong = [("the transposed data", transposed)]
    assert_matches(image, reference, technique, wrong)
    if technique == "auto":  # set_values reached both of its paths
        for path in ("direct", "cubemap"):
            actor.cubemarch.force = path
            image = cm.render_image(pl)
            assert actor.cubemarch.choice == path
            assert_matches(image, reference, path, wrong)


# --- c. opacity_unit_distance ----------------------------------------------------------------

@pytest.mark.parametrize("technique", TECHNIQUES)
def test_opacity_unit_distance_closed_form(plotter_factory, technique):
    """A constant medium, opacity o per unit u, through a chord L: T = (1 - o)^(L/u).

    o = 0.5, u = 0.8, L = 1.25 (parallel projection down z, every central pixel), emission
    c = #ff8000: the pixel is c (1 - T) + background T.
    catches: sigma = o / u in TransferFunction.from_colormap (seen to fail, every
    technique: 150 instead of 177 in red, 27 levels). Tolerance: 2 levels (module
    docstring); measured 1.
    """
    model = constant_slab()
    expected = slab_pixel(model, 1.25)
    o_over_u = np.exp(-OPACITY / UNIT * 1.25)  # what sigma = o / u would give
    wrong = model.transfer.table[0, :3] * (1 - o_over_u) + BG * o_over_u
    assert np.abs(to_uint8(expected).astype(int) - to_uint8(wrong).astype(int)).max() > 20
    image, mask = render_slab_down_z(plotter_factory, model, technique, step_scale=0.5)
    assert_closed_form(image, mask, expected, technique)


# --- d. early ray termination ----------------------------------------------------------------

def two_colour_column(stop_steps=6.5):
    """A medium 2 deep along z: its front half (z > 0) emits red, its back half blue.

    Its constant extinction sigma makes the opacity accumulated in steps of 1/16 (one
    texel) cross 0.5 half-way through step ``stop_steps`` + 1: far from a step boundary, so
    float rounding cannot change the step at which the ray stops.
    """
    n = 33
    grid = pv.ImageData(dimensions=(5, 5, n), spacing=(0.5, 0.5, 2.0 / (n - 1)),
                        origin=(-1.0, -1.0, -1.0))
    k = np.arange(grid.n_points) // (5 * 5)            # z index of each point (x fastest)
    grid.point_data["v"] = (k < 16).astype(np.float32)  # 0 (red) in front, 1 (blue) behind
    h = 2.0 / (n - 1)
    sigma = np.log(2.0) / (stop_steps * h)
    model = cm.make_volume(grid, cmap=["red", "blue"], opacity=1.0 - np.exp(-sigma),
                           clim=(0, 1), opacity_unit_distance=1.0)
    return model, h


@pytest.mark.parametrize("technique", TECHNIQUES)
def test_early_termination_stops_at_the_threshold(plotter_factory, technique):
    """stop_opacity=0.5: the ray stops after the first step whose opacity exceeds 0.5.

    Seen down z in parallel projection, marched in steps of 1 texel (1/16) from the front
    face: with sigma = ln 2 / 6.5 steps, six steps give opacity 0.473, seven 0.526, so the
    pixel is red * 0.526 + background * 0.474 and holds no blue. Run to the end, the red
    half alone reaches 0.82 and the blue half shows through (66 levels more red, 22 more
    blue); stopping a step early or late is 7 levels off. Tolerance: 2 levels; measured 0.
    catches: ``if (rgba.a > cm_stopOpacity) break;`` removed from ea_march.glsl (seen to
    fail, every technique: (212, 1, 37) instead of (146, 12, 15)).
    """
    model, h = two_colour_column()
    sigma = float(model.transfer.table[0, 3])
    red = model.transfer.table[0, :3].astype(np.float64)
    steps = 1 + int(np.floor(np.log(2.0) / (sigma * h)))
    alpha = 1.0 - np.exp(-sigma * h * steps)
    assert steps == 7 and 0.52 < alpha < 0.53
    expected = red * alpha + BG * (1 - alpha)
    front = 1 - np.exp(-sigma * 1.0)
    unstopped = np.array([front, 0.0, front * (1 - front)]) + BG * (1 - front) ** 2
    assert np.abs(to_uint8(unstopped).astype(int) - to_uint8(expected).astype(int)).max() > 30
    image, mask = render_slab_down_z(plotter_factory, model, technique, step_scale=1.0,
                                     stop_opacity=0.5)
    assert_closed_form(image, mask, expected, technique)


# --- e. the last, fractional segment ---------------------------------------------------------

@pytest.mark.parametrize("technique", TECHNIQUES)
def test_last_segment_gets_its_real_length(plotter_factory, technique):
    """A chord of 5 texels marched in steps of 3.7 texels (the cube map: 4, N = 2).

    That is 1.35 (1.25) steps: the second segment is cut at the exit. Given a full step,
    the medium would absorb over 7.4 (8) texels instead of 5.
    catches: ``fraction = 1.0`` in ea_march.glsl (seen to fail, every technique: 209 instead
    of 177 in red, 32 levels; cube map 38). Tolerance: 2 levels; measured 1.
    """
    model = constant_slab()
    step = 4.0 if technique == "cubemap" else 3.7
    expected = slab_pixel(model, 1.25)
    full_step = slab_pixel(model, 1.25 * np.ceil(5 / step) * step / 5)
    assert np.abs(to_uint8(full_step).astype(int) - to_uint8(expected).astype(int)).max() > 20
    image, mask = render_slab_down_z(plotter_factory, model, technique, step_scale=step)
    assert_closed_form(image, mask, expected, technique)


# --- f. rays exactly parallel to axes --------------------------------------------------------

@pytest.mark.parametrize("technique", TECHNIQUES)
def test_rays_exactly_parallel_to_two_axes(plotter_factory, technique):
    """A 49x49 perspective view down -z through the box centre, then a parallel one down -x.

    In perspective the central pixel's ray is exactly parallel to x and y (the direct
    marcher's texture-space direction has exact zeros), the central row's to y, the central
    column's to x. VTK's mapper interpolates its ray from the rasterised box, and the cube
    map marches through texel centres, never on the axis of a power-of-two face: they meet
    exactly axis-parallel rays under a parallel projection along an axis, the second view,
    where every ray is parallel to y and z. On the constant slab the central pixels are the
    closed form of their chord (1.25 down z, 2 down x; 2 levels, measured 1), and the
    perspective image of a blob matches the reference (measured >= 51.1 dB, 3 levels).
    catches: an axis the ray does not move along taken as outside its slab --
    ``inside = vec3(0.0)`` in ea_screen_ray.glsl (seen to fail for direct, cubemap and auto:
    the pixel is the background, 151 levels off); for vtk, the ``1e30`` of non-moving axes
    dropped from cm_leave in ea_vtk_ray_init.glsl (seen to fail: the parallel view).
    """
    size = (49, 49)
    model = constant_slab()
    pl = plotter_factory(size)
    cm.add_volume(pl, model, **options(model, technique, pixels=30.0))
    set_camera(pl, (0.0, 0.0, 4.0), angle=40.0)
    image = cm.render_image(pl)
    expected = slab_pixel(model, 1.25)   # within 0.2 % of every chord this near the axis
    centre = np.zeros((49, 49), dtype=bool)
    centre[24, 20:29] = centre[20:29, 24] = True
    assert_closed_form(image, centre, expected, technique)

    pl = plotter_factory(size)
    cm.add_volume(pl, model, **options(model, technique, pixels=32.0))
    parallel_view(pl, position=(5.0, 0.0, 0.0))
    image = cm.render_image(pl)
    # the box seen from +x: 1.25 wide (z), 2 high (y); every chord is 2 long, along x
    mask = central_pixels(size, (0.625, 1.0), 1.5)
    assert mask.sum() > 200
    assert_closed_form(image, mask, slab_pixel(model, 2.0), technique)

    blob = blob_model(17, unit=0.2)
    pl = plotter_factory(size)
    cm.add_volume(pl, blob, **options(blob, technique, pixels=30.0))
    camera = set_camera(pl, (0.0, 0.0, 4.0), angle=40.0)
    image = cm.render_image(pl)
    reference = cm.render_emission_absorption(blob, camera, size, background=BACKGROUND,
                                              near=pl.camera.clipping_range[0])
    assert_matches(image, reference, technique)


# --- g. parallel projection ------------------------------------------------------------------

@pytest.mark.parametrize("technique", TECHNIQUES)
@pytest.mark.parametrize("position", [(3.0, 2.0, 4.0), (0.0, 0.0, 4.0)],
                         ids=["oblique", "down-z"])
def test_parallel_projection(plotter_factory, technique, position):
    """Parallel projection (parallel_scale 1.6) of a blob against the reference.

    catches: rays built as if they all went through the eye (the near point taken on the
    line from the eye to the back point, in ea_screen_ray.glsl: right in perspective) --
    seen to fail for direct, cubemap and auto (28.6 dB / 75 levels oblique, 25.3 dB down z)
    while every perspective test stayed green; for vtk, the ray's direction taken from the
    eye in ea_vtk_ray_init.glsl (seen to fail: 27.8 dB oblique, 26.4 dB down z). The same
    camera in perspective is rejected by the same check (32.2 dB oblique, 20.2 dB down z).
    Down z, the test failed on the reference's slab-test defect (41 dB, 5 levels; see the
    module docstring). Measured: >= 52.3 dB, at most 3 levels (cube map: 9).
    """
    model = blob_model(20, unit=0.2)
    size = (48, 48)
    pl = plotter_factory(size)
    cm.add_volume(pl, model, **options(model, technique, pixels=0.6 * 48))
    set_camera(pl, position)
    pl.camera.parallel_projection = True
    pl.camera.parallel_scale = 1.6
    pl.renderer.ResetCameraClippingRange()
    camera = cm.Camera.from_pyvista(pl.camera)
    assert camera.parallel_projection
    image = cm.render_image(pl)
    reference = cm.render_emission_absorption(model, camera, size, background=BACKGROUND,
                                              near=pl.camera.clipping_range[0])
    perspective = cm.Camera(**dict(camera.__dict__, parallel_projection=False))
    wrong = cm.render_emission_absorption(model, perspective, size, background=BACKGROUND,
                                          near=pl.camera.clipping_range[0])
    assert_matches(image, reference, technique, wrong=[("the perspective view", wrong)])


def test_reference_parallel_rays_beside_the_box_miss_it():
    """The reference itself: a ray parallel to an axis, outside that axis' slab, misses.

    catches: the slab test giving such a ray an unbounded interval (the defect in the
    module docstring: every pixel of this view was the slab's colour).
    """
    model = constant_slab()
    camera = cm.Camera(position=(0.0, 0.0, 5.0), focal_point=(0.0, 0.0, 0.0),
                       parallel_projection=True, parallel_scale=1.5)
    image = cm.render_emission_absorption(model, camera, (48, 48), background=BACKGROUND)
    mask = central_pixels((48, 48), (1.0, 1.0), 1.5)
    outside = ~central_pixels((48, 48), (1.0, 1.0), 1.5, margin=-1.0)
    assert outside.mean() > 0.25
    assert np.abs(image[outside] - BG).max() == 0.0
    assert np.abs(image[mask] - slab_pixel(model, 1.25)).max() < 1e-3
