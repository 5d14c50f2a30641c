"""The CPU reference of a material grid with translucent materials: its faces, sorted.

Each material is a closed surface, as PyVista draws ``threshold`` + ``add_mesh(opacity=)``
per label: every grid plane a ray crosses between two voxels of different materials holds
the face of each of them (the one left first, then the one entered), with its colour and
opacity; the faces are sorted along the ray and composited front to back, the first opaque
one ending it. Found plane by plane (the ray's crossing of every grid plane, exactly in
float64), not by a traversal: an algorithm of its own, numpy only.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..core.camera import Camera
from .rays import clip_interval, cut_normals
from .shading import blinn_phong
from .voxels import _check_labels, _index_rays, face_normals


def render_voxel_layers(labels: np.ndarray, world_from_index: np.ndarray,
                        palette: np.ndarray, camera: Camera, size: tuple[int, int],
                        background: Sequence[float] = (0.0, 0.0, 0.0),
                        near: float | None = None, lights: Sequence = (),
                        shading: str = "unlit", ambient: float = 0.2,
                        specular: float = 0.3, specular_power: float = 30.0,
                        clip_planes: Sequence | None = None,
                        diffuse: float = 0.8) -> np.ndarray:
    """``(h, w, 3)`` image of a grid whose materials may be translucent.

    Arguments as :func:`~pv_cubemarch.reference.voxels.render_voxels`; a material's palette
    opacity between 0 and 1 makes it translucent, 1 opaque, 0 hidden. A face is lit (with
    ``shading``) by its normal toward the eye, as VTK lights both sides of a surface.
    ``clip_planes``: world ``(origin, normal)`` planes keeping ``normal . (x - origin) >=
    0``; faces outside the kept part are dropped and where a plane cuts a material its cut
    is one more face of it (lit facing the eye), as a clipped closed surface shows it.
    """
    labels = _check_labels(labels)
    palette = np.asarray(palette, dtype=np.float64)
    width, height = (int(v) for v in size)
    origins, directions = camera.rays((width, height))
    origins, directions = origins.reshape(-1, 3), directions.reshape(-1, 3)
    o, d = _index_rays(origins, directions, world_from_index, labels.shape)
    shape = np.array(labels.shape)
    # Crossings start at the eye or the near plane; the box needs no test (every plane
    # lies within it), which rounding at its faces would cut.
    t_start = np.zeros(len(o))
    if near is not None:
        _, _, forward = camera.basis()
        t_start = np.maximum(t_start, near / np.maximum(directions @ forward, 1e-12))
    alpha = palette[:, 3].copy()
    alpha[0] = 0.0
    padded = np.pad(labels.astype(np.int64), 1)            # 0 around: outside the grid
    padded = np.where(alpha[padded] > 0.0, padded, 0)      # hidden materials are empty
    ts, materials, faces = [], [], []
    rows = np.arange(len(o))
    kept = (np.full(len(o), -np.inf), np.full(len(o), np.inf))
    tolerance = 1e-7 / np.maximum(np.linalg.norm(d, axis=1), 1e-30)   # a 1e-7 voxel
    if clip_planes:
        kept = clip_interval(origins, directions, kept[0], kept[1], clip_planes)
        for t, side in ((kept[0], 1.0), (kept[1], -1.0)):   # the cuts, where inside
            cut = np.isfinite(t) & (t >= t_start) & (kept[1] > kept[0])
            inside = o + (np.where(cut, t, 0.0) + side * 1e-9)[:, None] * d
            voxel = np.floor(inside).astype(np.int64)
            cut &= np.all((voxel >= 0) & (voxel < shape), axis=1)
            material = np.where(cut, padded[tuple((np.clip(voxel, -1, shape) + 1).T)], 0)
            ts.append(np.where(cut & (material > 0), t, np.inf))
            materials.append(material)
            faces.append(np.full(len(o), -1))
    for axis in range(3):
        moving = d[:, axis] != 0.0
        sign = np.sign(d[:, axis]).astype(np.int64)
        others = [a for a in range(3) if a != axis]
        for plane in range(int(shape[axis]) + 1):
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (plane - o[:, axis]) / d[:, axis]
            # A crossing of a plane is one whose other coordinates fall inside the grid.
            # a crossing on a plane itself is not kept (the plane's cut is the face there)
            crossing = moving & (t >= t_start) & (t > kept[0] + tolerance) & (
                t < kept[1] - tolerance)
            point = o + np.where(crossing, t, 0.0)[:, None] * d
            cell = np.floor(point[:, others]).astype(np.int64)
            crossing &= (cell >= 0).all(axis=1) & (cell < shape[others]).all(axis=1)
            index = np.zeros((len(o), 3), dtype=np.int64)
            index[:, others] = np.clip(cell, 0, shape[others] - 1) + 1
            before, after = index.copy(), index.copy()
            before[:, axis] = np.where(sign > 0, plane, plane + 1)   # padded indices
            after[:, axis] = np.where(sign > 0, plane + 1, plane)
            left = padded[tuple(before.T)]
            entered = padded[tuple(after.T)]
            changes = crossing & (left != entered)
            face = 2 * axis + (sign > 0)
            for material in (left, entered):   # the face left first, then the one entered
                ts.append(np.where(changes & (material > 0), t, np.inf))
                materials.append(material)
                faces.append(np.broadcast_to(face, (len(o),)))
    ts, materials, faces = np.stack(ts, 1), np.stack(materials, 1), np.stack(faces, 1)
    order = np.argsort(ts, axis=1, kind="stable")
    ts, materials = np.take_along_axis(ts, order, 1), np.take_along_axis(materials, order, 1)
    faces = np.take_along_axis(faces, order, 1)
    color = np.zeros((len(o), 3))
    held = np.zeros(len(o))
    for layer in range(ts.shape[1]):
        present = np.isfinite(ts[:, layer]) & (held < 1.0)
        if not present.any():
            break
        ids = rows[present]
        material = materials[ids, layer]
        rgb = palette[material, :3]
        if shading != "unlit":
            toward_eye = -directions[ids]
            points = origins[ids] + directions[ids] * ts[ids, layer][:, None]
            normals = face_normals(faces[ids, layer], world_from_index, toward_eye)
            cut = faces[ids, layer] < 0   # a clip plane's cut
            normals[cut] = cut_normals(origins[ids][cut], directions[ids][cut],
                                       ts[ids, layer][cut], clip_planes, normals[cut])
            rgb = blinn_phong(rgb, normals, points, toward_eye, lights, shading, ambient,
                              specular, specular_power, diffuse_weight=diffuse)
        a = alpha[material]
        weight = (1.0 - held[ids]) * a
        color[ids] += weight[:, None] * np.clip(rgb, 0.0, 1.0)
        held[ids] = np.where(a >= 1.0, 1.0, held[ids] + weight)
    image = color + (1.0 - held)[:, None] * np.asarray(background, dtype=np.float64)
    return image.reshape(height, width, 3)
