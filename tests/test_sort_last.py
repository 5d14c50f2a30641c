"""render_sort_last on a Dask LocalCluster: a volume cut into slabs held by different workers,
each marching the whole volume's rays through its slab, composited on the client.

Oracle: one plotter in this process drawing the whole volume (``add_volume(...,
technique='direct')``, itself checked against the CPU reference elsewhere); it shares no
partitioning, ordering or compositing with what is checked. The data are in Hounsfield-like
units (negative values), on a non-cubic grid with anisotropic spacing and an origin far
from 0.
"""

from __future__ import annotations

import os
from pathlib import Path

import distributed
import numpy as np
import pytest
import pyvista as pv

import pv_cubemarch as cm
from pv_cubemarch.cluster import sort_last
from pv_cubemarch.core.camera import Camera
from pv_cubemarch.core.rendering import offscreen_plotter
from pv_cubemarch.image_metrics import compare_images

SIZE = (120, 90)
SHAPE = (41, 33, 29)
SPACING = (0.5, 0.7, 0.9)
ORIGIN = (-100.0, 20.0, 5.0)
BACKGROUND = (0.2, 0.3, 0.4)
LOOK = {"cmap": "viridis", "opacity": "linear"}


def hounsfield(x, y, z):
    """A soft-tissue ball with a bone shell in air, -1000 to about 1200 HU."""
    r = np.sqrt(x**2 + (1.2 * y) ** 2 + (0.9 * z) ** 2)
    return (-1000.0 + 1040.0 * (r < 0.8) + 1100.0 * np.exp(-((r - 0.65) / 0.08) ** 2)
            + 60.0 * np.sin(7.0 * x) * (r < 0.8)).astype(np.float32)


def values(shape=SHAPE):
    axes = [np.linspace(-1.0, 1.0, n) for n in shape]
    return hounsfield(*np.meshgrid(*axes, indexing="ij"))


def whole_grid(data):
    grid = pv.ImageData(dimensions=data.shape, spacing=SPACING, origin=ORIGIN)
    grid.point_data["hu"] = data.ravel(order="F")
    return grid


def whole_render(grid, camera, **look):
    """One plotter drawing the whole volume: the image sort-last must equal."""
    plotter = offscreen_plotter(SIZE)
    plotter.set_background(BACKGROUND)
    cm.add_volume(plotter, grid, technique="direct", show_scalar_bar=False, **look)
    camera.apply_to(plotter.camera)
    plotter.camera_set = True
    if camera.clipping_range is None:
        plotter.renderer.ResetCameraClippingRange()
    image = cm.render_image(plotter)
    plotter.close()
    return image


def drawn_share(image) -> float:
    """Share of pixels that differ from the background (a background-only image: 0)."""
    background = np.round(np.asarray(BACKGROUND) * 255)
    return float(np.mean(np.abs(image.astype(float) - background).sum(axis=-1) > 3))


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=":0")
    with distributed.Client(cluster) as client:
        yield client
    cluster.close()


GRID = whole_grid(values())
CENTRE = np.asarray(GRID.center)
# The cut planes along x of 4 slabs of 41 points: points 0, 10, 20, 30, 40, i.e. x = -100,
# -95, -90, -85, -80.
CAMERAS = {
    # outside, oblique: every slab seen, two of them through others
    "outside": Camera(tuple(CENTRE + [40.0, 22.0, 18.0]), tuple(CENTRE), (0, 0, 1)),
    # inside the third slab (x = -88.5), looking down x and sideways: rays start inside
    "inside": Camera((-88.5, 31.0, 17.0), (-80.0, 33.0, 15.0), (0, 0, 1)),
    # inside the second slab, with a near plane 6 units ahead that crosses the cut at
    # x = -95 (it spans about x = -98 to -94): some rays start in the first slab, some in
    # the second and then cross into the first
    "near plane": Camera((-93.5, 27.0, 17.0), (-98.5, 37.0, 14.0), (0, 0, 1),
                         clipping_range=(6.0, 80.0)),
    # parallel rays along the cut axis, both ways: the slabs' order is all that counts
    "along +x": Camera((-140.0, 31.2, 17.6), (-90.0, 31.2, 17.6), (0, 0, 1),
                       parallel_projection=True, parallel_scale=16.0),
    "along -x": Camera((-40.0, 31.2, 17.6), (-90.0, 31.2, 17.6), (0, 0, 1),
                       parallel_projection=True, parallel_scale=16.0),
}


@pytest.mark.parametrize("view, step_scale", [(view, 1.0) for view in CAMERAS]
                         + [("outside", 4.0), ("inside", 3.0)])
def test_slabs_composite_to_the_whole_volume_render(client, view, step_scale):
    # catches (seen failing): ...
    camera = CAMERAS[view]
    look = dict(LOOK, step_scale=step_scale)
    expected = whole_render(GRID, camera, **look)
    assert drawn_share(expected) > 0.2
    image = cm.render_sort_last(GRID, camera, SIZE, partitions=4, axis=0, client=client,
                                background=BACKGROUND, progress_bar=False, **look)
    assert image.shape == (SIZE[1], SIZE[0], 3)
    assert compare_images(image, expected).psnr >= 50.0


@pytest.mark.parametrize("blending", ["maximum", "minimum"])
def test_projections_keep_the_extreme_of_the_slabs(client, blending):
    # catches (seen failing): ...
    camera = CAMERAS["outside"]
    # the minimum of the negated volume: air at +1000, the shell's extreme the most opaque
    grid = GRID if blending == "maximum" else whole_grid(-values())
    opacity = "sigmoid" if blending == "maximum" else "sigmoid_r"
    look = {"cmap": "magma", "blending": blending, "opacity": opacity}
    expected = whole_render(grid, camera, **look)
    assert drawn_share(expected) > 0.2
    image = cm.render_sort_last(grid, camera, SIZE, partitions=3, axis=1, client=client,
                                background=BACKGROUND, progress_bar=False, **look)
    assert compare_images(image, expected).psnr >= 50.0
