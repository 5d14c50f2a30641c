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


def _placed_boxes(tmp_path, box, offsets, name="boxes.glb"):
    """A glTF scene placing ``box`` at each of ``offsets`` (x), one node each."""
    scene = trimesh.Scene()
    for i, x in enumerate(offsets):
        scene.add_geometry(box, node_name=f"n{i}",
                           transform=trimesh.transformations.translation_matrix((x, 0, 0)))
    scene.export(tmp_path / name)
    return tmp_path / name


def test_a_scene_graph_placing_too_many_copies_is_refused_before_they_are_made(
        tmp_path, box, monkeypatch):
    # glTF nodes each place a copy of a mesh (found by a review: a 660 KB file of 6,000
    # nodes over one 20,000-triangle mesh made 5.7 GB of copies). The placements are
    # counted and their bytes weighed against the memory budget before any copy. catches
    # (seen failing): the check left out (five boxes loaded under either limit).
    from pv_cubemarch.scene import meshes

    path = _placed_boxes(tmp_path, box, [0, 2, 4, 6, 8])
    assert len(cm.load_scene(path).meshes) == 5
    monkeypatch.setattr(meshes, "MAX_PLACED_MESHES", 4)
    with pytest.raises(cm.SceneLoadError, match="places 5 meshes, more than the 4"):
        cm.load_scene(path)
    monkeypatch.undo()
    monkeypatch.setenv("PV_CUBEMARCH_ARRAY_MAX_BYTES", "2000")
    with pytest.raises(cm.SceneLoadError, match="its 5 placed meshes would take"):
        cm.load_scene(path)


def test_a_mesh_placed_past_what_gl_draws_is_said_and_the_rest_drawn(tmp_path, box):
    # A node at 1e17 blanked the whole frame (USD's prims past 1e16 were already said).
    # catches (seen failing): no reach check for mesh files (both nodes loaded).
    path = _placed_boxes(tmp_path, box, [0.0, 1e17])
    with pytest.warns(cm.SceneWarning, match="reaches 1e\\+17 world units"):
        scene = cm.load_scene(path)
    assert [m.name for m in scene.meshes] == ["n0"]
    assert [k.path for k in scene.skipped if k.problem] == ["n1"]
    with pytest.raises(cm.SceneLoadError, match="no triangle meshes that can be drawn"), \
            pytest.warns(cm.SceneWarning):
        cm.load_scene(_placed_boxes(tmp_path, box, [1e17], name="far.glb"))
