"""The transfer keywords, declared once, reach the volume from every channel.

``cmap``, ``opacity``, ``clim``, ``opacity_unit_distance``, ``n_colors``, ``flip_scalars``,
``log_scale`` and ``categories`` are declared with the other volume options
(``pv_cubemarch.volume.options``); Python, the CLI flags, the USD attributes and the live
view's knobs are made from the declarations. Given with a volume already made, they change
its transfer function (they were ignored before).

Measured (160x120, llvmpipe): a made wavelet given five transfer keywords against PyVista's
``add_volume`` with the same: 53.1 dB (the made volume's own drawing: 13.0 dB).
"""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv
from pxr import Sdf, Usd, UsdVol

import pv_cubemarch as cm
from pv_cubemarch.cli import main
from pv_cubemarch.views.session import TuningSession

SIZE = (160, 120)
KEYWORDS = dict(cmap="coolwarm", clim=(60.0, 250.0), n_colors=16, flip_scalars=True,
                opacity="sigmoid")


def psnr(image, reference) -> float:
    diff = (np.asarray(image, np.float64) - np.asarray(reference, np.float64)) / 255.0
    return float(10 * np.log10(1.0 / max(np.mean(diff**2), 1e-12)))


def drawn(add):
    pl = pv.Plotter(off_screen=True, window_size=SIZE)
    pl.set_background("black")
    add(pl)
    pl.camera_position = "iso"
    pl.reset_camera(bounds=pv.Wavelet().bounds)
    image = cm.render_image(pl)
    pl.close()
    return image


def test_transfer_keywords_change_a_made_volume_as_pyvista_draws_them():
    """``add_volume(model, cmap=..., clim=..., n_colors=..., flip_scalars=..., opacity=...)``
    on a volume made with defaults: PyVista's image of the data with those keywords.

    catches (seen failing): the keywords ignored for a made volume (``with_transfer`` not
    called in ``add_volume``): 13.3 dB.
    """
    grid = pv.Wavelet()

    def theirs(pl):
        vol = pl.add_volume(grid, show_scalar_bar=False, **KEYWORDS)
        vol.prop.interpolation_type = "linear"
        vol.mapper.SetAutoAdjustSampleDistances(False)
        vol.mapper.SetSampleDistance(0.1)

    reference = drawn(theirs)
    made = cm.make_volume(grid)
    own = drawn(lambda pl: pl.cubemarch.add_volume(made, step_scale=0.1))
    image = drawn(lambda pl: pl.cubemarch.add_volume(made, step_scale=0.1, **KEYWORDS))
    assert psnr(own, reference) < 40.0
    assert psnr(image, reference) >= 45.0
    assert made.transfer.spec.cmap != "coolwarm"   # the made volume itself is left as it was


def test_a_table_given_as_is_cannot_take_transfer_keywords():
    table = cm.TransferFunction(table=np.ones((4, 4), np.float32), clim=(0.0, 1.0))
    model = cm.make_volume(np.random.default_rng(0).random((4, 4, 4)), transfer=table)
    pl = pv.Plotter(off_screen=True)
    with pytest.raises(cm.VolumeDataError, match="given as is"):
        pl.cubemarch.add_volume(model, cmap="jet")
    pl.close()


def write_stage(tmp_path, attributes):
    np.save(tmp_path / "d.npy", np.linspace(0, 255, 6**3).reshape(6, 6, 6))
    stage = Usd.Stage.CreateNew(str(tmp_path / "vol.usda"))
    volume = UsdVol.Volume.Define(stage, "/Vol")
    field = stage.DefinePrim("/Vol/density")
    field.CreateAttribute("filePath", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath("./d.npy"))
    volume.CreateFieldRelationship("density", field.GetPath())
    for key, (kind, value) in attributes.items():
        volume.GetPrim().CreateAttribute(f"cubemarch:{key}", kind).Set(value)
    stage.GetRootLayer().Save()
    return tmp_path / "vol.usda"


def test_usd_attributes_reach_the_transfer_function(tmp_path):
    """Every transfer attribute authored on a Volume prim is in its transfer function; one of
    the wrong kind skips the prim, saying which.

    catches: an attribute left out of the declarations' table (``nColors`` unread: 256).
    """
    types = Sdf.ValueTypeNames
    path = write_stage(tmp_path, {"cmap": (types.String, "jet"), "nColors": (types.Int, 12),
                                  "flipScalars": (types.Bool, True),
                                  "logScale": (types.Bool, True),
                                  "clim": (types.Float2, (10.0, 200.0)),
                                  "opacityUnitDistance": (types.Float, 2.5)})
    spec = cm.load_scene(path).volumes[0].transfer.spec
    assert (spec.cmap, spec.n_colors, spec.flip_scalars, spec.log_scale) == ("jet", 12, True,
                                                                              True)
    assert spec.data_clim == pytest.approx((10.0, 200.0)) and spec.opacity_unit_distance == 2.5
    path = write_stage(tmp_path, {"nColors": (types.Int, 0)})
    with pytest.warns(cm.SceneWarning, match="nColors"):
        assert cm.load_scene(path).volumes == []


def test_cli_flags_reach_the_transfer_function(tmp_path):
    """``--cmap --clim --n-colors --flip-scalars --opacity`` draw what the same keywords draw
    on the loaded scene (and not its default).

    catches: a flag parsed but not put in the volume's options (``_volume_options`` keeping
    only technique options): the image is the default.
    """
    path = write_stage(tmp_path, {})
    out, plain = tmp_path / "flags.png", tmp_path / "plain.png"
    flags = ["--cmap", "coolwarm", "--clim", "60", "250", "--n-colors", "16",
             "--flip-scalars", "--opacity", "0.3"]
    common = ["--size", "64x48", "--no-progress", "--technique", "direct"]
    assert main(["render", str(path), "-o", str(out), *common, *flags]) == 0
    assert main(["render", str(path), "-o", str(plain), *common]) == 0
    scene = cm.load_scene(path)
    scene.volume_options[scene.volumes[0].name] = dict(
        technique="direct", cmap="coolwarm", clim=(60.0, 250.0), n_colors=16,
        flip_scalars=True, opacity=0.3)
    expected = scene.render(size=(64, 48)).astype(int)
    from PIL import Image
    got = np.asarray(Image.open(out).convert("RGB")).astype(int)
    default = np.asarray(Image.open(plain).convert("RGB")).astype(int)
    assert np.abs(got - expected).max() <= 2
    assert np.abs(got - default).mean() > 5.0
    # one number, as Python's clim=c: -c..c
    out = tmp_path / "symmetric.png"
    assert main(["render", str(path), "-o", str(out), *common, "--clim", "250"]) == 0
    scene = cm.load_scene(path)
    scene.volume_options[scene.volumes[0].name] = dict(technique="direct", clim=250.0)
    expected = scene.render(size=(64, 48)).astype(int)
    got = np.asarray(Image.open(out).convert("RGB")).astype(int)
    assert np.abs(got - expected).max() <= 2 and np.abs(got - default).mean() > 2.0
    assert main(["render", str(path), "-o", str(out), *common, "--clim", "1", "2", "3"]) != 0


def test_live_view_knobs_reach_the_transfer_function(plotter_factory, tmp_path):
    """The colormap select and the flip switch of the live view redraw the volume with them.

    catches: a knob of a model option handed to add_volume and ignored there (the frame
    unchanged).
    """
    session = TuningSession(cm.load_scene(write_stage(tmp_path, {})), plotter_factory(SIZE))
    before = cm.render_image(session.plotter).astype(int)
    session.set("volume", "cmap", "coolwarm")
    session.set("volume", "flip_scalars", True)
    after = cm.render_image(session.plotter).astype(int)
    binding = next(item.binding for item in session.items.values() if item.kind == "volume")
    spec = binding.model.transfer.spec
    assert (spec.cmap, spec.flip_scalars) == ("coolwarm", True)
    assert np.abs(after - before).mean() > 3.0
