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

A ``Volume`` with ``cubemarch:technique = "voxels"`` (or every ``Volume`` with
``load_usd(..., as_voxels=True)``) is a material grid: its field (``field:labels``, else
``field:density``, else the first) holds integer labels, 0 = empty, drawn with
:func:`pv_cubemarch.add_voxels`. Its palette is ``cubemarch:palette`` (``color3f[]`` or
``color4f[]``, entry ``m`` for material ``m``, entry 0 unused) or ``cubemarch:cmap`` (a
colormap name), with optional ``cubemarch:paletteOpacity`` (``float[]``, one per palette
entry, 0 hides a material); its options are :data:`VOXEL_OPTIONS` (``traversal``,
``stepScale``, ``mipLevels``, ``distanceField``, ``mode``, ``shading``, ``ambient``,
``specular``, ``specularPower``, ``ambientOcclusion``, ``occlusionStrength``, ``proxy``,
``lod``, ``lodBias``), checked when the stage is loaded; ``cubemarch:chunkSize`` draws it in
chunks. A numpy label array fills voxels from ``cubemarch:origin`` (the grid box's corner),
as ``add_voxels`` places an array. Voxels Volumes with ``cubemarch:world`` and
``cubemarch:chunk`` are chunks of one world (:mod:`.voxel_worlds`).

A ``Volume`` with ``cubemarch:technique = "surface"`` is an implicit surface: the level
``cubemarch:isovalue`` of its field (``field:density``, else the first; one sample per point,
a cell centred on each), drawn with :func:`pv_cubemarch.add_surface`; its options are
:data:`SURFACE_OPTIONS` (``surfaceTechnique``: ``"active"`` or ``"full"``,
``surfaceTraversal``: ``"index"`` or ``"cell_boxes"``, ``steps``,
``refineSteps``, ``root``, ``activeTest``, ``activeSamples``, ``shading``, ``ambient``,
``specular``, ``specularPower``) and ``cubemarch:color``, checked when the stage is loaded.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pyvista
from pxr import Gf, Tf, Usd, UsdGeom, UsdShade, UsdVol

from ..api import voxel_options
from ..core.camera import Camera
from ..core.errors import SceneLoadError, VolumeDataError
from ..core.progress import progress
from ..core.registry import get_technique
from ..models.field_sources import make_field
from ..models.volume import make_volume
from ..models.voxels import Palette, make_voxels
from .grids import read_grid
from .model import Scene, SceneLight, SceneMesh, SkippedPrim
from .voxel_worlds import ChunkPrim, join_world

USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")
PRIMITIVES = ("Sphere", "Cube", "Cylinder", "Cone", "Capsule")
_CONTAINERS = ("", "Xform", "Scope", "Material", "Shader", "NodeGraph", "GeomSubset",
               "Camera", "DistantLight", "SphereLight", "DomeLight", "Volume", "Mesh",
               "OpenVDBAsset", "Field3DAsset", *PRIMITIVES)


def load_usd(path: str | Path, progress_bar: bool | None = None,
             as_voxels: bool = False) -> Scene:
    """Open ``path`` and convert its drawable prims; raise :class:`SceneLoadError` if it can't.

    Parameters
    ----------
    path : str or pathlib.Path
        The stage (.usd, .usda, .usdc, .usdz).
    progress_bar : bool, optional
        Show a progress bar; by default only on a terminal.
    as_voxels : bool
        Load every ``Volume`` prim as a voxel grid (integer material labels), whatever its
        ``cubemarch:technique``; its volume-only attributes are then ignored.

    Returns
    -------
    Scene
        What the stage draws, and the prims skipped with the reasons.
    """
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
    reader = _StageReader(stage, scene, as_voxels)
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
    for name, chunks in reader.world_chunks.items():
        world, options = join_world(name, chunks)
        scene.voxels.append(world)
        if options:
            scene.voxel_options[name] = options
    return scene


class _StageReader:
    """Converts prims of one stage; keeps the transform cache and stage-wide state."""

    def __init__(self, stage, scene: Scene, as_voxels: bool = False):
        self.stage = stage
        self.scene = scene
        self.as_voxels = as_voxels
        #: Chunks of voxel worlds by world name, joined once the stage is read.
        self.world_chunks: dict[str, list[ChunkPrim]] = {}
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
        voxels = self.as_voxels or _attr(prim, "cubemarch:technique") == "voxels"
        surface = not self.as_voxels and _attr(prim, "cubemarch:technique") == "surface"
        preferred = ("labels", "density") if voxels else ("density",)
        field_name = next((f for f in preferred if f in fields), sorted(fields)[0])
        field_prim = self.stage.GetPrimAtPath(fields[field_name])
        if not field_prim:
            raise SceneLoadError(f"Volume {name}: field:{field_name} targets missing prim "
                                 f"{fields[field_name]}.")
        grid = _read_field(field_prim, cells=voxels)
        if voxels:
            self._voxels(prim, name, field_prim, grid)
            return
        if surface:
            self._surface(prim, name, field_prim, grid)
            return
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

    def _voxels(self, prim, name: str, field_prim, grid) -> None:
        """A material grid from an integer field, with its palette and checked options."""
        where = f"Volume {name} (field {field_prim.GetPath()})"
        if not self.as_voxels:
            other = [f"cubemarch:{key}" for key in _VOLUME_ONLY
                     if _attr(prim, f"cubemarch:{key}") is not None]
            if other:
                raise SceneLoadError(
                    f"Volume {name}: {', '.join(other)} "
                    f"{'does' if len(other) == 1 else 'do'} not apply to "
                    'cubemarch:technique = "voxels" (volume options); remove '
                    f"{'it' if len(other) == 1 else 'them'}, or choose a volume technique.")
        authored = _authored(prim, name, VOXEL_OPTIONS)
        options = {option: value for option, value in authored.values()}
        try:
            voxel_options(**options)
        except ValueError as exc:
            raise _options_error(name, authored, "voxel", exc) from exc
        if not isinstance(grid, pyvista.ImageData):
            raise VolumeDataError(f"{where}: the file holds a {type(grid).__name__}; material "
                                  "labels come on an ImageData (cell or point data).")
        scalars = _field_array(field_prim, grid)
        try:
            model = make_voxels(grid, scalars, transform=self.world_matrix(prim), name=name)
        except VolumeDataError as exc:
            why = "as_voxels=True loads every Volume" if self.as_voxels else \
                'cubemarch:technique = "voxels" draws'
            raise VolumeDataError(f"{where}: {exc} ({why} as integer material labels, "
                                  "0 = empty.)") from exc
        model.palette = _palette(prim, name, where, int(model.labels.max()))
        world = _attr(prim, "cubemarch:world")
        if world is not None:
            key = _attr(prim, "cubemarch:chunk")
            if key is None or len(key) != 3 or min(int(k) for k in key) < 0:
                raise SceneLoadError(f"Volume {name}: cubemarch:world = {str(world)!r} needs "
                                     "cubemarch:chunk, an int3 of whole numbers >= 0 (the "
                                     "chunk's place in the world).")
            size = _attr(prim, "cubemarch:chunkSize")
            self.world_chunks.setdefault(str(world), []).append(ChunkPrim(
                tuple(int(k) for k in key), model, options, str(prim.GetPath()),
                None if size is None else int(size),
                lambda top, prim=prim: _palette(prim, name, where, top)))
            return
        self.scene.voxels.append(model)
        size = _attr(prim, "cubemarch:chunkSize")
        if size is not None:
            options["chunk_size"] = int(size)
        if options:
            self.scene.voxel_options[name] = options


    def _surface(self, prim, name: str, field_prim, grid) -> None:
        """A spline field from sampled data and ``cubemarch:isovalue``, options checked."""
        where = f"Volume {name} (field {field_prim.GetPath()})"
        authored = _authored(prim, name, SURFACE_OPTIONS)
        options = {option: value for option, value in authored.values()}
        color = _attr(prim, "cubemarch:color")
        if color is not None:
            options["color"] = tuple(float(c) for c in color)
        try:
            get_technique("surface", options.get("technique", "active")).make_options(
                {k: v for k, v in options.items() if k != "technique"})
        except ValueError as exc:
            raise _options_error(name, authored, "surface", exc) from exc
        isovalue = _attr(prim, "cubemarch:isovalue")
        if isovalue is None:
            raise SceneLoadError(f"Volume {name}: cubemarch:technique = \"surface\" needs "
                                 "cubemarch:isovalue (the level of the field to draw).")
        scalars = _field_array(field_prim, grid)
        try:
            surface = make_field(grid, float(_converted(name, "isovalue", isovalue, float)),
                                 scalars, transform=self.world_matrix(prim), name=name)
        except VolumeDataError as exc:
            raise VolumeDataError(f"{where}: {exc}") from exc
        self.scene.surfaces.append(surface)
        if options:
            self.scene.surface_options[name] = options


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


#: ``cubemarch:*`` attributes of a voxels Volume prim and the ``add_voxels`` options they set.
VOXEL_OPTIONS = (
    ("traversal", "traversal", str), ("stepScale", "step_scale", float),
    ("mipLevels", "mip_levels", int), ("distanceField", "distance_field", int),
    ("mode", "mode", str), ("shading", "shading", str),
    ("ambient", "ambient", float), ("specular", "specular", float),
    ("specularPower", "specular_power", float),
    ("ambientOcclusion", "ambient_occlusion", bool),
    ("occlusionStrength", "occlusion_strength", float), ("proxy", "proxy", str),
    ("lod", "lod", bool), ("lodBias", "lod_bias", float),
)

#: ``cubemarch:*`` attributes of a surface Volume prim and the ``add_surface`` options they
#: set (with ``cubemarch:isovalue``, required, and ``cubemarch:color``, a color3f).
SURFACE_OPTIONS = (
    ("surfaceTechnique", "technique", str), ("surfaceTraversal", "traversal", str),
    ("steps", "steps", int),
    ("refineSteps", "refine_steps", int), ("root", "root", str),
    ("activeTest", "active_test", str), ("activeSamples", "active_samples", int),
    ("shading", "shading", str), ("ambient", "ambient", float),
    ("specular", "specular", float), ("specularPower", "specular_power", float),
)

#: Volume attributes that a voxels Volume prim must not carry.
_VOLUME_ONLY = tuple(key for key in ("opacity", "clim", "opacityUnitDistance",
                                     *(usd_key for usd_key, _, _ in VOLUME_OPTIONS))
                     if key != "technique" and key not in {k for k, _, _ in VOXEL_OPTIONS})


def _options_error(name: str, authored: dict, kind: str, error: ValueError) -> SceneLoadError:
    """A SceneLoadError naming the authored attributes the options' ``error`` is about."""
    named = [f"cubemarch:{key} = {value!r}" for key, (option, value) in authored.items()
             if re.search(rf"\b{option}\b", str(error))]
    return SceneLoadError(f"Volume {name}: {', '.join(named) or f'its {kind} options'}: "
                          f"{error}")


def _field_array(field_prim, grid) -> str | None:
    """The grid's array the field prim's ``fieldName`` names, if the grid has it."""
    field_name = _attr(field_prim, "fieldName")
    return str(field_name) if field_name and str(field_name) in grid.array_names else None


def _authored(prim, name: str, table) -> dict:
    """The ``cubemarch:*`` options of ``table`` authored on ``prim``.

    ``{key: (option, value)}``, each converted to its kind (a SceneLoadError names a
    wrong one).
    """
    authored = {}
    for key, option, kind in table:
        value = _attr(prim, f"cubemarch:{key}")
        if value is not None:
            authored[key] = (option, _converted(name, key, value, kind))
    return authored


def _converted(name: str, key: str, value, kind):
    """An authored option value as ``kind``, or a SceneLoadError naming the attribute."""
    try:
        if kind is str:
            if not isinstance(value, str):
                raise TypeError
            return str(value)
        if kind is bool:
            if not isinstance(value, bool):
                raise TypeError
            return value
        if kind is int:
            if isinstance(value, (str, bool)) or float(value) != int(value):
                raise ValueError
            return int(value)
        if isinstance(value, (str, bool)):
            raise TypeError
        return kind(value)
    except (TypeError, ValueError, OverflowError):
        expected = {str: "a string or token", int: "a whole number", float: "a number",
                    bool: "a bool"}[kind]
        raise SceneLoadError(f"Volume {name}: cubemarch:{key} must be {expected}, got "
                             f"{value!r}.") from None


def _palette(prim, name: str, where: str, top: int) -> Palette:
    """The palette a voxels Volume prim asks for, covering labels ``0..top``."""
    colors = _attr(prim, "cubemarch:palette")
    opacity = _attr(prim, "cubemarch:paletteOpacity")
    cmap = _attr(prim, "cubemarch:cmap")
    if colors is not None and cmap is not None:
        raise SceneLoadError(f"Volume {name} sets both cubemarch:palette (a colour per "
                             "material) and cubemarch:cmap (a colormap name); keep one.")
    if opacity is not None:
        authored = opacity
        try:
            opacity = np.asarray(opacity, dtype=np.float64)
        except (TypeError, ValueError):
            opacity = np.zeros(())
        if opacity.ndim != 1:
            raise SceneLoadError(f"Volume {name}: cubemarch:paletteOpacity must be a float[] "
                                 f"(one opacity per palette entry), got {authored!r}.")
    if colors is not None:
        rgb = np.asarray(colors)
        if rgb.ndim != 2 or rgb.shape[1] not in (3, 4) or rgb.dtype.kind not in "fiu":
            raise SceneLoadError(f"Volume {name}: cubemarch:palette must be a color3f[] (or "
                                 "color4f[]) array, one colour per material (entry 0 unused), "
                                 f"got {colors!r}.")
        if len(rgb) <= top:
            raise VolumeDataError(f"{where}: cubemarch:palette has {len(rgb)} entries "
                                  f"(materials 0..{len(rgb) - 1}) but the labels go up to "
                                  f"{top}; give at least {top + 1} colours (entry 0, empty, "
                                  "is unused).")
        rgba = np.ones((len(rgb), 4))
        rgba[:, :rgb.shape[1]] = rgb
        source = "cubemarch:palette"
    else:
        if cmap is not None and not isinstance(cmap, str):
            raise SceneLoadError(f"Volume {name}: cubemarch:cmap must be a colormap name "
                                 f"(string or token), got {cmap!r}.")
        rows = max(top + 1, 0 if opacity is None else len(opacity))
        try:
            rgba = Palette.make(cmap, rows).rgba.astype(np.float64)
        except VolumeDataError as exc:
            raise SceneLoadError(f"Volume {name}: cubemarch:cmap = {cmap!r}: {exc}") from exc
        source = "cubemarch:cmap" if cmap is not None else "the default palette"
    if opacity is not None:
        if len(opacity) != len(rgba):
            raise SceneLoadError(f"Volume {name}: cubemarch:paletteOpacity has {len(opacity)} "
                                 f"values and {source} {len(rgba)} entries; give one opacity "
                                 "per entry (entry 0 unused, 0 hides a material).")
        rgba[1:, 3] = opacity[1:]
    rgba[0, 3] = 0.0
    try:
        return Palette(rgba)
    except VolumeDataError as exc:
        attrs = "cubemarch:palette" if colors is not None else ""
        attrs += (" / " if attrs and opacity is not None else "") + \
            ("cubemarch:paletteOpacity" if opacity is not None else "")
        raise SceneLoadError(f"Volume {name}: {attrs or source}: {exc}") from exc


def _is_field(prim) -> bool:
    return bool(prim.GetAttribute("filePath"))


def _attr(prim, name):
    attribute = prim.GetAttribute(name)
    return attribute.Get() if attribute and attribute.HasValue() else None


def _read_field(field_prim, cells: bool = False) -> pyvista.ImageData:
    """Load the grid a field prim's ``filePath`` names (.vti/.vtk/.npy/.npz).

    ``cells``: a numpy array's values fill voxels (material labels) instead of sitting on
    points (see :mod:`pv_cubemarch.scene.grids`).
    """
    asset = field_prim.GetAttribute("filePath").Get()
    where = f"field prim {field_prim.GetPath()}"
    if asset is None or not asset.path:
        raise SceneLoadError(f"{where} has no filePath.")
    resolved = asset.resolvedPath
    if not resolved:
        layer_dir = Path(field_prim.GetStage().GetRootLayer().realPath).parent
        raise SceneLoadError(f"{where}: volume file {asset.path!r} was not found "
                             f"(looked relative to {layer_dir}).")
    field_name = _attr(field_prim, "fieldName")
    return read_grid(resolved, where, asset.path, str(field_name) if field_name else None,
                     _attr(field_prim, "cubemarch:origin"), _attr(field_prim, "cubemarch:spacing"),
                     cells=cells)


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
