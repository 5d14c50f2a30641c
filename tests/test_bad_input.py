"""Bad volume input: a clear exception, and the plotter left as it was."""

from __future__ import annotations

import sys
import warnings

import numpy as np
import pytest
import pyvista as pv
from conftest import MARCHING_TECHNIQUES

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
    (lambda: pv.Sphere(), "PolyData is not a regular grid of samples"),
    (lambda: pv.Table({"a": np.arange(3.0)}), "Table is not a regular grid"),   # was an
    # AttributeError (found by a review)
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


def test_labels_come_as_add_volume_takes_a_grid_and_anything_else_is_named(plotter_factory):
    # Found by a review: a bare vtkImageData, which add_volume takes, and a uniform
    # RectilinearGrid were refused by add_voxels as "got shape ()", and so were meshes and
    # MultiBlocks, naming nothing. The VTK image and the RectilinearGrid draw the labels an
    # ImageData of them draws; the others are refused by name. catches (seen failing):
    # the VTK object not wrapped ("got shape ()"), the RectilinearGrid not made an image
    # (refused as a mesh), the MultiBlock's check left out ("got shape (2,)").
    from vtkmodules.vtkCommonDataModel import vtkImageData

    labels = pv.ImageData(dimensions=(5, 4, 3), spacing=(0.5, 1.0, 1.0))
    labels.cell_data["l"] = np.arange(labels.n_cells) % 3
    raw = vtkImageData()
    raw.DeepCopy(labels)
    rectilinear = labels.cast_to_rectilinear_grid()
    expected = cm.add_voxels(plotter_factory(), labels).cubemarch.model
    for grid in (raw, rectilinear):
        model = cm.add_voxels(plotter_factory(), grid).cubemarch.model
        assert np.array_equal(model.labels, expected.labels)
        assert np.allclose(model.grid_from_index, expected.grid_from_index)
    for grid, words in ((labels.cast_to_unstructured_grid(), "UnstructuredGrid is not a "
                         "regular grid"), (pv.Sphere(), "voxelize it"),
                        (pv.MultiBlock([labels, labels]), "a MultiBlock holds 2")):
        with pytest.raises(cm.VolumeDataError, match=words):
            cm.add_voxels(plotter_factory(), grid)


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


def _flat_grid():
    grid = pv.ImageData(dimensions=(5, 5, 5), spacing=(1, 0, 1))
    grid.point_data["v"] = np.arange(125, dtype=np.float32)
    return grid


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
    (lambda pl: pl.cubemarch.add_volume(pv.Wavelet(), shade="yes"), TypeError,
     "shade must be True or False, got 'yes'"),
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
    (lambda pl: pl.cubemarch.add_volume(_flat_grid()), cm.VolumeDataError,
     r"spacing must be three finite, non-zero numbers, got \(1.0, 0.0, 1.0\)"),
    (lambda pl: pl.cubemarch.add_volume(pv.Wavelet(), cmap="viridiss"), cm.VolumeDataError,
     r"cmap='viridiss' is not a colormap .*did you mean 'viridis'"),
    (lambda pl: pl.cubemarch.add_voxels(_labels(), cmap="magmaa"), cm.VolumeDataError,
     r"cmap='magmaa' is not a colormap .*did you mean 'magma'"),
    (lambda pl: pl.cubemarch.add_voxels(_labels()).cubemarch.set_voxels(
        (np.array([1, 9]), np.array([1, 1]), np.array([1, 2])), 0), IndexError,
     r"index arrays .* inside the grid's shape \(4, 4, 4\)"),
], ids=["cells=0", "isovalue=nan", "opacity=[]", "name=123", "shade='yes'", "voxels name",
        "palette=[]", "palette colour", "set_material colour", "nan transform", "zero spacing",
        "volume cmap", "voxels cmap", "index arrays"])
def test_bad_keywords_name_the_argument_and_the_fix(add, error, message):
    # Each was a misleading error or none (issue 25's list): cells=0 drew with 1 cell in
    # silence; isovalue=nan blamed the coefficients; opacity=[] raised numpy's
    # "zero-size array"; name=123 an AttributeError; palette=[] a broadcast error; a bad
    # colour pyvista's message naming no material; a NaN transform "got shape (4, 4)";
    # zero spacing drew a flat grid in silence; an unknown cmap named no choices; index
    # arrays in set_voxels gave numpy's "only 0-dimensional arrays can be converted";
    # shade='yes' was taken as True (PyVista's add_volume raises TypeError).
    # Breaks seen failing: each check removed (the old message returns).
    pl = pv.Plotter(off_screen=True)
    with pytest.raises(error, match=message):
        add(pl)
    pl.close()


def _placed_badly(geometry: dict, labels: bool):
    values = (_ball() > 0).astype(np.uint8) if labels else _ball()
    grid = pv.ImageData(dimensions=values.shape)
    grid.point_data["v"] = values.ravel(order="F")
    for key, value in geometry.items():
        if key == "spacing":
            grid.SetSpacing(*value)
        else:
            setattr(grid, key, value)
    return grid


@pytest.mark.parametrize("geometry, message", [
    (dict(origin=(np.nan, 0.0, 0.0)), r"origin must be three finite numbers, got \(nan"),
    (dict(origin=(0.0, np.inf, 0.0)), r"origin must be three finite numbers, got \(0.0, inf"),
    (dict(spacing=(np.inf, 1.0, 1.0)), r"spacing must be three finite, non-zero numbers, "
                                       r"got \(inf"),
    (dict(spacing=(1.0, 0.0, 1.0)), r"spacing must be three finite, non-zero numbers"),
    (dict(direction_matrix=np.zeros((3, 3))), "direction_matrix must be invertible"),
    (dict(direction_matrix=[[1.0, 0.0, 1.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]]),
     "direction_matrix must be invertible"),
], ids=["nan origin", "inf origin", "inf spacing", "zero spacing", "zero direction",
        "flat direction"])
@pytest.mark.parametrize("kind", ["volume", "voxels", "surface"])
def test_a_grid_that_cannot_be_placed_is_refused_by_its_name(kind, geometry, message):
    # Found by a review: a NaN origin drew a volume as nothing, in silence; voxels and
    # surfaces raised numpy's "matrix must have finite values", an infinite spacing was
    # blamed on opacity_unit_distance or read as NaN, and a singular direction raised
    # LinAlgError or "spacing must not be zero".
    # catches (seen failing): models/volume.check_geometry not called (those messages).
    pl = pv.Plotter(off_screen=True)
    grid = _placed_badly(geometry, kind == "voxels")
    add = {"volume": lambda: cm.add_volume(pl, grid),
           "voxels": lambda: cm.add_voxels(pl, grid),
           "surface": lambda: cm.add_surface(pl, grid, isovalue=0.0)}[kind]
    with pytest.raises(cm.VolumeDataError, match=message):
        add()
    pl.close()


def test_index_arrays_set_the_voxels_they_name(plotter_factory):
    # numpy's (i's, j's, k's): the voxels they name and no others
    actor = cm.add_voxels(plotter_factory((40, 40)), _labels())
    actor.cubemarch.set_voxels((np.array([0, 3]), np.array([0, 2]), np.array([1, 3])), 1)
    actor.cubemarch.set_voxels((np.array([1]), np.array([1]), np.array([1])), 0)
    labels = actor.cubemarch.model.labels
    assert labels[0, 0, 1] == 1 and labels[3, 2, 3] == 1 and labels[1, 1, 1] == 0
    assert (labels == 1).sum() == 8 + 2 - 1


def _closed_plotter_calls():
    volume = np.exp(-np.sum(np.mgrid[-1:1:8j, -1:1:8j, -1:1:8j] ** 2, axis=0))
    return {
        "add_volume vtk": lambda pl, a: cm.add_volume(pl, volume),
        "add_volume cubemap": lambda pl, a: cm.add_volume(pl, volume, technique="cubemap"),
        "add_voxels": lambda pl, a: cm.add_voxels(pl, _labels()),
        "add_surface": lambda pl, a: cm.add_surface(pl, _ball()),
        "set_voxels": lambda pl, a: a["voxels"].cubemarch.set_voxels((1, 1, 1), 0),
        "set_values": lambda pl, a: a["voxels"].cubemarch.set_values(_labels()),
        "set_material": lambda pl, a: a["voxels"].cubemarch.set_material(1, color="red"),
        "pick": lambda pl, a: a["voxels"].cubemarch.pick(10, 10),
        "volume set_values": lambda pl, a: a["volume"].cubemarch.set_values(volume),
    }


@pytest.mark.parametrize("call", list(_closed_plotter_calls()))
def test_a_closed_plotter_refuses_adds_edits_and_picks(call):
    # catches: adds that "succeeded" on a closed plotter (the cube map's AttributeError in
    # gl/overlay.py), edits that did nothing and a pick answering None as if nothing were
    # hit (break seen failing: the open_window/needs_open_plotter checks removed)
    pl = cm.offscreen_plotter((40, 40))
    actors = {"voxels": cm.add_voxels(pl, _labels()),
              "volume": cm.add_volume(pl, _ball(), technique="direct", clim=(-2, 1))}
    cm.render_image(pl)
    pl.close()
    with pytest.raises(cm.PlotterClosedError, match="closed"):
        _closed_plotter_calls()[call](pl, actors)


@pytest.mark.parametrize("technique", MARCHING_TECHNIQUES)
def test_a_volume_past_the_3d_texture_limit_is_an_error_not_a_blank(plotter_factory,
                                                                     technique):
    # catches: 'vtk' drawing a blank image (VTK logs "Invalid texture dimensions" and
    # draws nothing) and direct/cubemap's upload refused unread; 16500 points is past every
    # GL's GL_MAX_3D_TEXTURE_SIZE (2048 on Mesa, 16384 on NVIDIA), so the frame must raise
    values = np.zeros((16500, 3, 3), np.float32)
    values[::7] = 1.0
    pl = plotter_factory((40, 40))
    cm.add_volume(pl, values, technique=technique)
    with pytest.raises(cm.GpuLimitError, match=r"\(16500, 3, 3\)|\[16500, 3, 3\]"):
        cm.render_image(pl)   # a CubemarchError: the CLI says it (it was a traceback)


def test_a_texture_gl_refuses_is_an_error_not_a_blank(plotter_factory):
    # catches: GL_INVALID_VALUE after an upload left unread (the 65536-wide palette drew
    # nothing); 70000 texels is past Mesa's 16384 and every GPU's 2D width limit
    from pv_cubemarch.gl.textures import Texture
    pl = plotter_factory((40, 40))
    pl.add_mesh(pv.Sphere())
    cm.render_image(pl)
    texture = Texture(np.zeros((1, 70000, 4), np.float32), kind="2d")
    pl.ren_win.MakeCurrent()
    with pytest.raises(cm.GpuLimitError, match=r"GL refused a 2d texture of shape \(1, 70000, 4\) "
                                           r"\(GL_INVALID_VALUE\)"):
        texture.ensure(pl.ren_win)


def test_a_constant_volume_warns_and_says_what_to_do(plotter_factory):
    # catches: a constant volume drawn as nothing without a word
    pl = plotter_factory((40, 40))
    with pytest.warns(cm.VolumeDataWarning, match=r"constant \(every value is 7\).*clim="):
        cm.add_volume(pl, np.full((4, 4, 4), 7.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error", cm.VolumeDataWarning)
        cm.add_volume(pl, np.full((4, 4, 4), 7.0), clim=(0, 10), name="placed")
        cm.add_volume(pl, np.arange(64.0).reshape(4, 4, 4), name="ramp")


def test_a_file_path_is_read_as_pyvista_reads_it(plotter_factory, tmp_path, monkeypatch):
    # add_surface read a path; add_volume and add_voxels said "Unable to wrap str" (found
    # by a review). A path is read by pyvista.read: the same image as the dataset given;
    # a missing file is named. catches (seen failing): the path passed on unread.
    grid = pv.ImageData(dimensions=(12, 10, 8), spacing=(1.0, 1.5, 2.0), origin=(5, -3, 1))
    grid.point_data["v"] = np.linspace(0.0, 1.0, grid.n_points)
    grid.cell_data["labels"] = (np.arange(grid.n_cells) % 3).astype(np.uint8)
    grid.save(tmp_path / "g.vti")
    for add, keywords in ((cm.add_volume, dict(scalars="v")),
                          (cm.add_voxels, dict(scalars="labels"))):
        images = []
        monkeypatch.setenv("HOME", str(tmp_path))   # "~/g.vti" as pyvista.read takes it
        for data in (grid, str(tmp_path / "g.vti"), "~/g.vti"):
            pl = plotter_factory((64, 48))
            add(pl, data, **keywords)
            pl.camera_position = "iso"
            images.append(cm.render_image(pl))
        assert images[0].std() > 1, add.__name__
        assert all(np.array_equal(images[0], image) for image in images[1:]), add.__name__
        with pytest.raises(FileNotFoundError, match="nope.vti' does not exist"):
            add(pl, tmp_path / "nope.vti")


@pytest.mark.parametrize("background", [float("nan"), 2.5, "0", True])
def test_a_background_that_is_no_integer_id_is_refused_by_name(plotter_factory,
                                                               background, tmp_path):
    # catches (seen failing; found by a review): "cannot convert float NaN to integer"
    # (no keyword named) for a grid, and for a streamed pyramid
    labels = np.zeros((6, 6, 6), np.uint8)
    labels[2:4, 2:4, 2:4] = 1
    pl = plotter_factory((32, 24))
    for data in (labels, [labels]):
        with pytest.raises(cm.VolumeDataError, match="background=.*integer label id"):
            cm.add_voxels(pl, data, background=background)


def test_independent_components_on_a_numpy_volume_is_refused_by_name():
    # catches (seen failing; found by a docs review): the flag ignored in silence, the
    # (x, y, z, 4) uint8 array drawn as RGBA
    pl = pv.Plotter(off_screen=True, window_size=(32, 24))
    with pytest.raises(cm.VolumeDataError, match="independent_components=True.*ImageData"):
        cm.add_volume(pl, np.zeros((4, 4, 4, 4), np.uint8), independent_components=True)
    pl.close()


def test_a_cluster_without_distributed_says_which_extra_to_install(monkeypatch):
    # catches (seen failing; found by a docs review): a bare ModuleNotFoundError
    from pv_cubemarch.cluster.frames import local_client

    monkeypatch.setitem(sys.modules, "distributed", None)   # import raises ImportError
    with pytest.raises(ImportError, match=r"pv_cubemarch\[cluster\]"):
        with local_client(None, 1):
            pass


def test_float16_labels_are_read_without_a_numpy_warning():
    # catches (seen failing, found by a review): the 2**53 bound compared in float16,
    # where it overflows ("overflow encountered in cast").
    labels = np.zeros((4, 4, 4), np.float16)
    labels[1:3, 1:3, 1:3] = 2
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model = cm.make_voxels(labels)
    assert set(np.unique(model.labels).tolist()) == {0, 2}


def test_a_numpy_file_s_path_is_its_array_for_every_add(plotter_factory, tmp_path):
    # Found by a review: add_volume(pl, "v.npy") said "could not be read (VTK: 'v.npy')"
    # (pyvista.read reads no .npy), though the CLI renders one. Each add reads the array
    # as given in memory; a pickle is refused unread. catches (seen failing): the path
    # handed to pyvista.read (add_volume and add_voxels), or to make_field's (add_surface).
    values = np.random.default_rng(2).random((6, 5, 4))
    np.save(tmp_path / "v.npy", values)
    np.savez(tmp_path / "l.npz", labels=(values > 0.5).astype(np.uint8))
    volume = cm.add_volume(plotter_factory(), str(tmp_path / "v.npy")).cubemarch.model
    assert np.allclose(volume.values, cm.add_volume(plotter_factory(), values)
                       .cubemarch.model.values)
    labels = cm.add_voxels(plotter_factory(), tmp_path / "l.npz").cubemarch.model.labels
    assert np.array_equal(labels > 0, values > 0.5)
    field = cm.add_surface(plotter_factory(), str(tmp_path / "v.npy"), isovalue=0.5)
    assert np.allclose(field.cubemarch.model.coefficients,
                       cm.make_field(values, 0.5).coefficients)
    (tmp_path / "a.zip").write_bytes(b"PK")   # was "could not be read (VTK: 'a.zip')"
    with pytest.raises(cm.VolumeDataError, match="a .zip is read by no reader.*zipped zarr"):
        cm.add_volume(plotter_factory(), str(tmp_path / "a.zip"))
    (tmp_path / "a.what").write_bytes(b"?")
    with pytest.raises(cm.VolumeDataError, match="pyvista.read has no reader for '.what'"):
        cm.add_voxels(plotter_factory(), str(tmp_path / "a.what"))
    np.save(tmp_path / "p.npy", np.array([{"a": 1}], dtype=object))
    with pytest.raises(cm.VolumeDataError, match="could not read .*Python objects"):
        cm.add_volume(plotter_factory(), str(tmp_path / "p.npy"))
