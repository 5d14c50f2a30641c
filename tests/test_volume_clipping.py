"""Volumetric clipping planes, as PyVista and VTK clip their own volumes, in every technique.

The oracle is PyVista's ``pl.add_volume`` with the same planes on its mapper (VTK keeps
``normal . (x - origin) >= 0``, and shows the interior on the cut face), drawn in the same
run with the same data, keywords and camera; and the CPU reference, which cuts each world
ray with the planes on its own (``reference.rays.clip_interval``).

Measured (160x120, llvmpipe), wavelet with two oblique planes: vtk 49.4 dB, direct 50.1,
cubemap 50.2, auto 50.1; the unclipped image 15.8 dB. Floors 45 dB (cube map and auto: 42
on the moved plane, where its face texels resample a sharper cut). A crop box
(``mapper.SetCropping``) is six such planes, axis-aligned in the data's coordinates (the
grid's own frame before the volume's ``transform``: world axes, not a direction matrix's).
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
import pyvista as pv
import vtk
from conftest import MARCHING_TECHNIQUES, VOLUME_TECHNIQUES

import pv_cubemarch as cm

SIZE = (160, 120)
TECHNIQUES = VOLUME_TECHNIQUES
KEYWORDS = dict(cmap="viridis", opacity="linear", clim=(40, 280))
POSITION = [(40, 30, 35), (0, 0, 0), (0, 0, 1)]
PLANES = (((1.0, 0.0, 0.0), (1.0, 0.3, 0.2)), ((0.0, 4.0, 0.0), (0.0, -1.0, 0.0)))


def psnr(image, reference) -> float:
    diff = (np.asarray(image, np.float64) - np.asarray(reference, np.float64)) / 255.0
    return float(10 * np.log10(1.0 / max(np.mean(diff**2), 1e-12)))


def vtk_plane(origin, normal) -> vtk.vtkPlane:
    plane = vtk.vtkPlane()
    plane.SetOrigin(*origin)
    plane.SetNormal(*normal)
    return plane


def plotter(background="black") -> pv.Plotter:
    pl = pv.Plotter(off_screen=True, window_size=SIZE)
    pl.set_background(background)
    return pl


def pyvista_clipped(grid, planes, keywords=KEYWORDS, position=POSITION, background="black"):
    """PyVista's own volume with ``planes`` on its mapper: its image and camera."""
    pl = plotter(background)
    actor = pl.add_volume(grid, show_scalar_bar=False, **keywords)
    actor.prop.interpolation_type = "linear"
    actor.mapper.SetAutoAdjustSampleDistances(False)
    actor.mapper.SetSampleDistance(0.1 * min(grid.spacing))
    for origin, normal in planes:
        actor.mapper.AddClippingPlane(vtk_plane(origin, normal))
    pl.camera_position = position
    image = pl.screenshot()
    camera = cm.Camera.from_pyvista(pl.camera)
    pl.close()
    return image, camera


def ours_clipped(grid, technique, planes, keywords=KEYWORDS, position=POSITION):
    pl = plotter()
    fine = {} if technique == "cubemap" else dict(step_scale=0.1)
    actor = pl.cubemarch.add_volume(grid, technique=technique, **fine, **keywords)
    for origin, normal in planes:
        actor.mapper.AddClippingPlane(vtk_plane(origin, normal))
    pl.camera_position = position
    image = cm.render_image(pl)
    pl.close()
    return image


@pytest.fixture(scope="module")
def wavelet_clipped():
    grid = pv.Wavelet()
    reference, camera = pyvista_clipped(grid, PLANES)
    return grid, reference, camera


@pytest.mark.parametrize("technique", TECHNIQUES)
def test_planes_on_the_mapper_clip_as_pyvista_draws(wavelet_clipped, technique):
    """Two oblique planes on ``actor.mapper``: the same cut volume as PyVista's.

    catches (each seen failing, vtk): the planes ignored (``follow_clipping`` not called):
    24.5 dB; the kept side flipped (``rate > 0`` made ``rate < 0`` in clip_planes.glsl):
    14.0 dB; the planes pulled back without their translation (``world[3] = 0``): 18.6 dB.
    """
    grid, reference, _ = wavelet_clipped
    unclipped = ours_clipped(grid, technique, ())
    background = psnr(np.zeros_like(reference), reference)
    assert psnr(unclipped, reference) < 44.0 and background < 44.0   # the floor means it
    assert psnr(ours_clipped(grid, technique, PLANES), reference) >= 45.0


def test_cpu_reference_clips_as_pyvista_draws(wavelet_clipped):
    """The reference's own cut of each world ray, against PyVista's image.

    catches (seen failing): ``clip_interval`` keeping ``normal . (x - origin) <= 0``:
    12.5 dB.
    """
    grid, reference, camera = wavelet_clipped
    model = cm.make_volume(grid, **KEYWORDS)
    cpu = cm.render_emission_absorption(model, camera, SIZE, clip_planes=PLANES,
                                        near=camera.clipping_range[0])
    assert psnr(np.round(np.clip(cpu, 0, 1) * 255), reference) >= 45.0


MOVES = (((0, 0, 0), (-1, 0, 0)), ((3, -2, 1), (0.2, 1, -0.4)))


@pytest.fixture(scope="module")
def moved_plane_references(wavelet_clipped):
    """The CPU reference after each step of :func:`test_add_volume_clip_plane_works...`.

    Not PyVista's image here: once a plane was on its mapper, VTK draws dark dashes along
    the box's front edges (seams of its clipped bounding box; 43 dB against ours).
    """
    grid, _, camera = wavelet_clipped
    model = cm.make_volume(grid, **KEYWORDS)
    near = camera.clipping_range[0]
    return [np.round(np.clip(cm.render_emission_absorption(
        model, camera, SIZE, clip_planes=planes, near=near), 0, 1) * 255)
        for planes in ([MOVES[0]], [MOVES[1]], [])]


@pytest.mark.parametrize("technique", TECHNIQUES)
def test_add_volume_clip_plane_works_and_follows_the_plane(moved_plane_references, technique):
    """``pl.add_volume_clip_plane(actor)`` takes the returned volume of every technique, the
    cut follows the widget's plane when it moves (as the widget's callback moves it), and
    goes when the planes are removed.

    catches (seen failing): the returned actor not a ``pyvista.Volume`` (PyVista's
    TypeError); planes read once (``follow`` returning before reading after the first
    frame): 17.2 dB after the move; the marchers not rebuilt when the count drops to 0
    (``set_march_defines`` skipped): the cut stays (17.8 dB).

    Measured: vtk 53.0, 51.8, 50.1 dB. (With the planes on VTK's own drawing mapper, VTK
    rasterised a clipped bounding box whose front edges left dark dashes: 43.3, 42.4 dB.)
    """
    fine = {} if technique == "cubemap" else dict(step_scale=0.1)
    pl = plotter()
    actor = pl.cubemarch.add_volume(pv.Wavelet(), technique=technique, **KEYWORDS, **fine)
    widget = pl.add_volume_clip_plane(actor, normal="-x")
    widget.Off()   # its handles are not what is compared; its plane stays on the mapper
    pl.camera_position = POSITION
    plane = actor.mapper.GetClippingPlanes().GetItem(0)
    images = []
    for origin, normal in MOVES:
        plane.SetOrigin(*origin)
        plane.SetNormal(*normal)
        images.append(cm.render_image(pl))
    actor.mapper.RemoveAllClippingPlanes()
    images.append(cm.render_image(pl))
    pl.close()
    seen = [psnr(a, b) for a, b in zip(images, moved_plane_references, strict=True)]
    assert min(seen) >= (42.0 if technique in ("cubemap", "auto") else 45.0), seen


@pytest.mark.parametrize("technique", MARCHING_TECHNIQUES)
def test_axis_parallel_rays_and_a_far_volume(technique):
    """A plane parallel to the view rays (parallel projection: the ``rate == 0`` branch) on a
    CT placed 1e7 mm from the origin, in Hounsfield units, against the CPU reference.

    catches (seen failing): rays parallel to a plane kept on its clipped side (the
    ``start < 0`` branch dropped): 25.3 dB; the planes pulled back in float32 (``np.float32`` in
    ``texture_planes``): 27.2 dB (vtk).
    """
    n = 32
    x, y, z = np.mgrid[-1:1:n * 1j, -1:1:n * 1j, -1:1:n * 1j]
    hu = np.where(x**2 + y**2 + z**2 < 0.8, 300.0 + 900 * np.exp(-3 * (x**2 + y**2)), -1000)
    grid = pv.ImageData(dimensions=(n, n, n), spacing=(0.8, 0.8, 1.1),
                        origin=(1e7, -2e6, 3e6))
    grid.point_data["HU"] = hu.astype(np.int16).ravel(order="F")
    keywords = dict(cmap="bone", clim=(-200, 1300), opacity="linear")
    center = np.array(grid.center)
    planes = [(tuple(center + (2.0, 0, 0)), (1.0, 0.0, 0.0)),   # parallel to the view rays
              (tuple(center), (0.0, 0.6, 0.8))]
    pl = plotter()
    fine = {} if technique == "cubemap" else dict(step_scale=0.1)
    actor = pl.cubemarch.add_volume(grid, technique=technique, **fine, **keywords)
    for origin, normal in planes:
        actor.mapper.AddClippingPlane(vtk_plane(origin, normal))
    pl.enable_parallel_projection()
    pl.view_vector((0.0, 0.0, 1.0), viewup=(0, 1, 0))
    pl.reset_camera()
    image = cm.render_image(pl)
    camera = cm.Camera.from_pyvista(pl.camera)
    pl.close()
    model = cm.make_volume(grid, **keywords)
    cpu = np.round(np.clip(cm.render_emission_absorption(
        model, camera, SIZE, clip_planes=planes, near=camera.clipping_range[0]), 0, 1) * 255)
    unclipped = np.round(np.clip(cm.render_emission_absorption(
        model, camera, SIZE, near=camera.clipping_range[0]), 0, 1) * 255)
    assert psnr(unclipped, cpu) < 35.0   # the cut changes the picture
    assert psnr(image, cpu) >= (35.0 if technique == "cubemap" else 40.0)


def test_a_clipped_medium_casts_no_shadow():
    """With ``lights=``, the light map follows the planes: the cut-away half no longer
    shadows what is left, as in the CPU reference (which cuts its light rays itself).

    catches (seen failing): the light map not marched again when a plane moves
    (``light_map.invalidate()`` dropped from ``follow_clipping``): 22.2 dB; the light
    march ignoring the planes (``* cm_clipKeeps(middle)`` dropped): 21.3 dB.
    """
    n = 24
    x, y, z = np.mgrid[-1:1:n * 1j, -1:1:n * 1j, -1:1:n * 1j]
    grid = pv.ImageData(dimensions=(n, n, n), spacing=(2 / (n - 1),) * 3, origin=(-1, -1, -1))
    grid.point_data["density"] = (np.where(np.abs(x) < 0.9, 1.0, 0.0)
                                  * np.exp(-(y**2 + z**2))).ravel(order="F")
    light = pv.Light(position=(0, 0, 10), focal_point=(0, 0, 0), light_type="scene light")
    planes = [((0.0, 0.0, 0.0), (0.0, 0.0, -1.0))]   # keep z <= 0: the top half is cut
    pl = plotter()
    actor = pl.cubemarch.add_volume(grid, cmap="gray", clim=(0, 1), opacity=[0, 0.6],
                                    lights=[light], light_map_size=32, step_scale=0.1,
                                    technique="direct")
    pl.camera_position = [(6, -5, 1.5), (0, 0, -0.3), (0, 0, 1)]
    cm.render_image(pl)   # the light map of the whole medium
    plane = vtk_plane((0.0, 0.0, 0.5), (0.0, 0.0, -1.0))
    actor.mapper.AddClippingPlane(plane)
    cm.render_image(pl)   # ... and of the medium below z = 0.5
    plane.SetOrigin(*planes[0][0])   # moved, as a widget moves it: same count of planes
    image = cm.render_image(pl)
    camera = cm.Camera.from_pyvista(pl.camera)
    binding = actor.cubemarch
    pl.close()
    cpu = cm.render_emission_absorption(binding.model, camera, SIZE,
                                        lights=binding.light_map.lights,
                                        ambient=binding.light_map.ambient,
                                        clip_planes=planes, near=camera.clipping_range[0])
    assert psnr(image, np.round(np.clip(cpu, 0, 1) * 255)) >= 38.0


def test_stand_in_is_a_volume_with_the_bounds_and_draws_nothing():
    """The returned volume of the techniques that draw boxes is a ``pyvista.Volume`` with the
    volume's world bounds, and draws no fragment of its own (hidden, nothing is drawn).

    catches (seen failing): the stand-in left at the origin (``place_stand_in`` without
    ``SetOrigin``): its bounds, and so ``reset_camera`` and the clip-plane widget, are off.
    """
    grid = pv.Wavelet()
    for technique in ("direct", "cubemap", "auto"):
        pl = plotter()
        pl.add_mesh(pv.Sphere(radius=4, center=(14, 0, 0)), color="red")
        actor = pl.cubemarch.add_volume(grid, technique=technique, **KEYWORDS)
        assert isinstance(actor, pv.Volume)
        np.testing.assert_allclose(actor.bounds, grid.bounds, atol=1e-6)
        pl.camera_position = POSITION
        shown = cm.render_image(pl)
        actor.SetVisibility(False)
        hidden = cm.render_image(pl)
        pl.close()
        plain = plotter()
        plain.add_mesh(pv.Sphere(radius=4, center=(14, 0, 0)), color="red")
        plain.camera_position = POSITION
        assert np.array_equal(hidden, cm.render_image(plain))
        assert not np.array_equal(shown, hidden)
        plain.close()


REGION = (-7.0, 6.0, -10.0, 3.5, -4.0, 10.0)


def vtk_crop_region(region, grid):
    """The cropping planes to give VTK's GPU mapper so that it crops at ``region``.

    VTK maps a cropping plane ``x`` through its texture coordinates as if the texel centres
    sat on the grid's first and last points: it crops at ``lo + (x - lo) n / (n - 1) - h/2``
    (``n`` points ``h`` apart from ``lo``), up to half a voxel off (measured: 33.6 dB
    against the exact crop; 54.8 dB with this mapping). pv_cubemarch crops at ``x``.
    """
    bounds, dims = grid.bounds, grid.dimensions
    planes = []
    for index, value in enumerate(region):
        axis = index // 2
        lo, hi, n = bounds[2 * axis], bounds[2 * axis + 1], dims[axis]
        h = (hi - lo) / (n - 1)
        planes.append(lo + (value - lo + 0.5 * h) * (n - 1) / n)
    return planes


def pyvista_crop(grid, position=POSITION, background="black"):
    """PyVista's volume cropped to REGION by its mapper: its image and camera."""
    pl = plotter(background)
    actor = pl.add_volume(grid, show_scalar_bar=False, **KEYWORDS)
    actor.prop.interpolation_type = "linear"
    actor.mapper.SetAutoAdjustSampleDistances(False)
    actor.mapper.SetSampleDistance(0.1)
    actor.mapper.SetCropping(True)
    actor.mapper.SetCroppingRegionPlanes(*vtk_crop_region(REGION, grid))
    pl.camera_position = position
    image = cm.render_image(pl)
    camera = cm.Camera.from_pyvista(pl.camera)
    pl.close()
    return image, camera


@pytest.fixture(scope="module")
def pyvista_cropped():
    grid = pv.Wavelet()
    return grid, *pyvista_crop(grid)


@pytest.mark.parametrize("technique", TECHNIQUES)
def test_crop_box_crops_as_vtk_in_every_technique(pyvista_cropped, technique):
    """``mapper.SetCropping(True)`` with a sub-volume box: VTK's image of the same box.

    Measured: vtk 54.9 dB, direct 54.7, cubemap 54.4, auto 54.7.
    catches (seen failing): the crop box ignored (``crop_planes`` returning ``()``):
    14.8 dB; its planes' normals pointing out of the box (``sign`` swapped): 13.8 dB.
    """
    grid, reference, _ = pyvista_cropped
    pl = plotter()
    fine = {} if technique == "cubemap" else dict(step_scale=0.1)
    actor = pl.cubemarch.add_volume(grid, technique=technique, **fine, **KEYWORDS)
    actor.mapper.SetCropping(True)
    actor.mapper.SetCroppingRegionPlanes(*REGION)
    pl.camera_position = POSITION
    image = cm.render_image(pl)
    actor.mapper.SetCropping(False)
    uncropped = cm.render_image(pl)
    pl.close()
    assert psnr(uncropped, reference) < 40.0
    assert psnr(image, reference) >= (42.0 if technique in ("cubemap", "auto") else 45.0)


def test_crop_box_matches_the_reference_cut_by_its_six_planes(pyvista_cropped):
    """The CPU reference cut by the box's six planes is VTK's cropped image."""
    grid, reference, camera = pyvista_cropped
    box = [((REGION[0], 0, 0), (1, 0, 0)), ((REGION[1], 0, 0), (-1, 0, 0)),
           ((0, REGION[2], 0), (0, 1, 0)), ((0, REGION[3], 0), (0, -1, 0)),
           ((0, 0, REGION[4]), (0, 0, 1)), ((0, 0, REGION[5]), (0, 0, -1))]
    cpu = cm.render_emission_absorption(cm.make_volume(grid, **KEYWORDS), camera, SIZE,
                                        clip_planes=box, near=camera.clipping_range[0])
    assert psnr(np.round(np.clip(cpu, 0, 1) * 255), reference) >= 45.0


def test_crop_flags_other_than_a_sub_volume_are_refused():
    """A fence or cross of regions is not drawn: the frame says what is."""
    pl = plotter()
    actor = pl.cubemarch.add_volume(pv.Wavelet(), technique="direct", **KEYWORDS)
    actor.mapper.SetCropping(True)
    actor.mapper.SetCroppingRegionFlagsToFence()
    with pytest.raises(ValueError, match="sub-volume"):
        cm.render_image(pl)
    pl.close()


@pytest.mark.parametrize("technique", TECHNIQUES)
def test_crop_box_moves_with_a_placement_set_after_adding(technique):
    """``vol.position`` set after adding, then a crop box: VTK's image of the same.

    catches (seen failing, a review's find): the crop box placed with the volume's old
    placement on the frame the volume moved (``follow_clipping`` before the placement in
    ``follow_returned_volume``): direct, cubemap, auto 17.5 dB.
    """
    grid = pv.Wavelet()

    def cropped(pl, vol, region):
        vol.position = (6.0, 0.0, 0.0)
        vol.mapper.SetCropping(True)
        vol.mapper.SetCroppingRegionPlanes(*region)
        pl.camera_position = POSITION
        return cm.render_image(pl)

    pl = plotter()
    theirs = pl.add_volume(grid, show_scalar_bar=False, **KEYWORDS)
    theirs.prop.interpolation_type = "linear"
    theirs.mapper.SetAutoAdjustSampleDistances(False)
    theirs.mapper.SetSampleDistance(0.1)
    reference = cropped(pl, theirs, vtk_crop_region(REGION, grid))
    pl.close()
    pl = plotter()
    fine = {} if technique == "cubemap" else dict(step_scale=0.1)
    image = cropped(pl, pl.cubemarch.add_volume(grid, technique=technique, **fine, **KEYWORDS),
                    REGION)
    pl.close()
    assert psnr(image, reference) >= (42.0 if technique in ("cubemap", "auto") else 45.0)


def usd_and_cli_images(tmp_path, grid, attribute: str, numbers, blending=None) -> tuple:
    """``grid`` drawn through a USD stage with ``cubemarch:<attribute>`` (at POSITION, on
    black) and through ``pv-cubemarch render`` with its flag (at the grid scene's default
    camera), with ``blending`` if given: both images, that camera and the scene's
    background."""
    from conftest import write_voxel_stage
    from PIL import Image

    from pv_cubemarch.cli import main
    path = tmp_path / "wavelet.vti"
    grid.save(path)
    stage = write_voxel_stage(tmp_path, None, technique="direct", file_name="wavelet.vti",
                              translate=(0.0, 0.0, 0.0), rotate_y=0.0, attrs={
                                  f"cubemarch:{attribute}": ("FloatArray", list(numbers)),
                                  "cubemarch:stepScale": ("Float", 0.1),
                                  "cubemarch:cmap": ("Token", "viridis"),
                                  "cubemarch:clim": ("FloatArray", [40.0, 280.0]),
                                  **({"cubemarch:blending": ("Token", blending)}
                                     if blending else {})})
    scene = cm.load_scene(stage)
    scene.cameras.clear()   # PyVista's view angle, as the oracle's
    scene.background = (0.0, 0.0, 0.0)
    pl = plotter()
    scene.add_to(pl)
    pl.camera_position = POSITION
    staged = cm.render_image(pl)
    pl.close()
    grid_scene = cm.load_scene(path)
    camera = grid_scene.default_camera(SIZE[0] / SIZE[1])
    flag = "--" + re.sub("([A-Z])", lambda m: "-" + m.group(1).lower(), attribute)
    out = tmp_path / "cli.png"
    assert main(["render", str(path), "--technique", "direct", "--step-scale", "0.1",
                 "--cmap", "viridis", "--clim", "40", "280", flag, *map(str, numbers),
                 *(("--blending", blending) if blending else ()), "-o", str(out),
                 "--size", "160x120", "--no-progress"]) == 0
    drawn = np.asarray(Image.open(out))[..., :3]
    return staged, drawn, [camera.position, camera.focal_point, camera.view_up], \
        grid_scene.background


def test_clip_planes_from_python_usd_and_the_command_line(wavelet_clipped, tmp_path):
    """``clip_planes=`` (six numbers a plane), ``cubemarch:clipPlanes`` and
    ``--clip-planes`` cut the volume as PyVista's planes on its mapper do.

    catches (seen failing): the planes not put on the mapper (``clip_plane_list`` given
    nothing): the unclipped image, 15.8 dB; a plane's point and normal swapped: 16.5 dB.
    """
    grid, reference, _ = wavelet_clipped
    numbers = [v for origin, normal in PLANES for v in (*origin, *normal)]
    pl = plotter()
    pl.cubemarch.add_volume(grid, technique="direct", step_scale=0.1, clip_planes=numbers,
                            **KEYWORDS)
    pl.camera_position = POSITION
    assert psnr(cm.render_image(pl), reference) >= 45.0
    pl.close()
    staged, drawn, position, background = usd_and_cli_images(tmp_path, grid, "clipPlanes",
                                                             numbers)
    assert psnr(staged, reference) >= 45.0
    theirs, _ = pyvista_clipped(grid, PLANES, position=position, background=background)
    assert psnr(drawn, theirs) >= 45.0
    with pytest.raises(ValueError, match="six numbers a plane"):
        cm.add_volume(pv.Plotter(off_screen=True), grid, clip_planes=[1, 2, 3])
    with pytest.raises(ValueError, match="not zero"):
        cm.add_volume(pv.Plotter(off_screen=True), grid, clip_planes=[0, 0, 0, 0, 0, 0])


def test_crop_box_from_python_usd_and_the_command_line(pyvista_cropped, tmp_path):
    """``crop_box=``, ``cubemarch:cropBox`` and ``--crop-box`` crop as VTK's mapper does.

    catches (seen failing): the box not set on the mapper (the uncropped image).
    """
    grid, reference, _ = pyvista_cropped
    pl = plotter()
    pl.cubemarch.add_volume(grid, technique="direct", step_scale=0.1, crop_box=REGION,
                            **KEYWORDS)
    pl.camera_position = POSITION
    assert psnr(cm.render_image(pl), reference) >= 45.0
    pl.close()
    staged, drawn, position, background = usd_and_cli_images(tmp_path, grid, "cropBox",
                                                             REGION)
    assert psnr(staged, reference) >= 45.0
    theirs, _ = pyvista_crop(grid, position, background)
    assert psnr(drawn, theirs) >= 45.0
    for bad in ([0, 1, 2], [5, 0, 0, 1, 0, 1], "box"):
        with pytest.raises(ValueError, match="crop_box takes six"):
            cm.add_volume(pv.Plotter(off_screen=True), grid, crop_box=bad)


def test_a_crop_box_that_keeps_nothing_is_said():
    # A box beside the data (in its coordinates, before user_matrix) draws nothing: said
    # once, naming the volume; a box that cuts the data, or one beside it in the world but
    # on it in the data's coordinates, says nothing.
    # catches (seen failing, found by a review): a box outside passed in silence (and
    # quality= reported it met at infinite PSNR)
    grid = pv.ImageData(dimensions=(8, 8, 8), spacing=(1.0, 2.0, 0.5), origin=(-500.0, 7.0, 0.0))
    grid.point_data["v"] = np.arange(512, dtype=float)
    moved = np.eye(4)
    moved[0, 3] = 1000.0   # the data placed at x = 500 .. 507 in the world
    for box, matrix, said in (((0.0, 5.0, 0.0, 5.0, 0.0, 5.0), None, True),
                              ((-497.0, -495.0, 8.0, 10.0, 1.0, 2.0), None, False),
                              ((-497.0, -495.0, 8.0, 10.0, 1.0, 2.0), moved, False),
                              ((500.0, 505.0, 8.0, 10.0, 1.0, 2.0), moved, True)):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            cm.add_volume(pv.Plotter(off_screen=True), grid, crop_box=box, name="scan",
                          user_matrix=matrix)
        messages = [str(w.message) for w in caught if "keeps none" in str(w.message)]
        assert bool(messages) == said, (box, messages)
        assert all("'scan'" in m for m in messages)
