"""USD import: every reader path, the skipped-prim report and bad files."""

from __future__ import annotations

import re

import numpy as np
import pytest
import pyvista as pv
from conftest import SCENE
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, UsdUtils, UsdVol

import pv_cubemarch as cm


def quad_mesh(stage, path, offset=(0, 0, 0)):
    mesh = UsdGeom.Mesh.Define(stage, path)
    points = [Gf.Vec3f(x + offset[0], y + offset[1], offset[2]) for x, y in
              ((0, 0), (1, 0), (1, 1), (0, 1))]
    mesh.CreatePointsAttr(points)
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    return mesh


def write_field_stage(tmp_path, file_name, field_attrs=None):
    stage = Usd.Stage.CreateNew(str(tmp_path / "vol.usda"))
    volume = UsdVol.Volume.Define(stage, "/Vol")
    field = stage.DefinePrim("/Vol/density")
    field.CreateAttribute("filePath", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(file_name))
    for name, (kind, value) in (field_attrs or {}).items():
        field.CreateAttribute(name, kind).Set(value)
    volume.CreateFieldRelationship("density", field.GetPath())
    stage.GetRootLayer().Save()
    return tmp_path / "vol.usda"


def test_mesh_normals_colors_material_and_xform_stack(tmp_path):
    stage = Usd.Stage.CreateNew(str(tmp_path / "m.usda"))
    parent = UsdGeom.Xform.Define(stage, "/Parent")
    parent.AddTranslateOp().Set(Gf.Vec3d(10, 0, 0))
    parent.AddScaleOp().Set(Gf.Vec3f(2, 2, 2))
    mesh = quad_mesh(stage, "/Parent/Quad")
    UsdGeom.Xformable(mesh).AddRotateZOp().Set(90.0)
    mesh.CreateNormalsAttr([Gf.Vec3f(0, 0, 1)] * 4)
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    colors = mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex)
    colors.Set([Gf.Vec3f(1, 0, 0), Gf.Vec3f(0, 1, 0), Gf.Vec3f(0, 0, 1), Gf.Vec3f(1, 1, 1)])
    plain = quad_mesh(stage, "/Plain", offset=(0, 5, 0))
    material = UsdShade.Material.Define(stage, "/Mat")
    shader = UsdShade.Shader.Define(stage, "/Mat/PS")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.2, 0.4, 0.6))
    shader.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(0.5)
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.25)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(plain.GetPrim()).Bind(material)
    stage.GetRootLayer().Save()

    scene = cm.load_scene(tmp_path / "m.usda")
    quad = next(m for m in scene.meshes if m.name == "/Parent/Quad")
    # rotate 90 about z, then scale 2, then translate 10 in x
    assert np.allclose(quad.mesh.points[1], (10, 2, 0), atol=1e-6)
    assert np.allclose(quad.mesh.points[2], (8, 2, 0), atol=1e-6)
    assert np.allclose(quad.mesh.point_data["Normals"], (0, 0, 1))
    assert quad.vertex_colors == "displayColor"
    assert np.allclose(quad.mesh.point_data["displayColor"][1], (0, 1, 0))
    plain_mesh = next(m for m in scene.meshes if m.name == "/Plain")
    assert np.allclose(plain_mesh.material.diffuse_color, (0.2, 0.4, 0.6))
    assert plain_mesh.material.opacity == pytest.approx(0.5)
    assert plain_mesh.material.roughness == pytest.approx(0.25)


def test_primitives_with_their_sizes(tmp_path):
    stage = Usd.Stage.CreateNew(str(tmp_path / "p.usda"))
    UsdGeom.Sphere.Define(stage, "/S").CreateRadiusAttr(2.0)
    UsdGeom.Cube.Define(stage, "/C").CreateSizeAttr(3.0)
    cyl = UsdGeom.Cylinder.Define(stage, "/Y")
    cyl.CreateRadiusAttr(0.5)
    cyl.CreateHeightAttr(4.0)
    cyl.CreateAxisAttr("Z")
    cone = UsdGeom.Cone.Define(stage, "/N")
    cone.CreateRadiusAttr(1.0)
    cone.CreateHeightAttr(2.0)
    cone.CreateAxisAttr("Y")
    cap = UsdGeom.Capsule.Define(stage, "/K")
    cap.CreateRadiusAttr(0.5)
    cap.CreateHeightAttr(2.0)
    cap.CreateAxisAttr("X")
    stage.GetRootLayer().Save()
    meshes = {m.name: np.asarray(m.mesh.bounds) for m in cm.load_scene(tmp_path / "p.usda").meshes}
    assert np.allclose(meshes["/S"], [-2, 2, -2, 2, -2, 2], atol=0.02)
    assert np.allclose(meshes["/C"], [-1.5, 1.5] * 3, atol=1e-6)
    assert np.allclose(meshes["/Y"][4:], [-2, 2], atol=1e-6)
    assert np.allclose(meshes["/Y"][:2], [-0.5, 0.5], atol=0.01)
    assert np.allclose(meshes["/N"][2:4], [-1, 1], atol=1e-6)
    assert np.allclose(meshes["/K"][:2], [-1.5, 1.5], atol=0.01)


def test_references_and_instancing(tmp_path):
    asset = Usd.Stage.CreateNew(str(tmp_path / "asset.usda"))
    root = UsdGeom.Xform.Define(asset, "/Asset")
    quad_mesh(asset, "/Asset/Quad")
    asset.SetDefaultPrim(root.GetPrim())
    asset.GetRootLayer().Save()
    stage = Usd.Stage.CreateNew(str(tmp_path / "scene.usda"))
    for i, instanceable in enumerate((False, True, True)):
        prim = stage.DefinePrim(f"/Copy{i}")
        prim.GetReferences().AddReference("./asset.usda")
        prim.SetInstanceable(instanceable)
        UsdGeom.Xformable(prim).AddTranslateOp().Set(Gf.Vec3d(0, 0, 10 * i))
    stage.GetRootLayer().Save()
    scene = cm.load_scene(tmp_path / "scene.usda")
    zs = sorted(float(m.mesh.points[:, 2].mean()) for m in scene.meshes)
    assert zs == [0.0, 10.0, 20.0]


def test_camera_lights_and_stage_metadata(tmp_path):
    stage = Usd.Stage.CreateNew(str(tmp_path / "c.usda"))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)
    camera = UsdGeom.Camera.Define(stage, "/Cam")
    camera.CreateFocalLengthAttr(50.0)
    camera.CreateVerticalApertureAttr(24.0)
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.5, 200.0))
    UsdGeom.Xformable(camera).AddTranslateOp().Set(Gf.Vec3d(1, 2, 30))
    sun = UsdLux.DistantLight.Define(stage, "/Sun")
    sun.CreateIntensityAttr(2.0)
    sun.CreateExposureAttr(1.0)
    UsdGeom.Xformable(sun).AddRotateXOp().Set(-90.0)  # -z rotated to point down -y... check
    bulb = UsdLux.SphereLight.Define(stage, "/Bulb")
    UsdGeom.Xformable(bulb).AddTranslateOp().Set(Gf.Vec3d(3, 4, 5))
    UsdLux.DomeLight.Define(stage, "/Sky").CreateColorAttr(Gf.Vec3f(0.5, 0.6, 0.7))
    quad_mesh(stage, "/Quad")
    stage.GetRootLayer().Save()
    scene = cm.load_scene(tmp_path / "c.usda")
    assert scene.up_axis == "Z" and scene.meters_per_unit == pytest.approx(0.01)
    cam = scene.cameras["/Cam"]
    assert cam.view_angle == pytest.approx(np.degrees(2 * np.arctan(12 / 50)), rel=1e-4)
    assert cam.clipping_range == pytest.approx((0.5, 200.0))
    assert np.allclose(cam.position, (1, 2, 30))
    assert np.allclose(np.subtract(cam.focal_point, cam.position) / np.linalg.norm(
        np.subtract(cam.focal_point, cam.position)), (0, 0, -1))
    lights = {li.name: li for li in scene.lights}
    assert lights["/Sun"].kind == "distant" and lights["/Sun"].intensity == pytest.approx(4.0)
    assert np.allclose(lights["/Sun"].direction, (0, -1, 0), atol=1e-6)
    assert lights["/Bulb"].kind == "sphere" and np.allclose(lights["/Bulb"].position, (3, 4, 5))
    assert lights["/Sky"].kind == "dome" and np.allclose(lights["/Sky"].color, (0.5, 0.6, 0.7))
    image = scene.render(size=(32, 24))
    assert image.shape == (24, 32, 3)


def test_skipped_prims_are_reported_with_reasons(tmp_path):
    stage = Usd.Stage.CreateNew(str(tmp_path / "s.usda"))
    quad_mesh(stage, "/Shown")
    hidden = UsdGeom.Xform.Define(stage, "/Hidden")
    hidden.CreateVisibilityAttr(UsdGeom.Tokens.invisible)
    quad_mesh(stage, "/Hidden/Child")
    quad_mesh(stage, "/Off").GetPrim().SetActive(False)
    quad_mesh(stage, "/Guide").CreatePurposeAttr(UsdGeom.Tokens.guide)
    quad_mesh(stage, "/Proxy").CreatePurposeAttr(UsdGeom.Tokens.proxy)    # usdview shows it
    quad_mesh(stage, "/Render").CreatePurposeAttr(UsdGeom.Tokens.render)  # and not this
    UsdGeom.NurbsPatch.Define(stage, "/Patch")
    stage.GetRootLayer().Save()
    scene = cm.load_scene(tmp_path / "s.usda")
    assert [m.name for m in scene.meshes] == ["/Shown", "/Proxy"]
    reasons = {s.path: s.reason for s in scene.skipped}
    assert reasons == {"/Hidden": "invisible", "/Off": "inactive", "/Guide": "purpose is guide",
                       "/Render": "purpose is render",
                       "/Patch": "NURBS patches are not tessellated", "/": reasons["/"]}
    assert reasons["/"].startswith("2 subdivision meshes")
    assert "/Hidden: invisible" in scene.summary()


def test_shipped_scene_loads_everything():
    scene = cm.load_scene(SCENE)
    assert len(scene.meshes) == 2 and len(scene.volumes) == 1
    assert list(scene.cameras) == ["/World/Camera"]
    assert {li.kind for li in scene.lights} == {"distant", "dome"}
    assert [s.path for s in scene.skipped] == ["/World/BoundsGuide"]
    volume = scene.volumes[0]
    assert volume.dimensions == (64, 64, 64)
    assert volume.transfer.clim == pytest.approx((0.0, 0.7))


def test_npy_and_npz_fields(tmp_path):
    data = np.random.default_rng(0).random((5, 6, 7)).astype(np.float32)
    np.save(tmp_path / "d.npy", data)
    path = write_field_stage(tmp_path, "./d.npy", {
        "cubemarch:spacing": (Sdf.ValueTypeNames.Float3, Gf.Vec3f(0.5, 0.5, 2.0)),
        "cubemarch:origin": (Sdf.ValueTypeNames.Float3, Gf.Vec3f(1, 2, 3))})
    volume = cm.load_scene(path).volumes[0]
    assert volume.dimensions == (5, 6, 7)
    assert np.allclose(volume.values, data)
    assert np.allclose(volume.world_bounds(), [1, 3, 2, 4.5, 3, 15])
    np.savez(tmp_path / "e.npz", other=np.zeros((2, 2, 2)), smoke=data)
    path = write_field_stage(tmp_path, "./e.npz", {
        "fieldName": (Sdf.ValueTypeNames.Token, "smoke")})
    assert np.allclose(cm.load_scene(path).volumes[0].values, data)


def test_grid_files_that_lack_the_field_or_lie_in_their_header_are_skipped_and_said(
        tmp_path, monkeypatch):
    # A fieldName the file lacks drew another array in silence (found by a review: the
    # .npz's first, the .vti's active scalars); a .npy shorter than its header says, an
    # empty .npz and an array past the memory budget are refused before any allocation.
    # catches (seen failing): the fallback to the first array (no skip, no note); the
    # budget not read from the header (the array read whole).
    data = np.random.default_rng(0).random((5, 6, 7)).astype(np.float32)
    np.savez(tmp_path / "two.npz", temperature=data, density=data)
    image = pv.ImageData(dimensions=data.shape)
    image.point_data["temperature"] = data.ravel(order="F")
    image.save(tmp_path / "two.vti")
    np.savez(tmp_path / "none.npz")
    np.save(tmp_path / "short.npy", data)
    with open(tmp_path / "short.npy", "r+b") as handle:
        handle.truncate(200)
    np.save(tmp_path / "d.npy", data)
    cases = [("./two.npz", "pressure", "has no array named 'pressure' .its arrays: "
              "temperature, density"),
             ("./two.vti", "pressure", "has no array named 'pressure' .its arrays: "
              "temperature"),
             ("./none.npz", None, "holds no arrays"),
             ("./short.npy", None, "could not read"),
             ("./d.npy", None, "holds an array of 840 bytes, more than the 100")]
    for asset, field, said in cases:
        # the budget only where it is the case (a header past it is refused first)
        monkeypatch.setenv("PV_CUBEMARCH_ARRAY_MAX_BYTES", "100" if asset == "./d.npy"
                           else "1e12")
        extra = {} if field is None else {"fieldName": (Sdf.ValueTypeNames.Token, field)}
        path = write_field_stage(tmp_path, asset, extra)
        with pytest.warns(UserWarning):
            scene = cm.load_scene(path)
        assert not scene.volumes, asset
        assert re.search(said, " ".join(e.reason for e in scene.skipped)), (asset, [
            e.reason for e in scene.skipped])


def test_a_usda_that_is_not_text_is_refused_naming_the_file(tmp_path):
    # catches (seen failing; found by a review): a UnicodeDecodeError, no file named (the
    # error's own message quoted the bytes it could not decode)
    path = tmp_path / "junk.usda"
    path.write_bytes(b"#usda 1.0\n" + np.random.default_rng(0).bytes(4096))
    with pytest.raises(cm.SceneLoadError, match="junk.usda' could not be opened"):
        cm.load_scene(path)


def test_a_volume_option_of_the_wrong_type_is_said_by_attribute(tmp_path):
    # catches (seen failing; found by a review): cubemarch:clim = "0 1" (a string) read
    # character by character: "could not convert string to float: ' '", no attribute named
    np.save(tmp_path / "d.npy", np.random.default_rng(0).random((5, 6, 7)))
    path = write_field_stage(tmp_path, "./d.npy")
    stage = Usd.Stage.Open(str(path))
    stage.GetPrimAtPath("/Vol").CreateAttribute("cubemarch:clim",
                                                Sdf.ValueTypeNames.String).Set("0 1")
    stage.GetRootLayer().Save()
    with pytest.warns(UserWarning):
        scene = cm.load_scene(path)
    assert not scene.volumes
    assert "cubemarch:clim = '0 1': numbers are wanted" in scene.skipped[0].reason


def test_usdc_and_usdz(tmp_path):
    stage = Usd.Stage.CreateNew(str(tmp_path / "a.usdc"))
    quad_mesh(stage, "/Quad")
    stage.GetRootLayer().Save()
    assert len(cm.load_scene(tmp_path / "a.usdc").meshes) == 1
    assert UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(str(tmp_path / "a.usdc")),
                                         str(tmp_path / "a.usdz"))
    assert len(cm.load_scene(tmp_path / "a.usdz").meshes) == 1


def test_pyvista_read_returns_multiblock():
    blocks = pv.read(SCENE)
    assert isinstance(blocks, pv.MultiBlock)
    assert set(blocks.keys()) == {"/World/Torus", "/World/Ground", "/World/Smoke"}
    assert isinstance(blocks["/World/Smoke"], pv.ImageData)


@pytest.mark.parametrize("content, message", [
    (None, "does not exist"),
    ("#usda 1.0\ndef Xform \"A\" {\n  bogus bogus\n", "could not be opened"),
    ("\x00\x01 not usd at all", "could not be opened"),
])
def test_bad_usd_files(tmp_path, content, message):
    path = tmp_path / "bad.usda"
    if content is not None:
        path.write_text(content)
    with pytest.raises(cm.SceneLoadError, match=message):
        cm.load_scene(path)


def reported(path, match: str):
    """Load ``path``: the problem is a SceneWarning and a skipped entry; strict raises it."""
    with pytest.warns(cm.SceneWarning, match=match):
        scene = cm.load_scene(path)
    assert any(re.search(match, s.reason) for s in scene.skipped), scene.summary()
    with pytest.raises(cm.CubemarchError, match=match):
        cm.load_scene(path, strict=True)
    return scene


def test_missing_field_file_names_it(tmp_path):
    path = write_field_stage(tmp_path, "./nowhere.vti")
    scene = reported(path, "nowhere.vti")
    assert not scene.volumes


def test_openvdb_field_is_a_clear_error(tmp_path):
    (tmp_path / "smoke.vdb").write_bytes(b"not really vdb")
    path = write_field_stage(tmp_path, "./smoke.vdb")
    reported(path, "OpenVDB")


def test_field_with_bad_data(tmp_path):
    np.save(tmp_path / "nan.npy", np.full((3, 3, 3), np.nan))
    reported(write_field_stage(tmp_path, "./nan.npy"), "NaN")
    np.save(tmp_path / "flat.npy", np.zeros((3, 3)))
    reported(write_field_stage(tmp_path, "./flat.npy"), "3 axes")
    np.save(tmp_path / "text.npy", np.array([[["a"]]]))
    reported(write_field_stage(tmp_path, "./text.npy"), "dtype")


def test_unknown_scene_suffix(tmp_path):
    (tmp_path / "x.abc").write_text("")
    with pytest.raises(cm.SceneLoadError, match="unknown scene type"):
        cm.load_scene(tmp_path / "x.abc")


def test_volume_interpolation_and_blending_attributes(tmp_path):
    """``cubemarch:interpolation`` and ``cubemarch:blending`` reach the volume as authored."""
    np.save(tmp_path / "d.npy", np.random.default_rng(0).random((4, 4, 4)))
    path = write_field_stage(tmp_path, "./d.npy")
    stage = Usd.Stage.Open(str(path))
    prim = stage.GetPrimAtPath("/Vol")
    prim.CreateAttribute("cubemarch:interpolation", Sdf.ValueTypeNames.String).Set("nearest")
    prim.CreateAttribute("cubemarch:blending", Sdf.ValueTypeNames.String).Set("maximum")
    stage.GetRootLayer().Save()
    scene = cm.load_scene(path)
    assert scene.volumes[0].interpolation == "nearest"
    assert [options["blending"] for options in scene.volume_options.values()] == ["maximum"]
    prim.GetAttribute("cubemarch:interpolation").Set("cubic")
    stage.GetRootLayer().Save()
    with pytest.warns(cm.SceneWarning, match="interpolation must be one of"):
        assert cm.load_scene(path).volumes == []   # the prim is skipped, saying why
