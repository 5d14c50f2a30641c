"""sweep_options on a Dask LocalCluster: every setting of an option grid timed one worker at
a time (a cluster-wide lock), its errors against one reference image.

Oracle: the same settings drawn by one plotter in this process, compared with the same
reference by hand; the timed spans the workers report must not overlap.
"""

from __future__ import annotations

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


def rendered(draw, camera, size):
    """``draw(plotter)`` rendered from ``camera`` by one plotter in this process."""
    plotter = offscreen_plotter(size)
    draw(plotter)
    camera.apply_to(plotter.camera)
    plotter.renderer.ResetCameraClippingRange()
    image = cm.render_image(plotter)
    plotter.close()
    return image


def fine_sphere(camera, size):
    """The reference: the sphere finely tessellated, smooth."""
    return rendered(lambda plotter: build(plotter, 256, True), camera, size)


def local(setting):
    return rendered(lambda plotter: build(plotter, **setting), CAMERA, SIZE)


@pytest.mark.slow   # long (10 s): its own CI step (pytest -m slow)
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


@pytest.mark.slow   # long: its own CI step (pytest -m slow)
def test_a_reference_made_in_bands_on_the_workers_is_the_whole_one(client):
    # catches (seen failing): the opaque layer not cut to each band's rows; a band's rays
    # one row off; the bands stacked in another order.
    from pv_cubemarch.cluster.offload import Offload
    from pv_cubemarch.reference.emission_absorption import render_emission_absorption

    data = np.linspace(-1000.0, 1500.0, 17 * 13 * 11).reshape(17, 13, 11)
    grid = pv.ImageData(dimensions=data.shape, spacing=(0.5, 0.7, 0.9), origin=(-5, 3, 2))
    grid.point_data["hu"] = data.ravel(order="F")
    volume = cm.make_volume(grid, cmap="bone", opacity="linear")
    camera = cm.Camera((12.0, -8.0, 9.0), tuple(grid.center), (0, 0, 1))
    size = (40, 31)
    rows, cols = np.mgrid[0:size[1], 0:size[0]]
    depth = 16.0 + 0.3 * rows + 0.1 * cols   # an opaque wall cutting the volume, per pixel
    colour = np.stack([rows / size[1], cols / size[0], 0.5 + 0 * rows], axis=-1)
    whole = render_emission_absorption(volume, camera, size, step_voxels=0.5,
                                       opaque_depth=depth, opaque_color=colour)
    banded = Offload(client).banded(render_emission_absorption, size, volume, camera, size,
                                    step_voxels=0.5, sliced={"opaque_depth": depth,
                                                             "opaque_color": colour}).result()
    assert np.array_equal(banded, whole)
    # the volume shows in front of the wall on most pixels, and the wall cuts it on some
    assert np.mean(np.abs(whole - colour).max(axis=-1) > 0.05) > 0.5
    free = render_emission_absorption(volume, camera, size, step_voxels=0.5)
    assert np.mean(np.abs(whole - free).max(axis=-1) > 0.05) > 0.2


@pytest.mark.slow   # long (7 s): its own CI step (pytest -m slow)
def test_bench_tradeoff_computes_its_references_on_the_cluster(client, tmp_path):
    # The same rows and errors as computed here; the rows still timed side by side here.
    # catches (seen failing): the reference's bands stacked in another order.
    import json

    from pv_cubemarch.cli import main

    runs = []
    for extra in ([], ["--scheduler", client.scheduler.address]):
        path = tmp_path / f"tradeoff{len(extra)}.json"
        assert main(["bench", "tradeoff", "direct", "--size", "64x48", "--no-stock",
                     "--json", str(path), *extra]) == 0
        runs.append(json.loads(path.read_text()))
    here, there = ([(r["setting"], r["errors"]["psnr"]) for r in run.get("results", run.get(
        "rows"))] for run in runs)
    assert here == there and len(here) >= 5


@pytest.mark.parametrize("reference", ["voxels", "surface"])
@pytest.mark.slow   # long: its own CI step (pytest -m slow)
def test_a_per_pixel_record_made_in_bands_is_the_whole_one(client, reference):
    # The voxel traversal's and the surface roots' records (dataclasses of per-pixel
    # images), stacked field by field. catches (seen failing): bands stacked in another
    # order.
    from pv_cubemarch.bench.surfaces import shape_field
    from pv_cubemarch.cluster.offload import Offload
    from pv_cubemarch.models.surface import active_cells
    from pv_cubemarch.reference.surfaces import trace_surface
    from pv_cubemarch.reference.voxels import trace_voxels

    size = (36, 27)
    if reference == "voxels":
        labels = np.zeros((9, 8, 7), np.uint16)
        labels[2:7, 1:6, 3:] = 4
        labels[::3, ::2, 1] = 9
        camera = cm.Camera((20.0, -14.0, 16.0), (4.5, 4.0, 3.5), (0, 0, 1))
        args, kwargs = (trace_voxels, labels, np.eye(4), camera, size), {"near": 0.1}
    else:
        field = shape_field("blobs", 12)
        camera = cm.Camera((3.0, -2.5, 2.0), (0.0, 0.0, 0.0), (0, 0, 1))
        args, kwargs = (trace_surface, field, active_cells(field), camera, size), {}
    whole = args[0](*args[1:], **kwargs)
    banded = Offload(client).banded(args[0], size, *args[1:], **kwargs).result()
    assert type(banded) is type(whole)
    for name in vars(whole):
        assert np.array_equal(getattr(banded, name), getattr(whole, name), equal_nan=True), name
    hit = whole.material > 0 if reference == "voxels" else whole.hit
    assert 0.1 < hit.mean() < 0.9
