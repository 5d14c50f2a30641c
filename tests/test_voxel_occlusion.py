"""Voxel ambient occlusion: the reference's formula by hand, and the GPU against it.

The scene of the hand-derived cases is a 6x6 floor (z = 0, material 1) with two blocks on
it, diagonal neighbours at (2, 2, 1) and (3, 3, 1) (material 2), and a hidden voxel at
(0, 5, 1) (material 3, opacity 0). The formula (``occlusion_factor``): for a face entered
moving ``+axis`` (face ``2 axis + 1``) the layer is ``voxel - e_axis``, else ``voxel +
e_axis``; ``u = (axis + 1) % 3``, ``v = (axis + 2) % 3``; corner ``(du, dv)`` has level 3
when ``side1 = layer + du e_u`` and ``side2 = layer + dv e_v`` are both drawn, else
``side1 + side2 + corner``; levels are mixed bilinearly at ``s = x_u - i_u``, ``r = x_v -
i_v``; ``factor = 1 - strength * level / 3``.
"""

from __future__ import annotations

import inspect

import numpy as np
import pytest
import pyvista as pv
from conftest import (
    BACKGROUND,
    assert_close_to_reference,
    light_with_sun_and_lamp,
    rotated_mirrored_placement,
    set_camera,
)

import pv_cubemarch as cm
from pv_cubemarch.core.registry import get_technique
from pv_cubemarch.reference.voxels import (
    VoxelHits,
    occlusion_factor,
    render_voxels,
    trace_voxels,
)
from pv_cubemarch.voxels.options import VoxelOptions
from pv_cubemarch.voxels.technique import voxel_recipe

PALETTE = {1: "tan", 2: "steelblue", 3: ("firebrick", 0.0)}
VISIBLE = np.array([False, True, True, False])


def floor_scene() -> np.ndarray:
    labels = np.zeros((6, 6, 3), np.uint8)
    labels[:, :, 0] = 1
    labels[2, 2, 1] = labels[3, 3, 1] = 2
    labels[0, 5, 1] = 3
    return labels


def floor_level(s, r):
    """The level on the top face (face 4: entered moving -z) of floor voxel (3, 2, 0).

    Layer (3, 2, 1); u = x, v = y. Corners (du, dv), at (s, r) = ((du + 1) / 2, (dv + 1) / 2):
    (-1, -1): side1 (2, 2, 1) block, side2 (3, 1, 1) empty, corner (2, 1, 1) empty -> 1;
    (+1, -1): (4, 2, 1), (3, 1, 1), (4, 1, 1) all empty -> 0;
    (-1, +1): side1 (2, 2, 1) and side2 (3, 3, 1) both blocks -> 3 (the corner (2, 3, 1)
    is empty: the plain sum would say 2);
    (+1, +1): side2 (3, 3, 1) block, side1 (4, 2, 1) and corner (4, 3, 1) empty -> 1.
    """
    return (1 - s) * (1 - r) * 1 + s * (1 - r) * 0 + (1 - s) * r * 3 + s * r * 1


def hits_at(rows) -> VoxelHits:
    """Hand-made hits: rows of ``(voxel, face, index-space point)``."""
    n = len(rows)
    return VoxelHits(index=np.array([[r[0] for r in rows]]), material=np.ones((1, n), int),
                     face=np.array([[r[1] for r in rows]]), depth=np.ones((1, n)),
                     near_edge=np.zeros((1, n), bool),
                     point=np.array([[r[2] for r in rows]], dtype=float))


def test_occlusion_factor_by_hand():
    # catches (seen to fail, each on its own, in occlusion_factor): the side1 && side2 -> 3
    # rule replaced by the plain sum (2.0625 -> 1.5 at the first point); the layer taken on
    # the far side of the face (the floor's top unoccluded, its bottom dark); no
    # interpolation (the nearest corner's level); u and v swapped in (s, r); hidden
    # materials counted as drawn.
    hits = hits_at([
        ((3, 2, 0), 4, (3.25, 2.75, 1.0)),   # floor top, near both blocks
        ((3, 2, 0), 4, (3.5, 2.5, 1.0)),     # the face's centre: the corners' mean
        ((3, 2, 0), 5, (3.25, 2.75, 0.0)),   # its bottom, seen from below: layer z = -1
        ((2, 2, 1), 0, (3.0, 2.5, 1.5)),     # a block's +x side (entered moving -x)
        ((0, 0, 0), 4, (0.3, 0.6, 1.0)),     # floor far from the blocks
        ((1, 4, 0), 4, (0.1, 4.9, 1.0)),     # floor next to the hidden voxel only
        ((3, 2, 0), -1, (3.25, 2.75, 0.5)),  # the ray starts inside the voxel
    ])
    factor = occlusion_factor(floor_scene(), hits, 0.5, visible=VISIBLE)[0]
    # floor_level(0.25, 0.75) = 0.1875 + 1.6875 + 0.1875 = 2.0625; 1 - 0.5 * 2.0625 / 3
    assert floor_level(0.25, 0.75) == 2.0625
    assert factor[0] == pytest.approx(0.65625, abs=1e-12)
    # the centre: (1 + 0 + 3 + 1) / 4 = 1.25 -> 1 - 0.5 * 1.25 / 3
    assert factor[1] == pytest.approx(1 - 0.5 * 1.25 / 3, abs=1e-12)
    assert factor[2] == 1.0
    # Block (2, 2, 1), face 0: layer (3, 2, 1), u = y, v = z, (s, r) = (0.5, 0.5).
    # (-1, -1): (3, 1, 1) empty, (3, 2, 0) floor, (3, 1, 0) floor -> 2; (+1, -1): (3, 3, 1)
    # block and (3, 2, 0) floor -> 3; (-1, +1): (3, 1, 1), (3, 2, 2), (3, 1, 2) empty -> 0;
    # (+1, +1): (3, 3, 1) block only -> 1. Level (2 + 3 + 0 + 1) / 4 = 1.5 -> 0.75.
    assert factor[3] == pytest.approx(0.75, abs=1e-12)
    assert factor[4] == factor[5] == factor[6] == 1.0
    assert occlusion_factor(floor_scene(), hits, 0.0, visible=VISIBLE).min() == 1.0


def plotter(plotter_factory, size, background=BACKGROUND):
    pl = plotter_factory(size)
    pl.disable_anti_aliasing()
    pl.ren_win.SetMultiSamples(0)
    pl.set_background(background)
    return pl


def test_floor_next_to_blocks_is_darkened_by_the_derived_factor(plotter_factory):
    # Looking straight down (parallel projection, pixel centres 0.1 apart on x.05): every
    # floor pixel against the hand-derived formula, unlit. catches (seen to fail, each on
    # its own, in the GLSL): the corner rule as a plain sum, no interpolation (the corners'
    # mean), the layer on the far side of the face, u and v swapped in (s, r), hidden
    # voxels occluding (labels read without the palette), no occlusion with 'unlit', and
    # the strength uniform never bound.
    size = (64, 64)
    pl = plotter(plotter_factory, size, background="black")
    actor = cm.add_voxels(pl, floor_scene(), palette=PALETTE, shading="unlit",
                          ambient_occlusion=True, occlusion_strength=0.5)
    pl.camera.parallel_projection = True
    pl.camera.parallel_scale = 3.2
    camera = set_camera(pl, (3.0, 3.0, 20.0), focal=(3.0, 3.0, 0.0))
    image = cm.render_image(pl).astype(float) / 255.0
    hits = trace_voxels(actor.cubemarch.model.labels, np.eye(4), camera, size,
                        near=pl.camera.clipping_range[0], visible=VISIBLE)
    assert not hits.near_edge.any()
    tan = np.array(pv.Color("tan").float_rgb)
    floor = (hits.material == 1) & (hits.face == 4)
    i, j = hits.index[..., 0], hits.index[..., 1]
    # Floor voxels more than one voxel from both blocks (in x or y) are not darkened.
    far = floor & ((np.maximum(abs(i - 2), abs(j - 2)) > 1) & (np.maximum(abs(i - 3),
                                                                           abs(j - 3)) > 1))
    assert far.sum() > 1000 and ((i == 1) & (j == 4) & far).any()   # by the hidden voxel
    assert np.abs(image[far] - tan).max() <= 1.0 / 255.0
    # The pixel at (3.25, 2.75) on floor voxel (3, 2, 0): 0.65625 (test_occlusion_factor_by_hand).
    assert tuple(hits.point[34, 34]) == (3.25, 2.75, 1.0)
    assert np.abs(image[34, 34] - 0.65625 * tan).max() <= 1.0 / 255.0
    # Every pixel of that voxel's top face against the hand formula.
    face = floor & (i == 3) & (j == 2)
    s, r = hits.point[face][:, 0] - 3.0, hits.point[face][:, 1] - 2.0
    expected = (1.0 - 0.5 * floor_level(s, r) / 3.0)[:, None] * tan
    assert face.sum() > 50 and np.abs(image[face] - expected).max() <= 1.0 / 255.0


@pytest.mark.parametrize("shading", ["unlit", "flat", "blinn"])
def test_gpu_occlusion_matches_the_reference(plotter_factory, shading):
    # A random grid on a rotated, mirrored, anisotropic placement, lit by a directional and
    # a point light: the GPU image against render_voxels(..., ambient_occlusion=True)
    # within 2/255 on every pixel away from voxel edges, and close overall (PSNR).
    # catches (seen to fail, each on its own, in the GLSL or in the reference): the corner
    # rule as a plain sum, no interpolation, the layer on the far side, u and v swapped in
    # (s, r), (GLSL) the hit point taken at the ray's start (cm_a) instead of the hit,
    # (unlit) no occlusion without lighting, and (blinn) the highlight occluded too.
    # Not caught on llvmpipe: dropping the grid-bounds check of cm_occupied (its
    # out-of-range texelFetch returns 0; GL leaves it undefined, so the check stays).
    rng = np.random.default_rng(21)
    labels = np.where(rng.random((12, 10, 8)) < 0.3, rng.integers(1, 4, (12, 10, 8)), 0)
    transform = rotated_mirrored_placement()
    size = (96, 72)
    pl = plotter(plotter_factory, size)
    light_with_sun_and_lamp(pl)
    palette = ["black", "tan", "steelblue", "firebrick"]
    # A broad highlight (power 10): occluding it too would be seen (up to 10/255 here).
    actor = cm.add_voxels(pl, labels, palette=palette, shading=shading, transform=transform,
                          specular_power=10.0, ambient_occlusion=True, occlusion_strength=0.8)
    camera = set_camera(pl, (-30.0, 26.0, 24.0), focal=(-6.0, 7.5, 4.0))
    image = cm.render_image(pl)
    model = actor.cubemarch.model
    lights = [cm.VolumeLight.from_pyvista(li, pl.camera) for li in pl.renderer.GetLights()]
    common = dict(near=pl.camera.clipping_range[0], lights=lights, shading=shading,
                  specular_power=10.0, background=BACKGROUND)
    expected = render_voxels(model.labels, model.world_from_index(), model.palette.rgba,
                             camera, size, ambient_occlusion=True, occlusion_strength=0.8,
                             **common)
    plain = render_voxels(model.labels, model.world_from_index(), model.palette.rgba,
                          camera, size, **common)
    hits = trace_voxels(model.labels, model.world_from_index(), camera, size,
                        near=common["near"])
    ok = ~hits.near_edge & (hits.material > 0)
    assert ok.mean() > 0.3 and np.abs(plain - expected)[ok].max() > 0.25   # AO matters
    assert np.abs(image.astype(float) / 255.0 - expected)[ok].max() <= 2.0 / 255.0
    assert_close_to_reference(image, expected, min_psnr=35.0)


def test_occlusion_is_compiled_only_when_on():
    # The shader holds only what runs: no occlusion snippet, define or uniform when off.
    off, on = voxel_recipe(VoxelOptions()), voxel_recipe(VoxelOptions(ambient_occlusion=True))
    assert "voxel_occlusion" not in off.snippet_names and not off.defines.get("CM_OCCLUSION")
    assert "voxel_occlusion" in on.snippet_names and on.defines["CM_OCCLUSION"]
    unlit = voxel_recipe(VoxelOptions(ambient_occlusion=True, shading="unlit"))
    assert "voxel_occlusion" in unlit.snippet_names and not unlit.defines["CM_LIGHTING"]


def test_the_registered_reference_takes_the_colour_options_by_name():
    # The registry's reference is render_voxels: every option that changes a colour image
    # is one of its parameters, same name and default, so render_voxels(..., **those)
    # draws what the technique does. catches (seen to fail): occlusion_strength renamed in
    # render_voxels only.
    technique = get_technique("voxels", "voxels")
    parameters = inspect.signature(technique.reference).parameters
    defaults = VoxelOptions()
    for name in ("shading", "ambient", "specular", "specular_power", "ambient_occlusion",
                 "occlusion_strength"):
        assert name in technique.option_names and name in parameters, name
        if name != "shading":   # the reference's own default is 'unlit'
            assert parameters[name].default == getattr(defaults, name), name


def test_occlusion_options_get_clear_errors(plotter_factory):
    pl = plotter(plotter_factory, (16, 16))
    labels = np.ones((2, 2, 2), int)
    with pytest.raises(ValueError, match="ambient_occlusion must be True or False"):
        cm.add_voxels(pl, labels, ambient_occlusion="yes")
    for strength in (-0.1, 1.5, "strong", float("nan")):
        with pytest.raises(ValueError, match="occlusion_strength must be"):
            cm.add_voxels(pl, labels, ambient_occlusion=True, occlusion_strength=strength)
    for mode in ("id", "face"):
        with pytest.raises(ValueError, match=f"ambient_occlusion darkens.*mode='{mode}'"):
            cm.add_voxels(pl, labels, ambient_occlusion=True, mode=mode)
    with pytest.raises(ValueError, match="traversal='fixed' does not know"):
        cm.add_voxels(pl, labels, ambient_occlusion=True, traversal="fixed")
    with pytest.raises(ValueError, match="occlusion_strength must be in"):
        render_voxels(labels, np.eye(4), np.ones((2, 4)), cm.Camera((5, 5, 5), (0, 0, 0)),
                      (8, 8), ambient_occlusion=True, occlusion_strength=2.0)
    # Both ends of the strength are valid, with every shading.
    for shading in ("unlit", "flat", "blinn"):
        for strength in (0.0, 1.0):
            cm.add_voxels(pl, labels, ambient_occlusion=True, occlusion_strength=strength,
                          shading=shading)
