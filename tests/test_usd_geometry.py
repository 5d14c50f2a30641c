"""USD geometry: primvars and normals of every interpolation, subsets, instancers, points,
curves, time samples, and malformed prims reported while the rest of the stage loads.

Expected values are written out by hand from the authored arrays.
"""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt

import pv_cubemarch as cm

#: Two unit quads side by side: 6 points, 2 faces, 8 corners.
POINTS = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2, 1, 0)]
COUNTS = [4, 4]
INDICES = [0, 1, 2, 3, 1, 4, 5, 2]


def two_quads(stage, path="/M", scheme="none"):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(POINTS)
    mesh.CreateFaceVertexCountsAttr(COUNTS)
    mesh.CreateFaceVertexIndicesAttr(INDICES)
    mesh.CreateSubdivisionSchemeAttr(scheme)
    return mesh


def new_stage(tmp_path, name="s.usda"):
    return Usd.Stage.CreateNew(str(tmp_path / name))


def load(stage, **kwargs):
    stage.GetRootLayer().Save()
    return cm.load_scene(stage.GetRootLayer().realPath, **kwargs)


@pytest.mark.parametrize("interpolation, values, where, expected", [
    ("constant", [(0.1, 0.2, 0.3)], "color", (0.1, 0.2, 0.3)),
    ("uniform", [(1, 0, 0), (0, 1, 0)], "cell", [(1, 0, 0), (0, 1, 0)]),
    ("vertex", [(i / 10, 0, 0) for i in range(6)], "point", [(i / 10, 0, 0) for i in range(6)]),
    ("varying", [(i / 10, 0, 0) for i in range(6)], "point", [(i / 10, 0, 0) for i in range(6)]),
    # faceVarying: one point per corner, in corner order
    ("faceVarying", [(c / 10, 1, 0) for c in range(8)], "point",
     [(c / 10, 1, 0) for c in range(8)]),
])
def test_display_color_in_every_interpolation(tmp_path, interpolation, values, where, expected):
    stage = new_stage(tmp_path)
    mesh = two_quads(stage)
    mesh.CreateDisplayColorPrimvar(interpolation).Set(values)
    part = load(stage).meshes[0]
    if where == "color":
        assert part.color == pytest.approx(expected) and part.vertex_colors is None
        return
    data = part.mesh.cell_data if where == "cell" else part.mesh.point_data
    assert part.vertex_colors == "displayColor"
    assert np.allclose(data["displayColor"], expected)
    assert part.mesh.n_points == (8 if interpolation == "faceVarying" else 6)
    if interpolation == "faceVarying":   # unwelded: corner c sits on point INDICES[c]
        assert np.allclose(part.mesh.points, np.asarray(POINTS)[INDICES])


def test_indexed_primvar_is_flattened(tmp_path):
    stage = new_stage(tmp_path)
    mesh = two_quads(stage)
    primvar = mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.uniform)
    primvar.Set([(1, 0, 0), (0, 0, 1)])
    primvar.SetIndices(Vt.IntArray([1, 0]))
    part = load(stage).meshes[0]
    assert np.allclose(part.mesh.cell_data["displayColor"], [(0, 0, 1), (1, 0, 0)])


@pytest.mark.parametrize("interpolation, values, expected", [
    ("constant", [(0, 0, 2)], [(0, 0, 1)] * 6),
    ("vertex", [(0, 0, 1)] * 3 + [(1, 0, 0)] * 3, [(0, 0, 1)] * 3 + [(1, 0, 0)] * 3),
    ("uniform", [(0, 0, 1), (0, 1, 0)], [(0, 0, 1)] * 4 + [(0, 1, 0)] * 4),
    ("faceVarying", [(0, 0, 1)] * 4 + [(0, 0, -1)] * 4, [(0, 0, 1)] * 4 + [(0, 0, -1)] * 4),
])
def test_normals_in_every_interpolation(tmp_path, interpolation, values, expected):
    # catches: the usd-wg schema test's `len()` of an int (normals interpolations other than
    # vertex and faceVarying), and uniform normals smeared over shared points.
    stage = new_stage(tmp_path)
    mesh = two_quads(stage)
    mesh.CreateNormalsAttr(values)
    mesh.SetNormalsInterpolation(interpolation)
    part = load(stage).meshes[0]
    assert part.shading == "normals"
    assert np.allclose(part.mesh.point_data["Normals"], expected)


def test_primvar_normals_override_the_attribute(tmp_path):
    stage = new_stage(tmp_path)
    mesh = two_quads(stage)
    mesh.CreateNormalsAttr([(0, 0, 1)] * 6)
    primvar = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("normals", Sdf.ValueTypeNames.Normal3fArray,
                                                      UsdGeom.Tokens.constant)
    primvar.Set([(1, 0, 0)])
    assert np.allclose(load(stage).meshes[0].mesh.point_data["Normals"], (1, 0, 0))


def test_normals_without_authoring_follow_the_subdivision_scheme(tmp_path):
    stage = new_stage(tmp_path)
    two_quads(stage, "/Flat", scheme="none")
    two_quads(stage, "/Smooth", scheme="catmullClark")
    parts = {m.name: m for m in load(stage).meshes}
    assert parts["/Flat"].shading == "flat" and "Normals" not in parts["/Flat"].mesh.point_data
    assert parts["/Smooth"].shading == "smooth"
    assert np.allclose(parts["/Smooth"].mesh.point_data["Normals"], (0, 0, 1))


def cell_normal(part) -> np.ndarray:
    return np.asarray(part.mesh.compute_normals(cell_normals=True,
                                                point_normals=False).cell_data["Normals"][0])


def test_left_handed_and_mirrored_meshes_wind_the_other_way(tmp_path):
    # catches: orientation ignored (back faces culled on a left-handed mesh), and a mirroring
    # transform (negative scale) flipping the winding once more unnoticed.
    stage = new_stage(tmp_path)
    two_quads(stage, "/Right")
    two_quads(stage, "/Left").CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
    mirrored = two_quads(stage, "/Mirror")
    mirrored.AddScaleOp().Set(Gf.Vec3f(1, 1, -1))
    parts = {m.name: m for m in load(stage).meshes}
    assert np.allclose(cell_normal(parts["/Right"]), (0, 0, 1))
    assert np.allclose(cell_normal(parts["/Left"]), (0, 0, -1))
    # mirrored in z: the right-handed quad's front now faces -z, and so does its winding
    assert np.allclose(cell_normal(parts["/Mirror"]), (0, 0, -1))


def test_malformed_meshes_are_reported_and_the_rest_loads(tmp_path):
    stage = new_stage(tmp_path)
    two_quads(stage, "/Good")
    bad = two_quads(stage, "/BadIndices")
    bad.CreateFaceVertexIndicesAttr([0, 1, 2, 3, 1, 4, 5, 99])
    short = two_quads(stage, "/ShortCounts")
    short.CreateFaceVertexCountsAttr([4])
    wrong = two_quads(stage, "/WrongColors")
    wrong.CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex).Set([(1, 0, 0)] * 5)
    degenerate = two_quads(stage, "/Degenerate")
    degenerate.CreateFaceVertexCountsAttr([4, 2, 2])
    UsdGeom.Mesh.Define(stage, "/Empty")
    stage.DefinePrim("/WrongType", "Sphere")   # a wrong-typed attribute, as hand edits make
    spec = stage.GetRootLayer().GetPrimAtPath("/WrongType")
    Sdf.AttributeSpec(spec, "radius", Sdf.ValueTypeNames.String).default = "big"
    stage.GetRootLayer().Save()
    path = tmp_path / "s.usda"
    with pytest.warns(cm.SceneWarning):
        scene = cm.load_scene(path)
    names = {m.name for m in scene.meshes}
    assert {"/Good", "/WrongColors", "/Degenerate"} <= names
    assert not names & {"/BadIndices", "/ShortCounts", "/WrongType"}
    reasons = {s.path: s.reason for s in scene.skipped}
    assert "99" in reasons["/BadIndices"] and "6 points" in reasons["/BadIndices"]
    assert "sum to 4" in reasons["/ShortCounts"]
    assert "5 values" in reasons["/WrongColors.primvars:displayColor"]
    assert "radius" in reasons["/WrongType"]
    assert reasons["/Degenerate"].startswith("2 faces of fewer than 3")
    assert next(m for m in scene.meshes if m.name == "/Degenerate").mesh.n_cells == 1
    with pytest.raises(cm.SceneLoadError, match="99"):
        cm.load_scene(path, strict=True)


def bind_color(stage, prim, name, color):
    material = UsdShade.Material.Define(stage, f"/Looks/{name}")
    shader = UsdShade.Shader.Define(stage, f"/Looks/{name}/PS")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*color))
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(prim).Bind(material)
    return material


def test_geom_subsets_get_their_own_materials(tmp_path):
    stage = new_stage(tmp_path)
    mesh = two_quads(stage)
    bind_color(stage, mesh.GetPrim(), "Base", (0.5, 0.5, 0.5))
    subset = UsdShade.MaterialBindingAPI(mesh.GetPrim()).CreateMaterialBindSubset(
        "right", Vt.IntArray([1]))
    bind_color(stage, subset.GetPrim(), "Red", (1, 0, 0))
    parts = {m.name: m for m in load(stage).meshes}
    assert set(parts) == {"/M:right", "/M:rest"}     # named by subset: names never collide
    assert parts["/M:right"].mesh.n_cells == 1 and parts["/M:rest"].mesh.n_cells == 1
    assert parts["/M:right"].mesh.bounds[:2] == pytest.approx((1, 2))
    assert parts["/M:right"].material.diffuse_color == pytest.approx((1, 0, 0))
    assert parts["/M:rest"].material.diffuse_color == pytest.approx((0.5, 0.5, 0.5))


def test_point_instancer_places_each_visible_instance(tmp_path):
    stage = new_stage(tmp_path)
    instancer = UsdGeom.PointInstancer.Define(stage, "/Inst")
    cube = UsdGeom.Cube.Define(stage, "/Inst/Protos/Box")
    cube.CreateSizeAttr(1.0)
    sphere = UsdGeom.Sphere.Define(stage, "/Inst/Protos/Ball")
    sphere.CreateRadiusAttr(0.5)
    instancer.CreatePrototypesRel().SetTargets([cube.GetPath(), sphere.GetPath()])
    instancer.CreateProtoIndicesAttr([0, 0, 1, 0])
    instancer.CreatePositionsAttr([(0, 0, 0), (10, 0, 0), (0, 10, 0), (0, 0, 10)])
    instancer.CreateScalesAttr([(1, 1, 1), (2, 2, 2), (1, 1, 1), (1, 1, 1)])
    instancer.CreateOrientationsAttr([Gf.Quath(1, 0, 0, 0)] * 4)
    instancer.CreateInvisibleIdsAttr([3])
    UsdGeom.Xformable(instancer).AddTranslateOp().Set(Gf.Vec3d(100, 0, 0))
    parts = {m.name: m for m in load(stage).meshes}
    assert set(parts) == {"/Inst[/Inst/Protos/Box]", "/Inst[/Inst/Protos/Ball]"}
    boxes = parts["/Inst[/Inst/Protos/Box]"].mesh
    # two boxes: a unit one at x=100 and one scaled 2 at x=110; the invisible one is gone
    assert boxes.bounds == pytest.approx((99.5, 111, -1, 1, -1, 1))
    assert parts["/Inst[/Inst/Protos/Ball]"].mesh.center == pytest.approx((100, 10, 0),
                                                                           abs=1e-6)


def test_points_become_spheres_of_their_widths(tmp_path):
    stage = new_stage(tmp_path)
    points = UsdGeom.Points.Define(stage, "/P")
    points.CreatePointsAttr([(0, 0, 0), (5, 0, 0)])
    points.CreateWidthsAttr([1.0, 3.0])
    points.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    mesh = load(stage).meshes[0].mesh
    # widths are diameters (radius-as-width would be twice as wide); 0.15: sphere facets
    assert mesh.bounds == pytest.approx((-0.5, 6.5, -1.5, 1.5, -1.5, 1.5), abs=0.15)


def test_curves_become_tubes(tmp_path):
    stage = new_stage(tmp_path)
    linear = UsdGeom.BasisCurves.Define(stage, "/Lin")
    linear.CreateTypeAttr(UsdGeom.Tokens.linear)
    linear.CreatePointsAttr([(0, 0, 0), (4, 0, 0), (4, 4, 0)])
    linear.CreateCurveVertexCountsAttr([3])
    linear.CreateWidthsAttr([0.5])
    bezier = UsdGeom.BasisCurves.Define(stage, "/Bez")
    bezier.CreateTypeAttr(UsdGeom.Tokens.cubic)
    bezier.CreateBasisAttr(UsdGeom.Tokens.bezier)
    # a Bezier arc: control points (0,0), (0,3), (3,3), (3,0) peak at y = 0.75*3 = 2.25
    bezier.CreatePointsAttr([(0, 0, 10), (0, 3, 10), (3, 3, 10), (3, 0, 10)])
    bezier.CreateCurveVertexCountsAttr([4])
    bezier.CreateWidthsAttr([0.2])
    parts = {m.name: m.mesh for m in load(stage).meshes}
    # flat caps at the ends (0, 0) and (4, 4); the tube's side reaches 0.25 out at (4, 0)
    assert parts["/Lin"].bounds == pytest.approx((0, 4.25, -0.25, 4, -0.25, 0.25), abs=0.03)
    assert parts["/Bez"].bounds[3] == pytest.approx(2.25 + 0.1, abs=0.01)


def test_time_samples_default_to_the_start_and_follow_time(tmp_path):
    stage = new_stage(tmp_path)
    stage.SetStartTimeCode(10)
    stage.SetEndTimeCode(20)
    mesh = two_quads(stage)
    op = mesh.AddTranslateOp()
    op.Set(Gf.Vec3d(0, 0, 0), 10)
    op.Set(Gf.Vec3d(0, 0, 10), 20)
    stage.GetRootLayer().Save()
    path = stage.GetRootLayer().realPath
    assert cm.load_scene(path).time == 10
    assert cm.load_scene(path).meshes[0].mesh.bounds[4] == pytest.approx(0)
    assert cm.load_scene(path, time=15).meshes[0].mesh.bounds[4] == pytest.approx(5)
    with pytest.raises(cm.SceneLoadError, match="time applies to USD"):
        cm.load_scene(tmp_path / "x.vti", time=1)


def test_wrong_typed_points_and_normals_and_a_singular_transform(tmp_path):
    # From the usd-wg schema tests: normals and points authored as scalars (int, double)
    # raised TypeError/ValueError, and a transform of scale 0 a LinAlgError in the normals.
    stage = new_stage(tmp_path)
    two_quads(stage, "/Good")
    flat = two_quads(stage, "/Flattened")
    flat.CreateNormalsAttr([(0, 0, 1)] * 6)
    flat.AddScaleOp().Set(Gf.Vec3f(1, 1, 0))
    two_quads(stage, "/ScalarNormals")
    two_quads(stage, "/ScalarPoints")
    stage.GetRootLayer().Save()
    layer = stage.GetRootLayer()
    for path, name, kind, value in (("/ScalarNormals", "normals", Sdf.ValueTypeNames.Int, 3),
                                    ("/ScalarPoints", "points", Sdf.ValueTypeNames.Double, 1.5)):
        spec = layer.GetPrimAtPath(path)
        if name in spec.properties:
            spec.RemoveProperty(spec.properties[name])
        Sdf.AttributeSpec(spec, name, kind).default = value
    layer.Save()
    with pytest.warns(cm.SceneWarning):
        scene = cm.load_scene(tmp_path / "s.usda")
    parts = {m.name: m for m in scene.meshes}
    assert {"/Good", "/Flattened", "/ScalarNormals"} <= set(parts)
    assert parts["/ScalarNormals"].shading == "flat"      # not the scalar: scheme "none"
    # x and y survive the flattening: the normal stays along z (the cofactor of diag(1,1,0))
    assert np.allclose(parts["/Flattened"].mesh.point_data["Normals"], (0, 0, 1))
    reasons = {s.path: s.reason for s in scene.skipped}
    assert "3-vectors" in reasons["/ScalarNormals"] and "3-vectors" in reasons["/ScalarPoints"]


def test_hole_indices_leave_faces_out(tmp_path):
    stage = new_stage(tmp_path)
    two_quads(stage).CreateHoleIndicesAttr([0])
    mesh = load(stage).meshes[0].mesh
    assert mesh.n_cells == 1 and mesh.bounds[:2] == pytest.approx((1, 2))


def every_imageable_type() -> list[str]:
    """Every concrete prim type this usd-core knows that can be drawn or placed."""
    from pxr import Tf
    registry = Usd.SchemaRegistry()
    names = []
    for kind in Tf.Type.FindByName("UsdGeomImageable").GetAllDerivedTypes():
        name = registry.GetSchemaTypeName(kind)
        if name and registry.IsConcrete(kind):
            names.append(str(name))
    return sorted(names)


def test_every_prim_type_loads_and_renders_or_is_reported(tmp_path):
    # Each concrete UsdGeom/UsdLux/UsdVol/... type, defined with no attributes at all (their
    # fallbacks only), then with one attribute of the wrong type: the stage loads, renders,
    # and whatever is not drawn is in the report. Catches any reader raising on a fallback.
    names = every_imageable_type()
    assert {"Mesh", "PointInstancer", "BasisCurves", "NurbsPatch", "Cylinder_1"} <= set(names)
    stage = new_stage(tmp_path)
    for name in names:
        stage.DefinePrim(f"/Empty_{name}", name)
        prim = stage.DefinePrim(f"/Bad_{name}", name)
        Sdf.AttributeSpec(stage.GetRootLayer().GetPrimAtPath(prim.GetPath()), "points",
                          Sdf.ValueTypeNames.String).default = "nonsense"
    stage.GetRootLayer().Save()
    with pytest.warns(cm.SceneWarning):
        scene = cm.load_scene(tmp_path / "s.usda")
    image = scene.render(size=(48, 36))
    assert image.shape == (36, 48, 3)
    drawn = {m.name.split("/")[1] for m in scene.meshes}
    assert {"Empty_Sphere", "Empty_Cube", "Empty_Cylinder_1", "Empty_Plane"} <= drawn
    reasons = {s.path: s.reason for s in scene.skipped}
    assert "3-vectors" in reasons["/Bad_Mesh"]
    assert reasons["/Empty_NurbsPatch"] == "NURBS patches are not tessellated"


def test_cylinder_of_two_radii_and_oriented_instances(tmp_path):
    stage = new_stage(tmp_path)
    cone = stage.DefinePrim("/Frustum", "Cylinder_1")
    cone.CreateAttribute("radiusBottom", Sdf.ValueTypeNames.Double).Set(2.0)
    cone.CreateAttribute("radiusTop", Sdf.ValueTypeNames.Double).Set(0.5)
    cone.CreateAttribute("height", Sdf.ValueTypeNames.Double).Set(4.0)
    cone.CreateAttribute("axis", Sdf.ValueTypeNames.Token).Set("Z")
    instancer = UsdGeom.PointInstancer.Define(stage, "/Inst")
    bar = UsdGeom.Cube.Define(stage, "/Inst/Protos/Bar")
    bar.AddScaleOp().Set(Gf.Vec3f(2, 0.5, 0.5))        # size 2 scaled: a 4 x 1 x 1 bar along x
    instancer.CreatePrototypesRel().SetTargets([bar.GetPath()])
    instancer.CreateProtoIndicesAttr([0])
    instancer.CreatePositionsAttr([(0, 0, 20)])
    half = np.sqrt(0.5)                                  # 90 degrees about z: along y now
    instancer.CreateOrientationsAttr([Gf.Quath(half, 0, 0, half)])
    parts = {m.name: m.mesh for m in load(stage).meshes}
    frustum = parts["/Frustum"]
    bottom = frustum.points[frustum.points[:, 2] < -1.99]
    top = frustum.points[frustum.points[:, 2] > 1.99]
    assert np.linalg.norm(bottom[:, :2], axis=1).max() == pytest.approx(2.0, abs=1e-6)
    assert np.linalg.norm(top[:, :2], axis=1).max() == pytest.approx(0.5, abs=1e-6)
    # turned onto y, centred on (0, 0, 20); 1e-3: orientations are half floats
    assert parts["/Inst[/Inst/Protos/Bar]"].bounds == pytest.approx(
        (-0.5, 0.5, -2, 2, 19.5, 20.5), abs=1e-3)


def test_normals_turn_by_the_inverse_transpose_and_stay_active(tmp_path):
    # A face in the plane x + y = 0 (normal (1, 1, 0)/√2) scaled by 2 in x lies in
    # x/2 + y = 0: its normal is (1/2, 1, 0)/|.| = (0.447, 0.894, 0), not M·n (0.894, 0.447).
    stage = new_stage(tmp_path)
    mesh = UsdGeom.Mesh.Define(stage, "/Tilted")
    mesh.CreatePointsAttr([(1, -1, 0), (1, -1, 1), (-1, 1, 1), (-1, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateNormalsAttr([(np.sqrt(0.5), np.sqrt(0.5), 0)] * 4)
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    mesh.AddScaleOp().Set(Gf.Vec3f(2, 1, 1))
    part = load(stage).meshes[0]
    assert part.mesh.point_data.active_normals_name == "Normals"   # VTK draws with them
    assert np.allclose(part.mesh.point_data["Normals"], (1 / np.sqrt(5), 2 / np.sqrt(5), 0))


def outward(part) -> bool:
    """Every face's winding normal points away from the part's centre."""
    mesh = part.mesh.compute_normals(cell_normals=True, point_normals=False,
                                     consistent_normals=False, auto_orient_normals=False)
    away = mesh.cell_centers().points - np.asarray(mesh.center)
    return bool((np.einsum("ij,ij->i", mesh.cell_data["Normals"], away) > 0).all())


def test_mirrored_primitives_and_instances_keep_their_fronts_outside(tmp_path):
    # catches: a negative scale drawing spheres inside out (back faces culled: the far side
    # shows), and mirrored instances or a zero-scale instance dropping the instancer.
    stage = new_stage(tmp_path)
    UsdGeom.Sphere.Define(stage, "/Mirror").AddScaleOp().Set(Gf.Vec3f(-1, 1, 1))
    instancer = UsdGeom.PointInstancer.Define(stage, "/Inst")
    ball = UsdGeom.Sphere.Define(stage, "/Inst/Protos/Ball")
    instancer.CreatePrototypesRel().SetTargets([ball.GetPath()])
    instancer.CreateProtoIndicesAttr([0, 0, 0])
    instancer.CreatePositionsAttr([(10, 0, 0), (20, 0, 0), (30, 0, 0)])
    instancer.CreateScalesAttr([(-1, 1, 1), (0, 0, 0), (1, 1, 1)])
    parts = {m.name: m for m in load(stage).meshes}
    assert outward(parts["/Mirror"])
    copies = parts["/Inst[/Inst/Protos/Ball]"].mesh
    assert copies.bounds[1] == pytest.approx(31, abs=0.01)    # the last copy is there
    winding = copies.compute_normals(cell_normals=True, point_normals=False,
                                     consistent_normals=False, auto_orient_normals=False)
    centres = winding.cell_centers().points
    mirrored = centres[:, 0] < 15                  # the copy scaled by (-1, 1, 1) at x = 10
    away = centres[mirrored] - (10.0, 0.0, 0.0)
    assert (np.einsum("ij,ij->i", winding.cell_data["Normals"][mirrored], away) > 0).all()


def test_nested_instancers_and_prototype_children(tmp_path):
    stage = new_stage(tmp_path)
    outer = UsdGeom.PointInstancer.Define(stage, "/Outer")
    inner = UsdGeom.PointInstancer.Define(stage, "/Outer/Protos/Inner")
    holder = UsdGeom.Xform.Define(stage, "/Outer/Protos/Inner/Protos/Holder")
    cube = UsdGeom.Cube.Define(stage, "/Outer/Protos/Inner/Protos/Holder/Box")
    cube.CreateSizeAttr(1.0)
    cube.AddTranslateOp().Set(Gf.Vec3d(0, 5, 0))          # a child below the prototype root
    inner.CreatePrototypesRel().SetTargets([holder.GetPath()])
    inner.CreateProtoIndicesAttr([0, 0])
    inner.CreatePositionsAttr([(0, 0, 0), (0, 0, 3)])
    outer.CreatePrototypesRel().SetTargets([inner.GetPath()])
    outer.CreateProtoIndicesAttr([0])
    outer.CreatePositionsAttr([(100, 0, 0)])
    (part,) = load(stage).meshes
    # two boxes (the inner instances), moved by the outer instance, 5 up from their holder
    assert part.mesh.n_cells == 2 * 12
    assert part.mesh.bounds == pytest.approx((99.5, 100.5, 4.5, 5.5, -0.5, 3.5))


def test_uniform_values_follow_their_faces_when_faces_are_dropped(tmp_path):
    stage = new_stage(tmp_path)
    mesh = UsdGeom.Mesh.Define(stage, "/M")
    mesh.CreatePointsAttr(POINTS)
    mesh.CreateFaceVertexCountsAttr([2, 4, 4])            # the first face is a segment
    mesh.CreateFaceVertexIndicesAttr([0, 1, *INDICES])
    mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.uniform).Set(
        [(1, 1, 1), (1, 0, 0), (0, 1, 0)])
    with pytest.warns(cm.SceneWarning):
        part = load(stage).meshes[0]
    assert np.allclose(part.mesh.cell_data["displayColor"], [(1, 0, 0), (0, 1, 0)])


def test_cubic_bases_and_wrap_modes():
    from pv_cubemarch.scene.usd.shapes import CURVE_SAMPLES, _cubic
    points = np.array([(0, 0, 0), (1, 2, 0), (3, 2, 0), (4, 0, 0), (6, 1, 0)], float)
    widths = np.ones(len(points))
    # Catmull-Rom interpolates its inner control points, segment by segment
    samples, _ = _cubic(points, widths, "catmullRom", "nonperiodic")
    assert np.allclose(samples[::CURVE_SAMPLES], points[1:4])
    # pinned: phantom end points make it start and end at the first and last points
    samples, _ = _cubic(points, widths, "bspline", "pinned")
    assert np.allclose(samples[0], points[0]) and np.allclose(samples[-1], points[-1])
    # periodic: closed
    samples, _ = _cubic(points, widths, "bspline", "periodic")
    assert np.allclose(samples[0], samples[-1])
    # a B-spline's first sample is (p0 + 4 p1 + p2) / 6
    samples, _ = _cubic(points, widths, "bspline", "nonperiodic")
    assert np.allclose(samples[0], (points[0] + 4 * points[1] + points[2]) / 6)


def test_animated_attributes_are_read_at_the_time(tmp_path):
    # catches: attributes read at the default time (only transforms followed the time), and
    # a stage with samples but no time range read at no time (its points missing).
    stage = new_stage(tmp_path)
    ball = UsdGeom.Sphere.Define(stage, "/Ball")
    ball.CreateRadiusAttr().Set(1.0, 1)
    ball.GetRadiusAttr().Set(3.0, 2)
    path = tmp_path / "s.usda"
    stage.GetRootLayer().Save()
    assert cm.load_scene(path).meshes[0].mesh.bounds[1] == pytest.approx(1.0, abs=0.01)
    assert cm.load_scene(path, time=2).meshes[0].mesh.bounds[1] == pytest.approx(3.0, abs=0.01)
