"""Surfaces from USD stages and the command line: placed as the stage says, drawn as the
reference draws their field, options checked when the stage is loaded."""

from __future__ import annotations

import numpy as np
import pytest
import pyvista
from conftest import write_voxel_stage
from PIL import Image

import pv_cubemarch as cm
from pv_cubemarch.cli import main
from pv_cubemarch.core.errors import SceneLoadError
from pv_cubemarch.models.surface import active_cells
from pv_cubemarch.reference.surfaces import trace_surface

SIZE = (64, 48)


def ball_samples(n=16, radius=5.0):
    """Signed distance samples of a ball (positive inside) on n^3 points."""
    p = np.indices((n, n, n)).reshape(3, -1).T.astype(float)
    return (radius - np.linalg.norm(p - (n - 1) / 2.0, axis=1)).reshape(n, n, n)


def surface_stage(tmp_path, attrs=None, name="ball.usda"):
    given = {"cubemarch:isovalue": ("Float", 0.0), "cubemarch:shading": ("Token", "unlit"),
             **(attrs or {})}
    return write_voxel_stage(tmp_path, ball_samples(), technique="surface", attrs=given,
                             eye=(20.0, 14.0, 19.0), target=(8.0, 6.0, 7.5),
                             stage_name=name)


def test_usd_surface_is_placed_and_drawn_as_its_field(tmp_path, plotter_factory):
    # catches: the stage's transform not applied to the field (drawn at the origin).
    path = surface_stage(tmp_path, {"cubemarch:steps": ("Int", 300),
                                    "cubemarch:root": ("Token", "exact"),
                                    "cubemarch:color": ("Color3f", (1.0, 1.0, 1.0))})
    scene = cm.load_scene(path)
    assert len(scene.surfaces) == 1 and "surfaces: 1" in scene.summary()
    field = scene.surfaces[0]
    assert scene.surface_options[field.name] == {"steps": 300, "root": "exact",
                                                 "color": (1.0, 1.0, 1.0), "shading": "unlit"}
    assert not np.allclose(field.transform, np.eye(4))
    pl = plotter_factory(SIZE)
    pl.disable_anti_aliasing()
    pl.ren_win.SetMultiSamples(0)
    actors = scene.add_to(pl)
    pl.set_background("black")
    assert actors[field.name].cubemarch.options.root == "exact"
    image = cm.render_image(pl)
    camera = cm.Camera.from_pyvista(pl.camera)
    hits = trace_surface(field, active_cells(field), camera, SIZE,
                         near=pl.camera.clipping_range[0])
    covered = image.max(axis=-1) > 127
    assert hits.hit.mean() > 0.1 and ((covered != hits.hit) & ~hits.ambiguous).sum() == 0


@pytest.mark.parametrize(("attrs", "message"), [
    ({"cubemarch:steps": ("Int", 0)}, "cubemarch:steps = 0"),
    ({"cubemarch:root": ("Token", "newton")}, "cubemarch:root = 'newton'"),
    ({"cubemarch:surfaceTraversal": ("Token", "boxes")},
     "cubemarch:surfaceTraversal = 'boxes'"),
    ({"cubemarch:steps": ("String", "many")}, "cubemarch:steps must be a whole number"),
])
def test_bad_surface_prims_are_named(tmp_path, attrs, message):
    with pytest.raises(SceneLoadError, match=message):
        cm.load_scene(surface_stage(tmp_path, attrs), strict=True)


def test_a_surface_prim_needs_its_isovalue(tmp_path):
    path = write_voxel_stage(tmp_path, ball_samples(), technique="surface",
                             stage_name="no_iso.usda")
    with pytest.raises(SceneLoadError, match="needs cubemarch:isovalue"):
        cm.load_scene(path, strict=True)


def test_cli_renders_a_surface_stage(tmp_path, capsys):
    out = tmp_path / "ball.png"
    assert main(["render", str(surface_stage(tmp_path)), "--out", str(out),
                 "--size", "64x48"]) == 0
    assert out.exists() and out.stat().st_size > 0
    assert main(["info", str(surface_stage(tmp_path, name="again.usda"))]) == 0
    assert "surfaces: 1" in capsys.readouterr().out


def test_the_spline_is_taken_from_every_channel(tmp_path, capsys):
    # load_scene(spline=), `render --spline` and a prim's cubemarch:spline make the
    # approximating field (its values: test_surface_field's oracle), and refuse a spline
    # without a level. Samples stepping sharply (0 to 10, a level of 9.5): the
    # interpolating spline overshoots into a sheet, the approximating one draws the box
    # alone. catches (seen failing): the spline dropped by load_scene, by the CLI, by the
    # USD reader (each drew the interpolating field).
    steps = np.zeros((12, 12, 12))
    steps[3:9, 3:9, 3:9] = 10.0
    path = tmp_path / "steps.npy"
    np.save(path, steps)
    expected = cm.make_field(steps, 0.5, spline="approximating").coefficients
    field = cm.load_scene(path, isovalue=0.5, spline="approximating").surfaces[0]
    assert np.allclose(field.coefficients, expected)
    with pytest.raises(SceneLoadError, match="give isovalue= too"):
        cm.load_scene(path, spline="approximating")
    stage = write_voxel_stage(tmp_path, steps, technique="surface", attrs={
        "cubemarch:isovalue": ("Float", 0.5),
        "cubemarch:spline": ("Token", "approximating")}, stage_name="steps.usda")
    assert np.allclose(cm.load_scene(stage).surfaces[0].coefficients, expected)
    covered = {}
    for spline in ("interpolating", "approximating"):
        out = tmp_path / f"{spline}.png"
        assert main(["render", str(path), "--isovalue", "9.5", "--spline", spline, "--out",
                     str(out), "--size", "64x48", "--shading", "unlit"]) == 0
        covered[spline] = (np.asarray(Image.open(out))[..., :3].min(axis=-1) > 200).sum()
    assert 0 < covered["approximating"] < 0.8 * covered["interpolating"], covered
    capsys.readouterr()
    assert main(["render", str(path), "--spline", "approximating", "--out",
                 str(tmp_path / "x.png")]) == 2
    assert "give isovalue= too" in capsys.readouterr().err


def test_a_grid_file_is_a_surface_with_isovalue(tmp_path, capsys):
    # The samples minus the isovalue, interpolated: the field equals them at the cell
    # centres (by hand: sample (i, j, k) sits at the centre of cell (i, j, k)). The CLI
    # draws it with the surface flags, refuses --isovalue with --technique voxels, and
    # warns of surface flags on a scene without surfaces. catches: --isovalue not passed
    # to the loader (a volume drawn: its options refused), the surface flags dropped.
    samples = ball_samples()
    path = tmp_path / "ball.npy"
    np.save(path, samples)
    scene = cm.load_scene(path, isovalue=1.0)
    assert not scene.volumes and len(scene.surfaces) == 1
    field = scene.surfaces[0]
    centres = np.argwhere(np.ones(samples.shape, bool)) + 0.5
    assert np.abs(field.at_cells(centres) - (samples.ravel() - 1.0)).max() < 1e-9
    out = tmp_path / "ball.png"
    assert main(["render", str(path), "--isovalue", "0", "--out", str(out), "--size", "64x48",
                 "--root", "exact", "--surface-traversal", "cell_boxes", "--steps", "80",
                 "--shading", "unlit"]) == 0
    image = np.asarray(Image.open(out))
    assert (image[..., :3].min(axis=-1) > 200).sum() > 200   # the white ball
    capsys.readouterr()
    assert main(["render", str(path), "--isovalue", "0", "--technique", "voxels", "--out",
                 str(out)]) == 2
    assert "--isovalue draws the grid as a surface" in capsys.readouterr().err
    with pytest.raises(SceneLoadError, match="isovalue applies to grid files"):
        cm.load_scene(surface_stage(tmp_path), isovalue=0.0)
    assert main(["render", str(path), "--out", str(out), "--size", "32x24", "--steps",
                 "50"]) == 0
    assert "--steps does not apply to this scene" in capsys.readouterr().err
    # Volume and voxel flags on a surface: left out, each with a warning (--traversal is
    # the voxels'; a surface's is --surface-traversal).
    assert main(["render", str(path), "--isovalue", "0", "--out", str(out), "--size",
                 "32x24", "--technique", "cubemap", "--traversal", "fixed"]) == 0
    err = capsys.readouterr().err
    assert "--technique does not apply" in err and "--traversal does not apply" in err


def test_pv_read_gives_a_surface_as_its_field_at_the_cell_centres(tmp_path):
    # A stage's surface comes back from pv.read as an ImageData placed in the world with
    # the field at each cell centre; interpolated again (isovalue 0) it is the same field
    # (the interpolation of centre values is one-to-one with mirror ends), drawn over the
    # same part of its cells: a field of point samples up to the points, so the block
    # holds them as point data. catches: the block left out, values at the corners (a
    # field shifted by half a cell); (seen failing; found by a review) the block as cell
    # data, drawn again out to the cells' faces (936 pixels past the stage's surface).
    path = surface_stage(tmp_path)
    field = cm.load_scene(path).surfaces[0]
    assert field.domain is not None   # the stage's samples are at points
    blocks = pyvista.read(path)
    block = blocks[field.name]
    assert block.n_points == np.prod(field.dimensions)
    again = cm.make_field(block, 0.0, "field")
    assert np.abs(again.coefficients - field.coefficients).max() < 1e-9
    assert np.allclose(again.world_from_index(), field.world_from_index())
    assert np.allclose(again.domain, field.domain)
    assert np.allclose(again.world_bounds(), field.world_bounds())
    mesh_field = cm.make_field(pyvista.Sphere(), cells=8)   # no domain: cells kept
    scene = cm.Scene(surfaces=[mesh_field])
    block = scene.to_multiblock()[mesh_field.name]
    assert block.n_cells == np.prod(mesh_field.dimensions)
    assert np.abs(cm.make_field(block, 0.0, "field").coefficients
                  - mesh_field.coefficients).max() < 1e-9
