"""Surfaces from USD stages and the command line: placed as the stage says, drawn as the
reference draws their field, options checked when the stage is loaded."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import write_voxel_stage

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
    ({"cubemarch:steps": ("String", "many")}, "cubemarch:steps must be a whole number"),
])
def test_bad_surface_prims_are_named(tmp_path, attrs, message):
    with pytest.raises(SceneLoadError, match=message):
        cm.load_scene(surface_stage(tmp_path, attrs))


def test_a_surface_prim_needs_its_isovalue(tmp_path):
    path = write_voxel_stage(tmp_path, ball_samples(), technique="surface",
                             stage_name="no_iso.usda")
    with pytest.raises(SceneLoadError, match="needs cubemarch:isovalue"):
        cm.load_scene(path)


def test_cli_renders_a_surface_stage(tmp_path, capsys):
    out = tmp_path / "ball.png"
    assert main(["render", str(surface_stage(tmp_path)), "--out", str(out),
                 "--size", "64x48"]) == 0
    assert out.exists() and out.stat().st_size > 0
    assert main(["info", str(surface_stage(tmp_path, name="again.usda"))]) == 0
    assert "surfaces: 1" in capsys.readouterr().out
