"""Geometry defects: mirrored placements, rays longer than one loop, far-away volumes.

Expected images come from the CPU reference (``render_emission_absorption``) or from a
closed form worked out by hand, never from the GPU compared with itself. Every check has a
floor that a background-only image fails.
"""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv
from conftest import (
    BACKGROUND,
    MARCHING_TECHNIQUES,
    VOLUME_TECHNIQUES,
    blob_grid,
    set_camera,
    technique_options,
)

import pv_cubemarch as cm
from pv_cubemarch import VolumeGroup, add_volumes
from pv_cubemarch.image_metrics import compare_images, to_uint8

SIZE = (48, 48)
ALL_TECHNIQUES = VOLUME_TECHNIQUES


def drawn(image) -> float:
    """Largest difference from the background, in 8-bit levels (0: nothing was drawn)."""
    return float(np.abs(image.astype(float) - to_uint8(np.array(BACKGROUND))).max())


def reference_of(pl, model, size=SIZE, **options):
    camera = cm.Camera.from_pyvista(pl.camera)
    return cm.render_emission_absorption(model, camera, size, background=BACKGROUND,
                                         near=pl.camera.clipping_range[0], **options)


# ----------------------------------------------------------------------------------------
# Defect 2: mirrored placements (negative determinant)


def mirrored_blob(how: str):
    """The blob of ``blob_grid(20)`` placed with a negative determinant, three ways.

    The blob is not symmetric (a second lobe at x = 0.4, y = -0.3), so a mirrored volume
    drawn unmirrored, or not at all, is far from the reference.
    """
    grid = blob_grid(20)
    density = grid.point_data["density"]
    if how == "transform":
        return cm.make_volume(grid, clim=(0, 1), opacity_unit_distance=0.2,
                              transform=np.diag([-1.0, 1.0, 1.0, 1.0]))
    if how == "spacing":
        # PyVista's constructor refuses a negative spacing; VTK's setter takes it.
        mirrored = pv.ImageData(dimensions=grid.dimensions, spacing=grid.spacing,
                                origin=(1.0, -1.0, -1.0))
        mirrored.SetSpacing(-grid.spacing[0], grid.spacing[1], grid.spacing[2])
    elif how == "rectilinear":  # x coordinates decreasing: a negative spacing once uniform
        axes = [np.linspace(-1.0, 1.0, 20) for _ in range(3)]
        mirrored = pv.RectilinearGrid(axes[0][::-1], axes[1], axes[2])
    else:  # a direction matrix with determinant -1
        mirrored = pv.ImageData(dimensions=grid.dimensions, spacing=grid.spacing,
                                origin=(-1.0, 1.0, -1.0))
        mirrored.direction_matrix = np.diag([1.0, -1.0, 1.0])
    mirrored.point_data["density"] = density
    return cm.make_volume(mirrored, clim=(0, 1), opacity_unit_distance=0.2)


@pytest.mark.parametrize("how", ["transform", "spacing", "rectilinear", "direction"])
@pytest.mark.parametrize("technique", ALL_TECHNIQUES)
def test_mirrored_volume_matches_reference(plotter_factory, technique, how):
    # Catches: the box actor keeping FrontfaceCullingOn under a mirroring placement
    # (direct, cubemap, auto then draw the box's near faces, so every ray ends where it
    # starts and nothing is drawn: 19-26 dB); VTK's mapper fed the user's grid as it is
    # (negative spacing: PyVista's "spacing values must all be greater than or equal to
    # 0.0" raised from _build_actor; a direction with det -1: VTK draws nothing, 26 dB);
    # a RectilinearGrid with decreasing coordinates turned into an ImageData through
    # PyVista's constructor (the same PyVista error, from make_volume). 'vtk' with a
    # mirroring transform was right before the fix; it catches VTK's input keeping the
    # grid's own origin and spacing while the actor's matrix places index space (18 dB).
    model = mirrored_blob(how)
    assert np.linalg.det(model.world_from_index()[:3, :3]) < 0
    pl = plotter_factory(SIZE)
    cm.add_volume(pl, model, **technique_options(model, technique))
    set_camera(pl, (3.0, 2.0, 4.0))
    image = cm.render_image(pl)
    reference = reference_of(pl, model)
    errors = compare_images(image, reference)
    assert errors.psnr >= 45, errors
    assert drawn(image) > 60
    # The mirror matters: the unmirrored blob's reference is far from this one.
    plain = cm.make_volume(blob_grid(20), clim=(0, 1), opacity_unit_distance=0.2)
    assert compare_images(reference_of(pl, plain), reference).psnr < 40


def test_negative_spacing_keeps_the_default_opacity_unit_distance():
    # Catches: the default opacity_unit_distance taken as the mean of the signed spacings
    # (a mirrored x axis makes it a third of the voxel: three times the extinction).
    plain = cm.make_volume(blob_grid(20), clim=(0, 1))
    mirrored = cm.make_volume(mirrored_blob("spacing").grid, clim=(0, 1))
    assert np.allclose(mirrored.transfer.table, plain.transfer.table)


@pytest.mark.parametrize("technique", ALL_TECHNIQUES)
def test_set_transform_to_a_mirrored_placement_and_back(plotter_factory, technique):
    # Catches: set_transform moving the box actor without choosing its culling again (a
    # box added unmirrored keeps culling its front faces once mirrored: nothing drawn,
    # 19 dB; and the way back breaks if the culling is flipped once and never restored);
    # for 'vtk', set_transform giving VTK's actor model.transform while its input grid
    # spans index space (VTK's box then covers the wrong pixels: 23 dB on the way back).
    model = cm.make_volume(blob_grid(20), clim=(0, 1), opacity_unit_distance=0.2)
    pl = plotter_factory(SIZE)
    actor = cm.add_volume(pl, model, **technique_options(model, technique))
    set_camera(pl, (3.0, 2.0, 4.0))
    cm.render_image(pl)
    mirror = np.diag([-1.0, 1.0, 1.0, 1.0])
    mirror[0, 3] = 0.1  # a shift too, so a placement that ignores it shows
    for placement in (mirror, np.eye(4)):
        actor.cubemarch.set_transform(placement)
        image = cm.render_image(pl)
        reference = reference_of(pl, actor.cubemarch.model)   # placed there
        errors = compare_images(image, reference)
        assert errors.psnr >= 45, (placement[0, 0], errors)
        assert drawn(image) > 60


# ----------------------------------------------------------------------------------------
# Defect 4: rays longer than the marcher's loop


def constant_medium(n=48):
    """A constant value on an n^3 grid over [-1, 1]^3, with a hand-made transfer table.

    Every row emits (1.0, 0.8, 0.6) with extinction ln(2) / 2: a chord of the full box
    (length 2) absorbs exactly half, whatever the step.
    """
    grid = pv.ImageData(dimensions=(n, n, n), spacing=(2.0 / (n - 1),) * 3,
                        origin=(-1.0, -1.0, -1.0))
    grid.point_data["v"] = np.ones(n ** 3, dtype=np.float32)
    sigma = np.log(2.0) / 2.0
    table = np.tile(np.array([[1.0, 0.8, 0.6, sigma]], dtype=np.float32), (256, 1))
    transfer = cm.TransferFunction(table=table, clim=(0.0, 2.0))
    return cm.make_volume(grid, transfer=transfer)


@pytest.mark.parametrize("technique", MARCHING_TECHNIQUES)
def test_long_rays_are_marched_to_the_end(plotter_factory, technique):
    # Catches: a marcher loop bounded at 16384 steps. step_scale 0.002 on 47 texels is
    # 23500 steps along z; cut at 16384 the chord absorbs 1 - 0.5**(16384/23500) = 0.38
    # instead of 0.5 (the pixel is 26 levels too dark). The cube map gets the same step
    # from max_samples (technique_options).
    model = constant_medium(48)
    pl = plotter_factory(SIZE)
    actor = cm.add_volume(pl, model, **technique_options(model, technique, step_scale=0.002,
                                                         pixels=32.0))
    # A parallel view along z: every ray inside the box's outline crosses it whole (chord 2).
    pl.camera.parallel_projection = True
    pl.camera.parallel_scale = 1.5
    set_camera(pl, (0.0, 0.0, 6.0))
    image = cm.render_image(pl)
    if technique == "cubemap":
        assert actor.cubemarch.lod.samples > 16384  # the test really asks for long rays
    # By hand: alpha = 1 - exp(-sigma * 2) = 0.5 over the background.
    expected = to_uint8(0.5 * np.array([1.0, 0.8, 0.6]) + 0.5 * np.array(BACKGROUND))
    # The box spans rows/columns 8..40 (2 of the 3 units in view); keep 2 pixels off edges.
    inner = image[10:38, 10:38].reshape(-1, 3).astype(int)
    assert np.abs(inner - expected.astype(int)).max() <= 2, (inner.min(axis=0),
                                                             inner.max(axis=0), expected)


def huge_and_tiny():
    """A blob over [-1, 1]^3 and, inside it, a tiny dense volume 1e4 times finer."""
    huge = cm.make_volume(blob_grid(24), clim=(0, 1), opacity_unit_distance=0.2, name="huge")
    spacing = 2e-5
    tiny_grid = pv.ImageData(dimensions=(8, 8, 8), spacing=(spacing,) * 3,
                             origin=(0.2, 0.1, 0.0))
    tiny_grid.point_data["v"] = np.linspace(0.0, 1.0, 512, dtype=np.float32)
    tiny = cm.make_volume(tiny_grid, cmap="viridis", clim=(0, 1),
                          opacity_unit_distance=1e-4, name="tiny")
    return huge, tiny


@pytest.mark.parametrize("technique", ["direct", "cubemap"])
def test_joint_group_of_a_huge_and_a_tiny_member(plotter_factory, technique):
    # Catches: the group's virtual grid as fine as its finest member (2e-5 here: 100001
    # points per axis, 200000 steps at step_scale 0.5) with the loop cut at 16384 steps
    # (only the first 8 % of each ray is drawn: 27 dB), or any joint march that steps the
    # whole union box at the tiny member's spacing.
    huge, tiny = huge_and_tiny()
    pl = plotter_factory(SIZE)
    group = VolumeGroup([huge, tiny])
    cm.add_volume(pl, group, **technique_options(group, technique))
    set_camera(pl, (3.0, 2.0, 4.0))
    image = cm.render_image(pl)
    # The reference steps 0.1 of the huge member's voxel: the tiny member (1.4e-4 wide) is
    # far below a pixel (0.06), so it hides no pixel's ray in either image.
    step = 0.1 * (2.0 / 23) / 2e-5
    reference = reference_of(pl, [huge, tiny], step_voxels=step)
    errors = compare_images(image, reference)
    assert errors.psnr >= 45, errors
    assert drawn(image) > 60
    # add_volumes groups the pair the same way.
    other = plotter_factory(SIZE)
    (actor,) = add_volumes(other, [huge, tiny], technique=technique)
    assert isinstance(actor.cubemarch.model, VolumeGroup)


def coarse_and_fine():
    """A faint coarse blob over [-1, 1]^3 and a fine, voxel-scale pattern 260 times finer."""
    coarse = cm.make_volume(blob_grid(16), clim=(0, 1), opacity_unit_distance=2.0,
                            name="coarse")
    n = 40
    i, j, k = np.meshgrid(*(np.arange(n),) * 3, indexing="ij")
    pattern = ((i // 2 + j // 2 + k // 2) % 2).astype(np.float32)
    fine_grid = pv.ImageData(dimensions=(n, n, n), spacing=(0.3 / (n - 1),) * 3,
                             origin=(-0.15, -0.15, -0.15))
    fine_grid.point_data["v"] = pattern.ravel(order="F")
    fine = cm.make_volume(fine_grid, cmap="viridis", clim=(0, 1), opacity=[0.0, 0.5],
                          opacity_unit_distance=0.05, name="fine")
    return coarse, fine


@pytest.mark.parametrize("technique", ["direct", "cubemap"])
def test_joint_group_steps_each_member_at_its_own_spacing(plotter_factory, technique):
    # Catches: a joint march that steps only on the group's virtual grid once that grid is
    # capped coarser than the finest member (the fine member, a pattern 2 voxels wide, is
    # then sampled every 1.6 of its voxels instead of every 0.5; the reference at that step
    # is 32 dB from the fine one). The camera sits inside the coarse member, near the fine.
    coarse, fine = coarse_and_fine()
    pl = plotter_factory(SIZE)
    group = VolumeGroup([coarse, fine])
    cm.add_volume(pl, group, **technique_options(group, technique))
    set_camera(pl, (0.35, 0.25, 0.45))
    image = cm.render_image(pl)
    reference = reference_of(pl, [coarse, fine], step_voxels=0.25)
    errors = compare_images(image, reference)
    assert errors.psnr >= 40, errors
    assert drawn(image) > 60


def test_refuses_a_step_no_ray_can_take(plotter_factory):
    # Catches: add_volume accepting any positive step_scale (1e-6 on 48 texels is 4.7e7
    # steps a ray, more than the marcher's nested loops take); the error must say why.
    model = constant_medium(48)
    with pytest.raises(ValueError, match="step_scale.*steps"):
        cm.add_volume(plotter_factory(SIZE), model, technique="direct", step_scale=1e-6)
    with pytest.raises(ValueError, match="max_samples.*steps"):
        cm.add_volume(plotter_factory(SIZE), model, technique="cubemap",
                      max_samples=100_000_000)


# ----------------------------------------------------------------------------------------
# Defect 6: volumes far from the origin


@pytest.mark.parametrize("offset", [1e6, 1e7], ids=["1e6", "1e7"])
@pytest.mark.parametrize("technique", MARCHING_TECHNIQUES)
def test_far_away_volume_matches_reference(plotter_factory, technique, offset):
    # Catches: VTK's mapper fed a grid whose points sit 1e6 from the origin (float32
    # vertex positions and texture coordinates: 39 dB at 1e6, 21 dB at 1e7 before the
    # fix), and, with the grid in index space, VTK's own clip position (its projection,
    # view and volume matrices multiplied in float32 on the GPU move the box's outline by
    # a pixel at 1e7: 44.5 dB, 16 levels at the edge). 'direct' and 'cubemap' were right
    # before; they (and 'vtk') catch the camera-relative matrices being multiplied in
    # float32 (cm_textureFromView from float32 view and placement: 20-36 dB).
    base = blob_grid(16)
    grid = pv.ImageData(dimensions=base.dimensions, spacing=base.spacing,
                        origin=np.array(base.origin) + offset)
    grid.point_data["density"] = base.point_data["density"]
    model = cm.make_volume(grid, clim=(0, 1), opacity_unit_distance=0.2)
    center = np.full(3, offset)
    pl = plotter_factory(SIZE)
    actor = cm.add_volume(pl, model, **technique_options(model, technique))
    # The camera a few box sizes away (box edge 2, distance 5.4).
    set_camera(pl, tuple(center + [3.0, 2.0, 4.0]), focal=tuple(center))
    image = cm.render_image(pl)
    reference = reference_of(pl, model)
    errors = compare_images(image, reference)
    assert errors.psnr >= 45, errors
    assert errors.max_abs <= 6, errors  # the outline too (2-3 levels at any offset)
    assert drawn(image) > 60
    # the volume's own copy of the model: the same arrays (nothing copied) and placement
    drawn_model = actor.cubemarch.model
    assert drawn_model.values is model.values
    assert np.array_equal(drawn_model.transform, model.transform)


@pytest.mark.parametrize("technique", MARCHING_TECHNIQUES)
def test_far_away_volume_cut_by_a_mesh(plotter_factory, technique):
    # Catches: VTK's mapper ending each ray at the opaque depth through its float32 inverse
    # matrices (inverse projection, model-view and volume matrices holding 1e6-sized
    # translations): with its own ray set-up the rays stop off the mesh, 39 dB and 4.5 %
    # bad pixels; our rays end where the camera-relative matrices put the depth (44 dB and
    # 1 % at 1e6, as at the origin: the rest is the mesh's multisampled outline). All three
    # catch cm_textureFromView multiplied in float32 (33-35 dB, 10-25 % bad pixels).
    offset = 1e6
    base = blob_grid(16)
    grid = pv.ImageData(dimensions=base.dimensions, spacing=base.spacing,
                        origin=np.array(base.origin) + offset)
    grid.point_data["density"] = base.point_data["density"]
    model = cm.make_volume(grid, clim=(0, 1), opacity_unit_distance=0.1)
    size = (64, 64)
    pl = plotter_factory(size)
    # Flat faces (no faceting against the exact mesh), float64 points placed far away.
    mesh = pv.Box(bounds=(-0.3, 0.5, -0.6, 0.4, -0.2, 0.3)).triangulate()
    mesh.points = mesh.points.astype(np.float64) + offset
    color = (0.2, 0.8, 0.3)
    pl.add_mesh(mesh, color=color, lighting=False)
    cm.add_volume(pl, model, technique=technique)
    center = np.full(3, offset)
    camera = set_camera(pl, tuple(center + [3.0, 2.0, 4.0]), focal=tuple(center))
    image = cm.render_image(pl)
    depth = cm.reference.mesh_depth(mesh, camera, size)
    assert 0.05 < np.isfinite(depth).mean() < 0.5
    backdrop = np.where(np.isfinite(depth)[..., None], color, BACKGROUND)
    reference = reference_of(pl, model, size, opaque_depth=depth, opaque_color=backdrop)
    errors = compare_images(image, reference)
    assert errors.psnr >= 42, errors
    assert errors.bad_pixel_fraction <= 0.02, errors
    assert drawn(image) > 60
