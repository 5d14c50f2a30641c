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

from ...core.budgets import host_budget
from ...models.image_files import ARRAY_BYTES_ENV
from ..parts import SceneMesh
from .context import PrimError, StageContext
from .primvars import cell_arrays, cofactor, reversed_connectivity

#: Bytes an instance takes before its copies (its index, mask, 4x4 transform, in float64).
INSTANCE_BYTES = 160
#: The most prototype reads of instancers nested in other instancers' prototypes one stage
#: makes (each is read once per copy of its parent: two prototypes a level, 12 levels,
#: read 8,192 and took 45 s).
MAX_NESTED_READS = 1_000
#: Bytes a copied point takes with what travels with it (position, normal, texture
#: coordinates, in float64) and the temporaries of copying it (VTK's arrays, numpy's).
COPY_BYTES_PER_POINT = 256


#: The most prims one stage reads through native instances (``instanceable`` references),
#: nested ones expanded: a 9.5 KB stage of five levels of ten instances each had 100,000
#: meshes read, and ran out of minutes and memory (USD composes it cheaply; each proxy is
#: read as a mesh of its own).
MAX_INSTANCE_PRIMS = 20_000

def instance_fits(ctx: StageContext, prim) -> bool:
    """Whether the prims below an (outermost) instance fit in :data:`MAX_INSTANCE_PRIMS`.

    Counted from its prototype before any is read; one that does not fit is reported
    and left out, and the rest of the stage is read.
    """
    below = _prims_below(prim.GetPrototype(), ctx.prototype_prims)
    total = ctx.counts.get("instance prims", 0) + below
    if total > MAX_INSTANCE_PRIMS:
        ctx.report(str(prim.GetPath()), f"an instance of {below:,} prims (its nested instances "
                   f"expanded) would bring the prims read through instances to {total:,}, "
                   f"more than the {MAX_INSTANCE_PRIMS:,} one stage may: not drawn (a "
                   "PointInstancer copies its prototypes' meshes far more cheaply)")
        return False
    ctx.counts["instance prims"] = total
    return True


def _prims_below(prototype, known: dict) -> int:
    """The prims a walk through instance proxies visits below ``prototype``."""
    key = str(prototype.GetPath())
    if key not in known:
        known[key] = 0   # USD refuses instancing cycles; this keeps a count finite anyway
        walk = iter(Usd.PrimRange(prototype, Usd.PrimAllPrimsPredicate))
        next(walk)   # the prototype itself
        known[key] = sum(1 + (_prims_below(child.GetPrototype(), known)
                              if child.IsInstance() else 0) for child in walk)
    return known[key]


def read_instancer(ctx: StageContext, prim, read_local: Callable[[object], list | None],
                   skip_reason: Callable) -> list[SceneMesh]:
    """Every visible instance's parts, in the instancer's own frame.

    ``read_local(prim)`` gives a drawable prim's parts in its own frame (``None`` for types
    not drawn; a nested PointInstancer's in its frame); ``skip_reason(ctx, prim)`` says why
    a prim under a prototype is left out (invisible, guide or render purpose), or ``None``.
    """
    path = str(prim.GetPath())
    if path in ctx.instancing:   # USD composes it; reading it would recurse forever
        raise PrimError(f"its prototypes hold it again ({' -> '.join(ctx.instancing)} -> "
                        f"{path}): a cycle of PointInstancers is not drawn")
    ctx.instancing.append(path)
    try:
        return _read_instances(ctx, prim, read_local, skip_reason)
    finally:
        ctx.instancing.pop()


def _read_instances(ctx: StageContext, prim, read_local, skip_reason) -> list[SceneMesh]:
    """:func:`read_instancer` once it is known not to hold itself."""
    instancer = UsdGeom.PointInstancer(prim)
    prototypes = instancer.GetPrototypesRel().GetTargets()
    if not prototypes:
        raise PrimError("it has no prototypes")
    declared = instancer.GetProtoIndicesAttr().Get(ctx.time) or []
    budget = host_budget(ARRAY_BYTES_ENV, PrimError)
    if budget is not None and len(declared) * INSTANCE_BYTES > budget:   # before copies
        raise PrimError(f"{len(declared):,} instances' transforms would take "
                        f"{len(declared) * INSTANCE_BYTES:,} bytes, more than the {budget:,} "
                        f"they may take ({ARRAY_BYTES_ENV})")
    nested = len(ctx.instancing) > 1   # read as another instancer's prototype
    reads = ctx.counts.get("nested prototype reads", 0) + (len(prototypes) if nested else 0)
    if reads > MAX_NESTED_READS:   # nested instancers fanning out: exponential work
        raise PrimError(f"nested instancers would read their prototypes {reads:,} times over "
                        f"the stage, more than {MAX_NESTED_READS:,}: flatten the nesting")
    ctx.counts["nested prototype reads"] = reads
    indices = np.asarray(declared, dtype=np.int64)
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
        for part, relative in _prototype_parts(ctx, root, read_local, skip_reason):
            check_copies(ctx, part, len(chosen))
            copy = _copied(part, instances[chosen] @ relative)
            copy.name = f"{prim.GetPath()}[{part.name}]"
            parts.append(copy)
    return parts


def _prototype_parts(ctx: StageContext, root, read_local, skip_reason):
    """(part, matrix from the part's frame to the prototype root's) under ``root``."""
    predicate = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
    walk = iter(Usd.PrimRange(root, predicate))
    for prim in walk:
        reason = skip_reason(ctx, prim)
        if reason is None and prim.IsInstance() and not prim.IsInstanceProxy() and \
                not instance_fits(ctx, prim):   # native instances in a prototype count too
            reason = ""
        if reason is not None:
            walk.PruneChildren()
            continue
        try:
            local = read_local(prim)
        except (PrimError, ValueError, TypeError, IndexError, ArithmeticError) as exc:
            if ctx.strict:   # the first prim that cannot be read ends the load
                raise
            ctx.report(str(prim.GetPath()), f"in a prototype: {exc}")
            walk.PruneChildren()
            continue
        if local is None:
            ctx.report(str(prim.GetPath()), f"{prim.GetTypeName()} in a prototype is not drawn")
            walk.PruneChildren()
            continue
        if str(prim.GetTypeName()) == "PointInstancer":
            walk.PruneChildren()          # its own prototypes are drawn through it
        if local:
            if prim == root:
                relative = np.eye(4)
            else:
                matrix, _ = ctx.xforms.ComputeRelativeTransform(prim, root)
                relative = np.array(matrix, dtype=np.float64).T
            for part in local:
                if part.mesh.n_cells:
                    yield part, relative


def check_copies(ctx: StageContext, part: SceneMesh, count: int) -> None:
    """Raise ``PrimError`` if ``count`` copies of ``part`` would take more than the budget.

    Nested instancers multiply (10 instances of 10 of 10 ...): a 2 KB stage asked for
    gigabytes before numpy ran out of memory. The stage's copies so far count too.
    """
    mesh = part.mesh
    ids = mesh.GetPolys().GetNumberOfConnectivityIds()
    nbytes = count * (mesh.n_points * COPY_BYTES_PER_POINT + ids * 8 + mesh.n_cells * 8)
    budget = host_budget(ARRAY_BYTES_ENV, PrimError)
    copied = ctx.counts.get("copied bytes", 0) + nbytes
    if budget is not None and copied > budget:
        raise PrimError(f"{count:,} instances of {part.name} ({mesh.n_points:,} points) would "
                        f"bring the stage's instanced copies to {copied:,} bytes, more than "
                        f"the {budget:,} they may take ({ARRAY_BYTES_ENV}, by default 80 % of "
                        "the memory available): instance fewer, or simpler prototypes")
    ctx.counts["copied bytes"] = copied   # counted once it is made


def _copied(part: SceneMesh, matrices: np.ndarray) -> SceneMesh:
    """``part`` copied once per matrix (column-vector 4x4s) into one mesh.

    Copies under a mirroring matrix wind their faces the other way; normals turn with the
    inverse transpose's direction (the cofactor matrix: defined for zero scales too).
    """
    mesh = part.mesh
    count = len(matrices)
    points = np.einsum("nij,pj->npi", matrices[:, :3, :3], mesh.points) + matrices[:, None, :3, 3]
    offsets, connectivity = cell_arrays(mesh)
    determinants = np.linalg.det(matrices[:, :3, :3])
    flipped = reversed_connectivity(offsets, connectivity)
    per_copy = np.where((determinants < 0)[:, None], flipped[None, :], connectivity[None, :])
    shift = (np.arange(count) * mesh.n_points)[:, None]
    all_connectivity = (per_copy + shift).ravel()
    all_offsets = np.concatenate([(offsets[:-1][None, :] + (np.arange(count) * len(
        connectivity))[:, None]).ravel(), [count * len(connectivity)]])
    out = pyvista.PolyData()   # PolyData(points) would add a vertex cell per point
    out.points = points.reshape(-1, 3)
    out.SetPolys(pyvista.CellArray.from_arrays(all_offsets, all_connectivity, deep=True))
    for name in mesh.point_data.keys():
        values = np.asarray(mesh.point_data[name])
        if name == "Normals":
            turn = cofactor(matrices[:, :3, :3])
            turn *= np.where(determinants < 0, -1.0, 1.0)[:, None, None]
            turned = np.einsum("nij,pj->npi", turn, values)
            turned /= np.maximum(np.linalg.norm(turned, axis=2, keepdims=True), 1e-300)
            out.point_data[name] = turned.reshape(-1, 3)
            out.point_data.active_normals_name = name
        else:
            out.point_data[name] = np.concatenate([values] * count)
    for name in mesh.cell_data.keys():
        out.cell_data[name] = np.concatenate([np.asarray(mesh.cell_data[name])] * count)
    for name in mesh.field_data.keys():
        out.field_data[name] = mesh.field_data[name]
    if mesh.active_texture_coordinates is not None:
        out.active_texture_coordinates = np.concatenate(
            [mesh.active_texture_coordinates] * count)
    return SceneMesh(**{**part.__dict__, "mesh": out})
