"""``pv-cubemarch bench voxel-layers``: translucent voxel materials against PyVista's paths.

A segmentation-like scene (a translucent shell around a translucent organ and an opaque
core, a translucent slab beside them) at a few sizes. Rows, drawn in turn in one run: our
grid (the opaque actor and the translucent layers), PyVista's ``threshold`` +
``add_mesh(opacity=...)`` per material with depth peeling (what a PyVista user draws to
see through labels), and the same meshes without peeling (order-dependent blending).
Each image is compared with the plane-crossing CPU reference
(:func:`~pv_cubemarch.reference.voxel_layers.render_voxel_layers`): PSNR and the share of
pixels more than 10/255 off.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pyvista

from ..api import add_voxels
from ..core.camera import Camera
from ..core.progress import progress
from ..reference.voxel_layers import render_voxel_layers
from .layer_rows import LayerRow, draw_rows

#: Material: (colour, opacity): the shell, the organ, the core, the slab.
MATERIALS = {1: ("lightsteelblue", 0.2), 2: ("tomato", 0.5), 3: ("gold", 1.0),
             4: ("seagreen", 0.35)}
BACKGROUND = (0.0, 0.0, 0.0)
ROWS = ("voxels (layers)", "pyvista meshes, depth peeling", "pyvista meshes, no peeling")


def layered_labels(n: int) -> np.ndarray:
    """The scene on an ``n``^3 grid (labels 1-4, see :data:`MATERIALS`)."""
    x, y, z = np.ogrid[0:n, 0:n, 0:n]
    c = (n - 1) / 2.0
    r = np.sqrt((x - c) ** 2 + (y - c) ** 2 + (z - c) ** 2) / n
    labels = np.zeros((n, n, n), np.uint8)
    labels[(r < 0.42) & (r > 0.36)] = 1
    labels[np.sqrt((x - c * 0.8) ** 2 + (y - c) ** 2 + ((z - c) * 1.4) ** 2) / n < 0.22] = 2
    labels[r < 0.08] = 3
    labels[: n // 6, : n // 2, :] = 4
    return labels


def _grid(labels: np.ndarray) -> pyvista.ImageData:
    grid = pyvista.ImageData(dimensions=np.array(labels.shape) + 1)
    grid.cell_data["labels"] = labels.ravel(order="F")
    return grid


def _ours(plotter, labels) -> None:
    add_voxels(plotter, _grid(labels), "labels", palette=MATERIALS, shading="unlit")


def _meshes(plotter, labels, peel: bool) -> None:
    if peel:
        plotter.enable_depth_peeling(number_of_peels=50, occlusion_ratio=0.0)
    grid = _grid(labels)
    for label, (colour, opacity) in MATERIALS.items():
        plotter.add_mesh(grid.threshold([label, label], scalars="labels"),
                         color=colour, opacity=opacity, lighting=False)


ADD = {ROWS[0]: _ours, ROWS[1]: lambda pl, labels: _meshes(pl, labels, True),
       ROWS[2]: lambda pl, labels: _meshes(pl, labels, False)}


def run_layers(size: Sequence[int] = (640, 480), grids: Sequence[int] = (64, 128),
               frames: int = 3, progress_bar: bool | None = None) -> list[LayerRow]:
    """Every row on every grid size, frames drawn in turn; errors against the reference."""
    size = tuple(int(v) for v in size)
    results = []
    rgba = np.zeros((5, 4))
    for label, (colour, opacity) in MATERIALS.items():
        rgba[label] = (*pyvista.Color(colour).float_rgb, opacity)
    for n in progress(list(grids), desc="bench voxel-layers", enabled=progress_bar):
        labels = layered_labels(int(n))
        camera = Camera(position=(n * 1.9, -n * 0.9, n * 1.5), focal_point=(n / 2,) * 3,
                        view_up=(0.0, 0.0, 1.0), view_angle=30.0)

        def reference(pl, labels=labels):
            return render_voxel_layers(labels, np.eye(4), rgba, Camera.from_pyvista(pl.camera),
                                       size, background=BACKGROUND,
                                       near=pl.camera.clipping_range[0])
        rows = {row: (lambda pl, row=row, labels=labels: ADD[row](pl, labels)) for row in ROWS}
        results += draw_rows(f"{n}^3", rows, size, camera, frames, reference, BACKGROUND)
    return results
