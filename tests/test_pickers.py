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


def _ct_ball() -> pv.ImageData:
    """Air at -1000 HU around a ball of 400 HU, int16, anisotropic, placed off 0."""
    x, y, z = np.mgrid[0:40, 0:40, 0:40]
    hu = np.full(x.shape, -1000, np.int16)
    hu[(x - 20) ** 2 + (y - 22) ** 2 + (z - 18) ** 2 < 100] = 400
    grid = pv.ImageData(dimensions=x.shape, spacing=(0.7, 0.7, 1.0), origin=(10, -5, 3))
    grid.point_data["HU"] = hu.ravel(order="F")
    return grid


#: A placement that moves the volume (its returned actor's ``user_matrix``).
MOVED = np.array([[1.0, 0, 0, 4.0], [0, 1, 0, 0], [0, 0, 1, -3.0], [0, 0, 0, 1]])


def _volume_picks(add, picker_class, set_values=None):
    """What ``picker_class`` picks on a lattice of pixels, before the first frame and after,
    the volume moved by :data:`MOVED`."""
    plotter = _plotter()
    actor = add(plotter)
    plotter.camera_position = "xz"
    plotter.reset_camera()
    cm.render_image(plotter)
    if hasattr(actor, "cubemarch"):   # ours moved as its docs say, theirs as PyVista's
        actor.cubemarch.set_transform(MOVED)
    else:
        actor.user_matrix = MOVED
    if set_values is not None:
        actor.cubemarch.set_values(set_values)
    picks = []
    for frame in range(2):
        for pixel in ((x, y) for x in range(3, SIZE[0], 8) for y in range(3, SIZE[1], 8)):
            picker = picker_class()
            picker.Pick(*pixel, 0, plotter.renderer)
            picks.append((picker.GetProp3D() is actor, np.asarray(picker.GetPickPosition())))
        if not frame:
            cm.render_image(plotter)
    plotter.close()
    return picks


@pytest.mark.parametrize("picker", ["vtkVolumePicker", "vtkCellPicker"])
@pytest.mark.parametrize("technique", ["direct", "cubemap", "vtk"])
def test_volume_pickers_pick_the_volume_where_they_pick_pyvista_s(technique, picker):
    # VTK's volume pickers (PyVista's picker='volume' and 'cell') cast through the mapper's
    # data with the property's opacity. Oracle: the same picker on PyVista's own volume of
    # the same data and keywords: the prop hit (or missed) and the point, before the first
    # frame and after it, the volume moved. Found by a review: they never hit ours (the
    # stand-in held 2x2x2 points). catches (seen failing): the values not held between
    # frames (the box's face picked, or air), the move placing the data's grid as the
    # drawn 2x2x2 one (the user's grid's spacing overwritten).
    grid = _ct_ball()
    keywords = dict(cmap="bone", opacity="linear", clim=(-1000, 400))
    picker_class = getattr(vtk, picker)
    theirs = _volume_picks(lambda pl: pl.add_volume(grid, **keywords), picker_class)
    ours = _volume_picks(lambda pl: cm.add_volume(pl, grid, technique=technique, **keywords),
                         picker_class)
    assert sum(hit for hit, _ in theirs) >= 20 and sum(not hit for hit, _ in theirs) >= 20
    for (their_hit, their_point), (our_hit, our_point) in zip(theirs, ours, strict=True):
        assert our_hit == their_hit
        if their_hit:
            assert np.abs(our_point - their_point).max() < 1e-6, (our_point, their_point)
    assert grid.origin == (10.0, -5.0, 3.0) and grid.spacing == (0.7, 0.7, 1.0)


def test_a_volume_picker_follows_set_values():
    # After set_values the picker reads the new values, not the dataset's old ones. The
    # ball moved by hand: +8 voxels along x. catches (seen failing): follow() left out.
    grid = _ct_ball()
    moved = np.roll(np.asarray(grid["HU"]).reshape(40, 40, 40, order="F"), 8, axis=0)
    keywords = dict(cmap="bone", opacity="linear", clim=(-1000, 400))
    theirs_grid = grid.copy()
    theirs_grid["HU"] = moved.ravel(order="F")
    theirs = _volume_picks(lambda pl: pl.add_volume(theirs_grid, **keywords), vtk.vtkVolumePicker)
    ours = _volume_picks(lambda pl: cm.add_volume(pl, grid, **keywords), vtk.vtkVolumePicker,
                         set_values=moved)
    assert [hit for hit, _ in ours] == [hit for hit, _ in theirs]
    for (hit, point), (_, theirs_point) in zip(ours, theirs, strict=True):
        if hit:
            assert np.abs(point - theirs_point).max() < 1e-4
