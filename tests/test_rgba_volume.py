"""RGBA (direct-colour) volumes: 4 uint8 components, drawn as PyVista's ``add_volume``.

The first three components are the colour itself; the fourth goes through the opacity
transfer function over ``clim`` (PyVista's default: the range of all four components),
per unit distance 1 (VTK reads an RGBA volume's unit distance from its fourth component,
which PyVista leaves at 1). Every technique against PyVista's own rendering of the same
data and camera, against the CPU reference, and against a slab derived by hand.

Measured (240x200, llvmpipe, ``pv.Wavelet()``: extent -10..10, alpha 0..255): every
technique 41.9 dB against PyVista (the table's colours instead: 18.6 dB), 57.9-58.1 dB
against the CPU reference, PyVista against the reference 42.3 dB.

VTK's own opacity reads the alpha as if normalised over its own range rather than 0..255
(seen: alpha 100 in a volume whose largest alpha is 100 is as opaque as alpha 39), so
PyVista's picture is the documented one only where the alpha spans 0..255; we draw the
alpha as the value it is, in every technique, and compare with PyVista on such data.
"""

from __future__ import annotations

import warnings

import matplotlib
import numpy as np
import pytest
import pyvista as pv
from conftest import VOLUME_TECHNIQUES, assert_close_to_reference, draw_at

import pv_cubemarch as cm
from pv_cubemarch.core.camera import Camera
from pv_cubemarch.core.errors import VolumeDataError
from pv_cubemarch.reference.emission_absorption import render_emission_absorption

SIZE = (240, 200)
TECHNIQUES = VOLUME_TECHNIQUES
POSITION = [(60, 40, 50), (0, 0, 0), (0, 0, 1)]


def wavelet_rgba(alpha_top: int = 255) -> pv.ImageData:
    """``pv.Wavelet()`` (extent -10..10) coloured by viridis, alpha rising as its square."""
    grid = pv.Wavelet()
    values = grid["RTData"]
    t = (values - values.min()) / np.ptp(values)
    rgb = (matplotlib.colormaps["viridis"](t)[:, :3] * 255).astype(np.uint8)
    grid["rgba"] = np.column_stack([rgb, (t**2 * alpha_top).astype(np.uint8)])
    return grid


def draw(add):
    """``add(pl)``'s image, actor and camera at POSITION."""
    return draw_at(add, SIZE, POSITION)


@pytest.fixture(scope="module")
def pyvista_image():
    """PyVista's own RGBA volume (VTK's GPU mapper)."""
    grid = wavelet_rgba()
    return draw(lambda pl: pl.add_volume(grid, scalars="rgba", mapper="gpu"))[0]


@pytest.mark.parametrize("technique", TECHNIQUES)
def test_rgba_volume_matches_pyvista_and_the_reference(technique, pyvista_image):
    # Breaks seen failing: the transfer table's colour emitted instead of the volume's own
    # (18.6 dB against PyVista); PyVista's default unit distance for scalars instead of 1
    # (33.0 dB).
    grid = wavelet_rgba()
    image, actor, camera = draw(lambda pl: cm.add_volume(pl, grid, scalars="rgba",
                                                         technique=technique))
    model = actor.cubemarch.model
    assert_close_to_reference(image, pyvista_image, 38.0, background=(0, 0, 0))
    reference = render_emission_absorption(model, camera, SIZE, step_voxels=0.25)
    assert_close_to_reference(image, reference, 50.0, background=(0, 0, 0))


def slab(rgba, thickness=4):
    """A 12x12 grid ``thickness`` voxels deep of one RGBA value (a black corner point gives
    clim 0..255 at default), seen face on in parallel projection."""
    grid = pv.ImageData(dimensions=(12, 12, thickness + 1), origin=(-6, -6, 0))
    values = np.tile(np.asarray(rgba, np.uint8), (grid.n_points, 1))
    values[0] = (0, 0, 0, 255)
    grid["rgba"] = values
    return grid


@pytest.mark.parametrize("technique", TECHNIQUES)
def test_rgba_slab_is_derived_by_hand(technique):
    # Through a slab of one colour c and alpha a, opacity o = (a - lo) / (hi - lo) per unit
    # length, so the pixel is c * (1 - (1 - o) ** thickness) over black. Alpha 100 with
    # clim 0..255 and a second case with alpha at the top of its own range (VTK's quirk:
    # reading it normalised over that range would draw o = 100/255 * 100/255).
    # Breaks seen failing: the alpha read without * 255 (direct, cube map, auto), the VTK
    # path reading the alpha over its own range (vtk: 0.77 of the colour, not 0.68).
    for rgba, clim in (((200, 100, 50, 100), None), ((40, 220, 160, 60), (0, 120))):
        grid = slab(rgba)
        if clim is not None:   # alpha 60 the largest alpha of all: no 255 corner
            grid["rgba"][0] = rgba
        pl = pv.Plotter(off_screen=True, window_size=(80, 80))
        pl.set_background("black")
        cm.add_volume(pl, grid, scalars="rgba", technique=technique, clim=clim,
                      interpolation="nearest")
        pl.camera_position = [(0, 0, 30), (0, 0, 2), (0, 1, 0)]
        pl.camera.parallel_projection = True
        pl.camera.parallel_scale = 3.0
        image = cm.render_image(pl)
        pl.close()
        lo, hi = (0.0, 255.0) if clim is None else clim
        opacity = (rgba[3] - lo) / (hi - lo)
        expected = np.array(rgba[:3]) / 255.0 * (1 - (1 - opacity) ** 4)
        centre = image[30:50, 30:50].reshape(-1, 3).astype(np.float64) / 255.0
        assert np.abs(centre - expected).max() <= 2.5 / 255, (technique, rgba, expected,
                                                              centre.mean(axis=0))


def test_numpy_rgba_and_new_values():
    # A numpy (x, y, z, 4) uint8 volume is RGBA; set_values takes new colours and the
    # image follows (the reference of the new data). Break seen failing: set_values
    # uploading the alpha alone (10.5 dB).
    rng = np.random.default_rng(5)
    rgba = rng.integers(0, 256, (10, 9, 8, 4)).astype(np.uint8)
    pl = pv.Plotter(off_screen=True, window_size=(120, 100))
    pl.set_background("black")
    actor = cm.add_volume(pl, rgba, technique="direct")
    pl.camera_position = [(25, 18, 20), (4.5, 4, 3.5), (0, 0, 1)]
    cm.render_image(pl)
    new = rgba.copy()
    new[..., 0] = 255 - new[..., 0]
    actor.cubemarch.set_values(new)
    image = cm.render_image(pl)
    camera = Camera.from_pyvista(pl.camera)
    with pytest.raises(ValueError, match="uint8 of shape"):
        actor.cubemarch.set_values(new[..., :3])
    pl.close()
    model = actor.cubemarch.model
    assert model.colors is not None and (model.colors == new).all()
    reference = render_emission_absorption(model, camera, (120, 100), step_voxels=0.25)
    assert_close_to_reference(image, reference, 40.0, background=(0, 0, 0))


def test_what_rgba_cannot_draw_is_refused():
    grid = wavelet_rgba()
    pl = pv.Plotter(off_screen=True)
    with pytest.raises(ValueError, match="blending='composite'"):
        cm.add_volume(pl, grid, scalars="rgba", blending="average")
    with pytest.raises(ValueError, match="shade=True"):
        cm.add_volume(pl, grid, scalars="rgba", shade=True)
    with pytest.warns(UserWarning, match="cmap colours nothing"):
        cm.add_volume(pl, grid, scalars="rgba", cmap="magma")
    three = grid.copy()
    three["rgb"] = grid["rgba"][:, :3]
    # Other multi-component arrays are channels (tests/test_volume_channels.py), not RGBA.
    assert len(cm.add_volume(pl, three, scalars="rgb").cubemarch.model.members) == 3
    floats = cm.add_volume(pl, three, scalars=grid["rgba"].astype(np.float32))
    assert len(floats.cubemarch.model.members) == 4
    with pytest.raises(VolumeDataError, match="4 uint8 components"):
        cm.make_volume(three, "rgb")
    actor = cm.add_volume(pl, grid, scalars="rgba", technique="direct")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ValueError, match="RGBA"):
            actor.cubemarch.set_blending("additive")
    pl.close()


def test_lit_rgba_volume_matches_the_lit_reference():
    # lights= lights an RGBA volume through its own alpha's extinction: its colours scaled
    # by the light reaching each sample, as the CPU reference lights them. Break seen
    # failing: the light map's pass reading the red component as the value (the light
    # map's sampler without CM_DIRECT_COLOR).
    grid = wavelet_rgba()
    light = cm.VolumeLight("directional", direction=(-1.0, -0.6, -0.2))
    image, actor, camera = draw(lambda pl: cm.add_volume(
        pl, grid, scalars="rgba", technique="direct", lights=[light]))
    reference = render_emission_absorption(actor.cubemarch.model, camera, SIZE,
                                           step_voxels=0.25, lights=[light])
    unlit = render_emission_absorption(actor.cubemarch.model, camera, SIZE,
                                       step_voxels=0.25)
    errors = assert_close_to_reference(image, reference, 40.0, background=(0, 0, 0))
    from pv_cubemarch.image_metrics import compare_images
    assert compare_images(image, unlit).psnr < errors.psnr - 6


def test_a_flat_rgba_grid_is_a_sheet():
    # A 1-point axis is drawn one voxel thick, as for scalars (found by review: a
    # TypeError from the 4-D shape handed to the grid). Its colour is the data's.
    grid = pv.ImageData(dimensions=(16, 16, 1))
    grid["rgba"] = np.tile(np.array([200, 100, 50, 255], np.uint8), (grid.n_points, 1))
    image, actor, _ = draw_at(lambda pl: cm.add_volume(pl, grid, scalars="rgba",
                                                       technique="direct"),
                              (80, 80), [(7.5, 7.5, 40), (7.5, 7.5, 0), (0, 1, 0)])
    assert actor.cubemarch.model.colors.shape == (16, 16, 2, 4)
    centre = image[40, 40].astype(float)
    assert centre[0] > centre[1] > centre[2] > 0
    pl = pv.Plotter(off_screen=True)
    assert cm.add_volume(pl, np.zeros((1, 1, 1, 4), np.uint8)).cubemarch.model.colors.shape \
        == (2, 2, 2, 4)
    pl.close()


def rgba_blob(origin, cmap, spacing=(1.0, 1.0, 1.0)) -> pv.ImageData:
    """A Gaussian bump of alpha (0..255) coloured by ``cmap`` over a pattern in x and y."""
    grid = pv.ImageData(dimensions=(24, 22, 20), spacing=spacing, origin=origin)
    points = grid.points
    t = np.exp(-np.sum((points - np.asarray(grid.center)) ** 2, axis=1) / (2 * 6.0**2))
    t = (t - t.min()) / np.ptp(t)
    hue = 0.5 + 0.45 * np.sin(0.3 * points[:, 0]) * np.cos(0.25 * points[:, 1])
    rgb = (matplotlib.colormaps[cmap](hue)[:, :3] * 255).astype(np.uint8)
    grid["rgba"] = np.column_stack([rgb, np.round(t * 255).astype(np.uint8)])
    return grid


def vtk_multi_volume(grids, unit, size, position) -> np.ndarray:
    """VTK's own multi-volume (one GPU mapper, one ``vtkMultiVolume``) of RGBA grids."""
    import vtk

    pl = pv.Plotter(off_screen=True, window_size=size)
    pl.set_background("black")
    mapper = vtk.vtkGPUVolumeRayCastMapper()
    mapper.SetAutoAdjustSampleDistances(False)
    mapper.SetSampleDistance(0.1)
    multi = vtk.vtkMultiVolume()
    multi.SetMapper(mapper)
    held = []
    for port, grid in enumerate(grids):
        mapper.SetInputDataObject(port, grid)
        prop = vtk.vtkVolumeProperty()
        prop.IndependentComponentsOff()
        prop.SetInterpolationTypeToLinear()
        ramp = vtk.vtkPiecewiseFunction()
        ramp.AddPoint(0, 0.0)
        ramp.AddPoint(255, 1.0)
        prop.SetScalarOpacity(ramp)
        for component in range(4):
            prop.SetScalarOpacityUnitDistance(component, unit)
        volume = vtk.vtkVolume()
        volume.SetProperty(prop)
        multi.SetVolume(volume, port)
        held.append((prop, ramp, volume))
    pl.renderer.AddVolume(multi)
    pl.camera_position = position
    image = pl.screenshot()
    pl.close()
    return image


@pytest.mark.parametrize("technique", ("direct", "cubemap"))
def test_overlapping_rgba_volumes_are_marched_jointly(technique):
    # Two overlapping RGBA volumes (one anisotropic), and an RGBA volume overlapping a
    # scalar one, are one medium (each member its own colour, the extinction of its
    # alpha), as VTK's vtkMultiVolume draws two RGBA inputs. Measured: 43.9 dB against VTK
    # (the background 11.5), 56.2 and 55.7 dB against the CPU reference. Breaks seen
    # failing: the members not marked direct (CM_DIRECT_MEMBERS left out: the red component
    # read as the value through the table): 11.5 dB; the table's colour emitted instead of
    # the member's own: 16.1 dB.
    from pv_cubemarch.image_metrics import to_uint8
    from pv_cubemarch.reference.emission_absorption import render_emission_absorption

    first = rgba_blob((-12, -11, -10), "turbo")
    second = rgba_blob((-2, -6, -4), "cool", (1.1, 0.9, 1.0))
    size, position = (200, 160), [(60, 45, 50), (2, -2, 0), (0, 0, 1)]
    a = cm.make_volume(first, "rgba", name="a", opacity_unit_distance=4.0)
    b = cm.make_volume(second, "rgba", name="b", opacity_unit_distance=4.0)
    image, actors, camera = draw_at(lambda pl: cm.add_volumes(pl, [a, b], technique=technique),
                                    size, position)
    assert len(actors) == 1   # one joint group
    assert_close_to_reference(image, vtk_multi_volume([first, second], 4.0, size, position),
                              40.0, background=(0, 0, 0))
    reference = to_uint8(render_emission_absorption(actors[0].cubemarch.model, camera, size,
                                                    step_voxels=0.25))
    assert_close_to_reference(image, reference, 50.0, background=(0, 0, 0))
    scalar = cm.make_volume(pv.Wavelet(), cmap="magma", clim=(40, 280), name="c",
                            opacity_unit_distance=6.0)
    image, actors, camera = draw_at(lambda pl: cm.add_volumes(pl, [a, scalar],
                                                              technique=technique),
                                    size, position)
    reference = to_uint8(render_emission_absorption(actors[0].cubemarch.model, camera, size,
                                                    step_voxels=0.25))
    assert_close_to_reference(image, reference, 50.0, background=(0, 0, 0))
    with pytest.raises(ValueError, match="RGBA volume marched jointly"):
        actors[0].cubemarch.set_values(np.zeros((24, 22, 20, 4), np.uint8), member="a")
