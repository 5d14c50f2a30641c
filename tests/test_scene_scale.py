"""Scenes of many prims: parts that draw alike become one actor, drawn as each alone is.

PyVista adds a named actor after looking its name up among all actors, so a stage of
20 000 prims added one actor each took minutes (quadratic); merged by how they draw, it is
a few actors. The oracle is the per-part path (each part its own ``add_mesh``, as PyVista
draws it), on the same scene and camera: the images must be the same pixels.
"""

from __future__ import annotations

import numpy as np
from pxr import Gf, Usd, UsdGeom

import pv_cubemarch as cm
from pv_cubemarch.scene import mesh_batches, model

SIZE = (160, 120)


def cube_stage(tmp_path, count: int, colors, opacity=None):
    stage = Usd.Stage.CreateNew(str(tmp_path / "cubes.usda"))
    UsdGeom.Xform.Define(stage, "/World")
    side = int(np.ceil(count ** (1 / 3)))
    for i in range(count):
        cube = UsdGeom.Cube.Define(stage, f"/World/C{i}")
        cube.CreateSizeAttr(0.6)
        cube.CreateDisplayColorAttr([colors[i % len(colors)]])
        if opacity is not None and i % 2:
            cube.CreateDisplayOpacityAttr([opacity])
        cube.AddTranslateOp().Set(Gf.Vec3d(i % side, (i // side) % side, i // side ** 2))
    stage.GetRootLayer().Save()
    return tmp_path / "cubes.usda"


def _render(scene, monkeypatch=None, alone=False):
    if alone:
        monkeypatch.setattr(model, "batched", lambda parts: [(p, [p.name]) for p in parts])
    plotter = cm.offscreen_plotter(SIZE)
    try:
        actors = scene.add_to(plotter, progress_bar=False)
        return actors, cm.render_image(plotter).astype(int)
    finally:
        plotter.close()


def test_parts_that_draw_alike_are_one_actor_drawn_as_each_alone(tmp_path, monkeypatch):
    # catches: one actor per prim again (the quadratic add), merged parts drawn otherwise
    # (normals, culling, colour lost in the merge), a part's name missing from the actors
    scene = cm.load_scene(cube_stage(tmp_path, 64, [(0.9, 0.2, 0.1), (0.1, 0.3, 0.9)]),
                          progress_bar=False)
    actors, merged = _render(scene)
    assert len(actors) == 64 and len({id(a) for a in actors.values()}) == 2
    _, alone = _render(scene, monkeypatch, alone=True)
    assert merged.std() > 10                                   # cubes, not background
    assert np.abs(merged - alone).max() <= 1


def test_a_merged_mesh_says_which_part_each_cell_came_from(tmp_path):
    scene = cm.load_scene(cube_stage(tmp_path, 5, [(1, 0, 0)]), progress_bar=False)
    [(part, names)] = mesh_batches.batched(scene.meshes)
    assert names == [m.name for m in scene.meshes]
    index = np.asarray(part.mesh.cell_data[mesh_batches.PART_INDEX])
    assert np.array_equal(np.bincount(index), [m.mesh.n_cells for m in scene.meshes])
    assert part.mesh.cell_data.active_scalars_name != mesh_batches.PART_INDEX


def test_translucent_parts_stay_apart(tmp_path):
    # catches: translucent parts merged (their drawing order would change)
    scene = cm.load_scene(cube_stage(tmp_path, 6, [(1, 0, 0)], opacity=0.5),
                          progress_bar=False)
    batches = mesh_batches.batched(scene.meshes)
    assert sorted(len(names) for _, names in batches) == [1, 1, 1, 3]


def test_shared_primitive_meshes_never_reach_a_part(tmp_path):
    # catches: the cached cube handed on as a part's mesh (an edit of one scene's cube
    # would change every later scene's), at the origin (no transform) or moved
    stage = Usd.Stage.CreateNew(str(tmp_path / "two.usda"))
    UsdGeom.Cube.Define(stage, "/Here").CreateSizeAttr(1.0)
    moved = UsdGeom.Cube.Define(stage, "/There")
    moved.CreateSizeAttr(1.0)
    moved.AddTranslateOp().Set(Gf.Vec3d(5, 0, 0))
    stage.GetRootLayer().Save()
    first = cm.load_scene(tmp_path / "two.usda", progress_bar=False)
    for part in first.meshes:
        part.mesh.points[:] = 0.0                 # a user edits the scene's meshes
    again = cm.load_scene(tmp_path / "two.usda", progress_bar=False)
    bounds = {m.name: np.round(m.mesh.bounds, 6).tolist() for m in again.meshes}
    assert bounds["/Here"] == [-0.5, 0.5, -0.5, 0.5, -0.5, 0.5]
    assert bounds["/There"] == [4.5, 5.5, -0.5, 0.5, -0.5, 0.5]
