"""Walk a composed USD stage and hand each prim to its reader.

USD composes references, payloads and instancing for us; we walk the composed stage
(instance proxies included) at one time code, load what is drawable and record what we
leave out and why. A prim that cannot be read is reported (a :class:`SceneWarning` and an
entry in ``scene.skipped``) and the rest of the stage is read, unless ``strict``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pxr import Tf, Usd, UsdGeom

from ...core.errors import CubemarchError, SceneLoadError, VolumeDataError
from ...core.progress import progress
from ..materials import SurfaceMaterial
from ..meshes import beyond_reach
from ..model import Scene
from ..parts import SceneMesh
from ..voxel_worlds import join_world
from .context import PrimError, StageContext
from .instancers import check_copies, instance_fits, read_instancer
from .layer_text import check_layer_nesting
from .lights import LIGHT_KINDS, read_camera, read_light
from .meshes import read_mesh
from .primvars import cofactor, with_winding_reversed
from .shapes import PRIMITIVES, is_template, read_curves, read_points, read_primitive
from .volumes import is_field, read_volume

#: Prim types read for what they hold (children, bindings) rather than drawn themselves.
CONTAINERS = ("", "Xform", "Scope", "Material", "Shader", "NodeGraph", "GeomSubset",
              "SkelRoot", "OpenVDBAsset", "Field3DAsset", "PluginLight", "LightFilter")
CURVES = ("BasisCurves", "NurbsCurves", "HermiteCurves")
_NOT_DRAWN = {
    "NurbsPatch": "NURBS patches are not tessellated",
    "TetMesh": "tetrahedral meshes are not drawn",
    "Skeleton": "skeletons are not drawn (skinned meshes are drawn in their rest pose)",
    "GeometryLight": "geometry lights are not drawn",
    "PortalLight": "portal lights are not drawn",
}


def load_usd(path: str | Path, progress_bar: bool | None = None, as_voxels: bool = False,
             time: float | None = None, strict: bool = False) -> Scene:
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
    time : float, optional
        The time code to read animated attributes at; by default the stage's start time
        when it is animated, else the default (un-animated) values.
    strict : bool
        Raise at the first prim that cannot be read, instead of reporting it (a
        :class:`~pv_cubemarch.core.errors.SceneWarning` and an entry in
        ``scene.skipped``) and reading the rest.

    Returns
    -------
    Scene
        What the stage draws, and the prims skipped with the reasons.
    """
    path = Path(path)
    if not path.is_file():
        raise SceneLoadError(f"USD file {str(path)!r} does not exist.")
    check_layer_nesting(path)
    try:
        stage = Usd.Stage.Open(str(path))
    except Tf.ErrorException as exc:
        try:   # USD's message may quote the file's bytes, which need not be text
            reason = str(exc)
        except UnicodeDecodeError:
            reason = "its bytes are not UTF-8 text"
        raise SceneLoadError(f"USD file {str(path)!r} could not be opened: {reason}") from exc
    if stage is None:
        raise SceneLoadError(f"USD file {str(path)!r} could not be opened (not a USD layer?).")
    if time is not None and not np.isfinite(time):
        raise SceneLoadError(f"time must be a finite time code, got {time!r}.")
    if time is None and stage.HasAuthoredTimeCodeRange():
        time = stage.GetStartTimeCode()
    up_axis = str(UsdGeom.GetStageUpAxis(stage))
    scene = Scene(source=str(path), up_axis=up_axis if up_axis in ("Y", "Z") else "Y",
                  meters_per_unit=float(UsdGeom.GetStageMetersPerUnit(stage)),
                  time=time, usd_lighting=True)
    # without a time range, each attribute's earliest sample (its default when it has none)
    ctx = StageContext(stage, scene, Usd.TimeCode(time) if time is not None
                       else Usd.TimeCode.EarliestTime(), as_voxels=as_voxels, strict=strict)
    if up_axis not in ("Y", "Z"):
        ctx.report("/", f"upAxis {up_axis!r} is not Y or Z (USD allows only those); Y is used")
    predicate = Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate)
    walk = iter(Usd.PrimRange(stage.GetPseudoRoot(), predicate))
    next(walk)  # the pseudo-root
    for prim in progress(walk, desc=f"loading {path.name}", enabled=progress_bar):
        if (prim.IsInstance() and not prim.IsInstanceProxy()
                and not instance_fits(ctx, prim)) or not _read_prim(ctx, prim):
            walk.PruneChildren()
    for name, chunks in ctx.world_chunks.items():
        try:
            world, options = join_world(name, chunks)
        except (SceneLoadError, VolumeDataError) as exc:
            if strict:
                raise
            ctx.report(chunks[0].path, str(exc))
            continue
        scene.voxels.append(world)
        if options:
            scene.voxel_options[name] = options
    if ctx.counts.get("subdivision"):
        ctx.report("/", f"{ctx.counts['subdivision']} subdivision meshes (catmullClark or "
                        "loop) drawn as their control meshes with smooth normals, not refined",
                   warn=False)
    return scene


def _read_prim(ctx: StageContext, prim) -> bool:
    """Read one prim; ``False`` when its children are not to be walked."""
    path = str(prim.GetPath())
    reason = _skip_reason(ctx, prim)
    if reason is not None:
        if reason:
            ctx.report(path, reason, warn=False)
        return False
    type_name = str(prim.GetTypeName())
    if type_name in CONTAINERS or is_field(prim):
        return True
    try:
        if type_name == "Camera":
            ctx.scene.cameras[path] = read_camera(ctx, prim)
        elif type_name in LIGHT_KINDS:
            ctx.scene.lights.append(read_light(ctx, prim, type_name))
        elif type_name == "Volume":
            read_volume(ctx, prim, path)
        else:
            matrix = ctx.world_matrix(prim)
            parts = _local_parts(ctx, prim)
            if parts is None:
                ctx.report(path, _NOT_DRAWN.get(type_name, f"unsupported prim type {type_name}"))
                return False
            if parts and not any(part.mesh.n_cells for part in parts):
                ctx.report(path, f"{type_name} has no faces to draw")
            parts = [part for part in parts if part.mesh.n_cells]
            if parts and not np.isfinite(matrix).all():
                raise PrimError("its transform holds NaN or infinite values")
            with np.errstate(over="ignore", invalid="ignore"):
                parts = [placed(with_fallback(part), matrix) for part in parts]
            for part in parts:
                _check_reach(part)
                if prim.IsInstanceProxy():   # copies a small stage may multiply
                    check_copies(ctx, part, 1)
            ctx.scene.meshes.extend(parts)
            if type_name == "PointInstancer":
                return False     # its prototypes are drawn through it only
    except (PrimError, CubemarchError, ValueError, TypeError, IndexError, Tf.ErrorException,
            ArithmeticError, RuntimeError) as exc:   # RuntimeError: PyVista's and VTK's
        if ctx.strict:
            if isinstance(exc, CubemarchError):
                raise
            raise SceneLoadError(f"{type_name} {path}: {exc}") from exc
        reason = str(exc) if isinstance(exc, (PrimError, CubemarchError)) else \
            f"could not be read ({type(exc).__name__}: {exc})"
        kind = type_name or "typeless prim"
        ctx.report(path, reason if reason.startswith(kind) else f"{kind}: {reason}")
        return False
    return True


def _local_parts(ctx: StageContext, prim) -> list[SceneMesh] | None:
    """A drawable prim's parts in its own frame; ``None`` for prim types we do not draw."""
    type_name = str(prim.GetTypeName())
    if type_name == "Mesh":
        return read_mesh(ctx, prim)
    if type_name == "PointInstancer":
        return read_instancer(ctx, prim, lambda p: _local_parts(ctx, p), _skip_reason)
    if type_name in PRIMITIVES:
        return read_primitive(ctx, prim, type_name)
    if type_name == "Points":
        return read_points(ctx, prim)
    if type_name in CURVES:
        return read_curves(ctx, prim, type_name)
    return None if type_name not in CONTAINERS else []


def _skip_reason(ctx: StageContext, prim) -> str | None:
    """Why the prim and its children are left out ('' to say nothing), or ``None``."""
    if not prim.IsActive():
        return "inactive"
    if prim.IsAbstract() or not prim.IsDefined():
        return ""
    imageable = UsdGeom.Imageable(prim)
    if imageable:
        if ctx.get(prim, "visibility") == UsdGeom.Tokens.invisible:
            return "invisible"
        purpose = ctx.get(prim, "purpose")
        if purpose in (UsdGeom.Tokens.guide, UsdGeom.Tokens.render):
            # usdview shows the default and proxy purposes, not guide or render
            return f"purpose is {purpose}"
    return None


def with_fallback(part: SceneMesh) -> SceneMesh:
    """Give a part without a material Storm's fallback: a UsdPreviewSurface of its colour."""
    if part.material is None:
        part.material = SurfaceMaterial(name="fallback", diffuse_color=part.color,
                                        opacity=part.opacity)
    return part


def _check_reach(part: SceneMesh) -> None:
    """Raise ``PrimError`` for a mesh placed past what GL draws (it blanked the frame)."""
    reason = beyond_reach(part.mesh)
    if reason:
        raise PrimError(reason)


def placed(part: SceneMesh, matrix: np.ndarray) -> SceneMesh:
    """``part`` moved by the column-vector 4x4 ``matrix``, its normals turned with it.

    A mirroring matrix (negative determinant) winds the faces the other way, so the side
    facing out stays the front.
    """
    if np.allclose(matrix, np.eye(4)):
        if is_template(part.mesh):      # a shared primitive: this part's own copy
            part.mesh = part.mesh.copy()
        return part
    mirrored = np.linalg.det(matrix[:3, :3]) < 0
    mesh = with_winding_reversed(part.mesh) if mirrored else part.mesh.copy()
    # in double precision: float32 points far from the origin would lose their shape
    mesh.points = np.asarray(mesh.points, dtype=np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
    if "Normals" in mesh.point_data and not np.array_equal(matrix[:3, :3], np.eye(3)):
        mesh.point_data["Normals"] = turned_normals(mesh.point_data["Normals"], matrix)
        mesh.point_data.active_normals_name = "Normals"
    part.mesh = mesh
    return part


def turned_normals(normals, matrix: np.ndarray) -> np.ndarray:
    """Unit normals moved by ``matrix`` (the inverse transpose's direction).

    The cofactor matrix gives that direction and stays defined for singular matrices.
    """
    turn = cofactor(matrix[:3, :3]) * (-1.0 if np.linalg.det(matrix[:3, :3]) < 0 else 1.0)
    out = np.asarray(normals, dtype=np.float64) @ turn.T
    lengths = np.linalg.norm(out, axis=1, keepdims=True)
    return out / np.where(lengths > 0, lengths, 1.0)
