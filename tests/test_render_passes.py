"""Techniques that read the scene's depth, under PyVista's eye-dome lighting and SSAO.

Both are VTK passes that draw the renderer's props into a framebuffer of their own, from
its origin, then composite it into the window's: the depth a translucent prop reads, and
the pixels its fragments lie at, are that framebuffer's while the renderer draws
(``gl/box.py`` ``pass_viewport_now``; supersampling: ``tests/test_supersampling.py``).

Oracles: a frame is the next frame of the same view (nothing moved), and a subplot's frame
is the plotter of its size drawing the same view alone. The labels are uint8 materials of
a terrain, two translucent; the volume is in Hounsfield units far from the origin.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import pyvista as pv
from test_voxel_world import terrain_labels

import pv_cubemarch as cm

SIZE = (192, 144)
PALETTE = {1: ("red", 0.4), 2: ("lime", 0.5), 3: "blue"}
EYE, FOCAL = (70.0, -30.0, 30.0), (24.0, 20.0, 8.0)
PASSES = {"eye-dome lighting": "enable_eye_dome_lighting", "ssao": "enable_ssao"}


def _ct():
    x, y, z = np.mgrid[-1:1:30j, -1:1:26j, -1:1:20j]
    grid = pv.ImageData(dimensions=x.shape, spacing=(1.6, 1.5, 1.2), origin=(-10.0, 0.0, 0.0))
    grid.point_data["hu"] = (-1000.0 + 1500.0 * np.exp(-3.0 * (x**2 + y**2 + z**2))).ravel(
        order="F").astype(np.float32)
    return grid


def _add(plotter, what):
    if what == "translucent labels":
        cm.add_voxels(plotter, terrain_labels(), palette=PALETTE)
    else:   # a volume the terrain's mesh cuts: its rays end at the mesh's depth
        cm.add_volume(plotter, _ct(), technique="direct", cmap="viridis",
                      opacity="linear", show_scalar_bar=False)
        plotter.add_mesh(pv.Plane(center=(24.0, 20.0, 8.0), direction=(1, 0, 0),
                                  i_size=30, j_size=30), color="white")


def _plotter(size, shape=None):
    plotter = pv.Plotter(off_screen=True, window_size=list(size),
                         **({"shape": shape} if shape else {}))
    plotter.disable_anti_aliasing()
    plotter.ren_win.SetMultiSamples(0)
    plotter.set_background("black")
    return plotter


def _look(plotter):
    plotter.camera.position, plotter.camera.focal_point = EYE, FOCAL
    plotter.camera.up = (0, 0, 1)
    plotter.renderer.ResetCameraClippingRange()


@pytest.mark.parametrize(("render_pass", "what"), [
    ("eye-dome lighting", "translucent labels"), ("ssao", "translucent labels"),
    # SSAO with an unshaded volume: VTK's pass adds code to its stand-in's shader reading
    # VTK's shading, which the stand-in declares (PyVista's own add_volume fails there)
    ("eye-dome lighting", "direct volume"), ("ssao", "direct volume")])
def test_the_first_frame_under_a_pass_is_the_next_one(render_pass, what):
    # catches (seen failing): the scene's depth copied from the window's framebuffer, not
    # the pass's (the first frame's translucent labels missing: 13786 of 27648 pixels
    # differ under eye-dome lighting, 13788 under SSAO; the volume's rays cut: 16878)
    plotter = _plotter(SIZE)
    getattr(plotter, PASSES[render_pass])()
    _add(plotter, what)
    _look(plotter)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        first, second = (cm.render_image(plotter).astype(int) for _ in range(2))
    plotter.close()
    assert (second.max(axis=-1) > 30).mean() > 0.1   # drawn
    assert np.array_equal(first, second), (np.abs(first - second).max(axis=-1) > 0).sum()


@pytest.mark.parametrize("render_pass", list(PASSES))
def test_a_direct_volume_under_a_pass_in_a_multisampled_window_is_drawn_as_single_sampled(
        render_pass):
    # The pass draws the props into its own single-sampled framebuffer: the window's
    # multisampled depth is not this frame's (none on the first frame, the last frame's
    # after), and VTK's depth copy resolves (to zeros, from the pass's float depth)
    # whenever the window is multisampled: such a frame is drawn single-sampled.
    # catches (seen failing; found by a review): the first frame's volume lost (0 of
    # 11,036 pixels; screenshot() showed it so), then a moved mesh's hole one frame late.
    frames = []
    for multisampled in (False, True):
        plotter = pv.Plotter(off_screen=True, window_size=list(SIZE))
        plotter.set_background("black")
        if not multisampled:
            plotter.disable_anti_aliasing()
            plotter.ren_win.SetMultiSamples(0)
        getattr(plotter, PASSES[render_pass])()
        _add(plotter, "direct volume")
        _look(plotter)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            first = cm.render_image(plotter).astype(int)
            plotter.actors[list(plotter.actors)[-1]].position = (0.0, 0.0, 20.0)
            moved = cm.render_image(plotter).astype(int)
        plotter.close()
        frames.append((first, moved))
    assert (frames[0][0].max(axis=-1) > 30).mean() > 0.1   # drawn
    for single, multi in zip(frames[0], frames[1], strict=True):
        off = (np.abs(single - multi).max(axis=-1) > 8).mean()
        assert off < 0.002, off


def test_a_cube_map_volume_under_depth_peeling_is_drawn_as_unpeeled():
    # Its ray-marching pass runs at the overlay's start, in the atlas framebuffer of its
    # own: not VTK's peeling framebuffer, though depth peeling is on and a framebuffer
    # other than the window's is bound (gl/box.py peeling_viewport_now). The opaque depth
    # is read at the renderer's viewport.
    # catches (seen failing; found by a review): the atlas's viewport taken for the
    # peeling's, the depth read at the wrong pixels (a mesh's hole in the volume moved:
    # 506 of 30,000 pixels off in the review's view).
    frames = []
    for peel in (False, True):
        plotter = _plotter((200, 150))
        cm.add_volume(plotter, pv.Wavelet(), technique="cubemap", cmap="viridis",
                      show_scalar_bar=False)
        plotter.add_mesh(pv.Sphere(radius=5.0, center=(12.0, 0.0, 0.0)), color="red")
        if peel:
            plotter.enable_depth_peeling()
        plotter.view_isometric()
        frames.append(cm.render_image(plotter).astype(int))
        plotter.close()
    assert (frames[0].max(axis=-1) > 30).mean() > 0.1
    off = (np.abs(frames[1] - frames[0]).max(axis=-1) > 8).mean()
    assert off == 0.0, off


def test_a_subplot_under_eye_dome_lighting_is_drawn_as_alone():
    # the labels in the right subplot, eye-dome lighting on its renderer: that half is the
    # frame of a plotter of its size
    # catches (seen failing): the pass's framebuffer read at the renderer's place in the
    # window, not at its origin (16693 pixels off)
    plotter = _plotter((2 * SIZE[0], SIZE[1]), shape=(1, 2))
    plotter.subplot(0, 1)
    plotter.enable_eye_dome_lighting()
    _add(plotter, "translucent labels")
    _look(plotter)
    alone = _plotter(SIZE)
    alone.enable_eye_dome_lighting()
    _add(alone, "translucent labels")
    _look(alone)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cm.render_image(plotter)
        half = cm.render_image(plotter)[:, SIZE[0]:].astype(int)
        cm.render_image(alone)
        expected = cm.render_image(alone).astype(int)
    plotter.close()
    alone.close()
    assert (expected.max(axis=-1) > 30).mean() > 0.1
    assert (np.abs(half - expected).max(axis=-1) > 8).sum() == 0


def test_a_shaded_volume_in_vtk_s_mapper_draws_under_ssao_what_pyvista_draws():
    # VTK's SSAO pass adds to the volume mapper's lighting function a line reading VTK's
    # shading gradient, which VTK declares only for its own shading: technique='vtk' (our
    # marcher in VTK's mapper, its own shading off) declares one of its own. Under SSAO it
    # then draws what PyVista's add_volume(shade=True) draws under the same pass, to the
    # pixel (in VTK 9.7 the volume takes no part in that frame: only the plane shows).
    # catches (seen failing): the declaration left out (ShaderCompileError,
    # 'shading_gradient' undeclared).
    images = []
    for add in ("pyvista", "vtk"):
        plotter = _plotter(SIZE)
        plotter.add_mesh(pv.Plane(center=(24.0, 20.0, -2.0), i_size=120, j_size=120),
                         color="white")
        keywords = dict(cmap="viridis", opacity="linear", shade=True, show_scalar_bar=False)
        if add == "pyvista":
            plotter.add_volume(_ct(), **keywords)
        else:
            cm.add_volume(plotter, _ct(), technique="vtk", **keywords)
        plotter.enable_ssao()
        _look(plotter)
        images.append(cm.render_image(plotter).astype(int))
        plotter.close()
    assert (images[0].max(axis=-1) > 30).mean() > 0.3   # the plane, shaded
    assert np.array_equal(images[0], images[1]), (np.abs(images[0] - images[1]).max(
        axis=-1) > 0).sum()


def _peeled(what, size, shape=None):
    """``what`` drawn with the plotter's depth peeling on (in subplot (0, 1) of ``shape``)."""
    plotter = _plotter(size, shape)
    if shape:
        plotter.subplot(0, 1)
    plotter.set_background("black")
    plotter.enable_depth_peeling(number_of_peels=20, occlusion_ratio=0.0)
    if what == "translucent surface":
        grid = pv.ImageData(dimensions=(20, 20, 20), spacing=(2.0, 2.0, 1.0))
        grid["f"] = np.linalg.norm(grid.points - grid.center, axis=1)
        plotter.add_mesh(pv.Sphere(radius=5.0, center=grid.center), color="white")
        plotter.cubemarch.add_surface(grid, isovalue=12.0, scalars="f", opacity=0.5,
                                      color="tan")
        plotter.camera_position = [(80.0, -40.0, 50.0), grid.center, (0, 0, 1)]
    else:
        _add(plotter, "translucent labels" if what == "translucent labels" else "volume")
        _look(plotter)
    image = cm.render_image(plotter).astype(int)
    plotter.close()
    return image[:, size[0] // 2:] if shape else image


@pytest.mark.parametrize("what", ["translucent labels", "translucent surface",
                                  "direct volume"])
def test_a_subplot_under_depth_peeling_is_drawn_as_alone(what):
    # VTK's depth peeling draws the translucent props into a framebuffer of its own, from
    # its origin (no pass of PyVista's is set): a subplot's fragments lie there, not at
    # its place in the window (gl/box.py peeling_viewport_now). The right subplot is the
    # plotter of its size drawing the same view alone (held to the references elsewhere).
    # catches (seen failing; found by a review): the subplot's place in the window used
    # (pixels off: the labels 50 %, the surface 14 %, the volume 23 %: lost or misplaced).
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        half = _peeled(what, (2 * SIZE[0], SIZE[1]), shape=(1, 2))
        alone = _peeled(what, SIZE)
    assert (alone.max(axis=-1) > 30).mean() > 0.1
    off = (np.abs(half - alone).max(axis=-1) > 8).mean()
    assert off == 0.0, off


@pytest.mark.parametrize("peel_first", [True, False])
def test_a_direct_volume_under_depth_peeling_is_drawn_as_unpeeled(peel_first):
    # PyVista's default window is multisampled; VTK's depth peeling copies the opaque
    # depth from it, which a multisampled framebuffer cannot give: every translucent prop
    # is lost (PyVista's own meshes too, here). A frame that peels a direct volume's box is
    # drawn single-sampled, and the box is peeled at its ray's entry, not its back face,
    # which lies behind the mesh inside the volume. As add_volume's volume (not peeled),
    # it is drawn as unpeeled (reference: a single-sampled window, no peeling), with
    # peeling on from the first frame or turned on and off; multisampling given back.
    # catches (seen failing; found by a review): the frame left multisampled (the volume
    # lost: 46 % of pixels off); the box peeled at its back face (22 % off: the volume
    # before the mesh lost).
    alone = _plotter(SIZE)
    _add(alone, "direct volume")
    _look(alone)
    expected = cm.render_image(alone).astype(int)
    alone.close()
    plotter = pv.Plotter(off_screen=True, window_size=list(SIZE))   # multisampled
    plotter.set_background("black")
    _add(plotter, "direct volume")
    _look(plotter)
    if not peel_first:
        cm.render_image(plotter)
    user = plotter.ren_win.GetMultiSamples()
    plotter.enable_depth_peeling()
    peeled = cm.render_image(plotter).astype(int)
    volume = np.abs(expected - 255 * (expected > 250)).max(axis=-1) > 30   # not the mesh
    assert volume.mean() > 0.1
    off = (np.abs(peeled - expected).max(axis=-1) > 8).mean()
    assert off < 0.002, off
    if not peel_first:
        plotter.disable_depth_peeling()
        cm.render_image(plotter)
        assert plotter.ren_win.GetMultiSamples() == user > 0
    plotter.close()


def _ao(add, size=(240, 180)):
    """What SSAO keeps of each pixel's colour (the frame under SSAO over the frame without
    it, brightest channel), where the frame without it is brighter than 60 (else NaN)."""
    frames = []
    for ssao in (True, False):
        plotter = _plotter(size)
        add(plotter)
        if ssao:
            plotter.enable_ssao()
        _look(plotter)
        frames.append(cm.render_image(plotter).astype(float).max(axis=-1))
        plotter.close()
    return np.where(frames[1] > 60, frames[0] / np.maximum(frames[1], 1.0), np.nan)


LIT_PALETTE = {1: "red", 2: "lime", 3: "blue"}


@pytest.mark.parametrize("drawing", [{}, {"chunk_size": 16, "world_traversal": "per_chunk"},
                                     {"chunk_size": 16, "world_traversal": "index"}])
@pytest.mark.parametrize("lit", [True, False])
def test_ssao_darkens_labels_as_it_darkens_pyvista_s_meshes_of_them(drawing, lit):
    # PyVista's SSAO darkens each pixel by the view positions and normals the props give
    # it: a grid's voxels give their hits' and their faces' (gl/bindings.py CM_SSAO), so
    # the darkening is the one SSAO gives threshold + add_mesh of the same cells; unlit,
    # none, as VTK's unlit meshes give none. Oracle: PyVista's own meshes under the pass.
    # catches (seen failing): CM_SSAO never given (lit: what VTK's pass fills in for the box
    # taken, 99.97 % of the pixels off by over 0.05, 0.148 on average); the faces' normals
    # flipped (all off, 0.62); unlit voxels giving their hits (99.98 % off).
    labels = terrain_labels()
    grid = pv.ImageData(dimensions=np.array(labels.shape) + 1)
    grid.cell_data["m"] = labels.ravel(order="F")

    def ours(plotter):
        cm.add_voxels(plotter, labels, palette=LIT_PALETTE,
                      shading="blinn" if lit else "unlit", **drawing)

    def theirs(plotter):
        plotter.add_mesh(grid.threshold(0.5, scalars="m"), scalars="m", lighting=lit,
                         cmap=list(LIT_PALETTE.values()), clim=(1, 3), show_scalar_bar=False)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mine, expected = _ao(ours), _ao(theirs)
    both = np.isfinite(mine) & np.isfinite(expected)
    assert both.mean() > 0.3
    if lit:
        assert np.mean(expected[both]) < 0.9   # SSAO darkens the meshes' creases
    off = np.abs(mine - expected)[both]
    assert (off > 0.05).mean() < 0.002 and off.mean() < 0.01, ((off > 0.05).mean(), off.mean())


@pytest.mark.parametrize("what", ["direct", "translucent labels"])
def test_ssao_takes_nothing_from_translucent_props(what):
    # A translucent prop gives SSAO no position or normal of its own (alpha 0: the blend
    # keeps what lies behind), so a plane under it and around it is darkened as the
    # plane alone is (SSAO darkens the whole frame drawn, the volume over the plane too:
    # the ratio with and without SSAO is the plane's). Oracle: the plane alone under the
    # pass. (The cube map is composited after the pass, by an overlay renderer: it takes
    # nothing and gives nothing.) An unshaded volume compiles: its stand-in declares what
    # VTK's pass reads (PyVista's own add_volume fails there).
    # catches (seen failing): the box's faces given (the plane darkened along the box's
    # outline: 21 % of the pixels off by over 0.05); the stand-in's declaration left out
    # (ShaderCompileError).
    plane = pv.Plane(center=(24.0, 20.0, -2.0), i_size=120, j_size=120)

    def alone(plotter):
        plotter.add_mesh(plane, color="white")

    def with_prop(plotter):
        alone(plotter)
        if what == "translucent labels":
            cm.add_voxels(plotter, terrain_labels(), palette={1: ("red", 0.3),
                                                              2: ("lime", 0.3),
                                                              3: ("blue", 0.3)})
        else:
            volume = _ct()
            volume.translate((30.0, 10.0, 8.0), inplace=True)
            cm.add_volume(plotter, volume, technique=what, cmap="viridis", opacity="linear",
                          show_scalar_bar=False)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mine, expected = _ao(with_prop), _ao(alone)
    both = np.isfinite(mine) & np.isfinite(expected)
    assert both.mean() > 0.3 and np.nanmean(expected) < 0.99   # the plane, darkened
    off = (np.abs(mine - expected)[both] > 0.05).mean()
    assert off < 0.002, off


def test_ssao_darkens_a_surface_as_it_darkens_pyvista_s_mesh_of_it():
    # A surface gives SSAO its hits' view positions and normals (the exact gradient's, the
    # side facing the eye), so a ball resting on a plane darkens the plane by it, and is
    # darkened, as PyVista's finely tessellated sphere. Oracle: pv.Sphere under the pass.
    # catches (seen failing): CM_SSAO never given (what VTK's pass fills in for the domain
    # box taken: 14 % of the pixels off by over 0.05). Not caught: the normal turned to
    # the eye or not (a ball seen from outside shows only its outer side).
    centre, radius = np.array([24.0, 20.0, 6.0]), 8.0
    grid = pv.ImageData(dimensions=(24, 24, 24), spacing=(1.0, 1.0, 1.0),
                        origin=tuple(centre - 11.5))
    grid["r"] = np.linalg.norm(grid.points - centre, axis=1)
    plane = pv.Plane(center=(24.0, 20.0, -2.0), i_size=120, j_size=120)

    def ours(plotter):
        plotter.add_mesh(plane, color="white")
        plotter.cubemarch.add_surface(grid, isovalue=radius, scalars="r", color="tan")

    def theirs(plotter):
        plotter.add_mesh(plane, color="white")
        plotter.add_mesh(pv.Sphere(radius=radius, center=centre, theta_resolution=240,
                                   phi_resolution=240), color="tan")

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mine, expected = _ao(ours), _ao(theirs)
    both = np.isfinite(mine) & np.isfinite(expected)
    assert both.mean() > 0.3 and np.mean(expected[both]) < 0.95
    off = np.abs(mine - expected)[both]
    assert (off > 0.05).mean() < 0.01 and off.mean() < 0.01, ((off > 0.05).mean(), off.mean())
