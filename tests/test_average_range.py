"""``blending='average'`` over a range of values, as VTK's ``SetAverageIPScalarRange``.

The oracle is VTK's GPU volume mapper (``pl.add_volume(mapper='gpu')``; PyVista's default
smart mapper does not pass the range on to it, measured: its image is the same with any
range) with the range on its mapper, drawn in the same run with the same data, keywords
and camera: a CT in Hounsfield units where air (-1000) is left out of the mean, or only
bone is kept. And the CPU reference, which keeps the samples in the range on its own.

Measured (160x120, llvmpipe): vtk, direct and auto 57.2-69.8 dB, the cube map 35.4-52.9;
the CPU reference 58.2-70.9. Ignoring the range: 15.7 dB (bone only), 32.9 (air out).
"""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv
from conftest import VOLUME_TECHNIQUES
from test_pyvista_parity import synthetic_ct
from test_volume_clipping import usd_and_cli_images

import pv_cubemarch as cm

SIZE = (160, 120)
TECHNIQUES = VOLUME_TECHNIQUES
KEYWORDS = dict(cmap="bone", clim=(-200, 1500), opacity="sigmoid")
#: air left out; bone only
RANGES = ((-500.0, 3000.0), (300.0, 3000.0))
#: Floors per range: the cube map resamples its face texels (a sharper loss on bone alone).
FLOORS = {RANGES[0]: {"vtk": 50.0, "direct": 50.0, "auto": 50.0, "cubemap": 45.0,
                      "reference": 45.0},
          RANGES[1]: {"vtk": 50.0, "direct": 50.0, "auto": 50.0, "cubemap": 30.0,
                      "reference": 45.0}}


def psnr(image, reference) -> float:
    diff = (np.asarray(image, np.float64) - np.asarray(reference, np.float64)) / 255.0
    return float(10 * np.log10(1.0 / max(np.mean(diff**2), 1e-12)))


def vtk_average(grid, kept, keywords=KEYWORDS, position="iso", background="black"):
    """VTK's GPU mapper averaging ``kept`` (None: every value): image, position, camera."""
    pl = pv.Plotter(off_screen=True, window_size=SIZE)
    pl.set_background(background)
    actor = pl.add_volume(grid, mapper="gpu", blending="average", show_scalar_bar=False,
                          **keywords)
    actor.prop.interpolation_type = "linear"
    actor.mapper.SetAutoAdjustSampleDistances(False)
    actor.mapper.SetSampleDistance(0.1 * min(grid.spacing))
    if kept is not None:
        actor.mapper.SetAverageIPScalarRange(*kept)
    pl.camera_position = position
    if position == "iso":
        pl.reset_camera(bounds=grid.bounds)
    image = pl.screenshot()
    out = image, pl.camera_position, cm.Camera.from_pyvista(pl.camera)
    pl.close()
    return out


def ours(grid, technique, position, **keywords):
    pl = pv.Plotter(off_screen=True, window_size=SIZE)
    pl.set_background("black")
    fine = {} if technique == "cubemap" else dict(step_scale=0.1)
    actor = pl.cubemarch.add_volume(grid, technique=technique, blending="average", **fine,
                                    **KEYWORDS, **keywords)
    pl.camera_position = position
    return pl, actor


@pytest.fixture(scope="module")
def ct():
    grid = synthetic_ct()
    return grid, {kept: vtk_average(grid, kept) for kept in (None, *RANGES)}


@pytest.mark.parametrize("kept", RANGES, ids=["air-out", "bone-only"])
def test_average_range_draws_what_vtk_draws(ct, kept):
    """``average_range=`` in every technique and the CPU reference, against VTK's mapper.

    catches (seen failing): the range not read (``cm_averageRange`` bound to +-1e38, every
    value averaged): bone-only 15.7 dB in every technique; samples outside the range
    counted in the mean (``state.y += 1.0`` outside the test in blend_average.glsl):
    bone-only 15.7 dB.
    """
    grid, images = ct
    reference, position, camera = images[kept]
    ignored = psnr(images[None][0], reference)
    model = cm.make_volume(grid, **KEYWORDS)
    cpu = cm.render_blended(model, camera, SIZE, "average", average_range=kept)
    measured = {"reference": psnr(np.round(np.clip(cpu, 0, 1) * 255), reference)}
    for technique in TECHNIQUES:
        pl, _ = ours(grid, technique, position, average_range=kept)
        measured[technique] = psnr(cm.render_image(pl), reference)
        pl.close()
    for what, value in measured.items():
        least = FLOORS[kept][what]
        assert least > ignored + 1.0          # no floor the unranged mean meets
        assert value >= least, (kept, measured, f"ignored {ignored:.1f}")


@pytest.mark.parametrize("technique", TECHNIQUES)
def test_the_range_set_on_the_returned_mapper_is_followed(ct, technique):
    """``vol.mapper.SetAverageIPScalarRange`` after a first frame: the next frame keeps
    only that range, as VTK's mapper does.

    catches (seen failing): the range read once when the marchers are bound (a tuple,
    not the mapper read at each draw): the unranged image, 15.7 dB, every technique.
    """
    grid, images = ct
    kept = RANGES[1]
    reference, position, _ = images[kept]
    pl, actor = ours(grid, technique, position)
    cm.render_image(pl)
    actor.mapper.SetAverageIPScalarRange(*kept)
    assert psnr(cm.render_image(pl), reference) >= FLOORS[kept][technique]
    pl.close()


def test_average_range_on_data_stored_shifted():
    """The range is in the data's units where the data are stored less an offset (int64
    near 2**40): the same image as the same data at 0 with the range at 0.

    catches (seen failing): the range bound in data units (``average_range`` not less
    ``value_offset``): every sample left out, the background.
    """
    base = np.zeros((12, 12, 12), np.int64)
    base[3:9, 3:9, 3:9] = 5
    base[5:7, 5:7, 2:10] = 9
    drawn = []
    for offset in (0, 2**40):
        pl = pv.Plotter(off_screen=True, window_size=(64, 64))
        pl.set_background("black")
        pl.cubemarch.add_volume(base + offset, technique="direct", blending="average",
                                clim=(offset, offset + 9), opacity=[0, 1], step_scale=0.25,
                                average_range=(offset + 4, offset + 10))
        pl.camera_position = "iso"
        drawn.append(cm.render_image(pl).astype(float))
        pl.close()
    assert drawn[0].max() > 40           # the kept values are drawn
    assert np.abs(drawn[0] - drawn[1]).max() <= 1


def test_average_range_from_usd_and_the_command_line(tmp_path):
    """``cubemarch:averageRange`` and ``--average-range`` keep the range, as VTK's mapper.

    catches (seen failing): the range not read (as above): nearer the unranged image
    than the ranged one, through both.
    """
    grid = pv.Wavelet()
    kept = (150.0, 300.0)
    wavelet = dict(cmap="viridis", opacity="linear", clim=(40, 280))
    staged, drawn, position, background = usd_and_cli_images(
        tmp_path, grid, "averageRange", kept, blending="average")
    for image, where, behind in ((staged, [(40, 30, 35), (0, 0, 0), (0, 0, 1)], "black"),
                                 (drawn, position, background)):
        reference = vtk_average(grid, kept, wavelet, where, behind)[0]
        ignored = vtk_average(grid, None, wavelet, where, behind)[0]
        assert psnr(image, ignored) + 5.0 < psnr(image, reference)
        assert psnr(image, reference) >= 45.0


def test_bad_average_ranges_are_refused_and_other_modes_warned():
    grid = pv.Wavelet()
    for bad in ([1, 2, 3], [5, 1], "range", [0, np.inf]):
        with pytest.raises(ValueError, match="average_range takes two finite numbers"):
            cm.add_volume(pv.Plotter(off_screen=True), grid, blending="average",
                          average_range=bad)
    with pytest.warns(UserWarning, match="blending='average' only"):
        actor = cm.add_volume(pv.Plotter(off_screen=True), grid, average_range=(0, 100))
    assert actor.mapper.GetAverageIPScalarRange() == (0.0, 100.0)
