"""Read a USD stage (.usd, .usda, .usdc, .usdz) into a :class:`~pv_cubemarch.scene.model.Scene`.

USD composes references, payloads and instancing for us; we walk the composed stage
(instance proxies included), load what is drawable and record what we skip and why.
Transfer functions are not part of USD: a ``Volume`` prim may carry ``cubemarch:cmap``,
``cubemarch:opacity``, ``cubemarch:clim`` and ``cubemarch:opacityUnitDistance``, and the
options of :func:`pv_cubemarch.add_volume` in camel case (:data:`VOLUME_OPTIONS`):
``cubemarch:technique``, ``stepScale``, ``stopOpacity``, ``skipEmpty``, ``downsample``,
``faceSize``, ``maxSamples``, ``upscale``, ``sampleFactor``, ``occlusionSharpness``,
``lights`` (``"scene"``: lit by the stage's lights, or ``"none"``), ``lightMapSize`` and
``ambient``. The field
prim a ``field:*`` relationship targets has an asset ``filePath`` (.vti/.vtk/.npy/.npz)
and, for numpy files, optional ``cubemarch:origin`` and ``cubemarch:spacing``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyvista
from pxr import Gf, Tf, Usd, UsdGeom, UsdShade, UsdVol

from ..core.camera import Camera
from ..core.errors import SceneLoadError, VolumeDataError
from ..core.progress import progress
from ..models.volume import make_volume
from .model import Scene, SceneLight, SceneMesh, SkippedPrim

USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")
PRIMITIVES = ("Sphere", "Cube", "Cylinder", "Cone", "Capsule")
_CONTAINERS = ("", "Xform", "Scope", "Material", "Shader", "NodeGraph", "GeomSubset",
               "Camera", "DistantLight", "SphereLight", "DomeLight", "Volume", "Mesh",
               "OpenVDBAsset", "Field3DAsset", *PRIMITIVES)


def load_usd(path: str | Path, progress_bar: bool | None = None) -> Scene:
    """Open ``path`` and convert its drawable prims; raise :class:`SceneLoadError` if it can't."""
    path = Path(path)
    if not path.is_file():
        raise SceneLoadError(f"USD file {str(path)!r} does not exist.")
    try:
        stage = Usd.Stage.Open(str(path))
    except Tf.ErrorException as exc:
        raise SceneLoadError(f"USD file {str(path)!r} could not be opened: {exc}") from exc
    if stage is None:
        raise SceneLoadError(f"USD file {str(path)!r} could not be opened (not a USD layer?).")
    scene = Scene(source=str(path), up_axis=str(UsdGeom.GetStageUpAxis(stage)),
                  meters_per_unit=float(UsdGeom.GetStageMetersPerUnit(stage)))
    reader = _StageReader(stage, scene)
    predicate = Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate)
    walk = iter(Usd.PrimRange(stage.GetPseudoRoot(), predicate))
    next(walk)  # the pseudo-root
    prims = progress(walk, desc=f"loading {path.name}", enabled=progress_bar)
    for prim in prims:
        reason = reader.skip_reason(prim)
        if reason:
            if reason != "silent":
                scene.skipped.append(SkippedPrim(str(prim.GetPath()), reason))
            walk.PruneChildren()
            continue
        reader.read(prim)
    return scene


class _StageReader:
    """Converts prims of one stage; keeps the transform cache and stage-wide state."""

    def __init__(self, stage, scene: Scene):
        self.stage = stage
        self.scene = scene
        self.time = Usd.TimeCode.Default()
        self.xforms = UsdGeom.XformCache(self.time)

    def skip_reason(self, prim) -> str | None:
        if not prim.IsActive():
            return "inactive"
        if prim.IsAbstract() or not prim.IsDefined():
            return "silent"
        imageable = UsdGeom.Imageable(prim)
        if imageable:
            if imageable.GetVisibilityAttr().Get(self.time) == UsdGeom.Tokens.invisible:
                return "invisible"
            purpose = imageable.GetPurposeAttr().Get(self.time)
            if purpose in (UsdGeom.Tokens.guide, UsdGeom.Tokens.proxy):
                return f"purpose is {purpose}"
        type_name = str(prim.GetTypeName())
        if type_name not in _CONTAINERS and not _is_field(prim):
            return f"unsupported prim type {type_name}"
        return None

    def world_matrix(self, prim) -> np.ndarray:
        """Column-vector 4x4 world matrix (USD stores row-vector matrices)."""
        return np.array(self.xforms.GetLocalToWorldTransform(prim), dtype=np.float64).T

    def read(self, prim) -> None:
        type_name = str(prim.GetTypeName())
        name = str(prim.GetPath())
        if type_name == "Mesh":
            self.scene.meshes.append(self._mesh(prim, name))
        elif type_name in PRIMITIVES:
            self.scene.meshes.append(self._primitive(prim, type_name, name))
        elif type_name == "Camera":
            self.scene.cameras[name] = self._camera(prim)
        elif type_name in ("DistantLight", "SphereLight", "DomeLight"):
            self.scene.lights.append(self._light(prim, type_name, name))
        elif type_name == "Volume":
            self._volume(prim, name)

    # -- geometry ---------------------------------------------------------------------
    def _mesh(self, prim, name: str) -> SceneMesh:
        usd_mesh = UsdGeom.Mesh(prim)
        points = np.asarray(usd_mesh.GetPointsAttr().Get(self.time) or [], dtype=np.float64)
        counts = np.asarray(usd_mesh.GetFaceVertexCountsAttr().Get(self.time) or [], dtype=int)
        indices = np.asarray(usd_mesh.GetFaceVertexIndicesAttr().Get(self.time) or [], dtype=int)
        if counts.sum() != indices.size or (indices.size and indices.max() >= len(points)):
            raise SceneLoadError(f"Mesh {name} has inconsistent faceVertexCounts/Indices.")
        if usd_mesh.GetOrientationAttr().Get(self.time) == UsdGeom.Tokens.leftHanded:
            indices = _reverse_faces(counts, indices)
        faces = np.insert(indices, np.cumsum(np.concatenate([[0], counts[:-1]])), counts)
        mesh = pyvista.PolyData(points.reshape(-1, 3), faces=faces if counts.size else None)
        normals = usd_mesh.GetNormalsAttr().Get(self.time)
        if normals is not None and len(normals):
            normals = np.asarray(normals, dtype=np.float64)
            interp = usd_mesh.GetNormalsInterpolation()
            if interp == UsdGeom.Tokens.faceVarying and len(normals) == indices.size:
                normals = _average_per_point(normals, indices, len(points))
            if len(normals) == len(points):
                mesh.point_data["Normals"] = normals
                mesh.point_data.active_normals_name = "Normals"
        scene_mesh = SceneMesh(name=name, mesh=mesh)
        self._material(prim, scene_mesh, counts, indices)
        scene_mesh.mesh = _transformed(scene_mesh.mesh, self.world_matrix(prim))
        return scene_mesh

    def _primitive(self, prim, type_name: str, name: str) -> SceneMesh:
        schema = getattr(UsdGeom, type_name)(prim)
        get = lambda attr: schema.GetPrim().GetAttribute(attr).Get(self.time)  # noqa: E731
        axis = {"X": (1, 0, 0), "Y": (0, 1, 0), "Z": (0, 0, 1)}
        if type_name == "Sphere":
            mesh = pyvista.Sphere(radius=get("radius"), theta_resolution=48, phi_resolution=32)
        elif type_name == "Cube":
            size = get("size")
            mesh = pyvista.Cube(x_length=size, y_length=size, z_length=size).triangulate()
        elif type_name == "Cylinder":
            mesh = pyvista.Cylinder(direction=axis[get("axis")], radius=get("radius"),
                                    height=get("height"), resolution=48)
        elif type_name == "Cone":
            mesh = pyvista.Cone(direction=axis[get("axis")], radius=get("radius"),
                                height=get("height"), resolution=48)
        else:
            mesh = pyvista.Capsule(direction=axis[get("axis")], radius=get("radius"),
                                   cylinder_length=get("height"), resolution=32)
        mesh = mesh.extract_surface() if not isinstance(mesh, pyvista.PolyData) else mesh
        scene_mesh = SceneMesh(name=name, mesh=mesh)
        self._material(prim, scene_mesh, None, None)
        scene_mesh.mesh = _transformed(mesh, self.world_matrix(prim))
        return scene_mesh

    def _material(self, prim, scene_mesh: SceneMesh, counts, indices) -> None:
        primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar("displayColor")
        if primvar and primvar.HasValue():
            colors = np.asarray(primvar.ComputeFlattened(self.time), dtype=np.float64)
            interp = primvar.GetInterpolation()
            n_points = scene_mesh.mesh.n_points
            if len(colors) == 1 or interp == UsdGeom.Tokens.constant:
                scene_mesh.color = tuple(float(c) for c in colors[0])
            elif interp == UsdGeom.Tokens.vertex and len(colors) == n_points:
                scene_mesh.mesh.point_data["displayColor"] = colors
                scene_mesh.vertex_colors = "displayColor"
            elif interp == UsdGeom.Tokens.uniform and len(colors) == scene_mesh.mesh.n_cells:
                scene_mesh.mesh.cell_data["displayColor"] = colors
                scene_mesh.vertex_colors = "displayColor"
            elif indices is not None and len(colors) == indices.size:
                scene_mesh.mesh.point_data["displayColor"] = _average_per_point(
                    colors, indices, n_points)
                scene_mesh.vertex_colors = "displayColor"
        opacity = UsdGeom.PrimvarsAPI(prim).GetPrimvar("displayOpacity")
        if opacity and opacity.HasValue():
            scene_mesh.opacity = float(np.mean(opacity.ComputeFlattened(self.time)))
        material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
        if not material:
            return
        shader = material.ComputeSurfaceSource()[0]
        if not shader or shader.GetIdAttr().Get() != "UsdPreviewSurface":
            return
        for input_name, setter in (("diffuseColor", "color"), ("opacity", "opacity"),
                                   ("roughness", "roughness")):
            value = _shader_input(shader, input_name)
            if value is None:
                continue
            if setter == "color":
                scene_mesh.color = tuple(float(c) for c in value)
                scene_mesh.vertex_colors = None
            else:
                setattr(scene_mesh, setter, float(value))

    # -- camera and lights ------------------------------------------------------------
    def _camera(self, prim) -> Camera:
        gf_camera = UsdGeom.Camera(prim).GetCamera(self.time)
        matrix = self.world_matrix(prim)
        position = matrix[:3, 3]
        forward = matrix[:3, :3] @ np.array([0.0, 0.0, -1.0])
        up = matrix[:3, :3] @ np.array([0.0, 1.0, 0.0])
        forward /= np.linalg.norm(forward)
        distance = gf_camera.focusDistance if gf_camera.focusDistance > 0 else 1.0
        clip = gf_camera.clippingRange
        camera = Camera(position=tuple(position), focal_point=tuple(position + forward * distance),
                        view_up=tuple(up / np.linalg.norm(up)),
                        view_angle=float(gf_camera.GetFieldOfView(Gf.Camera.FOVVertical)),
                        clipping_range=(float(clip.min), float(clip.max)))
        if gf_camera.projection == Gf.Camera.Orthographic:
            camera.parallel_projection = True
            camera.parallel_scale = gf_camera.verticalAperture * Gf.Camera.APERTURE_UNIT / 2.0
        return camera

    def _light(self, prim, type_name: str, name: str) -> SceneLight:
        def value(attr, default):
            attribute = prim.GetAttribute(attr)
            got = attribute.Get(self.time) if attribute else None
            return default if got is None else got

        intensity = float(value("inputs:intensity", 1.0)) * 2.0 ** float(
            value("inputs:exposure", 0.0))
        color = tuple(float(c) for c in value("inputs:color", (1.0, 1.0, 1.0)))
        matrix = self.world_matrix(prim)
        kind = {"DistantLight": "distant", "SphereLight": "sphere", "DomeLight": "dome"}[type_name]
        light = SceneLight(name=name, kind=kind, color=color, intensity=intensity)
        if kind == "distant":
            direction = matrix[:3, :3] @ np.array([0.0, 0.0, -1.0])
            light.direction = tuple(direction / np.linalg.norm(direction))
        elif kind == "sphere":
            light.position = tuple(matrix[:3, 3])
        return light

    # -- volumes ----------------------------------------------------------------------
    def _volume(self, prim, name: str) -> None:
        fields = UsdVol.Volume(prim).GetFieldPaths()
        if not fields:
            self.scene.skipped.append(SkippedPrim(name, "Volume has no field relationship"))
            return
        field_name = "density" if "density" in fields else sorted(fields)[0]
        field_prim = self.stage.GetPrimAtPath(fields[field_name])
        if not field_prim:
            raise SceneLoadError(f"Volume {name}: field:{field_name} targets missing prim "
                                 f"{fields[field_name]}.")
        grid = _read_field(field_prim)
        attrs = {key: _attr(prim, f"cubemarch:{key}") for key in
                 ("cmap", "opacity", "clim", "opacityUnitDistance",
                  *(usd_key for usd_key, _, _ in VOLUME_OPTIONS))}
        options = {}
        for key, option, kind in VOLUME_OPTIONS:
            if attrs[key] is not None:
                options[option] = kind(attrs[key])
        if options.get("lights") == "none":
            options["lights"] = None
        opacity = attrs["opacity"]
        if opacity is not None and not isinstance(opacity, str):
            opacity = [float(v) for v in opacity]
        try:
            volume = make_volume(
                grid, cmap=attrs["cmap"] or "magma", opacity=opacity or "linear",
                clim=tuple(attrs["clim"]) if attrs["clim"] is not None else None,
                opacity_unit_distance=attrs["opacityUnitDistance"],
                transform=self.world_matrix(prim), name=name)
        except VolumeDataError as exc:
            raise VolumeDataError(f"Volume {name} (field {field_prim.GetPath()}): {exc}") from exc
        self.scene.volumes.append(volume)
        if options:
            self.scene.volume_options[name] = options


#: ``cubemarch:*`` attributes of a Volume prim and the ``add_volume`` options they set.
VOLUME_OPTIONS = (
    ("stepScale", "step_scale", float), ("technique", "technique", str),
    ("stopOpacity", "stop_opacity", float), ("skipEmpty", "skip_empty", bool),
    ("downsample", "downsample", int), ("faceSize", "face_size", int),
    ("maxSamples", "max_samples", int), ("upscale", "upscale", float),
    ("sampleFactor", "sample_factor", float),
    ("occlusionSharpness", "occlusion_sharpness", float), ("lights", "lights", str),
    ("lightMapSize", "light_map_size", int), ("ambient", "ambient", float),
)


def _is_field(prim) -> bool:
    return bool(prim.GetAttribute("filePath"))


def _attr(prim, name):
    attribute = prim.GetAttribute(name)
    return attribute.Get() if attribute and attribute.HasValue() else None


def _read_field(field_prim) -> pyvista.ImageData:
    """Load the grid a field prim's ``filePath`` names (.vti/.vtk/.npy/.npz)."""
    asset = field_prim.GetAttribute("filePath").Get()
    where = f"field prim {field_prim.GetPath()}"
    if asset is None or not asset.path:
        raise SceneLoadError(f"{where} has no filePath.")
    resolved = asset.resolvedPath
    if not resolved:
        layer_dir = Path(field_prim.GetStage().GetRootLayer().realPath).parent
        raise SceneLoadError(f"{where}: volume file {asset.path!r} was not found "
                             f"(looked relative to {layer_dir}).")
    suffix = Path(resolved).suffix.lower()
    field_name = _attr(field_prim, "fieldName")
    if suffix == ".vdb":
        raise SceneLoadError(f"{where}: {asset.path!r} is an OpenVDB file, which pv_cubemarch "
                             "cannot read (no maintained OpenVDB reader on PyPI); convert it to "
                             ".vti or .npy.")
    if suffix in (".vti", ".vtk"):
        try:
            grid = pyvista.read(resolved)
        except Exception as exc:
            raise SceneLoadError(f"{where}: could not read {asset.path!r}: {exc}") from exc
        if field_name and field_name in grid.array_names:
            grid.set_active_scalars(str(field_name))
        return grid
    if suffix in (".npy", ".npz"):
        try:
            loaded = np.load(resolved, allow_pickle=False)
        except Exception as exc:
            raise SceneLoadError(f"{where}: could not read {asset.path!r}: {exc}") from exc
        if suffix == ".npz":
            keys = list(loaded.keys())
            key = str(field_name) if field_name and str(field_name) in keys else keys[0]
            loaded = loaded[key]
        if loaded.ndim != 3:
            raise VolumeDataError(f"{where}: {asset.path!r} holds an array of shape "
                                  f"{loaded.shape}; a volume needs 3 axes (x, y, z).")
        origin = _attr(field_prim, "cubemarch:origin")
        spacing = _attr(field_prim, "cubemarch:spacing")
        grid = pyvista.ImageData(dimensions=loaded.shape,
                                 origin=tuple(origin) if origin is not None else (0, 0, 0),
                                 spacing=tuple(spacing) if spacing is not None else (1, 1, 1))
        if loaded.dtype.kind not in "biuf":
            raise VolumeDataError(f"{where}: {asset.path!r} has dtype {loaded.dtype}; volumes "
                                  "need real numbers.")
        grid.point_data[str(field_name or "density")] = loaded.ravel(order="F")
        return grid
    raise SceneLoadError(f"{where}: unsupported volume file type {suffix!r} ({asset.path!r}); "
                         "use .vti, .vtk, .npy or .npz.")


def _shader_input(shader, name: str):
    shader_input = shader.GetInput(name)
    if not shader_input:
        return None
    for attribute in shader_input.GetValueProducingAttributes():
        value = attribute.Get()
        if value is not None:
            return value
    return None


def _reverse_faces(counts: np.ndarray, indices: np.ndarray) -> np.ndarray:
    out = indices.copy()
    start = 0
    for count in counts:
        out[start:start + count] = indices[start:start + count][::-1]
        start += count
    return out


def _average_per_point(values: np.ndarray, indices: np.ndarray, n_points: int) -> np.ndarray:
    sums = np.zeros((n_points, values.shape[1]))
    np.add.at(sums, indices, values)
    counts = np.bincount(indices, minlength=n_points)[:, None]
    return sums / np.maximum(counts, 1)


def _transformed(mesh: pyvista.PolyData, matrix: np.ndarray) -> pyvista.PolyData:
    if np.allclose(matrix, np.eye(4)):
        return mesh
    # Only points and the active normals move; colours and other 3-vectors must not.
    out = mesh.transform(matrix, inplace=False, transform_all_input_vectors=False)
    if "Normals" in out.point_data:
        normals = np.asarray(out.point_data["Normals"], dtype=np.float64)
        lengths = np.linalg.norm(normals, axis=1, keepdims=True)
        out.point_data["Normals"] = normals / np.where(lengths > 0, lengths, 1.0)
    return out
