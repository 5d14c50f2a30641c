"""Gprims other than meshes: implicit primitives, points (as spheres), curves (as tubes).

Each reader returns :class:`~pv_cubemarch.scene.model.SceneMesh` parts in the prim's local
frame. Cubic curves are evaluated (Bezier, B-spline and Catmull-Rom bases, every wrap mode)
at :data:`CURVE_SAMPLES` points per segment; widths become the tubes' and spheres' sizes.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pyvista
from pxr import UsdGeom

from ..parts import SceneMesh
from .context import PrimError, StageContext
from .meshes import _material_of

PRIMITIVES = ("Sphere", "Cube", "Cylinder", "Cone", "Capsule", "Plane", "Cylinder_1",
              "Capsule_1")
CURVE_SAMPLES = 8
_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}
#: Cubic bases as 4x4 matrices on (1, t, t², t³) (rows) and the step between segments.
_BASES = {
    "bezier": (np.array([[1, 0, 0, 0], [-3, 3, 0, 0], [3, -6, 3, 0], [-1, 3, -3, 1]]), 3),
    "bspline": (np.array([[1, 4, 1, 0], [-3, 0, 3, 0], [3, -6, 3, 0], [-1, 3, -3, 1]]) / 6, 1),
    "catmullRom": (np.array([[0, 2, 0, 0], [-1, 0, 1, 0], [2, -5, 4, -1], [-1, 3, -3, 1]]) / 2,
                   1),
}


def read_primitive(ctx: StageContext, prim, type_name: str) -> list[SceneMesh]:
    """An implicit primitive (Sphere, Cube, Cylinder, Cone, Capsule, Plane) as a mesh."""
    def number(name: str, default: float) -> float:
        value = ctx.get(prim, name, default)
        if isinstance(value, (bool, str)) or not np.isfinite(float(value)) or float(value) < 0:
            raise PrimError(f"{name} is {value!r}; it must be a number >= 0")
        return float(value)

    axis = str(ctx.get(prim, "axis", "Z"))
    if axis not in _AXES:
        raise PrimError(f"axis is {axis!r}; it must be X, Y or Z")
    names = _PARAMETERS.get(type_name, ())
    values = tuple(number(name, default) for name, default in names)
    if type_name == "Capsule_1" and values[0] != values[1]:
        ctx.report(str(prim.GetPath()), "a capsule of two radii is drawn with their mean")
    # one mesh per shape and size, shared: 20 000 cubes are built once, not 20 000 times;
    # placed() copies it (is_template), so it is never changed or handed on
    mesh = _primitive(type_name, axis, values)
    part = SceneMesh(name=str(prim.GetPath()), mesh=mesh, material=_material_of(ctx, prim),
                     double_sided=bool(ctx.get(prim, "doubleSided", False)))
    _display_color(ctx, prim, part)
    return [part]


#: The size attributes of each primitive, with USD's defaults.
_PARAMETERS = {
    "Sphere": (("radius", 1.0),), "Cube": (("size", 2.0),),
    "Cylinder": (("radius", 1.0), ("height", 2.0)), "Cone": (("radius", 1.0), ("height", 2.0)),
    "Capsule": (("radius", 0.5), ("height", 1.0)),
    "Cylinder_1": (("radiusBottom", 1.0), ("radiusTop", 1.0), ("height", 2.0)),
    "Capsule_1": (("radiusBottom", 0.5), ("radiusTop", 0.5), ("height", 1.0)),
    "Plane": (("width", 2.0), ("length", 2.0)),
}


#: ``id`` of each cached primitive mesh (an evicted one's id reused means one more copy).
_TEMPLATES: set[int] = set()


def is_template(mesh) -> bool:
    """Whether ``mesh`` is a cached primitive shared by many parts: copy it before use."""
    return id(mesh) in _TEMPLATES


@lru_cache(maxsize=256)
def _primitive(type_name: str, axis: str, values: tuple) -> pyvista.PolyData:
    """The mesh of a primitive of these sizes (cached and shared: never change it)."""
    mesh = _built_primitive(type_name, axis, values)
    _TEMPLATES.add(id(mesh))
    return mesh


def _built_primitive(type_name: str, axis: str, values: tuple) -> pyvista.PolyData:
    if type_name == "Sphere":
        mesh = pyvista.Sphere(radius=values[0], theta_resolution=48, phi_resolution=32)
    elif type_name == "Cube":
        mesh = pyvista.Cube(x_length=values[0], y_length=values[0],
                            z_length=values[0]).triangulate()
    elif type_name == "Cylinder":
        mesh = pyvista.Cylinder(direction=_AXES[axis], radius=values[0], height=values[1],
                                resolution=48)
    elif type_name == "Cone":
        mesh = pyvista.Cone(direction=_AXES[axis], radius=values[0], height=values[1],
                            resolution=48)
    elif type_name == "Capsule":
        mesh = pyvista.Capsule(direction=_AXES[axis], radius=values[0],
                               cylinder_length=values[1], resolution=32)
    elif type_name == "Cylinder_1":
        mesh = _frustum(axis, *values)
    elif type_name == "Capsule_1":
        mesh = pyvista.Capsule(direction=_AXES[axis], radius=(values[0] + values[1]) / 2,
                               cylinder_length=values[2], resolution=32)
    else:
        normal = {"X": (1, 0, 0), "Y": (0, 1, 0), "Z": (0, 0, 1)}[axis]
        mesh = pyvista.Plane(direction=normal, i_size=values[0], j_size=values[1],
                             i_resolution=1, j_resolution=1)
    return mesh if isinstance(mesh, pyvista.PolyData) else mesh.extract_surface()


def _frustum(axis: str, bottom: float, top: float, height: float) -> pyvista.PolyData:
    """A capped cylinder along ``axis`` whose radius goes from ``bottom`` to ``top``."""
    direction = np.array(_AXES[axis])
    mesh = pyvista.Cylinder(direction=tuple(direction), radius=1.0, height=height,
                            resolution=48).triangulate()
    along = mesh.points @ direction
    radius = bottom + (top - bottom) * (along / height + 0.5)
    mesh.points = along[:, None] * direction + (mesh.points - along[:, None] * direction) \
        * radius[:, None]
    return mesh


def _display_color(ctx: StageContext, prim, part: SceneMesh) -> None:
    """A constant ``displayColor``/``displayOpacity`` (or their mean) as the part's colour."""
    api = UsdGeom.PrimvarsAPI(prim)
    for name in ("displayColor", "displayOpacity"):
        primvar = api.GetPrimvar(name)
        if not primvar or not primvar.HasValue():
            continue
        try:
            values = np.asarray(primvar.ComputeFlattened(ctx.time), dtype=np.float64)
        except (TypeError, ValueError):
            ctx.report(f"{prim.GetPath()}.primvars:{name}", "not numeric; left out")
            continue
        if values.size == 0:
            continue
        if name == "displayColor":
            part.color = tuple(float(c) for c in values.reshape(-1, 3).mean(axis=0))
        else:
            part.opacity = float(values.mean())


def read_points(ctx: StageContext, prim) -> list[SceneMesh]:
    """``UsdGeom.Points`` as spheres of the authored widths (diameters)."""
    points = np.asarray(ctx.get(prim, "points", []), dtype=np.float64).reshape(-1, 3)
    if not len(points):
        raise PrimError("it has no points")
    widths = _widths(ctx, prim, len(points))
    cloud = pyvista.PolyData(points)
    cloud.point_data["diameter"] = widths
    ball = pyvista.Sphere(radius=0.5, theta_resolution=10, phi_resolution=8)
    mesh = cloud.glyph(geom=ball, scale="diameter", orient=False)
    part = SceneMesh(name=str(prim.GetPath()), mesh=mesh, material=_material_of(ctx, prim))
    _display_color(ctx, prim, part)
    return [part]


def _widths(ctx: StageContext, prim, count: int) -> np.ndarray:
    """One width per point (constant, per point or their mean otherwise), 1 by default."""
    values = np.asarray(ctx.get(prim, "widths", []) or [], dtype=np.float64).ravel()
    if values.size == count:
        return values
    return np.full(count, float(values.mean()) if values.size else 1.0)


def read_curves(ctx: StageContext, prim, type_name: str) -> list[SceneMesh]:
    """``BasisCurves`` (linear or cubic) as tubes of the authored widths."""
    if type_name != "BasisCurves":
        raise PrimError(f"{type_name} is not drawn (BasisCurves are)")
    points = np.asarray(ctx.get(prim, "points", []), dtype=np.float64).reshape(-1, 3)
    counts = np.asarray(ctx.get(prim, "curveVertexCounts", []), dtype=np.int64).ravel()
    if counts.sum() != len(points) or (counts.size and counts.min() < 0):
        raise PrimError(f"curveVertexCounts sum to {int(counts.sum())} but there are "
                        f"{len(points)} points")
    widths = _widths(ctx, prim, len(points))
    kind = str(ctx.get(prim, "type", "cubic"))
    basis = str(ctx.get(prim, "basis", "bezier"))
    wrap = str(ctx.get(prim, "wrap", "nonperiodic"))
    if kind == "cubic" and basis not in _BASES:
        raise PrimError(f"basis {basis!r} is not one of {', '.join(_BASES)}")
    lines, radii = [], []
    start = 0
    for count in counts:
        curve = slice(start, start + count)
        start += count
        if kind == "linear":
            xyz, width = _linear(points[curve], widths[curve], wrap)
        else:
            xyz, width = _cubic(points[curve], widths[curve], basis, wrap)
        if len(xyz) >= 2:
            lines.append(xyz)
            radii.append(width / 2.0)
    if not lines:
        raise PrimError("no curve has enough vertices to draw")
    offsets = np.cumsum([0] + [len(line) for line in lines])
    cells = np.concatenate([np.concatenate([[len(line)], np.arange(o, o + len(line))])
                            for line, o in zip(lines, offsets[:-1], strict=True)])
    polyline = pyvista.PolyData(np.concatenate(lines), lines=cells)
    polyline.point_data["radius"] = np.maximum(np.concatenate(radii), 1e-12)
    tube = polyline.tube(scalars="radius", absolute=True, n_sides=8, capping=True)
    part = SceneMesh(name=str(prim.GetPath()), mesh=tube.triangulate(),
                     material=_material_of(ctx, prim))
    _display_color(ctx, prim, part)
    return [part]


def _linear(points: np.ndarray, widths: np.ndarray, wrap: str):
    if wrap == "periodic" and len(points) > 2:
        return np.vstack([points, points[:1]]), np.concatenate([widths, widths[:1]])
    return points, widths


def _cubic(points: np.ndarray, widths: np.ndarray, basis: str, wrap: str):
    """Samples of one cubic curve and its widths (same basis), per its wrap mode."""
    matrix, step = _BASES[basis]
    values = np.column_stack([points, widths])
    if wrap == "periodic":
        values = np.vstack([values, values[:4 - step if step == 3 else 3]])
    elif wrap == "pinned" and basis != "bezier" and len(values) >= 2:
        values = np.vstack([2 * values[0] - values[1], values, 2 * values[-1] - values[-2]])
    segments = (len(values) - 4) // step + 1 if len(values) >= 4 else 0
    if segments <= 0:
        return points[:0], widths[:0]
    t = np.linspace(0.0, 1.0, CURVE_SAMPLES + 1)
    weights = np.column_stack([np.ones_like(t), t, t * t, t ** 3]) @ matrix   # (samples, 4)
    out = [weights @ values[s * step:s * step + 4] for s in range(segments)]
    samples = np.vstack([o[:-1] for o in out] + [out[-1][-1:]])
    return samples[:, :3], samples[:, 3]
