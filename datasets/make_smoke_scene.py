"""Make datasets/smoke_scene.usda and its density field smoke_density.vti.

A rising smoke plume (fractal value noise shaped by a widening column) on a 64^3 grid, a
torus that passes through it, a ground slab, a camera, a distant light and a dome light,
plus one guide prim that loaders must skip. Run: python datasets/make_smoke_scene.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyvista as pv
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, UsdVol

HERE = Path(__file__).resolve().parent
N = 64


def value_noise(shape, cells, rng):
    """Smooth random field: random lattice values, trilinear with smoothstep weights."""
    lattice = rng.random((cells + 1,) * 3)
    axes = [np.linspace(0, cells, n, endpoint=False) for n in shape]
    grid = np.meshgrid(*axes, indexing="ij")
    base = [np.floor(g).astype(int) for g in grid]
    frac = [g - b for g, b in zip(grid, base, strict=True)]
    w = [f * f * (3 - 2 * f) for f in frac]
    out = np.zeros(shape)
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                weight = ((w[0] if dx else 1 - w[0]) * (w[1] if dy else 1 - w[1])
                          * (w[2] if dz else 1 - w[2]))
                out += weight * lattice[base[0] + dx, base[1] + dy, base[2] + dz]
    return out


def smoke_density(n=N, seed=7):
    rng = np.random.default_rng(seed)
    x, y, z = np.meshgrid(*(np.linspace(-1, 1, n),) * 3, indexing="ij")
    fbm = sum(value_noise((n, n, n), 2 ** (o + 2), rng) / 2 ** o for o in range(4)) / 1.875
    height = (y + 1) / 2  # 0 at the bottom, 1 at the top
    radius = 0.18 + 0.45 * height
    sway = 0.15 * np.sin(3.0 * height)
    r = np.sqrt((x - sway) ** 2 + z ** 2)
    column = np.clip(1 - r / radius, 0, 1) ** 1.5 * np.clip(1.2 - height, 0, 1)
    density = np.clip(column * (0.4 + 1.2 * fbm) - 0.05, 0, None)
    return (density / density.max()).astype(np.float32)


def write_field(path: Path) -> None:
    grid = pv.ImageData(dimensions=(N, N, N), spacing=(2 / (N - 1),) * 3, origin=(-1, -1, -1))
    grid.point_data["density"] = smoke_density().ravel(order="F")
    grid.save(str(path), binary=True, compression="zlib")


def preview_material(stage, path, color, roughness):
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, f"{path}/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*color))
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(roughness)
    shader.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(1.0)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material


def write_stage(path: Path, field_file: str) -> None:
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())

    torus = pv.ParametricTorus(ringradius=0.55, crosssectionradius=0.14, u_res=72, v_res=24,
                              w_res=1).triangulate().clean()
    mesh = UsdGeom.Mesh.Define(stage, "/World/Torus")
    mesh.CreatePointsAttr([Gf.Vec3f(*map(float, p)) for p in np.asarray(torus.points)])
    faces = torus.faces.reshape(-1, 4)
    mesh.CreateFaceVertexCountsAttr([3] * len(faces))
    mesh.CreateFaceVertexIndicesAttr(faces[:, 1:].ravel().tolist())
    mesh.CreateSubdivisionSchemeAttr("none")
    xform = UsdGeom.Xformable(mesh)
    xform.AddTranslateOp().Set(Gf.Vec3d(0.35, -0.2, 0.0))
    xform.AddRotateXYZOp().Set(Gf.Vec3f(70, 0, 20))
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(
        preview_material(stage, "/World/Looks/Copper", (0.85, 0.45, 0.25), 0.35))

    ground = UsdGeom.Cube.Define(stage, "/World/Ground")
    ground.CreateSizeAttr(1.0)
    gx = UsdGeom.Xformable(ground)
    gx.AddTranslateOp().Set(Gf.Vec3d(0, -1.08, 0))
    gx.AddScaleOp().Set(Gf.Vec3f(4.0, 0.1, 4.0))
    UsdShade.MaterialBindingAPI.Apply(ground.GetPrim()).Bind(
        preview_material(stage, "/World/Looks/Slate", (0.35, 0.37, 0.42), 0.8))

    guide = UsdGeom.Cube.Define(stage, "/World/BoundsGuide")
    guide.CreatePurposeAttr(UsdGeom.Tokens.guide)
    guide.CreateSizeAttr(2.0)

    volume = UsdVol.Volume.Define(stage, "/World/Smoke")
    field = stage.DefinePrim("/World/Smoke/density")
    field.CreateAttribute("filePath", Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(field_file))
    field.CreateAttribute("fieldName", Sdf.ValueTypeNames.Token).Set("density")
    volume.CreateFieldRelationship("density", field.GetPath())
    prim = volume.GetPrim()
    prim.CreateAttribute("cubemarch:cmap", Sdf.ValueTypeNames.String).Set("inferno")
    prim.CreateAttribute("cubemarch:opacity", Sdf.ValueTypeNames.String).Set("linear")
    prim.CreateAttribute("cubemarch:clim", Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(0.0, 0.7))
    prim.CreateAttribute("cubemarch:opacityUnitDistance", Sdf.ValueTypeNames.Float).Set(0.06)

    camera = UsdGeom.Camera.Define(stage, "/World/Camera")
    camera.CreateFocalLengthAttr(35.0)
    camera.CreateHorizontalApertureAttr(36.0)
    camera.CreateVerticalApertureAttr(27.0)
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.1, 100.0))
    camera.CreateFocusDistanceAttr(5.2)
    eye = Gf.Vec3d(2.6, 1.3, 4.2)
    view = Gf.Matrix4d().SetLookAt(eye, Gf.Vec3d(0, -0.1, 0), Gf.Vec3d(0, 1, 0))
    UsdGeom.Xformable(camera).AddTransformOp().Set(view.GetInverse())

    sun = UsdLux.DistantLight.Define(stage, "/World/Sun")
    sun.CreateNormalizeAttr(True)   # intensity is the irradiance, not the sun disk's radiance
    sun.CreateIntensityAttr(3.0)
    sun.CreateColorAttr(Gf.Vec3f(1.0, 0.95, 0.85))
    UsdGeom.Xformable(sun).AddRotateXYZOp().Set(Gf.Vec3f(-50, 35, 0))
    dome = UsdLux.DomeLight.Define(stage, "/World/Sky")
    dome.CreateIntensityAttr(0.6)
    stage.GetRootLayer().Save()


def main() -> None:
    write_field(HERE / "smoke_density.vti")
    write_stage(HERE / "smoke_scene.usda", "./smoke_density.vti")
    print("wrote", HERE / "smoke_scene.usda", "and", HERE / "smoke_density.vti")


if __name__ == "__main__":
    main()
