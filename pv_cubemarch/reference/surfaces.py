"""The implicit-surface CPU reference: the first root of f along every pixel's ray.

:func:`trace_surface` walks each ray through the field's cells in float64 (the voxel
reference's traversal: crossings from the cell index, no drift); in each cell the surface
may cross (its Bernstein coefficients change sign: no other cell holds a zero) the field
along the ray is a polynomial of degree at most 6, sampled at :data:`BRACKETS` + 1 points;
the first sign change is refined by bisection to 1e-9 of the cell's diagonal. A ray whose
field comes within :data:`TANGENT_TOLERANCE` of zero, and flat, at a sample before that
root without changing sign (a tangent ray, or two roots closer than the samples), or whose
first root is one of a close pair with the field that near 0 between them, is marked
``ambiguous``: a float32 renderer may rightly see a hit there or not.

Conventions as :mod:`pv_cubemarch.reference.voxels`: world rays from :meth:`Camera.rays`
(unit directions, so ``depth`` is a world distance), the ray starting at ``max(0, domain
entry, near / dot(direction, forward))``; the field positive inside, the normal the unit
of ``-gradient`` (pointing out).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..core.camera import Camera
from ..models.lights import VolumeLight
from ..models.surface import SplineField, active_cells, bernstein_basis
from .rays import checked_pixels, clip_interval, ray_box_interval
from .shading import blinn_phong

#: Sample intervals per cell segment in which the first sign change is looked for.
BRACKETS = 256
#: Bisection steps on the bracketing interval (2^-40 of it: below 1e-9 of a diagonal).
BISECTIONS = 40
#: |f| along a ray below this share of the cell's largest Bernstein coefficient, with a
#: slope (per cell length) below FLAT_TOLERANCE of it, before the first sign change, marks
#: the pixel ambiguous (tangent).
TANGENT_TOLERANCE = 1e-4
FLAT_TOLERANCE = 1e-2
#: Sample intervals after the first sign change within which a return of the sign, with the
#: field that close to 0 between, makes the root a near-double one (ambiguous).
PAIR_BRACKETS = 2
#: Most roots along one ray a translucent surface composites.
MAX_LAYERS = 256


@dataclass
class SurfaceHits:
    """Per pixel ``(height, width)``: hit or not, its depth, world point, normal and cell.

    ``depth``: distance along the (unit) ray, ``inf`` where nothing is hit; ``normal``:
    outward unit normal (``-gradient``); ``cell``: the hit's cell, ``-1`` on a miss;
    ``ambiguous``: a tangent or near-double root before (or at) the first root found.
    """

    hit: np.ndarray
    depth: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    cell: np.ndarray
    ambiguous: np.ndarray


def trace_surface(field: SplineField, active: np.ndarray, camera: Camera,
                  size: Sequence[int], near: float = 0.0,
                  crop: tuple[int, int, int, int] | None = None,
                  start: np.ndarray | None = None, pixels: tuple | None = None
                  ) -> SurfaceHits:
    """The first root of ``field`` along each pixel's ray, within the ``active`` cells.

    ``active``: ``(n, 3)`` cells that may hold a zero (e.g.
    :func:`~pv_cubemarch.models.surface.active_cells` with ``'bernstein'``: exact); the
    others are passed through. ``crop``: ``(x, y, width, height)`` of the pixels to trace.
    ``start``: per traced pixel (``(height, width)``), the distance along its ray from
    which to look (``inf``: not at all), to find the roots after one already found.
    ``pixels``: ``(rows, columns)`` of the pixels to trace instead (a sample; rows from the
    top); the hits then have the shape ``(1, n)``.
    """
    origins, directions, shape = _pixel_rays(camera, size, crop, pixels)
    hits = _trace_levels(field, [active], np.zeros(1), np.zeros(len(origins), np.intp),
                         origins, directions, camera, near,
                         None if start is None else np.asarray(start, np.float64).ravel())
    return _shaped(hits, shape)


def _pixel_rays(camera: Camera, size: Sequence[int], crop, pixels
                ) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
    """The traced pixels' world rays, flat, and the shape their results take."""
    width, height = (int(v) for v in size)
    origins, directions = camera.rays((width, height))
    if pixels is not None:
        rows, columns = checked_pixels(pixels, crop, width, height)
        return origins[rows, columns], directions[rows, columns], (1, len(rows))
    x0, y0, w, h = crop if crop is not None else (0, 0, width, height)
    return (origins[y0:y0 + h, x0:x0 + w].reshape(-1, 3),
            directions[y0:y0 + h, x0:x0 + w].reshape(-1, 3), (h, w))


def _shaped(hits: SurfaceHits, shape: tuple[int, ...]) -> SurfaceHits:
    """``hits`` of flat rays in ``shape``."""
    return SurfaceHits(*(np.asarray(getattr(hits, name)).reshape(
        *shape, *np.shape(getattr(hits, name))[1:]) for name in
        ("hit", "depth", "point", "normal", "cell", "ambiguous")))


def _trace_levels(field: SplineField, actives: Sequence[np.ndarray], offsets: np.ndarray,
                  level: np.ndarray, origins: np.ndarray, directions: np.ndarray,
                  camera: Camera, near: float, start: np.ndarray | None,
                  end: np.ndarray | None = None) -> SurfaceHits:
    """Per flat ray, the first root of ``field - offsets[level]`` in ``actives[level]``.

    Rays of several levels are walked together (one pass for them all); a level's
    Bernstein coefficients are the field's less its offset (they sum to 1). ``start``,
    ``end``: where each ray's search begins and stops (world ``t``; clip planes).
    """
    world_from_index = field.world_from_index()
    index_from_world = np.linalg.inv(world_from_index)
    # Camera-relative: origins are moved to the grid's centre before the inverse is applied.
    dims = np.asarray(field.dimensions, dtype=np.float64)
    centre = world_from_index[:3, :3] @ (dims / 2) + world_from_index[:3, 3]
    o = (origins - centre) @ index_from_world[:3, :3].T + dims / 2
    d = directions @ index_from_world[:3, :3].T
    forward = np.asarray(camera.basis()[2])
    start = np.maximum(near / np.maximum(directions @ forward, 1e-300), 0.0) \
        if start is None else np.maximum(near / np.maximum(directions @ forward, 1e-300),
                                         np.maximum(start, 0))
    enter, leave = ray_box_interval(o, d, *field.domain_corners())   # the part drawn
    if end is not None:
        leave = np.minimum(leave, end)
    t = np.maximum(enter, start)
    n = len(o)
    depth = np.full(n, np.inf)
    cell_hit = np.full((n, 3), -1, np.int64)
    ambiguous = np.zeros(n, bool)
    mask = np.zeros((len(actives), *field.dimensions), bool)
    for k, active in enumerate(actives):
        if len(active):
            mask[(k, *np.asarray(active).T)] = True
    going = np.flatnonzero(t < leave)
    moving = d != 0
    with np.errstate(divide="ignore"):
        inverse = np.where(moving, 1.0 / np.where(moving, d, 1.0), 0.0)
    ahead = d > 0
    # First cell: the one the ray occupies just after its start (ahead on a boundary).
    p = o[going] + d[going] * t[going, None]
    cell = np.where(ahead[going], np.floor(p), np.ceil(p) - 1).astype(np.int64)
    cell = np.where(moving[going], cell, np.floor(p).astype(np.int64))
    cell = np.clip(cell, 0, np.asarray(field.dimensions) - 1)
    t_in = t[going]
    # The field at the previous cell's exit, where that cell was active (else NaN): a root
    # exactly on the face between two cells may round to the outside of both samples.
    last_end = np.full(len(going), np.nan)
    pending = []   # rays whose root is bracketed: (rays, cells, lo, hi, field at lo)
    while len(going):
        bound = cell + ahead[going]
        crossing = np.where(moving[going], (bound - o[going]) * inverse[going], np.inf)
        axis = np.argmin(crossing, axis=1)
        t_out = np.minimum(crossing[np.arange(len(going)), axis], leave[going])
        here = mask[(level[going], *cell.T)]
        done = np.zeros(len(going), bool)
        ends = np.full(len(going), np.nan)
        if here.any():
            rows = np.flatnonzero(here)
            rays = going[rows]
            bracket = _first_bracket(field, cell[rows], o[rays], d[rays], t_in[rows],
                                     t_out[rows], offsets[level[rays]])
            on_face = np.sign(last_end[rows]) * np.sign(bracket.start_value) < 0  # NaN: no
            found = on_face | bracket.found
            ambiguous[rays] |= bracket.unsure & ~on_face
            depth[rays[on_face]] = t_in[rows[on_face]]
            refine = bracket.found & ~on_face   # bisected once the traversal is over
            pending.append((rays[refine], bracket.along[refine], t_in[rows[refine]],
                            (t_out - t_in)[rows[refine]], bracket.lo[refine],
                            bracket.hi[refine], bracket.f_lo[refine]))
            cell_hit[rays[found]] = cell[rows[found]]
            done[rows[found]] = True
            ends[rows] = bracket.end_value
        step = np.where(ahead[going, axis], 1, -1)
        cell[np.arange(len(going)), axis] += step
        inside = np.all((cell >= 0) & (cell < np.asarray(field.dimensions)), axis=1)
        keep = ~done & inside & (t_out < leave[going])
        going, cell, t_in, last_end = going[keep], cell[keep], t_out[keep], ends[keep]
    if pending:
        rays, along, t0, span, lo, hi, f_lo = (np.concatenate(parts) for parts in zip(
            *pending, strict=True))
        depth[rays] = _bisect(along, t0, span, lo, hi, f_lo)
    hit = np.isfinite(depth)
    point = np.full((n, 3), np.nan)
    normal = np.full((n, 3), np.nan)
    if hit.any():
        local = o[hit] + d[hit] * depth[hit, None]
        point[hit] = origins[hit] + directions[hit] * depth[hit, None]
        gradient = field.gradient_at_cells(local) @ index_from_world[:3, :3]
        normal[hit] = -gradient / np.maximum(np.linalg.norm(gradient, axis=1,
                                                            keepdims=True), 1e-300)
    return SurfaceHits(hit, depth, point, normal, cell_hit, ambiguous)


@dataclass
class _Bracket:
    """Per ray, where its cell's field first changes sign, if it does (``found``).

    ``lo``/``hi`` bound the first root and ``f_lo`` is the field at ``lo`` (``lo == hi``
    where a sample is exactly 0); ``unsure``: a tangent or near-double root makes the ray
    ambiguous; the field at the segment's start and end.
    """

    found: np.ndarray
    unsure: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    f_lo: np.ndarray
    start_value: np.ndarray
    end_value: np.ndarray
    #: Per ray, the field along its segment as Bernstein coefficients of degree 6 in the
    #: segment's parameter (0 at ``t0``, 1 at ``t1``): what the bisection evaluates.
    along: np.ndarray | None = None


def _first_bracket(field: SplineField, cells: np.ndarray, o: np.ndarray, d: np.ndarray,
                   t0: np.ndarray, t1: np.ndarray, offset: np.ndarray | float = 0.0
                   ) -> _Bracket:
    """Per ray, the first of ``BRACKETS`` intervals of ``[t0, t1]`` where it meets its level.

    ``offset``: the level, per ray or one for all (the field less it is 0 on the surface).

    A segment whose polynomial's Bernstein coefficients all lie beyond the tangent
    tolerance on one side has no root and no near-zero sample (the polynomial is their
    convex combination): only the others are sampled.
    """
    beta = field.cell_bernstein(cells) - np.reshape(offset, (-1, 1, 1, 1))
    scale = np.abs(beta).max(axis=(1, 2, 3))
    span = t1 - t0
    at_nodes = _at(beta, o, d, cells, t0[:, None] + span[:, None] * _NODES[None, :])
    along = at_nodes @ _TO_BERNSTEIN.T
    margin = TANGENT_TOLERANCE * scale
    sampled = np.flatnonzero(~((along.min(axis=1) > margin) | (along.max(axis=1) < -margin)))
    n = len(cells)
    bracket = _Bracket(np.zeros(n, bool), np.zeros(n, bool), t1.copy(), t1.copy(),
                       at_nodes[:, -1].copy(), at_nodes[:, 0].copy(), at_nodes[:, -1].copy(),
                       along)
    if len(sampled):
        values = at_nodes[sampled] @ _INTERPOLATE
        for sample, node in _ON_NODE:
            values[:, sample] = at_nodes[sampled, node]
        length = np.linalg.norm(d[sampled], axis=1) * span[sampled]   # cell units
        found = _bracket_samples(values, t0[sampled], span[sampled], scale[sampled], length)
        for name in ("found", "unsure", "lo", "hi", "f_lo", "start_value", "end_value"):
            getattr(bracket, name)[sampled] = getattr(found, name)
    return bracket


def _bracket_samples(values: np.ndarray, t0: np.ndarray, span: np.ndarray,
                     scale: np.ndarray, length: np.ndarray) -> _Bracket:
    """:func:`_first_bracket` from the field's ``BRACKETS + 1`` samples of each segment."""
    zero = values == 0.0
    # a sign change between neighbours, or a sample exactly 0 (np.sign's product, in fewer
    # passes: a third of this function's time went to it and the gradient)
    not_positive = values <= 0.0
    change = (not_positive[:, :-1] != not_positive[:, 1:]) | zero[:, :-1] | zero[:, 1:]
    first = np.where(change.any(axis=1), np.argmax(change, axis=1), BRACKETS)
    found = first < BRACKETS
    # Tangent: |f| comes near 0, and flat, before the bracket of the first sign change (at
    # any sample, the segment's ends included: a tangent point may lie on a cell's face; a
    # sample next to a root in the next cell is near 0 too, but steep).
    length = np.maximum(length, 1e-300)
    slope = np.empty_like(values)   # np.gradient's differences, written out
    slope[:, 1:-1] = (values[:, 2:] - values[:, :-2]) / 2.0
    slope[:, 0] = values[:, 1] - values[:, 0]
    slope[:, -1] = values[:, -1] - values[:, -2]
    slope = np.abs(slope) * BRACKETS / length[:, None]
    magnitude = np.abs(values)
    small = ((magnitude < TANGENT_TOLERANCE * scale[:, None])
             & (slope < FLAT_TOLERANCE * scale[:, None]))
    before = np.arange(BRACKETS + 1)[None, :] < first[:, None]
    unsure = (small & before).any(axis=1)
    # A near-double root: the sign comes back within PAIR_BRACKETS of the first change,
    # the field between them staying within TANGENT_TOLERANCE of 0 (a sliver a float32
    # renderer may rightly miss).
    interval = np.arange(BRACKETS)[None, :]
    after = (change & (interval > first[:, None])
             & (interval <= first[:, None] + PAIR_BRACKETS))
    sample = np.arange(BRACKETS + 1)[None, :]
    between = (sample > first[:, None]) & (sample <= first[:, None] + PAIR_BRACKETS)
    peak = np.where(between, magnitude, 0.0).max(axis=1)
    unsure |= found & after.any(axis=1) & (peak < TANGENT_TOLERANCE * scale)
    k = np.minimum(first, BRACKETS - 1)
    row = np.arange(len(values))
    lo, f_lo = t0 + span * _SAMPLES[k], values[row, k]
    hi = np.where(f_lo == 0.0, lo, t0 + span * _SAMPLES[np.minimum(k + 1, BRACKETS)])
    return _Bracket(found, unsure, lo, hi, f_lo, values[:, 0], values[:, -1])


def _bisect(along: np.ndarray, t0: np.ndarray, span: np.ndarray, lo: np.ndarray,
            hi: np.ndarray, f_lo: np.ndarray) -> np.ndarray:
    """The roots bracketed in ``[lo, hi]``, by ``BISECTIONS`` halvings (all rays at once).

    The field along each ray's segment is the degree-6 polynomial ``along`` holds
    (Bernstein coefficients over ``[t0, t0 + span]``), evaluated at each midpoint.
    """
    exact = f_lo == 0.0
    start = lo.copy()
    weights = np.array([math.comb(6, i) for i in range(7)], dtype=np.float64) * along
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        u = np.clip((mid - t0) / np.where(span > 0, span, 1.0), 0.0, 1.0)[:, None]
        f_mid = np.sum(weights * u ** _POWERS * (1.0 - u) ** _POWERS[::-1], axis=1)
        same = np.sign(f_mid) == np.sign(f_lo)
        lo = np.where(same, mid, lo)
        f_lo = np.where(same, f_mid, f_lo)
        hi = np.where(same, hi, mid)
    return np.where(exact, start, 0.5 * (lo + hi))


#: The field along a ray through one cell is a polynomial of degree 6 at most (quadratic
#: along each axis, each axis linear in the ray's parameter): its values at these 7
#: Chebyshev-Lobatto points of the segment give it whole.
_NODES = 0.5 - 0.5 * np.cos(np.pi * np.arange(7) / 6)
_NODES = np.where(np.abs(_NODES * BRACKETS - np.round(_NODES * BRACKETS)) < 1e-9,
                  np.round(_NODES * BRACKETS) / BRACKETS, _NODES)   # 1/4, 1/2, 3/4 exactly
_SAMPLES = np.linspace(0.0, 1.0, BRACKETS + 1)


def _lagrange(nodes: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``(len(points), len(nodes))``: the Lagrange basis of ``nodes`` at ``points``."""
    weights = np.ones((len(points), len(nodes)))
    for j, node in enumerate(nodes):
        for m, other in enumerate(nodes):
            if m != j:
                weights[:, j] *= (points - other) / (node - other)
    return weights


#: The samples' values from the nodes' (Lagrange interpolation, exact for degree 6).
_INTERPOLATE = _lagrange(_NODES, _SAMPLES).T
#: The Bernstein coefficients (degree 6 in the segment's parameter) from the nodes' values.
_TO_BERNSTEIN = np.linalg.inv(np.stack([
    math.comb(6, i) * _NODES ** i * (1.0 - _NODES) ** (6 - i) for i in range(7)], axis=1))
#: The Bernstein basis's powers of the parameter, degree 6.
_POWERS = np.arange(7)
#: Samples that are nodes (0, 1/4, 1/2, 3/4, 1): read as computed, not interpolated.
_ON_NODE = [(int(n * BRACKETS), j) for j, n in enumerate(_NODES)
            if n * BRACKETS == int(n * BRACKETS)]


def _at(beta: np.ndarray, o: np.ndarray, d: np.ndarray, cells: np.ndarray,
        t: np.ndarray) -> np.ndarray:
    """The cells' fields (Bernstein ``beta``) at ray parameters ``t`` (``(m, k)``: k per ray)."""
    local = np.clip(o[:, None, :] + d[:, None, :] * t[..., None] - cells[:, None, :], 0.0, 1.0)
    bu, bv, bw = (bernstein_basis(local[..., a]) for a in range(3))
    # contracted one axis at a time: w (a batched product), then v, then u
    m, k = t.shape
    along_w = (beta.reshape(m, 9, 3) @ bw.transpose(0, 2, 1)).reshape(m, 3, 3, k)
    along_v = (along_w * bv.transpose(0, 2, 1)[:, None, :, :]).sum(axis=2)
    return (along_v * bu.transpose(0, 2, 1)).sum(axis=1)


def render_surface(field: SplineField, camera: Camera, size: Sequence[int],
                   color: Sequence[float] = (1.0, 1.0, 1.0),
                   background: Sequence[float] = (0.0, 0.0, 0.0), near: float = 0.0,
                   lights: Sequence[VolumeLight] = (), shading: str = "unlit",
                   ambient: float = 0.2, diffuse: float = 0.8, specular: float = 0.3,
                   specular_power: float = 30.0, color_by: str | None = None,
                   lookup_table: np.ndarray | None = None,
                   clim: Sequence[float] = (0.0, 1.0), opacity: float = 1.0,
                   levels: Sequence[float] | None = None,
                   level_colors: Sequence[Sequence[float]] | None = None,
                   pixels: tuple | None = None,
                   clip_planes: Sequence | None = None) -> np.ndarray:
    """Render the surface f = 0: each pixel its first root's (lit) colour, both sides lit.

    ``clip_planes``: world ``(origin, normal)`` pairs; only roots where every plane keeps
    the point (``normal . (x - origin) >= 0``) are drawn, the cut left open (as a clipped
    mesh).

    ``opacity`` below 1: every root along the ray, each covering ``opacity`` of what lies
    behind, composited front to back over ``background`` (up to :data:`MAX_LAYERS`).
    ``levels``: draw the level sets f = each of them instead of f = 0 (``level_colors``
    one RGB each, else ``color``), every root of every level composited in depth order.

    The normal at the hit faces the eye (open surfaces show their back lit as their front);
    lighting as :func:`~pv_cubemarch.reference.shading.blinn_phong`. ``color_by``:
    ``'curvature'`` (the mean curvature at the hit) or ``'field'`` (the field's
    ``color_values`` there) through ``lookup_table`` (``(n, 3)``) over ``clim``, the entry
    nearest the value's place. Returns ``(height, width, 3)`` float64 RGB; with ``pixels``
    (``(rows, columns)``, rows from the top: a sample) the ``(1, n, 3)`` colours of those
    pixels.
    """
    if shading not in ("unlit", "flat", "blinn"):
        raise ValueError(f"shading must be 'unlit', 'flat' or 'blinn', got {shading!r}.")
    if not 0.0 <= opacity <= 1.0:
        raise ValueError(f"opacity must lie in [0, 1], got {opacity!r}.")
    width, height = (int(v) for v in size)
    origins, directions, shape = _pixel_rays(camera, (width, height), None, pixels)
    image = np.empty((*shape, 3))
    image[...] = np.asarray(background, dtype=np.float64)

    def shade(hits: SurfaceHits, colour: np.ndarray, toward_eye: np.ndarray) -> np.ndarray:
        """The (lit) colour of each hit ray (``colour``, ``toward_eye``: per hit)."""
        hit = hits.hit
        normals = hits.normal[hit]
        normals = np.where(np.sum(normals * toward_eye, axis=1, keepdims=True) < 0,
                           -normals, normals)
        base = np.broadcast_to(colour, normals.shape)
        if color_by is not None:
            local = (hits.point[hit] - field.world_from_index()[:3, 3]) @ np.linalg.inv(
                field.world_from_index()[:3, :3]).T
            values = (field.mean_curvature_at_cells(local) if color_by == "curvature" else
                      field.at_cells(local, field.color_values))
            table = np.asarray(lookup_table, dtype=np.float64)
            place = np.clip((values - clim[0]) / (clim[1] - clim[0]), 0.0, 1.0)
            base = table[np.floor(place * (len(table) - 1) + 0.5).astype(int)]
        return np.clip(blinn_phong(base, normals, hits.point[hit], toward_eye, lights,
                                   shading, ambient, specular, specular_power,
                                   diffuse_weight=diffuse), 0.0, 1.0)

    offsets = np.zeros(1) if levels is None else np.asarray(levels, dtype=np.float64)
    colours = np.asarray([color] * len(offsets) if level_colors is None else level_colors,
                         dtype=np.float64).reshape(len(offsets), 3)
    actives = [active_cells(replace(field, coefficients=field.coefficients - offset))
               if offset != 0.0 else active_cells(field) for offset in offsets]
    # Every level's rays walked at once: ray k * n + i is pixel i of level k.
    m = len(origins)
    level = np.repeat(np.arange(len(offsets)), m)
    origins, directions = np.tile(origins, (len(offsets), 1)), np.tile(directions,
                                                                        (len(offsets), 1))
    kept_from, kept_to = clip_interval(origins, directions, np.zeros(len(origins)),
                                       np.full(len(origins), np.inf), clip_planes)
    if opacity >= 1.0 and levels is None:
        hits = _trace_levels(field, actives, offsets, level, origins, directions, camera,
                             near, kept_from, kept_to)
        flat = image.reshape(-1, 3)
        flat[hits.hit] = shade(hits, colours[0], -directions[hits.hit])
        return image
    # Every root of every level along the ray, sorted by depth and composited front to
    # back, each covering `opacity`; the next root of a level looked for a millionth of a
    # cell past its last (roots are found to 1e-9).
    cell = float(np.linalg.norm(field.world_from_index()[:3, :3], axis=0).min())
    # Opaque levels: each level's first root only (the nearest of them is drawn).
    layers = MAX_LAYERS if opacity < 1.0 else 1
    shape = image.shape[:2]
    depths, shades = [], []
    start = kept_from
    for _ in range(layers):
        hits = _trace_levels(field, actives, offsets, level, origins, directions, camera,
                             near, start, kept_to)
        hit = hits.hit
        if not hit.any():
            break
        shade_here = np.zeros((len(origins), 3))
        shade_here[hit] = shade(hits, colours[level[hit]], -directions[hit])
        for k in np.unique(level[hit]):   # each level's layer: one depth image of them
            depths.append(np.where(hit, hits.depth, np.inf)[k * m:(k + 1) * m].reshape(shape))
            shades.append(shade_here[k * m:(k + 1) * m].reshape(*shape, 3))
        start = np.where(hit, hits.depth + 1e-6 * cell, np.inf)
    held = np.zeros((*shape, 3))
    cover = np.zeros(shape)
    if depths:
        depth, colour = np.stack(depths), np.stack(shades)
        order = np.argsort(depth, axis=0)
        depth = np.take_along_axis(depth, order, axis=0)
        colour = np.take_along_axis(colour, order[..., None], axis=0)
        for layer in range(len(depth)):
            hit = np.isfinite(depth[layer])
            weight = (1.0 - cover[hit]) * opacity
            held[hit] += weight[:, None] * colour[layer][hit]
            cover[hit] += weight
    return held + (1.0 - cover)[..., None] * image
