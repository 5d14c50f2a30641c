"""sweep_options on a Dask LocalCluster: every setting of an option grid timed one worker at
a time (a cluster-wide lock), its errors against one reference image.

Oracle: the same settings drawn by one plotter in this process, compared with the same
reference by hand; the timed spans the workers report must not overlap.
"""

from __future__ import annotations

import distributed
import numpy as np
import pytest
import pyvista as pv

import pv_cubemarch as cm
from pv_cubemarch.cluster import sweep
from pv_cubemarch.core.rendering import offscreen_plotter
from pv_cubemarch.image_metrics import compare_images

SIZE = (96, 72)
CAMERA = cm.Camera((3.0, -2.0, 1.5), (0.0, 0.0, 0.0), (0, 0, 1))


def build(plotter, resolution, smooth_shading=False):
    plotter.set_background("black")
    plotter.add_mesh(pv.Sphere(theta_resolution=resolution, phi_resolution=resolution),
                     color="tomato", smooth_shading=smooth_shading)


def fine_sphere(camera, size):
    """The reference: the sphere finely tessellated, smooth."""
    plotter = offscreen_plotter(size)
    build(plotter, 256, True)
    camera.apply_to(plotter.camera)
    plotter.renderer.ResetCameraClippingRange()
    image = cm.render_image(plotter)
    plotter.close()
    return image


def local(setting):
    plotter = offscreen_plotter(SIZE)
    build(plotter, **setting)
    CAMERA.apply_to(plotter.camera)
    plotter.renderer.ResetCameraClippingRange()
    image = cm.render_image(plotter)
    plotter.close()
    return image


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=":0")
    with distributed.Client(cluster) as client:
        yield client
    cluster.close()


def test_every_setting_is_timed_alone_and_compared_with_the_reference(client):
    # catches (seen failing): timed frames without the cluster-wide lock (two workers'
    # spans overlapped, twice in two runs); rows put in the order they finished.
    grid = {"resolution": [6, 12, 48], "smooth_shading": [False, True]}
    rows = cm.sweep_options(build, grid, CAMERA, SIZE, reference=fine_sphere, frames=40,
                            client=client, progress_bar=False)
    settings = [dict(resolution=r, smooth_shading=s) for r in (6, 12, 48) for s in (False, True)]
    assert [row.setting for row in rows] == settings
    reference = fine_sphere(CAMERA, SIZE)
    for row, setting in zip(rows, settings, strict=True):
        expected = compare_images(local(setting), reference)
        assert row.errors["psnr"] == pytest.approx(expected.psnr, abs=1e-9)
        assert len(row.frame_ms) == 40 and row.median_ms == np.median(row.frame_ms)
    # coarse flat facets are worse than fine smooth ones: the errors say something
    assert rows[-1].errors["psnr"] > rows[0].errors["psnr"] + 3.0
    spans = sorted(row.timed for row in rows)
    assert all(later[0] >= earlier[1] for earlier, later in zip(spans[:-1], spans[1:], strict=True))


def test_the_front_holds_the_rows_nothing_beats():
    # catches (seen failing): a row beaten by its equal (ties) dropped from the front.
    def row(ms, psnr):
        return sweep.SweepRow({}, [ms], ms, {"psnr": psnr})
    rows = [row(1, 20), row(2, 30), row(3, 25), row(2, 30), row(5, 40), row(6, 40)]
    sweep.mark_front(rows)
    assert [r.pareto for r in rows] == [True, True, False, True, True, False]


@pytest.mark.parametrize("grid, message", [
    ({"resolution": []}, "is empty"),
    ({"resolution": 6}, "must be a list"),
    ([], "non-empty list"),
    ([{"resolution": 6}, 3], "non-empty list"),
])
def test_bad_grids_are_refused(grid, message):
    with pytest.raises(ValueError, match=message):
        cm.sweep_options(build, grid, CAMERA, SIZE)
