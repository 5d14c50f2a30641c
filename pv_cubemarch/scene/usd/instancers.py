"""``UsdGeom.PointInstancer``: each prototype's parts read once, copied to every instance.

Instance transforms come from USD (positions, orientations, scales, protoIndices,
invisibleIds and the prototype root's own transform); the copies of one prototype part are
merged into one mesh, so thousands of instances are a few actors.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pyvista
from pxr import Usd, UsdGeom

from ..parts import SceneMesh
from .context import PrimError, StageContext


def read_instancer(ctx: StageContext, prim,
                   read_local: Callable[[object], list[SceneMesh]]) -> list[SceneMesh]:
    """Every visible instance's parts, placed in the world.

    ``read_local(prim)`` gives a drawable prim's parts in its own frame (or raises).
    """
    instancer = UsdGeom.PointInstancer(prim)
    prototypes = instancer.GetPrototypesRel().GetTargets()
    if not prototypes:
        raise PrimError("it has no prototypes")
    indices = np.asarray(instancer.GetProtoIndicesAttr().Get(ctx.time) or [], dtype=np.int64)
    if indices.size and (indices.min() < 0 or indices.max() >= len(prototypes)):
        raise PrimError(f"protoIndices go up to {int(indices.max())} but there are "
                        f"{len(prototypes)} prototypes")
    mask = np.asarray(instancer.ComputeMaskAtTime(ctx.time) or [True] * len(indices), bool)
    visible = indices[mask]
    # the transforms of the visible instances only (invisibleIds and the mask applied)
    matrices = instancer.ComputeInstanceTransformsAtTime(ctx.time, ctx.time)
    if len(matrices) != len(visible):
        raise PrimError(f"its {len(indices)} protoIndices and its positions/orientations/"
                        "scales do not match in length")
    placement = ctx.world_matrix(prim)
    instances = np.array([np.array(m, dtype=np.float64).T for m in matrices]).reshape(-1, 4, 4)
    parts = []
    for number, target in enumerate(prototypes):
        chosen = np.nonzero(visible == number)[0]
        root = ctx.stage.GetPrimAtPath(target)
        if not root:
            ctx.report(str(target), f"prototype of {prim.GetPath()} does not exist")
            continue
        if not chosen.size:
            continue
        for part, relative in _prototype_parts(ctx, root, read_local):
            copy = _copied(part, placement @ instances[chosen] @ relative)
            copy.name = f"{prim.GetPath()}[{part.name}]"
            parts.append(copy)
    return parts


def _prototype_parts(ctx: StageContext, root, read_local):
    """(part, matrix from the part's frame to the prototype root's) under ``root``."""
    predicate = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
    walk = iter(Usd.PrimRange(root, predicate))
    for prim in walk:
        imageable = UsdGeom.Imageable(prim)
        if imageable and ctx.get(prim, "visibility") == UsdGeom.Tokens.invisible:
            walk.PruneChildren()
            continue
        try:
            local = read_local(prim)
        except PrimError as exc:
            ctx.report(str(prim.GetPath()), str(exc))
            continue
        if local:
            if prim == root:
                relative = np.eye(4)
            else:
                matrix, _ = ctx.xforms.ComputeRelativeTransform(prim, root)
                relative = np.array(matrix, dtype=np.float64).T
            for part in local:
                if part.mesh.n_cells:
                    yield part, relative


def _copied(part: SceneMesh, matrices: np.ndarray) -> SceneMesh:
    """``part`` copied once per matrix (column-vector 4x4s) into one mesh."""
    mesh = part.mesh
    count = len(matrices)
    points = np.einsum("nij,pj->npi", matrices[:, :3, :3], mesh.points) + matrices[:, None, :3, 3]
    polys = mesh.GetPolys()
    offsets = pyvista.convert_array(polys.GetOffsetsArray()).astype(np.int64)
    connectivity = pyvista.convert_array(polys.GetConnectivityArray()).astype(np.int64)
    shift = (np.arange(count) * mesh.n_points)[:, None]
    all_connectivity = (connectivity[None, :] + shift).ravel()
    all_offsets = np.concatenate([(offsets[:-1][None, :] + (np.arange(count) * len(
        connectivity))[:, None]).ravel(), [count * len(connectivity)]])
    out = pyvista.PolyData()   # PolyData(points) would add a vertex cell per point
    out.points = points.reshape(-1, 3)
    out.SetPolys(pyvista.CellArray.from_arrays(all_offsets, all_connectivity, deep=True))
    for name in mesh.point_data.keys():
        values = np.asarray(mesh.point_data[name])
        if name == "Normals":
            inverse = np.linalg.inv(matrices[:, :3, :3]).transpose(0, 2, 1)
            turned = np.einsum("nij,pj->npi", inverse, values)
            turned /= np.maximum(np.linalg.norm(turned, axis=2, keepdims=True), 1e-300)
            out.point_data[name] = turned.reshape(-1, 3)
        else:
            out.point_data[name] = np.concatenate([values] * count)
    for name in mesh.cell_data.keys():
        out.cell_data[name] = np.concatenate([np.asarray(mesh.cell_data[name])] * count)
    return SceneMesh(**{**part.__dict__, "mesh": out})
