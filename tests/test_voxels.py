"""Material grids drawn by DDA traversal: exact against the CPU traversal, pixel by pixel.

The expected image is the numpy Amanatides & Woo traversal in float64 with the frame's
camera (``pv_cubemarch.reference.voxels``), itself checked against a brute-force slab test
in ``test_voxel_reference.py``. In id mode each pixel carries the voxel's index, so a
pixel is right or wrong; pixels whose ray passes within 1e-4 voxel of an edge (where
float32 may break the tie the other way) are counted apart and must be few.
"""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv
from conftest import light_with_sun_and_lamp, rotated_mirrored_placement, set_camera

import pv_cubemarch as cm
from pv_cubemarch.reference.voxels import face_colors, id_colors, render_voxels, trace_voxels

SIZE = (64, 48)
#: Pixels whose ray passes this close (in voxels) to a voxel edge, or grazes the grid box's
#: edge, are counted apart: float32 on the GPU may break those ties the other way.
EDGE = 1e-4


def plotter(plotter_factory, size=SIZE):
    pl = plotter_factory(size)
    pl.disable_anti_aliasing()
    pl.ren_win.SetMultiSamples(0)   # an id is a pixel's, never a blend of two
    pl.set_background("black")
    return pl


def random_labels(shape, fill, seed=1, materials=3):
    rng = np.random.default_rng(seed)
    return np.where(rng.random(shape) < fill, rng.integers(1, materials + 1, shape), 0)


def wrong_pixels(pl, model, camera, size=SIZE):
    """(wrong, near-edge) pixel counts of the id image against the CPU traversal."""
    image = cm.render_image(pl).astype(int)
    hits = trace_voxels(model.labels, model.world_from_index(), camera, size,
                        near=pl.camera.clipping_range[0], visible=model.palette.visible,
                        tie_tolerance=EDGE)
    expected = id_colors(hits, model.dimensions).astype(int)
    wrong = np.any(image != expected, axis=-1)
    return int((wrong & ~hits.near_edge).sum()), int(hits.near_edge.sum()), hits


@pytest.mark.parametrize(("mip_levels", "distance_field"),
                         [(0, 0), (1, 0), (3, 0), (6, 0), (0, 1), (0, 3), (3, 2)])
@pytest.mark.parametrize("fill", [0.01, 0.3])
@pytest.mark.parametrize("eye", [(40.0, 30.0, 35.0), (-16.0, -10.0, -19.0)])
@pytest.mark.parametrize("proxy", ["bricks", "box"])
def test_dda_is_exact_against_the_cpu_traversal(plotter_factory, fill, mip_levels,
                                                distance_field, eye, proxy):
    # With occupancy levels, also catches (seen to fail): an empty cell's exit taken on the
    # wrong side, and the voxel past it not stepped along the exit axis; the level rows
    # uploaded untransposed (levels 3+ read from the wrong texels). With distance fields:
    # the empty cube one voxel too large on its lower side (rays moving -axis) and on its
    # upper side (rays moving +axis: the second eye).
    # catches (seen to fail): the next boundary taken on the upper side whatever the
    # direction (11 of 15 tests fail), and a box drawn exactly to the grid's size (one
    # grazing pixel at a box edge was not rasterised: the box is drawn 1 % larger and each
    # ray clipped to the exact box in the shader).
    labels = random_labels((24, 20, 16), fill)
    labels[:12, :12, :12] = 0   # an empty corner the occupancy levels skip in one step
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, labels, mode="id", mip_levels=mip_levels,
                          distance_field=distance_field, proxy=proxy)
    camera = set_camera(pl, eye, focal=(12.0, 10.0, 8.0))
    wrong, edge, hits = wrong_pixels(pl, actor.cubemarch.model, camera)
    if proxy == "bricks":   # the rays did start at the shell
        assert actor.cubemarch.shell.on_shell and actor.cubemarch.shell.depth.runs > 0
    assert (hits.material > 0).mean() > 0.1   # many voxels in view: a real test
    assert wrong == 0 and edge < 0.02 * hits.material.size


def test_fixed_step_misses_what_dda_hits(plotter_factory):
    # The seed's fixed step (0.5 voxel here) steps over thin voxels and corners on a sparse
    # grid: many wrong pixels, where the DDA has none.
    labels = random_labels((24, 20, 16), 0.01)
    counts = {}
    for traversal in ("dda", "fixed"):
        pl = plotter(plotter_factory)
        options = {"step_scale": 0.5} if traversal == "fixed" else {}
        actor = cm.add_voxels(pl, labels, mode="id", traversal=traversal, **options)
        camera = set_camera(pl, (40.0, 30.0, 35.0), focal=(12.0, 10.0, 8.0))
        counts[traversal] = wrong_pixels(pl, actor.cubemarch.model, camera)[0]
    assert counts["dda"] == 0 and counts["fixed"] > 20, counts


def extreme_scene(case, labels, axis_point=(6.0, 5.0)):
    """``(labels, transform, eye, focal)`` of one of the extreme cases on a 12 x 10 x 8 grid.

    ``axis_point``: where the axis-parallel case's centre ray runs along z.
    """
    transform = np.eye(4)
    position, focal = (30.0, 22.0, 26.0), (6.0, 5.0, 4.0)
    if case == "inside-grid":
        position, focal = (6.0, 5.5, 4.2), (0.0, 0.0, 0.0)
        labels[6, 5, 4] = 0
    elif case == "inside-voxel":
        position, focal = (6.5, 5.5, 4.5), (0.0, 0.0, 0.0)
        labels[6, 5, 4] = 2
    elif case == "axis-parallel":
        position = (*axis_point, 40.0)   # the centre ray on voxel edges
        focal = (*axis_point, 4.0)
    elif case == "far-away":
        transform[:3, 3] = 1e6
        position = tuple(np.array(position) + 1e6)
        focal = tuple(np.array(focal) + 1e6)
    elif case == "anisotropic-mirrored":
        transform = np.diag([-0.5, 2.0, 1.0, 1.0])
        transform[0, 3] = 6.0
        position, focal = (14.0, 30.0, 26.0), (3.0, 10.0, 4.0)
    elif case in ("tiny", "huge"):   # voxels of 1e-4 and 1e4 world units, seen alike
        scale = 1e-4 if case == "tiny" else 1e4
        transform = np.diag([scale, scale, scale, 1.0])
        position = tuple(np.array(position) * scale)
        focal = tuple(np.array(focal) * scale)
    elif case == "one-voxel":
        labels = np.ones((1, 1, 1), int)
        position, focal = (2.2, 1.7, 2.9), (0.5, 0.5, 0.5)
    elif case == "sheet":
        labels = random_labels((1, 10, 8), 0.5, seed=4)
        position, focal = (12.0, 9.0, 10.0), (0.5, 5.0, 4.0)
    return labels, transform, position, focal


def finish_extreme_camera(pl, case, camera):
    """The parallel projection, or the near plane close to an eye inside the grid."""
    if case == "parallel-projection":
        pl.camera.parallel_projection = True
        pl.camera.parallel_scale = 9.0
        pl.renderer.ResetCameraClippingRange()
        camera = cm.Camera.from_pyvista(pl.camera)
    if case.startswith("inside"):
        pl.camera.clipping_range = (0.01, 100.0)
        camera.clipping_range = (0.01, 100.0)
    return camera


@pytest.mark.parametrize("case", ["inside-grid", "inside-voxel", "axis-parallel",
                                  "parallel-projection", "far-away", "anisotropic-mirrored",
                                  "one-voxel", "sheet", "tiny", "huge"])
@pytest.mark.parametrize("skipping", [{"mip_levels": 0}, {"mip_levels": 3, "distance_field": 2}],
                         ids=["plain", "mip3-df2"])
@pytest.mark.parametrize("proxy", ["bricks", "box"])
def test_extremes(plotter_factory, case, skipping, proxy):
    # With skipping, also catches (seen to fail): a skipped block's exit voxel taken from
    # the ray's start instead of its exit point (6 of the 8 cases fail).
    # Sparse with skipping, so empty cells and cubes are really left in one step.
    labels = random_labels((12, 10, 8), 0.25 if skipping["mip_levels"] == 0 else 0.04, seed=3)
    labels, transform, position, focal = extreme_scene(case, labels)
    pl = plotter(plotter_factory, (49, 49))
    actor = cm.add_voxels(pl, labels, mode="id", transform=transform, proxy=proxy,
                          **skipping)
    camera = finish_extreme_camera(pl, case, set_camera(pl, position, focal=focal, angle=50.0))
    wrong, edge, hits = wrong_pixels(pl, actor.cubemarch.model, camera, (49, 49))
    assert (hits.material > 0).any()
    assert wrong == 0, (case, wrong, edge)
    assert edge < 0.05 * hits.material.size, (case, edge)


@pytest.mark.parametrize("eye", [(40.0, 30.0, 35.0), (-16.0, -10.0, -19.0), (6.5, 5.5, 4.5)])
def test_face_mode_matches_the_cpu_traversal(plotter_factory, eye):
    # Every pixel's entered face (what the shading's normal comes from) equals the CPU
    # traversal's, from two octants and from inside a voxel (face -1).
    # catches (seen to fail): a face recorded with the wrong sign (2 * axis + 1 when
    # moving -axis), and a skipped block's exit face not recorded.
    labels = random_labels((24, 20, 16), 0.05)
    labels[6, 5, 4] = 1
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, labels, mode="face", mip_levels=4, distance_field=1)
    camera = set_camera(pl, eye, focal=(12.0, 10.0, 8.0))
    if eye == (6.5, 5.5, 4.5):
        pl.camera.clipping_range = (0.01, 100.0)
        camera.clipping_range = (0.01, 100.0)
    image = cm.render_image(pl).astype(int)
    hits = trace_voxels(labels, actor.cubemarch.model.world_from_index(), camera, SIZE,
                        near=pl.camera.clipping_range[0], tie_tolerance=EDGE)
    expected = face_colors(hits).astype(int)
    wrong = np.any(image != expected, axis=-1) & ~hits.near_edge
    faces = set(np.unique(hits.face[hits.material > 0]).tolist())
    if eye == (6.5, 5.5, 4.5):
        assert faces == {-1} and (hits.material > 0).all()   # inside voxel (6, 5, 4)
    else:
        assert len(faces) >= 3   # several faces in view
    assert wrong.sum() == 0, wrong.sum()


def test_id_mode_refuses_grids_beyond_24_bits(plotter_factory):
    # 2^24 voxels need 2^24 + 1 ids with 0 kept for "no voxel": one more than RGB8 holds.
    pl = plotter(plotter_factory)
    with pytest.raises(ValueError, match="24-bit"):
        cm.add_voxels(pl, np.zeros((256, 256, 256), np.uint8), mode="id")


def test_a_palette_dict_is_read_by_the_ids_it_names():
    # Keys are label ids: one no label here can be (negative, or past the ids kept as
    # rows) colours nothing and takes no row; a key that is not an integer is refused.
    # catches (seen failing; found by a review): -1 indexing the table's last row (label 3
    # drawn red), a key of 2**32 sizing a 64 GiB table, 3.7 read as 3 and "3" as 3.
    labels = np.zeros((4, 4, 4), np.uint8)
    labels[1:3, 1:3, 1:3] = 3
    for palette in ({3: "blue", -1: "red"}, {3: "blue", 2**32: "red"},
                    {np.int64(3): "blue", 70000: "red"}):
        rgba = cm.make_voxels(labels, palette=palette).palette.rgba
        assert len(rgba) == 4 and np.allclose(rgba[3], (0.0, 0.0, 1.0, 1.0)), rgba
    for key in (3.7, "3", True):
        with pytest.raises(cm.VolumeDataError, match="not an integer label id"):
            cm.make_voxels(labels, palette={key: "red"})
    wide = labels.astype(np.int64) * 1_000_000   # compacted ids: read by id too
    with pytest.raises(cm.VolumeDataError, match="not an integer label id"):
        cm.make_voxels(wide, palette={3e6: "red"})


def test_palette_colours_and_hiding_without_upload(plotter_factory):
    # catches: hiding a material re-uploading the labels, or hidden voxels still drawn
    # (the voxels behind them must show instead); seen to fail: the traversal stopping at
    # a hidden voxel instead of stepping through it (voxel_dda.glsl's `passing`).
    labels = random_labels((16, 12, 10), 0.3, seed=5)
    pl = plotter(plotter_factory)
    palette = ["black", "tan", "steelblue", "firebrick"]
    actor = cm.add_voxels(pl, labels, palette=palette, shading="unlit")
    camera = set_camera(pl, (30.0, 24.0, 26.0), focal=(8.0, 6.0, 5.0))
    model = actor.cubemarch.model
    for step in range(2):
        image = cm.render_image(pl).astype(float) / 255.0
        expected = render_voxels(model.labels, model.world_from_index(), model.palette.rgba,
                                 camera, SIZE, near=pl.camera.clipping_range[0])
        hits = trace_voxels(model.labels, model.world_from_index(), camera, SIZE,
                            near=pl.camera.clipping_range[0], visible=model.palette.visible)
        ok = ~hits.near_edge
        assert np.abs(image - expected)[ok].max() <= 1.5 / 255.0
        if step == 0:
            uploads = actor.cubemarch.labels.upload_count
            actor.cubemarch.set_material(2, opacity=0.0)
    assert actor.cubemarch.labels.upload_count == uploads == 1
    assert not (hits.material == 2).any() and (labels == 2).any()


def test_depth_against_a_mesh_crossing_the_grid(plotter_factory):
    # Each pixel shows the nearer of the voxel hit (CPU traversal's depth) and the plane
    # (exact ray/triangle depth). Catches: no gl_FragDepth at the hit (the box's back face
    # depth decides instead: the plane would hide voxels in front of it).
    labels = random_labels((16, 16, 16), 0.2, seed=7, materials=1)
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, labels, palette=["black", "white"], shading="unlit")
    plane = pv.Plane(center=(8, 8, 8), direction=(1, 0.2, 0.1), i_size=60, j_size=60)
    pl.add_mesh(plane, color="red", lighting=False)
    camera = set_camera(pl, (40.0, 14.0, 22.0), focal=(8.0, 8.0, 8.0))
    image = cm.render_image(pl)
    model = actor.cubemarch.model
    hits = trace_voxels(model.labels, model.world_from_index(), camera, SIZE,
                        near=pl.camera.clipping_range[0], tie_tolerance=EDGE)
    mesh = cm.reference.mesh_depth(plane, camera, SIZE)
    voxel_first = hits.depth < mesh
    red = (image[..., 0] > 200) & (image[..., 1] < 50)
    white = image.min(axis=-1) > 200
    # away from the plane's silhouette against voxels (rasterisation vs exact, 1 pixel)
    settled = np.abs(hits.depth - mesh) > 0.2
    assert voxel_first[settled].any() and (~voxel_first[settled]).any()
    assert np.array_equal(white[settled], voxel_first[settled])
    assert np.array_equal(red[settled], ~voxel_first[settled])


def test_bad_labels_get_clear_errors(plotter_factory):
    pl = plotter(plotter_factory)
    with pytest.raises(cm.VolumeDataError, match="non-integer"):
        cm.add_voxels(pl, np.full((2, 2, 2), 0.5))
    with pytest.raises(cm.VolumeDataError, match="NaN"):
        cm.add_voxels(pl, np.full((2, 2, 2), np.nan))
    with pytest.raises(cm.VolumeDataError, match="beyond 2\\^53"):
        cm.add_voxels(pl, np.full((2, 2, 2), 2.0**60))
    with pytest.raises(cm.VolumeDataError, match="no colour"):
        cm.add_voxels(pl, np.full((2, 2, 2), 5), palette=["black", "red"])
    with pytest.raises(ValueError, match="step_scale is for traversal='fixed'"):
        cm.add_voxels(pl, np.ones((2, 2, 2), int), step_scale=0.1)
    with pytest.raises(ValueError, match="traversal must be one of"):
        cm.add_voxels(pl, np.ones((2, 2, 2), int), traversal="march")


def test_cell_and_point_data_and_uint16(plotter_factory):
    grid = pv.ImageData(dimensions=(5, 4, 3), spacing=(0.5, 0.5, 0.5), origin=(1, 2, 3))
    grid.cell_data["labels"] = np.arange(grid.n_cells) % 3
    model = cm.make_voxels(grid)
    assert model.dimensions == (4, 3, 2) and model.labels.dtype == np.uint8
    assert np.allclose(model.world_bounds(), (1, 3, 2, 3.5, 3, 4))
    points = pv.ImageData(dimensions=(4, 3, 2), spacing=(1, 1, 1))
    points.point_data["labels"] = np.arange(points.n_points) + 300
    model = cm.make_voxels(points, palette="turbo")
    assert model.labels.dtype == np.uint16 and np.allclose(model.world_bounds()[:2], (-.5, 3.5))
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, model, mode="id", mip_levels=3)
    camera = set_camera(pl, (8.0, 6.0, 7.0), focal=(1.5, 1.0, 0.5))
    wrong, _, hits = wrong_pixels(pl, model, camera)
    assert wrong == 0 and (hits.material >= 300).any()
    # Levels 1-3 of a 4x3x2 grid are 2x2x1, 1x1x1, 1x1x1 cells, past the labels along z
    # (z from 2), along x from 4 - (4 >> (L - 1)) + L - 1 = 0, 3, 5: the atlas is
    # max(4, 5 + 1) x max(3, 2) x (2 + 1) texels of two bytes.
    assert actor.cubemarch.labels.nbytes == 6 * 3 * 3 * 2
    assert actor.cubemarch.nbytes == (6 * 3 * 3 * 2 + model.palette.rgba.nbytes
                                      + actor.cubemarch.shell.nbytes)


def test_pick_returns_what_is_drawn(plotter_factory):
    # Every third pixel's pick against the id image drawn by the GPU (and the material
    # under it). Catches: a pick computed with another camera, rows counted from the
    # bottom, or the hidden materials forgotten.
    labels = random_labels((12, 10, 8), 0.3, seed=9)
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, labels, mode="id")
    actor.cubemarch.set_material(1, opacity=0.0)
    set_camera(pl, (30.0, 22.0, 26.0), focal=(6.0, 5.0, 4.0))
    image = cm.render_image(pl).astype(int)
    ids = image[..., 0] + 256 * image[..., 1] + 65536 * image[..., 2]
    nx, ny, _ = labels.shape
    checked = 0
    for y in range(0, SIZE[1], 3):
        for x in range(0, SIZE[0], 3):
            picked = actor.cubemarch.pick(x, y)
            if ids[y, x] == 0:
                assert picked is None
                continue
            i, j, k = picked.index
            assert i + nx * (j + ny * k) + 1 == ids[y, x] and picked.material == labels[i, j, k]
            assert picked.material != 1
            checked += 1
    assert checked > 50
    with pytest.raises(ValueError, match="pixel"):
        actor.cubemarch.pick(SIZE[0], 0)


@pytest.mark.parametrize("shading", ["flat", "blinn"])
def test_shading_from_the_scene_lights_matches_the_reference(plotter_factory, shading):
    # A directional and a point scene light on a rotated, mirrored, anisotropic grid,
    # against the reference's formula on the CPU traversal's faces. Catches (seen to fail):
    # normals mapped by the placement's inverse instead of its inverse transpose, normals
    # pointing along the ray, and the box's entry face left out (boundary voxels lit as if
    # facing the eye).
    labels = random_labels((12, 10, 8), 0.3, seed=11)
    transform = rotated_mirrored_placement()
    pl = plotter(plotter_factory)
    light_with_sun_and_lamp(pl)
    actor = cm.add_voxels(pl, labels, palette=["black", "tan", "steelblue", "firebrick"],
                          shading=shading, transform=transform)
    camera = set_camera(pl, (-30.0, 26.0, 24.0), focal=(-6.0, 7.5, 4.0))
    image = cm.render_image(pl).astype(float) / 255.0
    model = actor.cubemarch.model
    lights = [cm.VolumeLight.from_pyvista(li, pl.camera) for li in pl.renderer.GetLights()]
    near = pl.camera.clipping_range[0]
    expected = render_voxels(model.labels, model.world_from_index(), model.palette.rgba,
                             camera, SIZE, near=near, lights=lights, shading=shading)
    hits = trace_voxels(model.labels, model.world_from_index(), camera, SIZE, near=near)
    unlit = render_voxels(model.labels, model.world_from_index(), model.palette.rgba, camera,
                          SIZE, near=near)
    ok = ~hits.near_edge & (hits.material > 0)
    assert ok.mean() > 0.2 and np.abs(unlit - expected)[ok].max() > 0.2   # lights matter
    assert np.abs(image - expected)[ok].max() <= 2.0 / 255.0


def test_occupancy_levels_are_conservative():
    # Every filled voxel's cell is marked at every level, and a cell is marked only when
    # a voxel under it is filled (checked against a direct scan of each cell).
    from pv_cubemarch.models.voxel_levels import occupancy_levels

    labels = random_labels((13, 9, 6), 0.05, seed=12)
    for level, grid in enumerate(occupancy_levels(labels, 3), start=1):
        size = 2**level
        assert grid.shape == tuple(-(-n // size) for n in labels.shape)
        for index in np.ndindex(grid.shape):
            block = labels[tuple(slice(i * size, (i + 1) * size) for i in index)]
            assert grid[index] == int(block.any())


def test_large_sparse_grid_with_all_levels(plotter_factory):
    # A 96-voxel sphere shell and scattered voxels in empty space: exact at 0 and 3 levels.
    n = 96
    x, y, z = np.mgrid[0:n, 0:n, 0:n] - n / 2 + 0.5
    radius = np.sqrt(x**2 + y**2 + z**2)
    labels = ((radius > 30) & (radius < 32)).astype(np.uint8)
    labels[:, :, n // 2:] = 0
    labels[random_labels((n, n, n), 0.0005, seed=13) > 0] = 2
    for levels, radius in ((0, 0), (3, 0), (7, 0), (0, 3), (7, 3)):
        pl = plotter(plotter_factory)
        actor = cm.add_voxels(pl, labels, mode="id", mip_levels=levels,
                              distance_field=radius)
        camera = set_camera(pl, (150.0, 110.0, 160.0), focal=(48.0, 48.0, 40.0))
        wrong, edge, hits = wrong_pixels(pl, actor.cubemarch.model, camera)
        assert (hits.material > 0).mean() > 0.1 and wrong == 0, (levels, radius, wrong, edge)


def test_skipping_structures_leave_the_host_and_come_back_from_the_labels(plotter_factory):
    # After the first frame only the GPU holds the level atlas and the distance field;
    # a texture that must go up again (its GL object freed, as in a new window) is remade
    # from the labels, and the image stays exact.
    # catches (seen to fail): the host copy kept after upload; the rebuild not called
    # (a None array uploaded).
    labels = random_labels((24, 20, 16), 0.02, seed=16)
    pl = plotter(plotter_factory)
    actor = cm.add_voxels(pl, labels, mode="id", mip_levels=3, distance_field=2)
    camera = set_camera(pl, (40.0, 30.0, 35.0), focal=(12.0, 10.0, 8.0))
    assert wrong_pixels(pl, actor.cubemarch.model, camera)[0] == 0
    skipping = actor.cubemarch.derived_textures
    assert len(skipping) == 2 and all(t.host_nbytes == 0 for t in skipping)
    # The GPU still holds them: the distance field one byte per voxel, the labels with
    # their levels more.
    assert skipping[1].nbytes == labels.size and skipping[0].nbytes > labels.size
    assert actor.cubemarch.nbytes == (labels.size + skipping[0].nbytes
                                      + actor.cubemarch.palette_texture.nbytes
                                      + actor.cubemarch.shell.nbytes)
    for texture in skipping:
        texture.release()
    wrong, _, hits = wrong_pixels(pl, actor.cubemarch.model, camera)
    assert wrong == 0 and (hits.material > 0).mean() > 0.05
    assert [t.upload_count for t in skipping] == [2, 2]


def test_level_atlas_holds_the_labels_and_every_level_apart():
    # The labels and each level cut back out of the atlas equal the labels and the level
    # built alone, and no two share a texel (counted by marking each one's box).
    from pv_cubemarch.models.voxel_levels import level_atlas, occupancy_levels

    for shape in ((37, 21, 9), (1, 1, 1), (5, 300, 2)):
        labels = random_labels(shape, 0.02, seed=14).astype(np.uint16) * 300
        grids = occupancy_levels(labels, 7)
        atlas = level_atlas(labels, grids)
        assert atlas.texels.dtype == np.uint16
        used = np.zeros(atlas.texels.shape, int)
        for number, grid in enumerate([labels, *grids]):
            assert np.array_equal(atlas.level(number), grid)
            start = atlas.origin(number)
            used[tuple(slice(o, o + n) for o, n in zip(start, grid.shape, strict=True))] += 1
        assert used.max() == 1


def test_default_levels_follow_the_empty_share(plotter_factory):
    # One voxel in a 64^3 grid: levels 1-5 are all but empty (a share of 1 - 1/32^3 .. 7/8
    # at level 5), level 6 is the single covering cell (occupied): 5 levels. A full grid:
    # no empty cell anywhere, 0. Both read back from the built actor.
    one = np.zeros((64, 64, 64), np.uint8)
    one[40, 3, 17] = 1
    pl = plotter(plotter_factory)
    assert cm.add_voxels(pl, one).cubemarch.options.mip_levels == 5
    assert cm.add_voxels(pl, np.ones((8, 8, 8), np.uint8)).cubemarch.options.mip_levels == 0
    assert cm.add_voxels(pl, one, mip_levels=2).cubemarch.options.mip_levels == 2


def test_distance_field_is_the_largest_empty_cube():
    # Checked against a direct scan of the cube around every voxel (outside counts empty).
    # catches: a dilation that spreads along one axis only (cubes become slabs).
    from pv_cubemarch.models.voxel_levels import safe_radii

    labels = random_labels((11, 7, 5), 0.03, seed=15)
    radii = safe_radii(labels, 3)
    for index in np.ndindex(labels.shape):
        expected = 0
        for r in (1, 2, 3):
            cube = labels[tuple(slice(max(i - r, 0), i + r + 1) for i in index)]
            if labels[index] or cube.any():
                break
            expected = r
        assert radii[index] == expected, index
