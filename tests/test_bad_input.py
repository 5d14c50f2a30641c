"""Bad volume input: a clear exception, and the plotter left as it was."""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv

import pv_cubemarch as cm


def non_uniform_grid():
    grid = pv.RectilinearGrid(np.array([0, 1, 3, 7.0]), np.arange(4.0), np.arange(4.0))
    grid.point_data["v"] = np.zeros(grid.n_points)
    return grid


def uniform_rectilinear():
    grid = pv.RectilinearGrid(np.arange(4.0) * 0.5, np.arange(3.0), np.arange(5.0))
    grid.point_data["v"] = np.arange(grid.n_points, dtype=float)
    return grid


def image_with(values):
    grid = pv.ImageData(dimensions=(3, 3, 3))
    grid.point_data["v"] = values
    return grid


@pytest.mark.parametrize("make, message", [
    (non_uniform_grid, "non-uniform"),
    (lambda: image_with(np.where(np.arange(27) == 5, np.nan, 1.0)), "NaN"),
    (lambda: image_with(np.full(27, np.inf)), "NaN or infinite"),
    (lambda: image_with(np.ones(27) + 1j), "dtype"),
    (lambda: np.ones((4, 4)), "3D"),
    (lambda: pv.Sphere(), "Cannot render a PolyData"),
    (lambda: pv.ImageData(dimensions=(3, 3, 3)), "no scalar arrays"),
])
def test_bad_volume_input(plotter_factory, make, message):
    pl = plotter_factory((32, 32))
    pl.add_mesh(pv.Sphere())
    before = dict(pl.renderer.actors)
    image_before = cm.render_image(pl)
    with pytest.raises(cm.VolumeDataError, match=message):
        cm.add_volume(pl, make())
    assert dict(pl.renderer.actors) == before
    assert np.array_equal(cm.render_image(pl), image_before)


def test_wrong_scalars_name_lists_arrays(plotter_factory):
    with pytest.raises(cm.VolumeDataError, match="'v'"):
        cm.add_volume(plotter_factory(), image_with(np.ones(27)), scalars="density")


def test_nan_policy_zero_draws(plotter_factory):
    values = np.ones(27)
    values[4] = np.nan
    actor = cm.add_volume(plotter_factory((16, 16)), image_with(values), nan_policy="zero")
    assert actor.cubemarch.model.values.ravel(order="F")[4] == 0


def test_uniform_rectilinear_and_cell_data_are_accepted():
    model = cm.make_volume(uniform_rectilinear())
    assert model.dimensions == (4, 3, 5)
    assert np.allclose(model.grid.spacing, (0.5, 1, 1))
    cells = pv.ImageData(dimensions=(4, 4, 4))
    cells.cell_data["c"] = np.arange(cells.n_cells, dtype=float)
    assert cm.make_volume(cells).dimensions == (4, 4, 4)


def test_integer_and_bool_data_become_float():
    model = cm.make_volume(np.arange(27, dtype=np.int16).reshape(3, 3, 3))
    assert model.values.dtype == np.float32
    assert cm.make_volume(np.ones((2, 2, 2), bool)).values.dtype == np.float32


@pytest.mark.parametrize("bad", ["missing.usda", "corrupt.usda", "missing_field.usda"])
def test_bad_scene_leaves_plotter_as_it_was(plotter_factory, tmp_path, bad):
    from pxr import Sdf, Usd, UsdVol

    (tmp_path / "corrupt.usda").write_text("#usda 1.0\ndef Xform \"A\" {\n  nonsense\n")
    stage = Usd.Stage.CreateNew(str(tmp_path / "missing_field.usda"))
    volume = UsdVol.Volume.Define(stage, "/V")
    field = stage.DefinePrim("/V/density")
    field.CreateAttribute("filePath", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath("./no.vti"))
    volume.CreateFieldRelationship("density", field.GetPath())
    stage.GetRootLayer().Save()
    pl = plotter_factory((24, 24))
    pl.add_mesh(pv.Sphere())
    before = dict(pl.renderer.actors)
    with pytest.raises(cm.SceneLoadError):
        pl.cubemarch.add_scene(tmp_path / bad, strict=True)
    assert dict(pl.renderer.actors) == before


def test_remove_frees_gpu_resources(plotter_factory):
    pl = plotter_factory((24, 24))
    actor = cm.add_volume(pl, image_with(np.linspace(0, 1, 27)))
    cm.render_frame(pl)
    texture = actor.cubemarch.bindings.textures["cm_transferTable"]
    assert texture.gl_object is not None
    assert pl.cubemarch.remove(actor)
    assert texture.gl_object is None and pl.cubemarch.memory == {}
    assert actor not in pl.renderer.actors.values()


def _labels():
    labels = np.zeros((4, 4, 4), np.uint8)
    labels[1:3, 1:3, 1:3] = 1
    return labels


def _ball():
    return 0.8 - np.sum(np.mgrid[-1:1:12j, -1:1:12j, -1:1:12j] ** 2, axis=0)


@pytest.mark.parametrize("add, error, message", [
    (lambda pl: pl.cubemarch.add_surface(pv.Sphere(), cells=0), cm.VolumeDataError,
     "cells must be a whole number"),
    (lambda pl: pl.cubemarch.add_surface(_ball(), isovalue=float("nan")),
     cm.VolumeDataError, "isovalue must be a finite number"),
    (lambda pl: pl.cubemarch.add_volume(pv.Wavelet(), opacity=[]), cm.VolumeDataError,
     "opacity is an empty curve"),
    (lambda pl: pl.cubemarch.add_volume(pv.Wavelet(), name=123), TypeError,
     "name must be a string"),
    (lambda pl: pl.cubemarch.add_voxels(_labels(), name=5), TypeError,
     "name must be a string"),
    (lambda pl: pl.cubemarch.add_voxels(_labels(), palette=[]), cm.VolumeDataError,
     "palette is empty"),
    (lambda pl: pl.cubemarch.add_voxels(_labels(), palette=["black", "notacolor"]),
     ValueError, "'notacolor' of material 1 is not a colour"),
    (lambda pl: pl.cubemarch.add_voxels(_labels()).cubemarch.set_material(
        1, color="notacolor"), ValueError, "is not a colour"),
    (lambda pl: pl.cubemarch.add_volume(pv.Wavelet(), transform=np.full((4, 4), np.nan)),
     cm.VolumeDataError, "transform must be finite; it holds 16 NaN"),
], ids=["cells=0", "isovalue=nan", "opacity=[]", "name=123", "voxels name", "palette=[]",
        "palette colour", "set_material colour", "nan transform"])
def test_bad_keywords_name_the_argument_and_the_fix(add, error, message):
    # Each was a misleading error or none (issue 25's list): cells=0 drew with 1 cell in
    # silence; isovalue=nan blamed the coefficients; opacity=[] raised numpy's
    # "zero-size array"; name=123 an AttributeError; palette=[] a broadcast error; a bad
    # colour pyvista's message naming no material; a NaN transform "got shape (4, 4)".
    # Breaks seen failing: each check removed (the old message returns).
    pl = pv.Plotter(off_screen=True)
    with pytest.raises(error, match=message):
        add(pl)
    pl.close()
