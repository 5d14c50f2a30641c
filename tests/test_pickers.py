"""PyVista's pickers on what pv_cubemarch draws.

The pickers that read the depth buffer (``picker='world'`` and ``'prop'``, and
``pick_mouse_position``) land on the drawn voxel or surface, since the box's fragments
write their hit's depth; the point and cell pickers intersect the box's polygons on the
CPU (docs/pyvista_parity.md). Oracle: the CPU references' first hits, which import
nothing of the renderer.
"""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv
import vtk

import pv_cubemarch as cm
from pv_cubemarch.models.surface import active_cells
from pv_cubemarch.reference.surfaces import trace_surface
from pv_cubemarch.reference.voxels import trace_voxels

SIZE = (160, 120)


def _plotter():
    plotter = pv.Plotter(off_screen=True, window_size=SIZE)
    plotter.disable_anti_aliasing()
    plotter.ren_win.SetMultiSamples(0)
    return plotter


def _picked(plotter, kind: str, x: int, y: int) -> np.ndarray:
    """The picker's point at the centre of pixel ``(x, y)`` (y from the bottom, VTK's)."""
    picker = vtk.vtkWorldPointPicker() if kind == "world" else vtk.vtkPropPicker()
    picker.Pick(x + 0.5, y + 0.5, 0, plotter.renderer)
    return np.asarray(picker.GetPickPosition())


@pytest.mark.parametrize("kind", ["world", "prop"])
@pytest.mark.parametrize("what", ["voxels", "surface"])
def test_depth_buffer_pickers_land_on_what_is_drawn(kind, what):
    # catches (seen failing): the box's raster depth written instead of the hit's (the
    # picks on the box's back face: 4.7 units off for the voxels, 10.2 for the surface).
    plotter = _plotter()
    if what == "voxels":
        labels = np.zeros((16, 12, 10), np.uint8)
        labels[4:12, 3:9, 2:7] = 1
        labels[6:9, 5:12, 6:10] = 2
        actor = cm.add_voxels(plotter, labels, palette={1: "tan", 2: "teal"},
                              transform=np.diag([1.2, 0.8, 1.0, 1.0]))
    else:
        grid = pv.ImageData(dimensions=(20, 18, 16), spacing=(1.0, 1.1, 1.2),
                            origin=(3.0, -4.0, 2.0))
        grid["r"] = np.linalg.norm((grid.points - grid.center) / (7.0, 6.0, 5.0), axis=1)
        actor = plotter.cubemarch.add_surface(grid, isovalue=1.0, scalars="r")
    plotter.camera_position = [(-25.0, 30.0, 24.0), (9.0, 5.0, 6.0), (0.0, 0.0, 1.0)]
    plotter.camera.clipping_range = (1.0, 200.0)
    cm.render_image(plotter)
    camera = cm.Camera.from_pyvista(plotter.camera)
    if what == "voxels":
        world_from_index = actor.cubemarch.model.world_from_index()
        hits = trace_voxels(labels, world_from_index, camera, SIZE, near=1.0)
        hit = hits.material > 0   # points in index space
        points = np.nan_to_num(hits.point) @ world_from_index[:3, :3].T + world_from_index[:3, 3]
    else:
        field = actor.cubemarch.model
        found = trace_surface(field, active_cells(field), camera, SIZE, near=1.0)
        points, hit = found.point, found.hit
    rows, columns = np.nonzero(hit)
    assert len(rows) > 500, len(rows)
    for index in np.linspace(0, len(rows) - 1, 12).astype(int):
        row, x = int(rows[index]), int(columns[index])
        y = SIZE[1] - 1 - row   # the references' rows run from the top
        error = np.linalg.norm(_picked(plotter, kind, x, y) - points[row, x])
        assert error < 1e-3 * np.linalg.norm(points[row, x] - camera.position), (x, y, error)
    plotter.close()
