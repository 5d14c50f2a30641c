"""``UsdGeom.Mesh`` prims as PyVista meshes: primvars, normals, subsets and their materials.

Each mesh (or each ``GeomSubset`` bound to its own material) becomes one
:class:`~pv_cubemarch.scene.model.SceneMesh` in the prim's local frame; the caller places
it. The primvars kept are those the materials read, ``displayColor``/``displayOpacity`` and
the normals, each in its authored interpolation (see :mod:`.primvars`).
"""

from __future__ import annotations

import numpy as np
import pyvista
from pxr import UsdGeom, UsdShade

from ..materials import PrimvarInput, SurfaceMaterial
from ..parts import SceneMesh
from .context import PrimError, StageContext
from .preview_surface import bound_material, read_material
from .primvars import (
    CONSTANT,
    FACE_VARYING,
    UNIFORM,
    Polygons,
    check_length,
    per_corner,
    polydata,
    read_polygons,
    vectors,
)


def read_mesh(ctx: StageContext, prim) -> list[SceneMesh]:
    """The mesh's drawn parts in its local frame, faces wound counter-clockwise (outward).

    A mirroring placement winds them back when the parts are placed (``stage.placed``).
    """
    usd_mesh = UsdGeom.Mesh(prim)
    name = str(prim.GetPath())
    left = ctx.get(prim, "orientation") == UsdGeom.Tokens.leftHanded
    polygons = read_polygons(ctx.get(prim, "points", []), ctx.get(prim, "faceVertexCounts", []),
                             ctx.get(prim, "faceVertexIndices", []), reverse=left,
                             holes=ctx.get(prim, "holeIndices", []))
    if polygons.dropped:
        ctx.report(name, f"{polygons.dropped} faces of fewer than 3 vertices left out")
    parts = _material_parts(ctx, prim, polygons)
    wanted = {"displayColor", "displayOpacity"}
    for material, _, _ in parts:
        if material is not None:
            wanted |= material.primvars()
    primvars = _primvars(ctx, prim, polygons, wanted)
    normals = _normals(ctx, usd_mesh, polygons)
    welded = not any(interp == FACE_VARYING for _, interp in primvars.values()) and (
        normals is None or normals[1] not in (UNIFORM, FACE_VARYING))
    scheme = ctx.get(prim, "subdivisionScheme", "catmullClark")
    if scheme != "none":
        ctx.counts["subdivision"] = ctx.counts.get("subdivision", 0) + 1
    double_sided = bool(ctx.get(prim, "doubleSided", False))
    meshes = []
    for material, faces, label in parts:
        mesh, source = polydata(polygons, welded, faces)
        shading = _attach_normals(mesh, polygons, welded, source, normals, scheme)
        part = SceneMesh(name=name if len(parts) == 1 else f"{name}:{label}",
                         mesh=mesh, material=material, shading=shading,
                         double_sided=double_sided)
        _attach_primvars(ctx, part, polygons, welded, source, faces, primvars)
        meshes.append(part)
    return meshes


def _material_parts(ctx: StageContext, prim, polygons: Polygons
                    ) -> list[tuple[SurfaceMaterial | None, np.ndarray | None, str]]:
    """(material, drawn faces, label) of the mesh's material subsets and the rest.

    A label is the subset's prim name (unique among its siblings), or ``rest``.
    """
    whole = _material_of(ctx, prim)
    subsets = UsdShade.MaterialBindingAPI(prim).GetMaterialBindSubsets()
    if not subsets:
        return [(whole, None, "")]
    drawn_of_authored = np.full(polygons.authored_faces, -1)
    drawn_of_authored[polygons.face_source] = np.arange(len(polygons.face_source))
    taken = np.zeros(len(polygons.counts), dtype=bool)
    parts = []
    for subset in subsets:
        indices = np.asarray(subset.GetIndicesAttr().Get(ctx.time) or [], dtype=np.int64)
        if indices.size and (indices.min() < 0 or indices.max() >= polygons.authored_faces):
            ctx.report(str(subset.GetPath()), "GeomSubset indices outside the mesh's faces; "
                       "its faces keep the mesh's material")
            continue
        faces = drawn_of_authored[indices]
        faces = np.unique(faces[(faces >= 0) & ~taken[np.maximum(faces, 0)]])
        if faces.size:
            taken[faces] = True
            parts.append((_material_of(ctx, subset.GetPrim()), faces,
                          str(subset.GetPrim().GetName())))
    rest = np.nonzero(~taken)[0]
    if rest.size:
        parts.append((whole, rest, "rest"))
    return parts


def _material_of(ctx: StageContext, prim) -> SurfaceMaterial | None:
    material = bound_material(prim)
    if material is None:
        return None
    prim = material.GetPrim()
    # instances share their prototype's material: read (and reported) once
    key = str(prim.GetPrimInPrototype().GetPath() if prim.IsInstanceProxy() else prim.GetPath())
    if key not in ctx.materials:
        ctx.materials[key] = read_material(ctx, material)
    return ctx.materials[key]


def _primvars(ctx: StageContext, prim, polygons: Polygons, wanted: set[str]) -> dict:
    """``{name: (values, interpolation)}`` of the wanted primvars that fit the mesh."""
    api = UsdGeom.PrimvarsAPI(prim)
    found = {}
    for name in sorted(wanted):
        primvar = api.GetPrimvar(name)
        if not primvar or not primvar.HasValue():
            continue
        where = f"{prim.GetPath()}.primvars:{name}"
        try:
            values = primvar.ComputeFlattened(ctx.time)
            values = np.asarray(values if values is not None else [], dtype=np.float64)
        except (TypeError, ValueError):
            ctx.report(where, f"not numeric ({primvar.GetTypeName()}); left out")
            continue
        if not primvar.GetTypeName().isArray:   # one value authored without brackets
            values = values.reshape(1, -1)
        if values.ndim == 1:
            values = values[:, None]
        columns = {"displayColor": 3, "displayOpacity": 1}.get(name)
        if columns is not None and values.shape[1] != columns or values.ndim != 2:
            ctx.report(where, f"has {values.shape[1:]} components per value, not "
                       f"{columns}; left out")
            continue
        interpolation = str(primvar.GetInterpolation())
        try:
            check_length(f"primvars:{name}", values, interpolation, polygons)
        except PrimError as exc:
            ctx.report(where, f"{exc}; left out")
            continue
        found[name] = (values, interpolation)
    return found


def _normals(ctx: StageContext, usd_mesh, polygons: Polygons):
    """(normals, interpolation) authored as ``primvars:normals`` or ``normals``, or ``None``."""
    prim = usd_mesh.GetPrim()
    primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar("normals")
    if primvar and primvar.HasValue():
        values, interpolation = primvar.ComputeFlattened(ctx.time), primvar.GetInterpolation()
    else:
        values = ctx.get(prim, "normals")
        interpolation = usd_mesh.GetNormalsInterpolation()
    try:
        values = vectors(values, "normals")
        if len(values) == 0:
            return None
        check_length("normals", values, str(interpolation), polygons)
    except PrimError as exc:
        ctx.report(str(prim.GetPath()), f"{exc}; normals computed instead")
        return None
    return values, str(interpolation)


def _attach_normals(mesh: pyvista.PolyData, polygons: Polygons, welded: bool,
                    source: np.ndarray, normals, scheme: str) -> str:
    """Give ``mesh`` point normals; return its shading ('normals', 'smooth' or 'flat')."""
    if normals is not None:
        values, interpolation = normals
        if welded:
            point_values = values[source] if interpolation != CONSTANT else \
                np.repeat(values[:1], len(source), axis=0)
        else:
            point_values = per_corner(values, interpolation, polygons)[source]
        mesh.point_data["Normals"] = _unit(point_values)
        mesh.point_data.active_normals_name = "Normals"
        return "normals"
    if scheme == "none" or mesh.n_cells == 0:
        return "flat"
    whole, whole_source = polydata(polygons, welded=True)
    smooth = np.zeros((len(polygons.points), 3))
    smooth[whole_source] = whole.compute_normals(
        cell_normals=False, split_vertices=False, consistent_normals=False,
        auto_orient_normals=False).point_data["Normals"]
    mesh.point_data["Normals"] = smooth[source] if welded else smooth[polygons.indices[source]]
    mesh.point_data.active_normals_name = "Normals"
    return "smooth"


def _attach_primvars(ctx: StageContext, part: SceneMesh, polygons: Polygons, welded: bool,
                     source: np.ndarray, faces, primvars: dict) -> None:
    """Store primvars on the part's mesh; set its display colour and opacity."""
    mesh = part.mesh
    drawn_faces = np.arange(len(polygons.counts)) if faces is None else np.unique(faces)
    material = part.material
    read = material.diffuse_color.name if material is not None and isinstance(
        material.diffuse_color, PrimvarInput) else None
    for name, (values, interpolation) in primvars.items():
        if interpolation == CONSTANT:
            if name == "displayColor" and material is None or name == read:
                part.color = tuple(float(c) for c in np.resize(values[0], 3))
            elif name == "displayOpacity":
                part.opacity = float(values[0][0])
            else:
                mesh.field_data[name] = values[:1]
            continue
        if interpolation == UNIFORM and welded:
            mesh.cell_data[name] = values[polygons.face_source[drawn_faces]]
        elif welded:
            mesh.point_data[name] = values[source]
        else:
            mesh.point_data[name] = per_corner(values, interpolation, polygons)[source]
        if name == "displayColor" and material is None or name == read:
            # Storm ignores displayColor under a bound material unless the material reads it
            colors = mesh.point_data if name in mesh.point_data else mesh.cell_data
            if colors[name].shape[1:] != (3,):    # a float primvar read as a colour: grey
                colors[f"{name}:rgb"] = np.repeat(np.asarray(colors[name])[:, :1], 3, axis=1)
                name = f"{name}:rgb"
            part.vertex_colors = name
        elif name == "displayOpacity":
            part.opacity = float(np.mean(values))


def _unit(vectors: np.ndarray) -> np.ndarray:
    lengths = np.linalg.norm(vectors, axis=1, keepdims=True)
    return vectors / np.where(lengths > 0, lengths, 1.0)
