"""The command line and PyVista's entry points."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import SCENE
from PIL import Image

from pv_cubemarch.cli import main


def test_render_command_writes_png(tmp_path, capsys):
    out = tmp_path / "out.png"
    assert main(["render", str(SCENE), "--out", str(out), "--size", "64x48", "--no-progress"]) == 0
    image = np.asarray(Image.open(out))
    assert image.shape[:2] == (48, 64)
    assert image.std() > 5
    assert "wrote" in capsys.readouterr().out


def test_render_with_step_scale_and_camera(tmp_path):
    out = tmp_path / "o.png"
    assert main(["render", str(SCENE), "-o", str(out), "--size", "32x24", "--step-scale", "1.0",
                 "--camera", "/World/Camera", "--no-progress"]) == 0
    assert out.exists()


def test_info_lists_skipped_prims(capsys):
    assert main(["info", str(SCENE)]) == 0
    out = capsys.readouterr().out
    assert "/World/BoundsGuide: purpose is guide" in out and "/World/Smoke" in out


def test_info_gl_json(capsys):
    assert main(["info", "--gl", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["gl"]["window_class"].endswith("RenderWindow")


def test_errors_exit_2_with_message(tmp_path, capsys):
    assert main(["render", str(tmp_path / "missing.usda"), "--out", str(tmp_path / "x.png")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["render", str(SCENE), "--out", str(tmp_path / "x.png"), "--camera", "/Nope",
                 "--no-progress"]) == 2
    assert "/Nope" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["render", str(SCENE), "--out", "x.png", "--size", "big"])
    assert main(["info"]) == 2


def test_plotter_component_via_entry_point_in_fresh_process():
    code = ("import pyvista as pv; import numpy as np; pl = pv.Plotter(off_screen=True); "
            "a = pl.cubemarch.add_volume(np.random.rand(8, 8, 8)); "
            "print(type(pl.cubemarch).__name__, pl.cubemarch.screenshot().shape)")
    env = dict(os.environ, VTK_DEFAULT_OPENGL_WINDOW="vtkEGLRenderWindow")
    env.pop("DISPLAY", None)
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            env=env, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split()[0] == "CubemarchComponent"


def test_pyvista_read_usd_in_fresh_process():
    code = f"import pyvista as pv; print(sorted(pv.read({str(SCENE)!r}).keys()))"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr
    assert "/World/Torus" in result.stdout


@pytest.mark.parametrize("arguments, expected", [
    (["--technique", "direct", "--stop-opacity", "0.95", "--no-skip-empty", "--downsample",
      "2"],
     {"technique": "direct", "stop_opacity": 0.95, "skip_empty": False, "downsample": 2}),
    (["--technique", "cubemap", "--face-size", "64", "--max-samples", "50", "--upscale", "2",
      "--sample-factor", "1.5", "--occlusion-sharpness", "0.25", "--lights", "scene",
      "--light-map-size", "16", "--ambient", "0.3"],
     {"technique": "cubemap", "face_size": 64, "max_samples": 50, "upscale": 2.0,
      "sample_factor": 1.5, "occlusion_sharpness": 0.25, "lights": "scene",
      "light_map_size": 16, "ambient": 0.3}),
    (["--technique", "auto", "--lights", "none"], {"technique": "auto", "lights": None}),
], ids=["direct", "cubemap", "auto"])
def test_render_options_reach_every_volume(tmp_path, monkeypatch, arguments, expected):
    import pv_cubemarch.api as ea

    seen = []
    real = ea.add_volume

    def spy(plotter, volume, scalars=None, **kwargs):
        seen.append(kwargs)
        return real(plotter, volume, scalars, **kwargs)

    monkeypatch.setattr(ea, "add_volume", spy)
    out = tmp_path / "d.png"
    assert main(["render", str(SCENE), "-o", str(out), "--size", "40x30", *arguments,
                 "--no-progress"]) == 0
    assert seen == [expected]
    assert out.stat().st_size > 500


def test_usd_volume_options(tmp_path):
    from pxr import Sdf, Usd

    import pv_cubemarch as cm

    stage = Usd.Stage.Open(str(SCENE))
    prim = stage.GetPrimAtPath("/World/Smoke")
    prim.CreateAttribute("cubemarch:technique", Sdf.ValueTypeNames.String).Set("direct")
    prim.CreateAttribute("cubemarch:stepScale", Sdf.ValueTypeNames.Float).Set(0.25)
    prim.CreateAttribute("cubemarch:skipEmpty", Sdf.ValueTypeNames.Bool).Set(False)
    prim.CreateAttribute("cubemarch:downsample", Sdf.ValueTypeNames.Int).Set(2)
    path = tmp_path / "scene.usda"
    stage.GetRootLayer().Export(str(path))
    (tmp_path / "smoke_density.vti").write_bytes((SCENE.parent / "smoke_density.vti").read_bytes())
    scene = cm.load_scene(path)
    assert scene.volume_options["/World/Smoke"] == {"technique": "direct", "step_scale": 0.25,
                                                    "skip_empty": False, "downsample": 2}
    assert scene.render(size=(40, 30)).std() > 3


def test_usd_cubemap_options(tmp_path):
    from pxr import Sdf, Usd

    import pv_cubemarch as cm

    stage = Usd.Stage.Open(str(SCENE))
    prim = stage.GetPrimAtPath("/World/Smoke")
    values = {"technique": ("String", "cubemap"), "faceSize": ("Int", 128),
              "maxSamples": ("Int", 60), "upscale": ("Float", 2.0),
              "sampleFactor": ("Float", 1.5), "occlusionSharpness": ("Float", 0.25),
              "lights": ("String", "scene"), "lightMapSize": ("Int", 16),
              "ambient": ("Float", 0.5)}
    for key, (kind, value) in values.items():
        prim.CreateAttribute(f"cubemarch:{key}", getattr(Sdf.ValueTypeNames, kind)).Set(value)
    path = tmp_path / "scene.usda"
    stage.GetRootLayer().Export(str(path))
    (tmp_path / "smoke_density.vti").write_bytes((SCENE.parent / "smoke_density.vti").read_bytes())
    scene = cm.load_scene(path)
    assert scene.volume_options["/World/Smoke"] == {
        "technique": "cubemap", "face_size": 128, "max_samples": 60, "upscale": 2.0,
        "sample_factor": 1.5, "occlusion_sharpness": 0.25, "lights": "scene",
        "light_map_size": 16, "ambient": 0.5}
    pl = cm.offscreen_plotter((64, 48))
    try:
        actor = scene.add_to(pl)["/World/Smoke"]
        image = cm.render_image(pl)
        assert actor.cubemarch.light_map is not None  # lit by the stage's lights
        assert actor.cubemarch.lod.level_size <= 128
        assert image.std() > 3
    finally:
        pl.close()
