"""Reduced-resolution marching with depth-aware upsampling (direct technique)."""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv
from conftest import BACKGROUND, set_camera

import pv_cubemarch as cm
from pv_cubemarch.image_metrics import compare_images, to_uint8

SIZE = (96, 96)
GREEN = (0.2, 0.8, 0.3)


def scene_images(blob, downsample, sharpness=None):
    model = cm.make_volume(blob, clim=(0, 1), opacity_unit_distance=0.1)
    sphere = pv.Sphere(radius=0.45, center=(0.25, 0.1, 0.3))
    pl = cm.offscreen_plotter(SIZE)
    try:
        pl.set_background(BACKGROUND)
        pl.add_mesh(sphere, color=GREEN, lighting=False)
        camera = set_camera(pl, (3.0, 2.0, 4.0))
        actor = cm.add_volume(pl, model, technique="direct", downsample=downsample)
        if sharpness is not None:
            actor.cubemarch.bindings.set_uniform("cm_depthSharpness", sharpness)
        image = cm.render_image(pl)
        low = actor.cubemarch.targets[-1].size
    finally:
        pl.close()
    depth = cm.reference.mesh_depth(sphere, camera, SIZE)
    backdrop = np.where(np.isfinite(depth)[..., None], GREEN, BACKGROUND)
    reference = cm.render_emission_absorption(model, camera, SIZE, background=BACKGROUND,
                                              opaque_depth=depth, opaque_color=backdrop)
    return image, reference, depth, low


@pytest.mark.parametrize("downsample, min_psnr", [(2, 44.0), (4, 40.0)])
@pytest.mark.slow   # long: its own CI step (pytest -m slow)
def test_reduced_resolution_against_reference(blob, downsample, min_psnr):
    image, reference, _, low = scene_images(blob, downsample)
    assert low == (SIZE[0] // downsample, SIZE[1] // downsample)
    errors = compare_images(image, reference)
    assert errors.psnr >= min_psnr, errors


@pytest.mark.slow   # long: its own CI step (pytest -m slow)
def test_depth_aware_upsampling_keeps_mesh_edges_clean(blob):
    image, reference, depth, _ = scene_images(blob, 4)
    plain, _, _, _ = scene_images(blob, 4, sharpness=0.0)  # plain bilinear weights
    hit = np.isfinite(depth)
    edge = hit ^ np.roll(hit, 1, 0) | hit ^ np.roll(hit, -1, 0) | hit ^ np.roll(hit, 1, 1) \
        | hit ^ np.roll(hit, -1, 1)
    near_edge = edge | np.roll(edge, 1, 0) | np.roll(edge, -1, 0) | np.roll(edge, 1, 1) \
        | np.roll(edge, -1, 1)
    ref8 = to_uint8(reference).astype(int)

    def halo(img):
        return np.abs(img.astype(int) - ref8).max(axis=-1)[near_edge].mean()

    # at 1/4 resolution, within two pixels of the sphere's outline
    assert halo(image) < 0.5 * halo(plain), (halo(image), halo(plain))
    assert halo(image) < 12.0


def test_downsample_needs_direct_and_whole_numbers(plotter_factory, blob):
    pl = plotter_factory()
    with pytest.raises(ValueError, match="technique='direct'"):
        cm.add_volume(pl, blob, downsample=2)
    with pytest.raises(ValueError, match="whole number"):
        cm.add_volume(pl, blob, technique="direct", downsample=1.5)


def test_overlay_renderer_removed_on_close(blob):
    pl = cm.offscreen_plotter((32, 32))
    window = pl.ren_win
    before = window.GetRenderers().GetNumberOfItems()
    cm.add_volume(pl, blob, technique="direct", downsample=2)
    assert window.GetRenderers().GetNumberOfItems() == before + 1
    cm.render_frame(pl)
    pl.cubemarch.__plotter_close__()
    assert window.GetRenderers().GetNumberOfItems() == before
    pl.close()
