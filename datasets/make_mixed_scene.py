"""Make datasets/mixed_scene.usda: every technique and import feature in one small stage.

- a textured stone ground (``UsdUVTexture`` on a repeated ``st``, through a
  ``UsdTransform2d``), a cut-out fence (``opacityThreshold`` on the texture's alpha), a
  polished metal ball and a row of instanced posts (``PointInstancer``);
- smoke from an OpenVDB file (``OpenVDBAsset``, emission/absorption, ``cubemarch:technique
  = "cubemap"``), a voxel terrain (``"voxels"``) and an implicit surface (``"surface"``);
- a sky dome with a latitude-longitude texture (image-based lighting and background) and
  a sun, and a camera.

Run: ``python datasets/make_mixed_scene.py``. The OpenVDB file is written by OpenVDB itself
(Debian's ``python3-openvdb`` under ``/usr/bin/python3``); the rest with usd-core and numpy.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
from PIL import Image
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, UsdVol

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from make_smoke_scene import smoke_density  # noqa: E402

SMOKE_VOXELS = 40
#: Written by /usr/bin/python3 with Debian's pyopenvdb: a fog volume from a .npy array.
_WRITE_VDB = """
import sys, numpy, pyopenvdb as vdb
values = numpy.load(sys.argv[1])
grid = vdb.FloatGrid()
grid.copyFromArray(values, ijk=(0, 0, 0), tolerance=0.02)
grid.name = "density"
grid.gridClass = vdb.GridClass.FOG_VOLUME
grid.transform = vdb.createLinearTransform(voxelSize=float(sys.argv[3]))
grid.saveFloatAsHalf = True
vdb.write(sys.argv[2], grids=[grid])
"""


def write_textures() -> None:
    """Stone tiles, a fence with holes and a sky, all small PNGs."""
    rng = np.random.default_rng(3)
    stone = np.zeros((32, 32, 3))
    stone[:] = (0.55, 0.53, 0.5)
    stone[::16, :] = stone[:, ::16] = (0.3, 0.29, 0.28)          # mortar lines
    stone *= 0.85 + 0.3 * rng.random((32, 32, 1))
    Image.fromarray((stone * 255).astype(np.uint8)).save(HERE / "mixed_stone.png")
    fence = np.zeros((32, 32, 4), np.uint8)
    fence[..., :3] = (150, 100, 60)
    fence[..., 3] = 0
    fence[:, 2:6, 3] = fence[:, 14:18, 3] = fence[:, 26:30, 3] = 255   # boards
    fence[6:9, :, 3] = fence[22:25, :, 3] = 255                      # rails
    Image.fromarray(fence).save(HERE / "mixed_fence.png")
    height = np.linspace(1.0, 0.0, 32)[:, None, None]               # row 0: the zenith
    sky = (1 - height) * np.array([0.85, 0.8, 0.7]) + height * np.array([0.35, 0.55, 0.9])
    sky = np.broadcast_to(sky, (32, 64, 3))
    Image.fromarray((sky * 255).astype(np.uint8)).save(HERE / "mixed_sky.png")


def write_grids() -> None:
    """The smoke (OpenVDB), the terrain labels and the surface samples (numpy)."""
    smoke = smoke_density(SMOKE_VOXELS, seed=11)
    np.save(HERE / "mixed_smoke.npy", smoke)
    try:
        subprocess.run(["/usr/bin/python3", "-c", _WRITE_VDB, str(HERE / "mixed_smoke.npy"),
                        str(HERE / "mixed_smoke.vdb"), str(2.0 / SMOKE_VOXELS)], check=True)
    finally:
        (HERE / "mixed_smoke.npy").unlink()
    x, y = np.meshgrid(np.arange(24), np.arange(24), indexing="ij")
    ground = (3 + 2 * np.sin(x / 4.0) + 1.5 * np.cos(y / 5.0)).astype(int)
    labels = np.zeros((24, 24, 10), np.uint8)
    for k in range(10):
        labels[..., k] = np.where(k < ground - 1, 1, np.where(k < ground, 2, 0))  # stone, grass
    labels[10:13, 10:13, :9] = np.where(labels[10:13, 10:13, :9] == 0, 3, 3)     # a tower
    np.save(HERE / "mixed_terrain.npy", labels)
    axes = np.linspace(-1.3, 1.3, 20)
    px, py, pz = np.meshgrid(axes, axes, axes, indexing="ij")
    ring = np.sqrt(px ** 2 + pz ** 2) - 0.8
    np.save(HERE / "mixed_surface.npy", (np.sqrt(ring ** 2 + py ** 2) - 0.3).astype(np.float32))


def preview(stage, path, **inputs) -> UsdShade.Material:
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    for name, value in inputs.items():
        kind = Sdf.ValueTypeNames.Color3f if isinstance(value, tuple) else \
            Sdf.ValueTypeNames.Float
        shader.CreateInput(name, kind).Set(Gf.Vec3f(*value) if isinstance(value, tuple)
                                           else value)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material


def textured(stage, path, file, scale=1.0, cutout=False) -> UsdShade.Material:
    """A material whose colour (and, for cut-outs, opacity) is a texture."""
    material = preview(stage, path, roughness=0.8)
    shader = UsdShade.Shader(stage.GetPrimAtPath(f"{path}/Surface"))
    reader = UsdShade.Shader.Define(stage, f"{path}/St")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
    repeat = UsdShade.Shader.Define(stage, f"{path}/Repeat")
    repeat.CreateIdAttr("UsdTransform2d")
    repeat.CreateInput("in", Sdf.ValueTypeNames.Float2).ConnectToSource(
        reader.ConnectableAPI(), "result")
    repeat.CreateInput("scale", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(scale, scale))
    texture = UsdShade.Shader.Define(stage, f"{path}/Texture")
    texture.CreateIdAttr("UsdUVTexture")
    texture.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(f"./{file}")
    texture.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(
        repeat.ConnectableAPI(), "result")
    for wrap in ("wrapS", "wrapT"):
        texture.CreateInput(wrap, Sdf.ValueTypeNames.Token).Set("repeat")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(
        texture.ConnectableAPI(), "rgb")
    if cutout:
        shader.CreateInput("opacity", Sdf.ValueTypeNames.Float).ConnectToSource(
            texture.ConnectableAPI(), "a")
        shader.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(0.5)
    return material


def quad(stage, path, corners, st_scale=1.0):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(corners)
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateSubdivisionSchemeAttr("none")
    normal = np.cross(np.subtract(corners[1], corners[0]), np.subtract(corners[3], corners[0]))
    mesh.CreateNormalsAttr([Gf.Vec3f(*(normal / np.linalg.norm(normal)).tolist())])
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.constant)
    st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray,
                                                 UsdGeom.Tokens.vertex)
    st.Set([(0, 0), (st_scale, 0), (st_scale, 1), (0, 1)])
    return mesh


def volume(stage, path, file, technique, field="density", asset_type="OpenVDBAsset",
           **attrs):
    prim = UsdVol.Volume.Define(stage, path)
    if asset_type == "OpenVDBAsset":
        asset = UsdVol.OpenVDBAsset.Define(stage, f"{path}/{field}")
        asset.CreateFieldNameAttr(field)
        asset.CreateFilePathAttr(Sdf.AssetPath(f"./{file}"))
        asset_path = asset.GetPath()
    else:
        asset_prim = stage.DefinePrim(f"{path}/{field}")
        asset_prim.CreateAttribute("filePath", Sdf.ValueTypeNames.Asset).Set(f"./{file}")
        asset_path = asset_prim.GetPath()
    prim.CreateFieldRelationship(field, asset_path)
    prim.GetPrim().CreateAttribute("cubemarch:technique", Sdf.ValueTypeNames.Token).Set(
        technique)
    for name, (kind, value) in attrs.items():
        prim.GetPrim().CreateAttribute(f"cubemarch:{name}", kind).Set(value)
    return prim


def write_stage(path: Path) -> None:
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    ground = quad(stage, "/World/Ground", [(-6, 0, 6), (6, 0, 6), (6, 0, -6), (-6, 0, -6)])
    UsdShade.MaterialBindingAPI.Apply(ground.GetPrim()).Bind(
        textured(stage, "/World/Looks/Stone", "mixed_stone.png", scale=6.0))
    fence = quad(stage, "/World/Fence", [(-5, 0, -5), (5, 0, -5), (5, 1.2, -5), (-5, 1.2, -5)],
                 st_scale=8.0)
    fence.CreateDoubleSidedAttr(True)
    UsdShade.MaterialBindingAPI.Apply(fence.GetPrim()).Bind(
        textured(stage, "/World/Looks/Fence", "mixed_fence.png", cutout=True))
    ball = UsdGeom.Sphere.Define(stage, "/World/Ball")
    ball.CreateRadiusAttr(0.9)
    ball.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.9, 2.5))
    UsdShade.MaterialBindingAPI.Apply(ball.GetPrim()).Bind(
        preview(stage, "/World/Looks/Metal", diffuseColor=(0.95, 0.75, 0.45), metallic=1.0,
                roughness=0.25))
    posts = UsdGeom.PointInstancer.Define(stage, "/World/Posts")
    post = UsdGeom.Cylinder.Define(stage, "/World/Posts/Prototypes/Post")
    post.CreateRadiusAttr(0.12)
    post.CreateHeightAttr(1.6)
    post.CreateAxisAttr("Y")
    post.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.8, 0.0))
    post.CreateDisplayColorPrimvar().Set([Gf.Vec3f(0.45, 0.3, 0.2)])
    posts.CreatePrototypesRel().SetTargets([post.GetPath()])
    posts.CreatePositionsAttr([(x, 0.0, 4.5) for x in (-4.5, -2.25, 0.0, 2.25, 4.5)])
    posts.CreateProtoIndicesAttr([0] * 5)
    smoke = volume(stage, "/World/Smoke", "mixed_smoke.vdb", "cubemap",
                   cmap=(Sdf.ValueTypeNames.String, "inferno"),
                   opacityUnitDistance=(Sdf.ValueTypeNames.Float, 0.4),
                   clim=(Sdf.ValueTypeNames.Float2, Gf.Vec2f(0.0, 0.8)))
    smoke.AddTranslateOp().Set(Gf.Vec3d(-3.5, 0.0, 0.0))
    smoke.AddScaleOp().Set(Gf.Vec3f(1.2, 1.5, 1.2))
    terrain = volume(stage, "/World/Terrain", "mixed_terrain.npy", "voxels", field="labels",
                     asset_type="Field",
                     palette=(Sdf.ValueTypeNames.Color3fArray,
                              [(0, 0, 0), (0.5, 0.5, 0.52), (0.35, 0.6, 0.25),
                               (0.75, 0.3, 0.2)]))
    terrain.AddTranslateOp().Set(Gf.Vec3d(1.5, 0.0, -2.0))
    terrain.AddScaleOp().Set(Gf.Vec3f(0.15, 0.15, 0.15))
    terrain.AddRotateXOp().Set(-90.0)     # the labels' z is up
    ring = volume(stage, "/World/Ring", "mixed_surface.npy", "surface", asset_type="Field",
                  isovalue=(Sdf.ValueTypeNames.Float, 0.0),
                  color=(Sdf.ValueTypeNames.Color3f, Gf.Vec3f(0.3, 0.75, 0.85)))
    ring.AddTranslateOp().Set(Gf.Vec3d(-0.8, 1.6, -1.0))
    ring.AddScaleOp().Set(Gf.Vec3f(0.08, 0.08, 0.08))
    sky = UsdLux.DomeLight.Define(stage, "/World/Sky")
    sky.CreateTextureFileAttr(Sdf.AssetPath("./mixed_sky.png"))
    sky.CreateIntensityAttr(0.8)
    sun = UsdLux.DistantLight.Define(stage, "/World/Sun")
    sun.CreateIntensityAttr(2.5)
    sun.CreateNormalizeAttr(True)   # intensity is the irradiance, not the sun disk's radiance
    sun.AddRotateXYZOp().Set(Gf.Vec3f(-50.0, 30.0, 0.0))
    camera = UsdGeom.Camera.Define(stage, "/World/Camera")
    camera.CreateFocalLengthAttr(24.0)
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.1, 100.0))
    camera.AddTranslateOp().Set(Gf.Vec3d(0.0, 4.5, 11.0))
    camera.AddRotateXOp().Set(-20.0)
    stage.GetRootLayer().Save()


if __name__ == "__main__":
    write_textures()
    write_grids()
    write_stage(HERE / "mixed_scene.usda")
    print("wrote", HERE / "mixed_scene.usda", "and its textures and grids")
