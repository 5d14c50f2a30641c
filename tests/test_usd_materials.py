"""UsdPreviewSurface materials, textures and lights, read from stages written here and drawn.

Expected pixels come from the scene's geometry worked out by hand (where the quad and its
transparent strip fall on screen) and from the shading model (a Lambertian albedo a under
irradiance E returns a·E/π, and VTK's PBR writes it gamma 1/2.2), never from our output.
"""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, UsdUtils

import pv_cubemarch as cm
from pv_cubemarch.scene.materials import TextureInput
from pv_cubemarch.scene.textures import base_color_image, normal_image, texture_values

SIZE = 200
#: The quad [0, 1]² seen from (0.5, 0.5, 4) with USD's default camera (50 mm focal length,
#: 15.2908 mm vertical aperture): half the view is 4·tan(atan(15.2908 / 100)) = 0.6116 units,
#: so the quad spans pixels 100 ± 100·0.5/0.6116 = 18.2 .. 181.8 in x and y.
QUAD_FIRST, QUAD_LAST = 18.2, 181.8


def column_of(x: float) -> int:
    """The pixel column at quad coordinate ``x``."""
    return int(round(QUAD_FIRST + x * (QUAD_LAST - QUAD_FIRST)))


def texture_file(path, strip_alpha=64):
    """64x64 RGBA: the top half red, the bottom half blue, the left eighth of alpha ``strip``."""
    image = np.zeros((64, 64, 4), np.uint8)
    image[..., 3] = 255
    image[:32, :, 0] = 255
    image[32:, :, 2] = 255
    image[:, :8, 3] = strip_alpha
    Image.fromarray(image).save(path)


def primvar_reader(stage, name: str):
    """/Mat/St: a UsdPrimvarReader_float2 of the primvar ``name``."""
    reader = UsdShade.Shader.Define(stage, "/Mat/St")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set(name)
    return reader


def uv_texture(stage, file: str, st_source):
    """/Mat/Tex: a UsdUVTexture of ``file`` whose st is ``st_source``'s result."""
    tex = UsdShade.Shader.Define(stage, "/Mat/Tex")
    tex.CreateIdAttr("UsdUVTexture")
    tex.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(file)
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(
        st_source.ConnectableAPI(), "result")
    return tex


def quad_stage(tmp_path, texture="./tex.png", threshold=0.5, lights="sun", name="q.usda"):
    stage = Usd.Stage.CreateNew(str(tmp_path / name))
    mesh = UsdGeom.Mesh.Define(stage, "/Quad")
    mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateSubdivisionSchemeAttr("none")
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                                 UsdGeom.Tokens.faceVarying)
    st.Set([(0, 0), (1, 0), (1, 1), (0, 1)])
    material = UsdShade.Material.Define(stage, "/Mat")
    surface = UsdShade.Shader.Define(stage, "/Mat/PS")
    surface.CreateIdAttr("UsdPreviewSurface")
    if texture is not None:
        tex = uv_texture(stage, texture, primvar_reader(stage, "st"))
        surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
            tex.ConnectableAPI(), "rgb")
        surface.CreateInput("opacity", Sdf.ValueTypeNames.Float).ConnectToSource(
            tex.ConnectableAPI(), "a")
        surface.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(threshold)
    else:
        surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(
            Gf.Vec3f(0.8, 0.8, 0.8))
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    UsdGeom.Camera.Define(stage, "/Cam").AddTranslateOp().Set(Gf.Vec3d(0.5, 0.5, 4.0))
    if lights == "sun":
        sun = UsdLux.DistantLight.Define(stage, "/Sun")
        sun.CreateIntensityAttr(1.0)
        sun.CreateNormalizeAttr(True)        # the intensity is the irradiance
    elif lights == "sun disk":   # a sun disk of 0.53° and radiance 1/Ω: irradiance 1 again
        sun = UsdLux.DistantLight.Define(stage, "/Sun")
        sun.CreateIntensityAttr(1.0 / (2 * np.pi * (1 - np.cos(np.radians(0.53 / 2)))))
    elif lights == "behind":   # points along +z: the quad's back is lit, its front is not
        sun = UsdLux.DistantLight.Define(stage, "/Sun")
        sun.AddRotateYOp().Set(180.0)
    elif lights == "dome":
        UsdLux.DomeLight.Define(stage, "/Dome").CreateIntensityAttr(1.0)
    stage.GetRootLayer().Save()
    return tmp_path / name


def render(path):
    return cm.load_scene(path).render(size=(SIZE, SIZE)).astype(int)


def test_texture_orientation_colours_and_cutout(tmp_path):
    # catches: the image drawn upside down (t = 0 is the image's bottom row), the base colour
    # texture without its sRGB flag (VTK drops it: the quad turns white), opacityThreshold
    # ignored (the strip drawn), and texture coordinates not made active (one colour).
    # the strip's alpha 64/255 = 0.25 is under the threshold 0.5: cut out, not blended
    texture_file(tmp_path / "tex.png", strip_alpha=64)
    image = render(quad_stage(tmp_path))
    background = image[3, 3]
    top, bottom = image[60, 100], image[140, 100]
    assert top[0] > top[2] + 60 and bottom[2] > bottom[0] + 60
    assert np.abs(image[100, column_of(0.06)] - background).sum() <= 6       # cut out
    assert np.abs(image[100, column_of(0.2)] - background).sum() > 100       # drawn


@pytest.mark.parametrize("lights", ["sun", "sun disk"])
def test_lambert_level_of_a_sun_of_irradiance_one(tmp_path, lights):
    # A white sun of irradiance 1 head-on: red albedo 1 returns 1/π; VTK writes (1/π)^(1/2.2)
    # = 0.594 → 151, plus a little specular (F0 = 0.04 at roughness 0.5). Catches light
    # intensities rescaled (the old division by the strongest light, or by π twice) and, for
    # the un-normalized sun, its disk's solid angle left out (McUsd's default 50000 sun then
    # burns everything white, as the usd-wg survey found).
    texture_file(tmp_path / "tex.png", strip_alpha=255)
    red = render(quad_stage(tmp_path, lights=lights))[60, 100]
    assert 140 <= red[0] <= 175


def test_default_camera_light_only_without_lights(tmp_path):
    # catches: usdview's camera light missing (the quad black) or added to a lit stage (a sun
    # behind the quad then leaves its front lit).
    lit = render(quad_stage(tmp_path, texture=None, lights=None))[100, 100]
    dark = render(quad_stage(tmp_path, texture=None, lights="behind", name="b.usda"))[100, 100]
    assert lit.min() > 110            # 0.8/π → 0.538 → 137 (and some specular)
    assert dark.max() < 40


def test_uniform_dome_light_is_image_based_ambient(tmp_path):
    # A uniform dome of radiance 1 gives irradiance π: albedo 0.8 returns 0.8, written
    # 0.8^(1/2.2) = 0.904 → 230. Catches the dome dropped (VTK's PBR has no ambient term).
    pixel = render(quad_stage(tmp_path, texture=None, lights="dome"))[100, 100]
    assert np.all(np.abs(pixel - 230) <= 14)


def uv_texture_stage(tmp_path, inputs: dict, output="rgb"):
    """A material whose diffuseColor comes from a UsdUVTexture with ``inputs``."""
    stage = Usd.Stage.CreateNew(str(tmp_path / "uv.usda"))
    UsdGeom.Sphere.Define(stage, "/Ball")
    material = UsdShade.Material.Define(stage, "/Mat")
    surface = UsdShade.Shader.Define(stage, "/Mat/PS")
    surface.CreateIdAttr("UsdPreviewSurface")
    tex = UsdShade.Shader.Define(stage, "/Mat/Tex")
    tex.CreateIdAttr("UsdUVTexture")
    for name, (kind, value) in inputs.items():
        tex.CreateInput(name, kind).Set(value)
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        tex.ConnectableAPI(), output)
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(stage.GetPrimAtPath("/Ball")).Bind(material)
    stage.GetRootLayer().Save()
    return tmp_path / "uv.usda"


def test_uv_texture_settings_are_read(tmp_path):
    Image.new("RGB", (4, 4), (188, 100, 50)).save(tmp_path / "t.png")
    path = uv_texture_stage(tmp_path, {
        "file": (Sdf.ValueTypeNames.Asset, "./t.png"),
        "wrapS": (Sdf.ValueTypeNames.Token, "mirror"),
        "wrapT": (Sdf.ValueTypeNames.Token, "clamp"),
        "scale": (Sdf.ValueTypeNames.Float4, Gf.Vec4f(2, 2, 2, 1)),
        "bias": (Sdf.ValueTypeNames.Float4, Gf.Vec4f(-1, -1, -1, 0)),
        "sourceColorSpace": (Sdf.ValueTypeNames.Token, "raw")}, output="g")
    texture = cm.load_scene(path).meshes[0].material.diffuse_color
    assert isinstance(texture, TextureInput)
    assert texture.wrap == ("mirror", "clamp") and texture.channels == "g"
    assert texture.scale == (2, 2, 2, 1) and texture.bias == (-1, -1, -1, 0)
    # raw: green 100/255 = 0.392, scaled and biased: 2·0.392 - 1 = -0.216
    assert texture_values(texture)[0, 0, 0] == pytest.approx(2 * 100 / 255 - 1)


def test_texture_values_decode_srgb_pick_channels_and_pack_for_vtk(tmp_path):
    rgba = np.zeros((2, 2, 4), np.uint8)
    rgba[..., 0], rgba[..., 1], rgba[..., 2], rgba[..., 3] = 188, 128, 255, 64
    Image.fromarray(rgba).save(tmp_path / "c.png")
    color = TextureInput(file=str(tmp_path / "c.png"))
    # sRGB 188/255 = 0.737 decodes to ((0.737 + 0.055) / 1.055)^2.4 = 0.503
    assert texture_values(color)[0, 0] == pytest.approx([0.5029, 0.2158, 1.0], abs=1e-3)
    alpha = TextureInput(file=str(tmp_path / "c.png"), channels="a")
    assert texture_values(alpha)[0, 0, 0] == pytest.approx(64 / 255)   # alpha is never sRGB
    packed = base_color_image(color, alpha)
    assert packed[0, 0].tolist() == [188, 128, 255, 64]                # encoded back for VTK
    Image.fromarray(np.full((2, 2, 3), (128, 128, 255), np.uint8)).save(tmp_path / "n.png")
    normal = TextureInput(file=str(tmp_path / "n.png"), color_space="raw",
                          scale=(2, 2, 2, 1), bias=(-1, -1, -1, 0))
    # USD's [-1, 1] normal back in VTK's [0, 1] encoding: the texel itself
    assert normal_image(normal)[0, 0].tolist() == [128, 128, 255]
    gray16 = np.full((2, 2), 65535 // 4, np.uint16)
    Image.fromarray(gray16).save(tmp_path / "g16.png")
    deep = TextureInput(file=str(tmp_path / "g16.png"), channels="r")
    assert texture_values(deep)[0, 0, 0] == pytest.approx(0.25, abs=1e-4)   # 16-bit is raw


def test_transform_2d_material_interface_and_primvar_reader(tmp_path):
    stage = Usd.Stage.CreateNew(str(tmp_path / "net.usda"))
    UsdGeom.Sphere.Define(stage, "/Ball")
    material = UsdShade.Material.Define(stage, "/Mat")
    tint = material.CreateInput("tint", Sdf.ValueTypeNames.Color3f)
    tint.Set(Gf.Vec3f(0.1, 0.6, 0.3))
    surface = UsdShade.Shader.Define(stage, "/Mat/PS")
    surface.CreateIdAttr("UsdPreviewSurface")
    surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(tint)
    transform = UsdShade.Shader.Define(stage, "/Mat/Move")
    transform.CreateIdAttr("UsdTransform2d")
    transform.CreateInput("scale", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(2, 3))
    transform.CreateInput("rotation", Sdf.ValueTypeNames.Float).Set(90.0)
    transform.CreateInput("translation", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0.5, 0.25))
    transform.CreateInput("in", Sdf.ValueTypeNames.Float2).ConnectToSource(
        primvar_reader(stage, "uv").ConnectableAPI(), "result")
    Image.new("RGB", (2, 2)).save(tmp_path / "r.png")
    tex = uv_texture(stage, "./r.png", transform)
    surface.CreateInput("roughness", Sdf.ValueTypeNames.Float).ConnectToSource(
        tex.ConnectableAPI(), "r")
    material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(stage.GetPrimAtPath("/Ball")).Bind(material)
    stage.GetRootLayer().Save()
    read = cm.load_scene(tmp_path / "net.usda").meshes[0].material
    assert read.diffuse_color == pytest.approx((0.1, 0.6, 0.3))   # through the interface
    assert read.roughness.st == "uv"
    # scale (2, 3), then rotate 90°, then translate: (1, 0) -> (2, 0) -> (0, 2) -> (0.5, 2.25)
    st = read.roughness.st_transform @ np.array([1.0, 0.0, 1.0])
    assert st[:2] == pytest.approx((0.5, 2.25))


def test_problems_in_materials_are_reported(tmp_path):
    path = uv_texture_stage(tmp_path, {"file": (Sdf.ValueTypeNames.Asset, "./nowhere.png")})
    with pytest.warns(cm.SceneWarning, match="nowhere.png"):
        scene = cm.load_scene(path)
    assert scene.meshes and scene.meshes[0].material.diffuse_color == pytest.approx(
        (0.18, 0.18, 0.18))       # UsdPreviewSurface's default, as the spec says
    stage = Usd.Stage.Open(str(path))
    stage.GetPrimAtPath("/Mat/PS").GetAttribute("info:id").Set("ND_standard_surface")
    stage.GetRootLayer().Save()
    with pytest.warns(cm.SceneWarning, match="not UsdPreviewSurface"):
        cm.load_scene(path)


def test_textures_inside_a_usdz_package(tmp_path):
    texture_file(tmp_path / "tex.png", strip_alpha=255)
    quad_stage(tmp_path, name="pack.usdc")
    assert UsdUtils.CreateNewUsdzPackage(Sdf.AssetPath(str(tmp_path / "pack.usdc")),
                                         str(tmp_path / "pack.usdz"))
    (tmp_path / "tex.png").unlink()    # only the package's copy is left
    image = render(tmp_path / "pack.usdz")
    assert image[60, 100][0] > image[60, 100][2] + 60


def test_light_colour_temperature_area_and_shaping(tmp_path):
    stage = Usd.Stage.CreateNew(str(tmp_path / "l.usda"))
    warm = UsdLux.DistantLight.Define(stage, "/Warm")
    warm.CreateEnableColorTemperatureAttr(True)
    warm.CreateColorTemperatureAttr(2000.0)
    rect = UsdLux.RectLight.Define(stage, "/Rect")
    rect.CreateWidthAttr(2.0)
    rect.CreateHeightAttr(3.0)
    rect.CreateIntensityAttr(5.0)
    UsdLux.ShapingAPI.Apply(rect.GetPrim()).CreateShapingConeAngleAttr(30.0)
    disk = UsdLux.DiskLight.Define(stage, "/Disk")
    disk.CreateNormalizeAttr(True)
    stage.GetRootLayer().Save()
    lights = {li.name: li for li in cm.load_scene(tmp_path / "l.usda").lights}
    red, _, blue = lights["/Warm"].color
    assert red > 2 * blue                      # 2000 K is orange-red
    assert lights["/Rect"].kind == "rect" and lights["/Rect"].area == pytest.approx(6.0)
    assert lights["/Rect"].cone_angle == pytest.approx(30.0)
    assert lights["/Disk"].area == 1.0         # normalized: power independent of size


def test_instanced_materials_and_display_opacity(tmp_path):
    # Materials bound inside an instanceable asset reach every instance proxy; a mesh of
    # displayOpacity 0.5 is translucent (red over a blue wall: both colours in the pixel).
    asset = Usd.Stage.CreateNew(str(tmp_path / "asset.usda"))
    root = UsdGeom.Xform.Define(asset, "/Asset")
    ball = UsdGeom.Sphere.Define(asset, "/Asset/Ball")
    material = UsdShade.Material.Define(asset, "/Asset/Looks/Gold")
    shader = UsdShade.Shader.Define(asset, "/Asset/Looks/Gold/PS")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(1, 0.8, 0.2))
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    UsdShade.MaterialBindingAPI.Apply(ball.GetPrim()).Bind(material)
    asset.SetDefaultPrim(root.GetPrim())
    asset.GetRootLayer().Save()
    stage = Usd.Stage.CreateNew(str(tmp_path / "inst.usda"))
    for i in range(2):
        prim = stage.DefinePrim(f"/Copy{i}")
        prim.GetReferences().AddReference("./asset.usda")
        prim.SetInstanceable(True)
    stage.GetRootLayer().Save()
    balls = cm.load_scene(tmp_path / "inst.usda").meshes
    assert len(balls) == 2
    assert all(b.material.diffuse_color == pytest.approx((1, 0.8, 0.2)) for b in balls)

    stage = Usd.Stage.CreateNew(str(tmp_path / "glass.usda"))
    front = UsdGeom.Mesh.Define(stage, "/Front")
    back = UsdGeom.Mesh.Define(stage, "/Back")
    for mesh, z, size, color in ((front, 0, 1, (1, 0, 0)), (back, -1, 3, (0, 0, 1))):
        lo = (1 - size) / 2
        mesh.CreatePointsAttr([(lo, lo, z), (lo + size, lo, z), (lo + size, lo + size, z),
                               (lo, lo + size, z)])
        mesh.CreateFaceVertexCountsAttr([4])
        mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
        mesh.CreateDisplayColorPrimvar().Set([color])
    front.CreateDisplayOpacityPrimvar().Set([0.5])
    UsdGeom.Camera.Define(stage, "/Cam").AddTranslateOp().Set(Gf.Vec3d(0.5, 0.5, 6.0))
    stage.GetRootLayer().Save()
    image = cm.load_scene(tmp_path / "glass.usda").render(size=(100, 100)).astype(int)
    middle, wall = image[50, 50], image[50, 5]
    assert middle[0] > wall[0] + 40 and middle[2] > 60      # red over blue, both seen


def test_single_sided_meshes_cull_their_back_and_double_sided_do_not(tmp_path):
    # Seen from behind (camera at z = -4 looking along +z): usdview culls a single-sided
    # quad's back, draws a doubleSided one. Catches culling ignored or applied to both.
    images = {}
    for sided in (False, True):
        path = quad_stage(tmp_path, texture=None, lights=None, name=f"s{sided}.usda")
        stage = Usd.Stage.Open(str(path))
        UsdGeom.Mesh(stage.GetPrimAtPath("/Quad")).CreateDoubleSidedAttr(sided)
        camera = UsdGeom.Xformable(stage.GetPrimAtPath("/Cam"))
        camera.ClearXformOpOrder()
        camera.AddTranslateOp().Set(Gf.Vec3d(0.5, 0.5, -4.0))
        camera.AddRotateYOp().Set(180.0)
        stage.GetRootLayer().Save()
        images[sided] = render(path)
    background = images[False][3, 3]
    assert np.abs(images[False][100, 100] - background).sum() <= 6
    assert np.abs(images[True][100, 100] - background).sum() > 100


def test_textured_dome_lights_and_is_the_background(tmp_path):
    # A dome whose image is pure green: the background is green (the skybox, gamma as the
    # PBR output) and the white quad reflects green light only.
    Image.new("RGB", (16, 8), (0, 255, 0)).save(tmp_path / "sky.png")
    path = quad_stage(tmp_path, texture=None, lights=None)
    stage = Usd.Stage.Open(str(path))
    dome = UsdLux.DomeLight.Define(stage, "/Dome")
    dome.CreateTextureFileAttr(Sdf.AssetPath("./sky.png"))
    stage.GetRootLayer().Save()
    image = render(path)
    sky, quad = image[3, 3], image[100, 100]
    assert sky[1] > 230 and sky[0] < 20 and sky[2] < 20
    assert quad[1] > 150 and quad[0] < 40 and quad[2] < 40


def latlong_markers(path):
    """A latitude-longitude image (OpenEXR/USD convention: u = 0.5 looks along +z, u = 0.25
    along +x, the top row straight up) grey but for coloured columns at +x, +z, -x, -z."""
    image = np.full((32, 64, 3), 128, np.uint8)
    for u, color in ((0.25, (0, 255, 0)), (0.5, (255, 0, 0)), (0.75, (0, 0, 255))):
        column = int(u * 64)
        image[:, column - 4:column + 4] = color
    image[:, :4] = image[:, -4:] = (255, 255, 0)
    image[:6] = (255, 0, 255)        # the pole
    Image.fromarray(image).save(path)


@pytest.mark.parametrize("look, rotate, expected", [
    ((1, 0, 0), None, "green"), ((0, 0, 1), None, "red"), ((-1, 0, 0), None, "blue"),
    ((0, 0, -1), None, "yellow"),
    ((1, 0, 0), ("Y", 90.0), "red"),    # the dome turned 90° about y: its +z faces +x
    ((0, 0, 1), ("X", 90.0), "magenta"),  # turned 90° about x: its pole (+y) faces +z
    ((0, 1, 0), ("X", 90.0), "yellow"),   # ... and its -z column faces +y
])
def test_dome_texture_orientation(tmp_path, look, rotate, expected):
    # catches: VTK's own latitude-longitude convention (a quarter turn off USD's) and the
    # dome prim's rotation ignored.
    latlong_markers(tmp_path / "sky.png")
    stage = Usd.Stage.CreateNew(str(tmp_path / "dome.usda"))
    dome = UsdLux.DomeLight.Define(stage, "/Dome")
    dome.CreateTextureFileAttr(Sdf.AssetPath("./sky.png"))
    if rotate is not None:
        getattr(dome, f"AddRotate{rotate[0]}Op")().Set(rotate[1])
    camera = UsdGeom.Camera.Define(stage, "/Cam")
    up = Gf.Vec3d(0, 0, 1) if look[1] else Gf.Vec3d(0, 1, 0)
    view = Gf.Matrix4d().SetLookAt(Gf.Vec3d(0, 0, 0), Gf.Vec3d(*look), up)
    camera.AddTransformOp().Set(view.GetInverse())
    stage.GetRootLayer().Save()
    centre = cm.load_scene(tmp_path / "dome.usda").render(size=(64, 48))[24, 32].astype(int)
    colors = {"green": (0, 255, 0), "red": (255, 0, 0), "blue": (0, 0, 255),
              "yellow": (255, 255, 0), "magenta": (255, 0, 255), "grey": (128, 128, 128)}
    nearest = min(colors, key=lambda name: np.abs(centre - colors[name]).sum())
    assert nearest == expected, centre


def test_orm_packing_and_texture_settings_reach_vtk(tmp_path):
    # catches: the ORM channels out of order (VTK: occlusion R, roughness G, metallic B), the
    # wrap mode, the UsdTransform2d and the emissive texture's sRGB flag not handed to VTK.
    from pv_cubemarch.scene.textures import orm_image
    Image.new("RGB", (2, 2), (10, 200, 30)).save(tmp_path / "rough.png")
    rough = TextureInput(file=str(tmp_path / "rough.png"), channels="g", color_space="raw")
    assert orm_image(0.2, rough, 0.7)[0, 0].tolist() == [51, 200, 178]
    path = uv_texture_stage(tmp_path, {
        "file": (Sdf.ValueTypeNames.Asset, "./rough.png"),
        "wrapS": (Sdf.ValueTypeNames.Token, "mirror"),
        "wrapT": (Sdf.ValueTypeNames.Token, "mirror")})
    stage = Usd.Stage.Open(str(path))
    surface = UsdShade.Shader(stage.GetPrimAtPath("/Mat/PS"))
    tex = UsdShade.Shader(stage.GetPrimAtPath("/Mat/Tex"))
    surface.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        tex.ConnectableAPI(), "rgb")
    move = UsdShade.Shader.Define(stage, "/Mat/Move")
    move.CreateIdAttr("UsdTransform2d")
    move.CreateInput("translation", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0.25, 0.5))
    tex.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(move.ConnectableAPI(),
                                                                     "result")
    ball = UsdGeom.Sphere(stage.GetPrimAtPath("/Ball"))
    stage.RemovePrim("/Ball")
    mesh = UsdGeom.Mesh.Define(stage, "/Ball")
    mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (1, 1, 0)])
    mesh.CreateFaceVertexCountsAttr([3])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2])
    UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                            UsdGeom.Tokens.vertex).Set([(0, 0), (1, 0), (1, 1)])
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(
        UsdShade.Material(stage.GetPrimAtPath("/Mat")))
    del ball
    stage.GetRootLayer().Save()
    pl = cm.offscreen_plotter((32, 32))
    try:
        actors = cm.load_scene(path).add_to(pl)
        actor = actors["/Ball"]
        prop = actor.GetProperty()
        albedo = prop.GetTexture("albedoTex")
        assert albedo.GetWrap() == albedo.MirroredRepeat
        assert prop.GetTexture("emissiveTex").GetUseSRGBColorSpace()
        st = np.asarray(actor.mapper.dataset.active_texture_coordinates)
        assert st.tolist() == [[0.25, 0.5], [1.25, 0.5], [1.25, 1.5]]
    finally:
        pl.close()


def test_constant_normal_and_default_valued_inputs(tmp_path):
    # From the usd-wg survey: a constant `normal = (0, 0, 1)` on a textured material crashed
    # the drawing (a tuple taken for a normal map), and inputs authored at their defaults
    # (clearcoat 0, ior 1.5) flooded the report though nothing is lost.
    texture_file(tmp_path / "tex.png")
    path = quad_stage(tmp_path)
    stage = Usd.Stage.Open(str(path))
    surface = UsdShade.Shader(stage.GetPrimAtPath("/Mat/PS"))
    surface.CreateInput("normal", Sdf.ValueTypeNames.Normal3f).Set(Gf.Vec3f(0, 0, 1))
    surface.CreateInput("clearcoat", Sdf.ValueTypeNames.Float).Set(0.0)
    surface.CreateInput("ior", Sdf.ValueTypeNames.Float).Set(1.5)
    surface.CreateInput("clearcoatRoughness", Sdf.ValueTypeNames.Float).Set(0.3)
    stage.GetRootLayer().Save()
    scene = cm.load_scene(path)
    assert scene.meshes[0].material.normal is None
    assert scene.meshes[0].material.ignored == ["clearcoatRoughness"]
    assert render(path)[60, 100][0] > 100          # drawn, textured


def test_an_up_axis_other_than_y_or_z_is_reported(tmp_path):
    path = tmp_path / "x.usda"
    path.write_text('#usda 1.0\n(\n    upAxis = "X"\n)\ndef Sphere "Ball" {}\n')
    with pytest.warns(cm.SceneWarning, match="upAxis 'X'"):
        scene = cm.load_scene(path)
    assert scene.up_axis == "Y" and scene.render(size=(32, 24)).shape == (24, 32, 3)


def _bomb_png(path, width=40000, height=40000):
    """A small PNG whose header claims ``width`` x ``height`` (Pillow refuses it at open)."""
    import struct
    import zlib as _zlib
    tmp = path.with_suffix(".small.png")
    Image.fromarray(np.zeros((4, 4, 3), np.uint8)).save(tmp)
    raw = bytearray(tmp.read_bytes())
    raw[16:24] = struct.pack(">II", width, height)                 # IHDR width, height
    raw[29:33] = struct.pack(">I", _zlib.crc32(bytes(raw[12:29])))  # and its CRC
    path.write_bytes(bytes(raw))


def test_a_decompression_bomb_is_a_warning_and_the_quad_still_draws(tmp_path):
    # catches: Pillow's DecompressionBombError escaping (the whole render failed)
    _bomb_png(tmp_path / "tex.png")
    with pytest.warns(cm.SceneWarning, match="decompression bomb"):
        image = render(quad_stage(tmp_path))
    assert np.abs(image[100, 100] - image[3, 3]).sum() > 30       # the quad, untextured


def test_a_texture_over_the_budget_is_reduced_kept_as_bytes_and_noted(tmp_path, monkeypatch):
    # catches: textures decoded as float64 RGBA and copied (7.8 GB for an 8k texture) and
    # an image over the budget kept whole. By hand: 6000 x 5000 at 4 bytes a texel is
    # 120 MB; reduced 2x, 30 MB, still over 16 MiB; 3x: 2000 x 1667 x 4 = 13.3 MB.
    import tracemalloc

    from pv_cubemarch.scene import textures
    monkeypatch.setenv(textures.TEXTURE_BYTES_ENV, str(16 << 20))
    picture = np.zeros((5000, 6000, 3), np.uint8)
    picture[:2500, :, 0] = 200                                     # top half red
    Image.fromarray(picture).save(tmp_path / "big.png")
    texture = TextureInput(file=str(tmp_path / "big.png"))
    textures._decoded.cache_clear()
    textures._values.cache_clear()
    tracemalloc.start()
    try:
        image = base_color_image(texture, 1.0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert image.shape == (5000 // 3 + 1, 2000, 4) and image.dtype == np.uint8
    assert tuple(image[0, 0]) == (200, 0, 0, 255) and tuple(image[-1, -1]) == (0, 0, 0, 255)
    # the kept bytes and the packed image (2 x 13.3 MB); one float64 RGBA copy is 107 MB
    assert peak < 40 << 20, f"{peak / 2**20:.0f} MiB traced"
    note = textures.texture_note(texture)
    assert "6000x5000" in note and "2000x1667" in note and textures.TEXTURE_BYTES_ENV in note


def test_a_dome_texture_bomb_is_a_warning_and_the_rest_draws(tmp_path):
    # catches: the dome image decoded with no bomb check and as float64 (an uncaught
    # DecompressionBombError ended the render)
    _bomb_png(tmp_path / "sky.png")
    path = quad_stage(tmp_path, texture=None, lights=None)
    stage = Usd.Stage.Open(str(path))
    UsdLux.DomeLight.Define(stage, "/Dome").CreateTextureFileAttr(Sdf.AssetPath("./sky.png"))
    stage.GetRootLayer().Save()
    with pytest.warns(cm.SceneWarning, match="decompression bomb"):
        image = render(path)
    assert np.abs(image[100, 100] - image[3, 3]).sum() > 30        # the quad is drawn
