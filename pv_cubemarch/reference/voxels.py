"""The voxel CPU reference: which voxel each pixel sees, by exact grid traversal.

:func:`trace_voxels` walks every pixel's ray through a labelled grid with the
Amanatides & Woo traversal in float64 and reports the first visible filled voxel, the face
the ray entered it through and the distance to that entry. :func:`render_voxels` turns the
hits into a (lit) image through a palette, :func:`id_colors` into an 8-bit id buffer;
:func:`occlusion_factor` is the per-vertex ambient occlusion of the hit faces.

Conventions
-----------
``labels`` is an ``(nx, ny, nz)`` integer grid, 0 = empty. Voxel ``(i, j, k)`` occupies
``[i, i+1] x [j, j+1] x [k, k+1]`` in index space; ``world_from_index`` (4x4 affine, may
mirror or be anisotropic) maps index space to world. Rays are traversed in index space:
origins and directions are mapped by the inverse of the affine's 3x3 part after subtracting
the world position of the grid's centre, so the traversal keeps its precision for grids
1e6-1e7 world units from the origin. Directions stay unnormalised in index space, so a ray
parameter ``t`` is the world distance from the ray origin :meth:`Camera.rays` gives.

A ray starts at ``max(0, box entry, near / dot(direction, forward))`` (as in
:func:`~pv_cubemarch.reference.emission_absorption.render_emission_absorption`). Its first
voxel is the one it occupies just after that start: ``floor`` of the start point, or
``ceil - 1`` on axes along which it moves in ``-axis`` (so a start exactly on a boundary
picks the voxel ahead), clamped into the grid. Crossing ``t`` are always computed as
``(boundary - origin) * (1 / direction)``, the expression of
:func:`~pv_cubemarch.reference.rays.ray_box_interval`, from the voxel index (never by
accumulation), so a traversal has no drift however long it is.

Tie rule
--------
One axis is stepped per iteration: the one whose next boundary crossing has the smallest
``t``. When the next crossings of several axes are at exactly the same ``t`` (float64
equality) x is stepped before y before z (``argmin`` with ties to the lowest axis); the ray
then visits the in-between voxels with zero length, and one of them that is filled is hit.
Axes along which the index-space direction is exactly 0 are never crossed (their crossing
``t`` is ``inf``, set explicitly, never a division by zero).

Pixels a float32 GPU may legitimately get otherwise (``VoxelHits.near_edge``)
----------------------------------------------------------------------------
At every boundary crossing up to and including the one into the hit voxel (or out of the
grid on a miss; the box entry counts as a crossing of its axis), the ray's coordinates on
the *other* axes are checked: one within ``tie_tolerance`` voxel lengths of an integer
means the ray passes that close to a voxel edge or corner (for a non-parallel axis ``b``
that is the same as the crossings of the two axes lying within
``tie_tolerance / |direction_b|`` of each other). Also flagged: a ray starting inside the
grid (camera or near plane inside) within ``tie_tolerance`` of a voxel face, and a ray
missing the box, or starting past its exit, by at most ``tie_tolerance`` of path length.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..core.camera import Camera
from ..models.lights import VolumeLight
from .rays import clip_interval, cut_normals, ray_box_interval
from .shading import blinn_phong
from .voxel_edges import edge_coverage, label_edge_coverage


@dataclass
class VoxelHits:
    """Per-pixel result of :func:`trace_voxels`; arrays are ``(height, width)`` images.

    Attributes
    ----------
    index : numpy.ndarray
        ``(h, w, 3)`` int64 voxel index ``(i, j, k)`` of the first visible filled voxel,
        -1 where the ray misses.
    material : numpy.ndarray
        ``(h, w)`` int64 label of that voxel, 0 on a miss.
    face : numpy.ndarray
        ``(h, w)`` int64 face the ray entered the voxel through: ``2 * axis + 0`` through
        its upper face (ray moving in ``-axis``), ``2 * axis + 1`` through its lower face
        (ray moving in ``+axis``); -1 where the ray starts inside the hit voxel (camera or
        near plane inside it) or misses.
    depth : numpy.ndarray
        ``(h, w)`` float64 distance along the ray (world units, from the ray origin
        :meth:`Camera.rays` gives) to the voxel entry, or to the ray's start where it starts
        inside the voxel; ``inf`` on a miss.
    near_edge : numpy.ndarray
        ``(h, w)`` bool: the ray passed within ``tie_tolerance`` voxel lengths of a voxel
        edge or corner before the hit (see the module docstring): pixels where a float32
        GPU traversal may legitimately differ.
    point : numpy.ndarray or None
        ``(h, w, 3)`` float64 index-space point at ``depth`` along the ray (on the entered
        face, or the ray's start where it starts inside the voxel); NaN on a miss. Filled
        by :func:`trace_voxels`; :func:`occlusion_factor` needs it.
    """

    index: np.ndarray
    material: np.ndarray
    face: np.ndarray
    depth: np.ndarray
    near_edge: np.ndarray
    point: np.ndarray | None = None


def _check_labels(labels: np.ndarray) -> np.ndarray:
    labels = np.asarray(labels)
    if labels.ndim != 3 or 0 in labels.shape:
        raise ValueError(f"labels must be a non-empty (nx, ny, nz) grid, got shape "
                         f"{labels.shape}.")
    if not (np.issubdtype(labels.dtype, np.integer) or labels.dtype == bool):
        raise ValueError(f"labels must hold integers (0 = empty), got dtype {labels.dtype}.")
    if labels.dtype == bool:
        return labels.astype(np.uint8)
    if np.issubdtype(labels.dtype, np.signedinteger) and labels.min() < 0:
        raise ValueError("labels must be >= 0 (0 = empty).")
    return labels   # its own type: a 2048 x 2048 x 512 grid as int64 would take 16 GiB


def _index_rays(origins: np.ndarray, directions: np.ndarray, world_from_index: np.ndarray,
                shape: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """World rays ``(n, 3)`` in index space, relative to the grid centre for precision."""
    matrix = np.asarray(world_from_index, dtype=np.float64)
    if matrix.shape != (4, 4) or not np.isfinite(matrix).all():
        raise ValueError(f"world_from_index must be a finite 4x4 matrix, got shape "
                         f"{matrix.shape}.")
    linear = matrix[:3, :3]
    condition = np.linalg.cond(linear)
    if not np.isfinite(condition) or condition > 1e12:
        raise ValueError("world_from_index is singular: its 3x3 part cannot be inverted.")
    centre = 0.5 * np.asarray(shape, dtype=np.float64)
    centre_world = linear @ centre + matrix[:3, 3]
    index_from_world = np.linalg.inv(linear)
    o_idx = (origins - centre_world) @ index_from_world.T + centre
    d_idx = directions @ index_from_world.T
    return o_idx, d_idx


def _drawn(labels: np.ndarray, visible: np.ndarray | None) -> np.ndarray:
    """Bool grid of the drawn voxels: a nonzero label whose ``visible`` entry is set."""
    max_label = int(labels.max())
    if visible is None:
        table = np.ones(max_label + 1, dtype=bool)
    else:
        table = np.asarray(visible, dtype=bool).ravel()
        if table.size <= max_label:
            raise ValueError(f"visible has {table.size} entries but labels go up to "
                             f"{max_label}; give one per material id.")
    table = table.copy()
    table[0] = False
    return table[labels]


def _fraction_to_boundary(p: np.ndarray) -> np.ndarray:
    """Distance of each coordinate to the nearest integer (voxel boundary)."""
    return np.abs(p - np.rint(p))


def trace_voxels(
    labels: np.ndarray,
    world_from_index: np.ndarray,
    camera: Camera,
    size: tuple[int, int],
    near: float | None = None,
    visible: np.ndarray | None = None,
    tie_tolerance: float = 1e-4,
    crop: Sequence[int] | None = None,
    clip_planes: Sequence | None = None,
    far: float | None = None,
) -> VoxelHits:
    """Find the first visible filled voxel along every pixel's ray (exact float64 traversal).

    Parameters
    ----------
    labels : numpy.ndarray
        ``(nx, ny, nz)`` integer material labels, 0 = empty.
    world_from_index : numpy.ndarray
        4x4 affine from index space (voxel ``(i, j, k)`` is ``[i, i+1] x [j, j+1] x
        [k, k+1]``) to world; may mirror or be anisotropic.
    camera : Camera
        The view; rays run through pixel centres, rows top to bottom.
    size : tuple of int
        ``(width, height)`` in pixels.
    near : float, optional
        Distance along the view axis of the near clipping plane; rays start there.
    visible : numpy.ndarray, optional
        Bool per material id (index = label); a hidden label is traversed as empty. Default:
        every nonzero label visible. Label 0 is always empty.
    tie_tolerance : float
        Distance, in voxel lengths, from a voxel edge or corner within which a pixel is
        flagged in ``near_edge``.
    crop : sequence of int, optional
        ``(x, y, width, height)`` of a pixel window (from the top-left) of the ``size``
        image: only those rays are traced.
    clip_planes : sequence of (origin, normal), optional
        World planes keeping ``normal . (x - origin) >= 0``: each ray is cut to the part
        all keep (a ray starting on a plane inside a filled voxel hits it there, face -1).
    far : float, optional
        Distance along the view axis of the far clipping plane: a first hit past it is no
        hit (nothing behind it is nearer). Hits within ``tie_tolerance`` voxel lengths (or
        a millionth of ``far``) of it are flagged in ``near_edge``.

    Returns
    -------
    VoxelHits
        Images of the crop (or of the whole ``size``).
    """
    labels = _check_labels(labels)
    drawn = _drawn(labels, visible)
    if drawn.any() and not drawn.all():
        # Nothing is hit outside the drawn voxels' bounding box: traverse only that box (the
        # same rays, the sub-grid placed where it sits), then put its indices back.
        spans = [np.nonzero(drawn.any(axis=tuple(a for a in range(3) if a != axis)))[0]
                 for axis in range(3)]
        low = np.array([span[0] for span in spans])
        high = np.array([span[-1] + 1 for span in spans])
        if np.any(low > 0) or np.any(high < labels.shape):
            shift = np.eye(4)
            shift[:3, 3] = low
            box = tuple(slice(lo, hi) for lo, hi in zip(low, high, strict=True))
            hits = trace_voxels(labels[box],
                                np.asarray(world_from_index, dtype=np.float64) @ shift, camera,
                                size, near=near, visible=visible,
                                tie_tolerance=tie_tolerance, crop=crop,
                                clip_planes=clip_planes, far=far)
            seen = hits.material > 0
            hits.index[seen] += low
            hits.point[seen] += low
            return hits
    shape = np.array(labels.shape, dtype=np.int64)
    filled = drawn.ravel(order="F")
    flat_labels = labels.ravel(order="F")
    strides = np.array([1, shape[0], shape[0] * shape[1]], dtype=np.int64)

    width, height = (int(v) for v in size)
    if width <= 0 or height <= 0:
        raise ValueError(f"size must be two positive ints (width, height), got {size}.")
    origins, directions = camera.rays((width, height))
    if crop is not None:
        x, y, width, height = (int(v) for v in crop)
        if x < 0 or y < 0:
            raise ValueError(f"crop {tuple(crop)} does not fit in an image of size {size}.")
        origins = origins[y:y + height, x:x + width]
        directions = directions[y:y + height, x:x + width]
        if origins.shape[:2] != (height, width):
            raise ValueError(f"crop {tuple(crop)} does not fit in an image of size {size}.")
    origins = origins.reshape(-1, 3)
    directions = directions.reshape(-1, 3)
    n_rays = origins.shape[0]

    o_idx, d_idx = _index_rays(origins, directions, world_from_index, labels.shape)
    t0, t1 = ray_box_interval(o_idx, d_idx, np.zeros(3), shape.astype(np.float64))
    box_t1 = t1
    kept0, t1 = clip_interval(origins, directions, t0, t1, clip_planes)
    t_start = np.maximum(kept0, 0.0)
    if near is not None:
        _, _, forward = camera.basis()
        t_start = np.maximum(t_start, near / np.maximum(directions @ forward, 1e-12))
    from_entry = t0 >= t_start   # started on the box face (not inside the box)

    index = np.full((n_rays, 3), -1, dtype=np.int64)
    material = np.zeros(n_rays, dtype=np.int64)
    face = np.full(n_rays, -1, dtype=np.int64)
    depth = np.full(n_rays, np.inf)
    near_edge = np.zeros(n_rays, dtype=bool)
    tol = float(tie_tolerance)

    # Rays missing the box, or starting past its exit, by at most the tolerance.
    speed = np.linalg.norm(d_idx, axis=1)
    enter = t_start <= t1
    with np.errstate(invalid="ignore"):
        gap = (t_start - t1) * speed
    near_edge[~enter & np.isfinite(gap) & (gap <= tol)] = True
    # A plane's exit near a voxel face: float32 may end the ray on the other side of it.
    cut = enter & (t1 < box_t1)
    ends = o_idx[cut] + t1[cut, None] * d_idx[cut]
    near_edge[np.flatnonzero(cut)[_fraction_to_boundary(ends).min(axis=1) <= tol]] = True

    ids = np.nonzero(enter)[0]
    o = o_idx[ids]
    d = d_idx[ids]
    ts = t_start[ids]
    te = t1[ids]   # where the kept part of the ray ends (the box's or a plane's exit)
    step = np.where(d > 0, 1, np.where(d < 0, -1, 0)).astype(np.int64)
    parallel = d == 0
    with np.errstate(divide="ignore"):
        inv = np.where(parallel, np.inf, 1.0 / np.where(parallel, 1.0, d))
    p = o + ts[:, None] * d
    idx = np.where(step < 0, np.ceil(p) - 1, np.floor(p))
    idx = np.clip(idx, 0, shape - 1).astype(np.int64)
    # The entry axis: the one whose slab entry is the box entry (ties to the lowest axis).
    entry_t = np.where(parallel, -np.inf, (np.where(step > 0, 0.0, shape) - o) * inv)
    entry_axis = np.where(from_entry[ids], np.argmax(entry_t, axis=1), -1)
    dist = _fraction_to_boundary(p)
    rows = np.arange(ids.size)
    has_entry = entry_axis >= 0
    dist[rows[has_entry], entry_axis[has_entry]] = np.inf
    near_edge[ids[dist.min(axis=1) <= tol]] = True

    lin = idx @ strides
    hit = filled[lin]
    hit_ids = ids[hit]
    index[hit_ids] = idx[hit]
    material[hit_ids] = flat_labels[lin[hit]]
    depth[hit_ids] = ts[hit]
    face[hit_ids] = np.where(has_entry[hit],
                             2 * entry_axis[hit] + (step[rows[hit], entry_axis[hit]] > 0),
                             -1)

    keep = ~hit
    ids, o, d, ts, te, step, inv, idx, lin = (
        a[keep] for a in (ids, o, d, ts, te, step, inv, idx, lin))
    bound = idx + (step > 0)
    with np.errstate(invalid="ignore"):
        t_next = np.where(step == 0, np.inf, (bound - o) * inv)
    all_rows = np.arange(ids.size)
    for _ in range(int(shape.sum()) + 3):
        if ids.size == 0:
            break
        rows = all_rows[:ids.size]
        axis = np.argmin(t_next, axis=1)
        t = t_next[rows, axis]
        s = step[rows, axis]
        moved = idx[rows, axis] + s
        idx[rows, axis] = moved
        lin += s * strides[axis]
        out = (moved < 0) | (moved >= shape[axis]) | (t >= te)   # entered at the end: not in
        # Does the ray pass near an edge as it crosses this boundary?
        dist = _fraction_to_boundary(o + t[:, None] * d)
        dist[rows, axis] = np.inf
        near_edge[ids[dist.min(axis=1) <= tol]] = True
        t_next[rows, axis] = (moved + (s > 0) - o[rows, axis]) * inv[rows, axis]
        hit = ~out & filled[np.where(out, 0, lin)]
        if hit.any():
            hit_ids = ids[hit]
            index[hit_ids] = idx[hit]
            material[hit_ids] = flat_labels[lin[hit]]
            depth[hit_ids] = np.maximum(t[hit], ts[hit])
            face[hit_ids] = 2 * axis[hit] + (s[hit] > 0)
        done = hit | out
        if done.any():
            keep = ~done
            ids, o, d, ts, te, step, inv, idx, lin, t_next = (
                a[keep] for a in (ids, o, d, ts, te, step, inv, idx, lin, t_next))
    else:
        if ids.size:
            raise RuntimeError("voxel traversal did not finish; this is a bug.")

    if far is not None:
        _, _, forward = camera.basis()
        past = depth * (directions @ forward) - float(far)
        voxel = np.linalg.norm(np.asarray(world_from_index, np.float64)[:3, :3], axis=0).min()
        near_edge |= (material > 0) & (np.abs(past) <= max(tol * voxel, 1e-6 * abs(far)))
        cut = (material > 0) & (past > 0)
        material[cut], index[cut], face[cut], depth[cut] = 0, -1, -1, np.inf
    point = np.full((n_rays, 3), np.nan)
    seen = material > 0
    point[seen] = o_idx[seen] + depth[seen, None] * d_idx[seen]
    return VoxelHits(
        index=index.reshape(height, width, 3),
        material=material.reshape(height, width),
        face=face.reshape(height, width),
        depth=depth.reshape(height, width),
        near_edge=near_edge.reshape(height, width),
        point=point.reshape(height, width, 3),
    )


def render_voxels(
    labels: np.ndarray,
    world_from_index: np.ndarray,
    palette: np.ndarray,
    camera: Camera,
    size: tuple[int, int],
    background: Sequence[float] = (0.0, 0.0, 0.0),
    near: float | None = None,
    lights: Sequence[VolumeLight] = (),
    shading: str = "unlit",
    ambient: float = 0.2,
    specular: float = 0.3,
    specular_power: float = 30.0,
    ambient_occlusion: bool = False,
    diffuse: float = 0.8,
    occlusion_strength: float = 0.5,
    show_edges: bool = False,
    edge_color: Sequence[float] = (0.0, 0.0, 0.0),
    line_width: float = 1.0,
    edge_opacity: float = 1.0,
    edge_mode: str = "voxels",
    clip_planes: Sequence | None = None,
) -> np.ndarray:
    """Render a labelled grid: each pixel the (lit) colour of the voxel it sees.

    Parameters
    ----------
    labels, world_from_index, camera, size, near
        As in :func:`trace_voxels`.
    palette : numpy.ndarray
        ``(n_materials, 4)`` RGBA floats, row = material id; a material whose alpha is 0 is
        hidden (traversed as empty). Row 0 (empty) is never drawn.
    background : sequence of float
        RGB where the ray hits no visible voxel.
    lights : sequence of VolumeLight
        Directional and point lights (world coordinates) for ``'flat'`` and ``'blinn'``.
    shading : str
        ``'unlit'``: the palette colour. ``'flat'``: Lambert on the face the ray entered,
        ``colour * (ambient + diffuse * sum light * max(n.l, 0))``. ``'blinn'``: that
        plus ``specular * sum light * max(n.h, 0) ** specular_power``, ``h`` halfway
        between the light and the eye. A ray that starts inside its voxel faces the eye.
    ambient, specular, specular_power : float
        The shading's ambient term (added, as VTK's), specular weight and exponent.
    diffuse : float
        The weight of the lights' sum (VTK's diffuse term).
    ambient_occlusion : bool
        Darken each hit face near the drawn voxels around it by the factor ``ao`` of
        :func:`occlusion_factor`: ``'unlit'`` gives ``colour * ao``, ``'flat'`` and
        ``'blinn'`` ``colour * ao * (ambient + diffuse * sum light * max(n.l, 0))``
        (plus the unoccluded highlight).
    occlusion_strength : float
        How dark a fully occluded corner gets (0-1): ``ao = 1 - occlusion_strength`` there.
    show_edges : bool
        Outline every hit face as VTK draws a mesh's edges
        (:func:`~pv_cubemarch.reference.voxel_edges.edge_coverage`).
    edge_color : sequence of float
        The edges' RGB (floats).
    line_width : float
        The edges' width in pixels (drawn at least 1.1 wide, as VTK).
    edge_opacity : float
        The share of the edge colour on a fully covered pixel.
    edge_mode : str
        ``'voxels'``: every hit face's outline; ``'labels'``: only the edges between
        different labels (:func:`~pv_cubemarch.reference.voxel_edges.label_edge_coverage`).
    clip_planes : sequence of (origin, normal), optional
        World planes cutting the rays, as :func:`trace_voxels` takes them.

    Returns
    -------
    numpy.ndarray
        ``(height, width, 3)`` float64 RGB.
    """
    palette = np.asarray(palette, dtype=np.float64)
    if palette.ndim != 2 or palette.shape[1] != 4:
        raise ValueError(f"palette must be (n_materials, 4) RGBA, got shape {palette.shape}.")
    if shading not in ("unlit", "flat", "blinn"):
        raise ValueError(f"shading must be 'unlit', 'flat' or 'blinn', got {shading!r}.")
    max_label = int(_check_labels(labels).max())
    if palette.shape[0] <= max_label:
        raise ValueError(f"palette has {palette.shape[0]} rows but labels go up to "
                         f"{max_label}; give one RGBA row per material id.")
    hits = trace_voxels(labels, world_from_index, camera, size, near=near,
                        visible=palette[:, 3] > 0, clip_planes=clip_planes)
    width, height = (int(v) for v in size)
    image = np.empty((height, width, 3))
    image[...] = np.asarray(background, dtype=np.float64)
    hit = hits.material > 0
    color = palette[hits.material[hit], :3]
    occlusion = np.ones(len(color))
    if ambient_occlusion:
        occlusion = occlusion_factor(labels, hits, occlusion_strength,
                                     visible=palette[:, 3] > 0)[hit]
    if shading == "unlit":
        color = color * occlusion[:, None]
    else:
        origins, directions = camera.rays((width, height))
        toward_eye = -directions[hit]
        points = origins[hit] + directions[hit] * hits.depth[hit][:, None]
        normals = face_normals(hits.face[hit], world_from_index, toward_eye)
        inside = hits.face[hit] < 0   # starting on a clip plane: its cut
        normals[inside] = cut_normals(origins[hit][inside], directions[hit][inside],
                                      hits.depth[hit][inside], clip_planes, normals[inside])
        color = blinn_phong(color * occlusion[:, None], normals, points, toward_eye, lights,
                            shading, ambient, specular, specular_power, diffuse_weight=diffuse)
        if show_edges:   # the highlight alone: the shading of black
            highlight = np.clip(blinn_phong(np.zeros_like(color), normals, points, toward_eye,
                                            lights, shading, ambient, specular,
                                            specular_power, diffuse_weight=diffuse), 0.0, 1.0)
    if show_edges:
        if edge_mode == "labels":
            drawn = np.where(_drawn(labels, palette[:, 3] > 0), labels, 0)
            cover = label_edge_coverage(hits, drawn, world_from_index, camera,
                                        (width, height), line_width, edge_opacity,
                                        clip_planes)[hit][:, None]
        else:
            cover = edge_coverage(hits, world_from_index, camera, (width, height),
                                  line_width, edge_opacity)[hit][:, None]
        edge = np.asarray(edge_color, dtype=np.float64)
        if shading == "unlit":
            color = color * (1.0 - cover) + edge * cover
        else:
            shaded = np.clip(color, 0.0, 1.0)
            color = (shaded - highlight) * (1.0 - cover) + edge * cover + highlight
    image[hit] = np.clip(color, 0.0, 1.0)
    return image


def occlusion_factor(labels: np.ndarray, hits: VoxelHits, strength: float = 0.5,
                     visible: np.ndarray | None = None) -> np.ndarray:
    """Per-vertex ("Minecraft") ambient occlusion of every pixel's hit face, ``(h, w)``.

    For a hit entered through face ``2 * axis + 1`` (moving ``+axis``; the face's normal
    points ``-axis``) the *layer* is the voxel on the viewer's side of the face,
    ``voxel - e_axis`` (``voxel + e_axis`` for face ``2 * axis``). The face's other two
    axes are ``u = (axis + 1) % 3`` and ``v = (axis + 2) % 3``. Each of its 4 corners
    ``(du, dv)`` (each -1 or +1) looks at 3 voxels of the layer's plane: ``side1 = layer +
    du e_u``, ``side2 = layer + dv e_v`` and ``corner = layer + du e_u + dv e_v``; its
    level is 3 when both sides are drawn, else ``side1 + side2 + corner`` (0-3). The level
    at the hit is the bilinear interpolation of the corners' at the hit point's place on
    the face, ``s = point_u - voxel_u`` and ``r = point_v - voxel_v`` (clamped to [0, 1];
    the corner ``(-1, -1)`` is at ``(0, 0)``), and ``factor = 1 - strength * level / 3``.

    Drawn means a nonzero label whose ``visible`` entry is set (as the traversal: a hidden
    material casts no occlusion); voxels outside the grid are empty. The factor is 1 where
    the ray misses or starts inside its voxel (face -1). ``hits`` comes from
    :func:`trace_voxels` on the same ``labels`` and ``visible``.
    """
    strength = float(strength)
    if not 0.0 <= strength <= 1.0:
        raise ValueError(f"occlusion_strength must be in [0, 1], got {strength!r}.")
    if hits.point is None:
        raise ValueError("occlusion_factor needs the hit points (hits.point), which "
                         "trace_voxels fills.")
    labels = _check_labels(labels)
    factor = np.ones(hits.face.shape)
    faced = hits.face >= 0
    level = occlusion_levels(_drawn(labels, visible), hits.index[faced], hits.face[faced],
                             hits.point[faced])
    factor[faced] = 1.0 - strength * level / 3.0
    return factor


def occlusion_levels(drawn: np.ndarray, index: np.ndarray, face: np.ndarray,
                     point: np.ndarray) -> np.ndarray:
    """The interpolated occlusion level (0-3) of ``n`` hits, as :func:`occlusion_factor`.

    ``drawn``: the bool grid; ``index``: ``(n, 3)`` voxels; ``face``: ``(n,)`` entry faces
    (all >= 0); ``point``: ``(n, 3)`` index-space hit points.
    """
    rows = np.arange(len(face))
    axis = face // 2
    u, v = (axis + 1) % 3, (axis + 2) % 3
    layer = index + 1   # in the grid padded by one empty voxel on every side
    layer[rows, axis] += np.where(face % 2 == 1, -1, 1)
    padded = np.pad(drawn, 1)

    def occupied(du: int, dv: int) -> np.ndarray:
        cell = layer.copy()
        cell[rows, u] += du
        cell[rows, v] += dv
        return padded[cell[:, 0], cell[:, 1], cell[:, 2]].astype(np.float64)

    s = np.clip(point[rows, u] - index[rows, u], 0.0, 1.0)
    r = np.clip(point[rows, v] - index[rows, v], 0.0, 1.0)
    level = np.zeros(len(face))
    for du in (-1, 1):
        for dv in (-1, 1):
            side1, side2, corner = occupied(du, 0), occupied(0, dv), occupied(du, dv)
            corner_level = np.where((side1 > 0) & (side2 > 0), 3.0, side1 + side2 + corner)
            weight = (s if du > 0 else 1.0 - s) * (r if dv > 0 else 1.0 - r)
            level += weight * corner_level
    return level


def face_normals(face: np.ndarray, world_from_index: np.ndarray,
                 toward_eye: np.ndarray) -> np.ndarray:
    """Unit world normals of the faces rays entered through (facing back along the ray).

    ``face`` as in :class:`VoxelHits`; -1 (the ray starts inside its voxel) faces the eye.
    """
    axis = np.clip(face, 0, None) // 2
    sign = np.where(face % 2 == 1, -1.0, 1.0)   # entered moving +axis: the normal is -axis
    normal_index = np.zeros((len(face), 3))
    normal_index[np.arange(len(face)), axis] = sign
    normal = normal_index @ np.linalg.inv(np.asarray(world_from_index)[:3, :3])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    inside = face < 0
    normal[inside] = toward_eye[inside] / np.linalg.norm(toward_eye[inside], axis=1,
                                                         keepdims=True)
    return normal


def face_colors(hits: VoxelHits) -> np.ndarray:
    """Encode the entered face of every pixel's hit as 8-bit RGB (0, 0, 0 on a miss).

    ``r = 32 * (face + 2)``: 32 for a ray that starts inside its voxel (face -1), 64 + 32 *
    ``(2 * axis + 1)`` for a face entered moving +axis, 64 + 32 * ``2 * axis`` moving -axis;
    ``g = b = 0``.
    """
    red = np.where(hits.material > 0, 32 * (hits.face + 2), 0)
    zero = np.zeros_like(red)
    return np.stack([red, zero, zero], axis=-1).astype(np.uint8)


def id_colors(hits: VoxelHits, shape: tuple[int, int, int]) -> np.ndarray:
    """Encode the hit voxel of every pixel as an 8-bit RGB id (0, 0, 0 on a miss).

    The id is ``v = i + nx * (j + ny * k) + 1``, stored as ``r = v & 255``,
    ``g = (v >> 8) & 255``, ``b = (v >> 16) & 255``; ``shape`` is the grid's
    ``(nx, ny, nz)``.
    """
    nx, ny, nz = (int(v) for v in shape)
    if nx * ny * nz + 1 > 1 << 24:
        raise ValueError(f"a grid of {nx}x{ny}x{nz} voxels has more ids than 24 bits hold.")
    i, j, k = (hits.index[..., a] for a in range(3))
    v = np.where(i >= 0, i + nx * (j + ny * k) + 1, 0)
    return np.stack([v & 255, (v >> 8) & 255, (v >> 16) & 255], axis=-1).astype(np.uint8)
