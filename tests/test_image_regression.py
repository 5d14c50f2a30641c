"""Small renders against stored baselines (refresh: pytest --update-baselines)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import BASELINES, SCENE, blob_grid, set_camera
from PIL import Image

import pv_cubemarch as cm
from pv_cubemarch.image_metrics import assert_images_close, compare_images, images_match


def render_scene():
    return cm.load_scene(SCENE).render(size=(160, 120), progress_bar=False)


def render_mixed():
    """Textures, a cut-out, image-based lighting, OpenVDB smoke, voxels and a surface."""
    return cm.load_scene(SCENE.parent / "mixed_scene.usda").render(size=(200, 125),
                                                                    progress_bar=False)


def render_blob():
    pl = cm.offscreen_plotter((64, 64))
    try:
        pl.set_background((0.1, 0.1, 0.12))
        set_camera(pl, (3.0, 2.0, 4.0))
        cm.add_volume(pl, blob_grid(24), cmap="viridis", opacity="sigmoid", clim=(0, 1),
                      opacity_unit_distance=0.2)
        return cm.render_image(pl)
    finally:
        pl.close()


CASES = {"smoke_scene": render_scene, "blob_volume": render_blob, "mixed_scene": render_mixed}


@pytest.mark.parametrize("name", sorted(CASES))
def test_matches_baseline(name, update_baselines):
    image = CASES[name]()
    path = BASELINES / f"{name}.png"
    if update_baselines or not path.exists():
        if not update_baselines:
            pytest.fail(f"no baseline {path.name}; run pytest --update-baselines and check it")
        Image.fromarray(image).save(path)
    assert_images_close(image, np.asarray(Image.open(path))[..., :3], what=name)


def test_tolerance_catches_real_changes():
    baseline = np.asarray(Image.open(BASELINES / "smoke_scene.png"))[..., :3]
    brighter = np.clip(baseline.astype(float) * 1.05, 0, 255).astype(np.uint8)
    assert not images_match(compare_images(brighter, baseline))
    shifted = np.roll(baseline, 3, axis=1)
    assert not images_match(compare_images(shifted, baseline))
    with pytest.raises(AssertionError, match="baseline"):
        assert_images_close(shifted, baseline)
    assert images_match(compare_images(baseline, baseline))
