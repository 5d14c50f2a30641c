"""What a frame holds decides how it is drawn; removing a volume through PyVista releases it.

Defects 1, 5 and 9 of issue 9, each test seen to fail on the code before the fix (the
commit before the layout change):
1. a cube-map volume added after a direct one turned multisampling off for good, and the
   direct volume (which had chosen to read a multisampled depth) vanished;
5. ``pl.remove_actor`` left a cube-map volume drawn and every technique tracked; adding
   again under the same name kept the old volume drawn;
9. per-frame waste: a depth copy per direct volume, the opaque-prop scan per cube-map
   volume, the cube map's frame choice made twice on ``auto`` frames, window settings
   left changed after the last volume left.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import VOLUME_TECHNIQUES, set_camera

import pv_cubemarch as cm
from pv_cubemarch.gl.frame_inputs import frame_inputs
from pv_cubemarch.image_metrics import compare_images

SIZE = (96, 64)


def blob(name, shift=0.0, cmap="gray", unit=3.0):
    x, y, z = np.mgrid[-1:1:20j, -1:1:20j, -1:1:20j]
    values = np.exp(-3 * (x**2 + y**2 + z**2)).astype(np.float32)
    transform = np.eye(4)
    transform[0, 3] = shift
    return cm.make_volume(values, name=name, cmap=cmap, opacity_unit_distance=unit,
                          transform=transform)


def multisampled_plotter(plotter_factory):
    pl = plotter_factory(SIZE)
    pl.set_background("black")
    pl.enable_anti_aliasing("msaa", multi_samples=4)
    return pl


def view(pl):
    return set_camera(pl, (23.0, 9.5, 75.0), focal=(23.0, 9.5, 9.5))


def test_direct_volume_stays_drawn_when_a_cubemap_volume_joins(plotter_factory):
    # catches: the direct path fixing its depth source when added (the old code drew the
    # left volume black: max 0 where the reference is 150+), and the window's samples
    # not given back once the cube map left.
    pl = multisampled_plotter(plotter_factory)
    a, b = blob("a"), blob("b", shift=28.0)
    cm.add_volume(pl, a, technique="direct")
    second = cm.add_volume(pl, b, technique="cubemap")
    camera = view(pl)
    both = cm.render_image(pl)
    reference = cm.render_emission_absorption([a, b], camera, SIZE)
    errors = compare_images(both, reference)
    background = compare_images(np.zeros_like(both), reference)
    assert errors.psnr >= 40 > background.psnr + 10, (errors, background)
    assert pl.ren_win.GetMultiSamples() == 0          # the cube map's frame
    pl.remove_actor(second)
    alone = cm.render_image(pl)
    assert pl.ren_win.GetMultiSamples() == 4          # the user's setting is back
    errors = compare_images(alone, cm.render_emission_absorption(a, camera, SIZE))
    assert errors.psnr >= 40, errors


@pytest.mark.parametrize("technique", VOLUME_TECHNIQUES)
def test_two_volumes_one_behind_the_other_composite_the_nearer_over(plotter_factory,
                                                                   technique):
    # Two volumes along x, seen along x from either side: every ray crosses the nearer
    # before the farther, so the image is the nearer composited over the farther, as the
    # CPU reference marches both (whichever was added first). VTK composites volumes and
    # translucent props in its prop list's order (PyVista's own add_volume: the far one
    # over the near one when the near one came first); ours are sorted farthest first.
    # catches (seen failing; found by a review): 'vtk' and 'direct' (and 'auto' when it
    # picks 'direct', so it flipped with the window's size) in adding order: the far
    # volume over the near one, 26 dB from one side (52-54 dB sorted).
    red = blob("red", cmap="Reds", unit=0.3)   # index space: x from 0 to 19
    blue = blob("blue", shift=24.0, cmap="Blues", unit=0.3)
    for eye in ((-40.0, 12.0, 11.0), (83.0, 12.0, 11.0)):
        pl = plotter_factory(SIZE)
        pl.set_background("black")
        for model in (red, blue):
            cm.add_volume(pl, model, technique=technique)
        camera = set_camera(pl, eye, focal=(21.5, 9.5, 9.5), up=(0, 0, 1))
        image = cm.render_image(pl)
        reference = cm.render_emission_absorption([red, blue], camera, SIZE)
        errors = compare_images(image, reference)
        background = compare_images(np.zeros_like(image), reference)
        pl.close()
        assert errors.psnr >= 45 > background.psnr + 10, (eye, errors, background)


def test_window_settings_come_back_after_the_last_volume(plotter_factory):
    # catches: SetUseOIT(False) / SetMultiSamples(0) left set after the last volume left.
    pl = multisampled_plotter(plotter_factory)
    pl.renderer.SetUseOIT(True)
    direct = cm.add_volume(pl, blob("a"), technique="direct")
    cube = cm.add_volume(pl, blob("b", shift=28.0), technique="cubemap")
    view(pl)
    cm.render_image(pl)
    assert not pl.renderer.GetUseOIT() and pl.ren_win.GetMultiSamples() == 0
    pl.remove_actor(direct)
    pl.remove_actor(cube)
    cm.render_image(pl)
    assert pl.renderer.GetUseOIT() and pl.ren_win.GetMultiSamples() == 4


@pytest.mark.parametrize("technique", VOLUME_TECHNIQUES)
def test_remove_actor_removes_and_releases(plotter_factory, technique):
    # catches: remove_actor returning True while the cube map stays drawn, and every
    # technique staying tracked (its textures and observers alive).
    pl = plotter_factory(SIZE)
    pl.set_background("black")
    renderers = pl.ren_win.GetRenderers().GetNumberOfItems()
    actor = cm.add_volume(pl, blob("a"), technique=technique)
    view(pl)
    assert cm.render_image(pl).max() > 100
    binding = actor.cubemarch
    assert pl.remove_actor(actor)
    assert cm.render_image(pl).max() == 0
    assert pl.cubemarch.tracked == [] and binding._released
    assert pl.ren_win.GetRenderers().GetNumberOfItems() == renderers   # no overlay left


@pytest.mark.parametrize("technique", ["direct", "cubemap"])
def test_adding_again_under_a_name_replaces_the_volume(plotter_factory, technique):
    # catches: the old binding leaking under a reused name (the cube map drew both).
    pl = plotter_factory(SIZE)
    pl.set_background("black")
    first, second = blob("a"), blob("b", shift=28.0)
    cm.add_volume(pl, first, technique=technique, name="v")
    camera = view(pl)
    cm.render_image(pl)
    cm.add_volume(pl, second, technique=technique, name="v")
    image = cm.render_image(pl)
    assert len(pl.cubemarch.tracked) == 1
    errors = compare_images(image, cm.render_emission_absorption(second, camera, SIZE))
    assert errors.psnr >= 40, errors
    assert image[:, :40].max() == 0   # nothing left where the first one was


def test_hidden_actor_hides_the_volume(plotter_factory):
    # catches: the overlay's box not following the returned actor's visibility.
    pl = plotter_factory(SIZE)
    pl.set_background("black")
    actor = cm.add_volume(pl, blob("a"), technique="cubemap")
    view(pl)
    assert cm.render_image(pl).max() > 100
    actor.SetVisibility(False)
    assert cm.render_image(pl).max() == 0


def test_one_depth_copy_per_frame_for_every_direct_volume(plotter_factory):
    # catches: each single-sampled direct volume copying the whole depth buffer (3 copies).
    pl = plotter_factory(SIZE)
    pl.set_background("black")
    pl.disable_anti_aliasing()
    pl.ren_win.SetMultiSamples(0)
    for index in range(3):
        cm.add_volume(pl, blob(f"v{index}", shift=14.0 * index), technique="direct")
    pl.add_mesh(cm.make_volume(np.ones((2, 2, 2)), name="m").grid.outline())
    view(pl)
    cm.render_image(pl)
    depth = frame_inputs(pl.renderer).depth
    before = depth.copies
    cm.render_image(pl)
    assert depth.copies - before == 1


def test_opaque_props_scanned_once_per_frame(plotter_factory):
    # catches: has_opaque_props walking the renderer's actors once per cube-map volume.
    pl = plotter_factory(SIZE)
    for index in range(3):
        cm.add_volume(pl, blob(f"v{index}", shift=14.0 * index), technique="cubemap")
    view(pl)
    cm.render_image(pl)
    calls = []
    real = pl.renderer.GetActors
    pl.renderer.GetActors = lambda: calls.append(1) or real()
    try:
        cm.render_image(pl)
    finally:
        del pl.renderer.GetActors
    assert len(calls) == 1


def test_auto_chooses_the_cube_frame_once(plotter_factory):
    # catches: CubeFrame.update run by the choice and again by the cube pass on auto frames.
    pl = plotter_factory(SIZE)
    actor = cm.add_volume(pl, blob("a"), technique="auto")
    actor.cubemarch.force = "cubemap"
    view(pl)
    cm.render_image(pl)
    frame = actor.cubemarch.cubemap.frame
    before = frame.frames
    cm.render_image(pl)
    assert frame.frames - before == 1


def test_removed_auto_volume_leaves_nothing_drawn(plotter_factory):
    # catches: the auto technique's direct box left in the renderer after removal (drawn
    # with its observers gone when the last frame chose the direct path).
    pl = plotter_factory(SIZE)
    pl.set_background("black")
    actors = pl.renderer.GetActors().GetNumberOfItems()
    actor = cm.add_volume(pl, blob("a"), technique="auto")
    actor.cubemarch.force = "direct"
    view(pl)
    assert cm.render_image(pl).max() > 100
    pl.remove_actor(actor)
    assert cm.render_image(pl).max() == 0
    assert pl.renderer.GetActors().GetNumberOfItems() == actors


@pytest.mark.parametrize("technique", ["cubemap", "direct", "auto"])
def test_hidden_volume_runs_no_pass(plotter_factory, technique):
    # catches: the cube pass (and the reduced-resolution pass) marching every frame for a
    # volume whose actor is hidden.
    pl = plotter_factory(SIZE)
    options = {"downsample": 2} if technique == "direct" else {}
    actor = cm.add_volume(pl, blob("a"), technique=technique, **options)
    if technique == "auto":
        actor.cubemarch.force = "cubemap"
    view(pl)
    cm.render_image(pl)
    binding = actor.cubemarch.cubemap if technique == "auto" else actor.cubemarch
    render_pass = binding.targets[-1]
    runs = render_pass.runs
    actor.SetVisibility(False)
    cm.render_image(pl)
    cm.render_image(pl)
    assert render_pass.runs == runs
    actor.SetVisibility(True)
    cm.render_image(pl)
    assert render_pass.runs == runs + 1


def test_depth_copy_freed_with_the_last_volume(plotter_factory):
    # catches: the renderer's shared depth copy living on after its last volume left.
    pl = plotter_factory(SIZE)
    pl.ren_win.SetMultiSamples(0)
    actor = cm.add_volume(pl, blob("a"), technique="direct")
    view(pl)
    cm.render_image(pl)
    depth = frame_inputs(pl.renderer).depth
    assert depth.gl_object is not None
    pl.remove_actor(actor)
    cm.render_image(pl)
    assert depth.gl_object is None
    assert "_cubemarch_frame_inputs" not in pl.renderer.__dict__


def test_downsampled_joint_group_matches_reference(plotter_factory):
    # catches: the upsampling box compiled with the group's joint sampling (its shader
    # did not compile).
    pl = plotter_factory(SIZE)
    pl.set_background("black")
    a, b = blob("a"), blob("b", shift=8.0)
    cm.add_volumes(pl, [a, b], technique="direct", downsample=2)
    camera = view(pl)
    image = cm.render_image(pl)
    reference = cm.render_emission_absorption(cm.VolumeGroup([a, b]), camera, SIZE)
    errors = compare_images(image, reference)
    assert errors.psnr >= 35 > compare_images(np.zeros_like(image), reference).psnr + 10, errors


def test_auto_follows_a_mirroring_transform_on_cube_map_frames(plotter_factory):
    # catches: the auto technique's cube box keeping the old culling after a mirroring
    # set_transform (the cube-map frames then drew nothing).
    pl = plotter_factory(SIZE)
    pl.set_background("black")
    model = blob("a")
    actor = cm.add_volume(pl, model, technique="auto")
    actor.cubemarch.force = "cubemap"
    camera = view(pl)
    cm.render_image(pl)
    mirror = np.diag([-1.0, 1.0, 1.0, 1.0])
    mirror[0, 3] = 19.0   # the mirrored box covers the same place
    actor.cubemarch.set_transform(mirror)
    image = cm.render_image(pl)
    errors = compare_images(image, cm.render_emission_absorption(model, camera, SIZE))
    assert errors.psnr >= 40, errors
