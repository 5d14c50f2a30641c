"""Mesh and scene files through trimesh."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pv_cubemarch as cm


@pytest.fixture
def box():
    mesh = trimesh.creation.box(extents=(1, 2, 3))
    mesh.visual.face_colors = [200, 100, 50, 255]
    return mesh


@pytest.mark.parametrize("suffix", [".obj", ".stl", ".ply", ".off", ".glb"])
def test_formats_load_with_geometry(tmp_path, box, suffix):
    path = tmp_path / f"box{suffix}"
    box.export(path)
    scene = cm.load_scene(path)
    assert len(scene.meshes) == 1
    assert np.allclose(scene.meshes[0].mesh.bounds, [-0.5, 0.5, -1, 1, -1.5, 1.5], atol=1e-5)
    assert scene.meshes[0].mesh.n_cells == 12


def test_gltf_scene_graph_transforms_and_colors(tmp_path, box):
    scene = trimesh.Scene()
    scene.add_geometry(box, node_name="a", transform=trimesh.transformations.translation_matrix(
        (5, 0, 0)))
    scene.add_geometry(box, node_name="b", transform=trimesh.transformations.translation_matrix(
        (0, 0, -7)))
    scene.export(tmp_path / "two.glb")
    loaded = cm.load_scene(tmp_path / "two.glb")
    centers = sorted(tuple(np.round(m.mesh.center, 6)) for m in loaded.meshes)
    assert centers == [(0.0, 0.0, -7.0), (5.0, 0.0, 0.0)]
    color = loaded.meshes[0].color
    assert np.allclose(color, (200 / 255, 100 / 255, 50 / 255), atol=0.02)
    image = loaded.render(size=(24, 24))
    assert image.std() > 0


def test_missing_and_corrupt_mesh_files(tmp_path):
    with pytest.raises(cm.SceneLoadError, match="does not exist"):
        cm.load_scene(tmp_path / "none.obj")
    (tmp_path / "bad.glb").write_bytes(b"garbage")
    with pytest.raises(cm.SceneLoadError, match="could not be read"):
        cm.load_scene(tmp_path / "bad.glb")
    (tmp_path / "empty.obj").write_text("# nothing\n")
    with pytest.raises(cm.SceneLoadError):
        cm.load_scene(tmp_path / "empty.obj")
