"""Clip planes cut an implicit surface as ``mesh.clip`` cuts its contour: the cut left open.

Oracles: the CPU reference (numpy only) given the same world planes, lit by the same
headlight, for every way a surface is drawn; and PyVista's ``contour(...).clip(...)``
drawn by ``add_mesh`` (VTK's own clipping of a mesh, no code of ours).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import pyvista as pv
import vtk
from conftest import headlit_plotter
from PIL import Image

import pv_cubemarch as cm
from pv_cubemarch.core.rendering import read_pixels, render_frame
from pv_cubemarch.image_metrics import compare_images
from pv_cubemarch.reference.surfaces import render_surface

SIZE = (160, 120)
#: A plane through the ball's centre keeping its far half (the inside shows through the cut),
#: and one taking a cap off its side (the outline changes): a point, then the normal kept.
PLANES = (9.5, 9.5, 9.5, -1.0, -1.0, -0.6,
          13.0, 9.5, 9.5, -1.0, 0.0, 0.0)
DRAWINGS = {
    "index": {},
    "index-exact": {"root": "exact"},
    "cell_boxes": {"traversal": "cell_boxes"},
    "full": {"technique": "full"},
    "translucent": {"opacity": 0.5},
}


def ball() -> np.ndarray:
    x, y, z = np.meshgrid(*(np.linspace(-1.0, 1.0, 20),) * 3, indexing="ij")
    return 0.6 - np.sqrt(x * x + 1.3 * y * y + z * z)


def world_planes(numbers) -> list:
    values = np.reshape(numbers, (-1, 6))
    return [(tuple(row[:3]), tuple(row[3:])) for row in values]


def lights(plotter) -> list:
    return [cm.VolumeLight.from_pyvista(light, plotter.camera)
            for light in plotter.renderer.GetLights()]


def drawn_and_expected(add, planes, **look):
    """``add(plotter)``'s frame and the reference's image of its field cut by ``planes``."""
    plotter = headlit_plotter(SIZE)
    plotter.set_background("black")
    actor = add(plotter)
    plotter.camera_position = [(38.0, 30.0, 26.0), (9.5, 9.5, 9.5), (0.0, 0.0, 1.0)]
    plotter.renderer.ResetCameraClippingRange()
    render_frame(plotter)
    image = read_pixels(plotter)
    expected = render_surface(
        actor.cubemarch.model, cm.Camera.from_pyvista(plotter.camera), SIZE,
        color=pv.Color("tan").float_rgb, background=(0.0, 0.0, 0.0),
        near=plotter.camera.clipping_range[0], lights=lights(plotter), shading="blinn",
        clip_planes=planes, **look)
    return image, expected, actor, plotter


@pytest.mark.parametrize("drawing", DRAWINGS)
def test_clip_planes_cut_the_surface_as_the_reference_cuts_it(drawing):
    """Each way of drawing, the surface added with two planes: the reference's image of
    roots only where both keep the ray; uncut, the reference differs.

    Measured (llvmpipe): identical for index, exact roots and cell boxes; full 95.7 dB,
    translucent 62.4 dB. catches (seen failing): the span not cut in ``cm_domainRay``
    (every drawing but cell boxes: the whole ball drawn, 22.8-24.7 dB); the cell boxes'
    span not cut (24.5 dB).
    """
    keywords = DRAWINGS[drawing]
    look = {"opacity": keywords["opacity"]} if "opacity" in keywords else {}
    image, expected, actor, plotter = drawn_and_expected(
        lambda pl: cm.add_surface(pl, ball(), isovalue=0.0, color="tan", steps=200,
                                  refine_steps=30, clip_planes=PLANES, **keywords),
        world_planes(PLANES), **look)
    uncut = render_surface(actor.cubemarch.model, cm.Camera.from_pyvista(plotter.camera),
                           SIZE, color=pv.Color("tan").float_rgb,
                           near=plotter.camera.clipping_range[0], lights=lights(plotter),
                           shading="blinn", **look)
    assert compare_images(expected, uncut).psnr < 26.0   # the cut shows (24.5 dB, translucent 22.7)
    assert compare_images(image, expected).psnr >= 38.0, compare_images(image, expected)
    plotter.close()


def test_a_plane_widget_s_planes_and_set_clip_planes_cut_it_and_move():
    """Planes put on the returned actor's mapper after adding (what PyVista's plane widgets
    do) cut as ``clip_planes=`` does, follow a moved plane, and go with it; nothing is said
    of them. ``set_clip_planes`` cuts too, and ``None`` takes its planes away.

    Measured: identical to the reference at each step. catches (seen failing): the
    mapper's planes said as not drawn and left out (``follows_mapper_planes`` off).
    """
    plane = vtk.vtkPlane()
    plane.SetOrigin(*PLANES[:3])
    plane.SetNormal(*PLANES[3:6])
    image, expected, actor, plotter = drawn_and_expected(
        lambda pl: cm.add_surface(pl, ball(), isovalue=0.0, color="tan", steps=200,
                                  refine_steps=30), world_planes(PLANES[:6]))
    whole = image
    with warnings.catch_warnings():
        warnings.simplefilter("error")   # drawn: nothing said
        actor.mapper.AddClippingPlane(plane)
        render_frame(plotter)
    assert compare_images(read_pixels(plotter), expected).psnr >= 38.0
    plane.SetOrigin(6.0, 9.5, 9.5)   # moved: the cut follows
    render_frame(plotter)
    moved = render_surface(actor.cubemarch.model, cm.Camera.from_pyvista(plotter.camera),
                           SIZE, color=pv.Color("tan").float_rgb,
                           near=plotter.camera.clipping_range[0], lights=lights(plotter),
                           shading="blinn", clip_planes=[((6.0, 9.5, 9.5), PLANES[3:6])])
    assert compare_images(read_pixels(plotter), moved).psnr >= 38.0
    actor.mapper.RemoveAllClippingPlanes()
    actor.cubemarch.set_clip_planes(PLANES[6:])
    render_frame(plotter)
    capped = render_surface(actor.cubemarch.model, cm.Camera.from_pyvista(plotter.camera),
                            SIZE, color=pv.Color("tan").float_rgb,
                            near=plotter.camera.clipping_range[0], lights=lights(plotter),
                            shading="blinn", clip_planes=world_planes(PLANES[6:]))
    assert compare_images(read_pixels(plotter), capped).psnr >= 38.0
    actor.cubemarch.set_clip_planes(None)
    render_frame(plotter)
    assert np.array_equal(read_pixels(plotter), whole)
    plotter.close()


def test_several_isosurfaces_are_cut_by_the_returned_prop_s_planes():
    """Two opaque levels (each its own surface): a plane on the returned prop's mapper cuts
    both, as the reference cuts them.

    catches (seen failing): the planes followed by the first level only (30.9 dB).
    """
    plane = vtk.vtkPlane()
    plane.SetOrigin(*PLANES[:3])
    plane.SetNormal(*PLANES[3:6])

    def add(pl):
        actor = cm.add_surface(pl, ball(), isosurfaces=[0.0, 0.25], color="tan", steps=200,
                               refine_steps=30)
        actor.mapper.AddClippingPlane(plane)
        return actor

    image, expected, actor, plotter = drawn_and_expected(add, world_planes(PLANES[:6]),
                                                         levels=[0.0, 0.25])
    assert compare_images(image, expected).psnr >= 38.0, compare_images(image, expected)
    actor.mapper.RemoveAllClippingPlanes()   # set_clip_planes on the returned prop: both
    actor.cubemarch.set_clip_planes(PLANES[:6])
    render_frame(plotter)
    assert compare_images(read_pixels(plotter), expected).psnr >= 38.0
    plotter.close()


def test_a_cut_surface_draws_what_pyvista_draws_of_its_clipped_contour():
    """An isosurface of samples on a grid with its extent off 0, cut by a plane: PyVista's
    ``contour`` clipped by ``clip(invert=False)`` (which keeps the normal's side, as VTK's
    clipping planes do) and drawn by ``add_mesh``, unlit.

    The B-spline surface and marching cubes differ by a fraction of a cell: 33.8 dB, 0.7 %
    of the pixels off. catches (seen failing): the cut's side flipped (10.6 dB); no cut
    (15.1 dB).
    """
    n = 40
    grid = pv.ImageData(dimensions=(n, n, n), spacing=(0.5, 0.5, 0.5), origin=(-10, -10, -10))
    grid.SetExtent(-3, n - 4, 0, n - 1, 2, n + 1)
    points = grid.points
    grid.point_data["f"] = np.linalg.norm((points - grid.center) * [1, 1.3, 0.8], axis=1)
    # a cap off the top (the outline changes; unlit, the inside shows as the outside)
    origin, normal = np.asarray(grid.center) + [0.0, 0.0, 2.0], np.array([0.3, 0.0, -1.0])
    position = [np.asarray(grid.center) + [30.0, 20.0, 16.0], grid.center, (0.0, 0.0, 1.0)]
    images = []
    for add in (lambda pl: pl.add_mesh(grid.contour([6.0], scalars="f").clip(
                    normal=normal, origin=origin, invert=False), color="tan", lighting=False),
                lambda pl: pl.cubemarch.add_surface(
                    grid, isovalue=6.0, scalars="f", color="tan", shading="unlit",
                    clip_planes=(*origin, *normal))):
        pl = pv.Plotter(off_screen=True, window_size=SIZE)
        pl.set_background("black")
        add(pl)
        pl.camera_position = position
        pl.renderer.ResetCameraClippingRange()
        images.append(cm.render_image(pl))
        pl.close()
    reference, image = images
    errors = compare_images(image, reference)
    assert errors.psnr >= 28.0 and errors.bad_pixel_fraction <= 0.02, errors


def test_usd_and_cli_take_a_surface_s_clip_planes(tmp_path):
    """``cubemarch:clipPlanes`` on a surface prim and ``--clip-planes`` cut the surface as
    the reference cuts it.

    catches (seen failing): the attribute not reaching ``add_surface`` (the ball whole:
    21.4 dB).
    """
    from conftest import write_voxel_stage

    from pv_cubemarch import cli

    n = 16
    p = np.indices((n, n, n)).reshape(3, -1).T.astype(float)
    samples = (5.0 - np.linalg.norm(p - (n - 1) / 2.0, axis=1)).reshape(n, n, n)
    plane = [7.5, 7.5, 9.0, 0.0, 0.25, -1.0]   # a cap off the top
    path = write_voxel_stage(tmp_path, samples, technique="surface", attrs={
        "cubemarch:isovalue": ("Float", 0.0), "cubemarch:shading": ("Token", "unlit"),
        "cubemarch:clipPlanes": ("FloatArray", plane)},
        eye=(20.0, 14.0, 19.0), target=(8.0, 6.0, 7.5))
    scene = cm.load_scene(path)
    field = scene.surfaces[0]
    assert scene.surface_options[field.name]["clip_planes"] == pytest.approx(plane)
    pl = pv.Plotter(off_screen=True, window_size=(96, 72))
    pl.ren_win.SetMultiSamples(0)
    scene.add_to(pl)
    pl.set_background("black")
    image = cm.render_image(pl)
    expected = render_surface(field, cm.Camera.from_pyvista(pl.camera), (96, 72),
                              near=pl.camera.clipping_range[0],
                              clip_planes=world_planes(plane))   # in the world, as given
    whole = render_surface(field, cm.Camera.from_pyvista(pl.camera), (96, 72),
                           near=pl.camera.clipping_range[0])
    assert compare_images(expected, whole).psnr < 30.0
    assert compare_images(image, expected).psnr >= 30.0, compare_images(image, expected)
    pl.close()
    out, staged_out = tmp_path / "cut.png", tmp_path / "staged.png"
    other = [7.5, 7.5, 6.0, 0.0, 0.0, 1.0]   # the flag's plane: the bottom cap off instead
    assert cli.main(["render", str(path), "--out", str(out), "--size", "96x72",
                     "--clip-planes", *map(str, other)]) == 0
    assert cli.main(["render", str(path), "--out", str(staged_out), "--size", "96x72"]) == 0
    flagged, staged = (np.asarray(Image.open(p).convert("RGB"), dtype=int)
                       for p in (out, staged_out))
    assert (np.abs(flagged - staged).max(axis=2) > 30).sum() > 100   # the flag drawn
