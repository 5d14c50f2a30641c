"""A far clipping plane that cuts the scene: nothing past it is drawn, nothing before it lost.

VTK clips a mesh at the far plane; a marched box must do the same with its rays. Expected
images are the CPU references' (float64, sharing no code with the shaders) with their first
hits past the far plane taken out; each case's plane cuts the drawn part in two, so drawing
everything, or nothing past the box's own far side, fails.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import set_camera
from test_surfaces import DRAWINGS, blob
from test_surfaces import plotter as surface_plotter
from test_voxels import EDGE, SIZE, plotter, random_labels

import pv_cubemarch as cm
from pv_cubemarch.models.surface import active_cells
from pv_cubemarch.reference.surfaces import trace_surface
from pv_cubemarch.reference.voxels import face_colors, trace_voxels

#: How each voxel drawing is asked for: the grid whole (box or brick proxy), a world of
#: chunks drawn per chunk or by one traversal, and the grid cut by a clip plane.
VOXEL_DRAWINGS = {
    "box": {"proxy": "box"},
    "bricks": {"proxy": "bricks"},
    "per_chunk": {"chunk_size": 8, "world_traversal": "per_chunk"},
    "index": {"chunk_size": 8, "world_traversal": "index"},
    "clipped": {"clip_planes": [((12.0, 10.0, 8.0), (0.3, -0.2, 1.0))]},
}


def cut_near_focus(pl, before):
    """Put the far plane ``before`` world units before the focal point; the Camera."""
    near = pl.camera.clipping_range[0]
    pl.camera.clipping_range = (near, pl.camera.distance - before)
    return cm.Camera.from_pyvista(pl.camera)


@pytest.mark.parametrize("drawing", VOXEL_DRAWINGS)
@pytest.mark.parametrize("parallel", [False, True])
def test_voxels_past_the_far_plane_are_not_drawn(plotter_factory, drawing, parallel):
    # catches (seen failing): rays not ended at the far plane (voxels past it drawn: 452
    # to 855 pixels wrong per case); the box's back faces not pulled onto the plane (the
    # voxels before it lost where the faces lie past it: 387 to 811).
    labels = random_labels((24, 20, 16), 0.06, seed=7).astype(np.uint8)
    options = dict(VOXEL_DRAWINGS[drawing])
    clip = options.pop("clip_planes", None)
    pl = plotter(plotter_factory)
    cm.add_voxels(pl, labels, mode="face", palette=["black", "red", "lime", "blue"],
                  clip_planes=clip, **options)
    set_camera(pl, (40.0, 30.0, 35.0), focal=(12.0, 10.0, 8.0))
    if parallel:
        pl.camera.parallel_projection = True
        pl.camera.parallel_scale = 14.0
        pl.renderer.ResetCameraClippingRange()
    near = pl.camera.clipping_range[0]
    camera = cut_near_focus(pl, 4.0)
    image = cm.render_image(pl).astype(int)
    planes = [(np.array(o), np.array(n) / np.linalg.norm(n)) for o, n in clip or []]
    hits = trace_voxels(labels, np.eye(4), camera, SIZE, near=near, far=camera.clipping_range[1],
                        tie_tolerance=EDGE, clip_planes=planes)
    uncut = trace_voxels(labels, np.eye(4), camera, SIZE, near=near, clip_planes=planes)
    wrong = np.any(image != face_colors(hits).astype(int), axis=-1) & ~hits.near_edge
    # The plane cuts the drawn voxels: many first hits lie past it, many before.
    assert (hits.material > 0).sum() > 300, int((hits.material > 0).sum())
    assert (uncut.material > 0).sum() - (hits.material > 0).sum() > 300
    assert wrong.sum() == 0, int(wrong.sum())


@pytest.mark.parametrize("drawing", DRAWINGS)
def test_a_surface_past_the_far_plane_is_not_drawn(plotter_factory, drawing):
    # catches (seen failing): rays not ended at the far plane (the surface past it drawn
    # where the domain's back faces lie before it), for each of the three drawings.
    field = blob()
    pl = surface_plotter(plotter_factory)
    cm.add_surface(pl, field, **DRAWINGS[drawing], root="exact" if drawing != "full" else
                   "march", shading="unlit", steps=50, refine_steps=30)
    set_camera(pl, (16.0, -8.0, 12.0), focal=(6.0, 5.0, 4.0), up=(0, 0, 1))
    near = pl.camera.clipping_range[0]
    camera = cut_near_focus(pl, 2.0)
    far = camera.clipping_range[1]
    covered = cm.render_image(pl).max(axis=-1) > 127
    hits = trace_surface(field, active_cells(field), camera, SIZE, near=near)
    forward = np.subtract(camera.focal_point, camera.position)
    forward /= np.linalg.norm(forward)
    view_depth = np.where(hits.hit, (np.nan_to_num(hits.point) - camera.position) @ forward,
                          0.0)
    kept = hits.hit & (view_depth <= far)
    tie = np.abs(view_depth - far) <= 1e-4 * far
    wrong = (covered != kept) & ~hits.ambiguous & ~tie
    assert kept.sum() > 200 and (hits.hit & ~kept).sum() > 200
    assert wrong.sum() == 0, int(wrong.sum())
