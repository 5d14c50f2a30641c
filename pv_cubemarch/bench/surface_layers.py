"""``pv-cubemarch bench surface-layers``: translucent surfaces against PyVista's paths.

Two shapes of the surface bench (blobs, the holey sphere: up to 8 crossings a ray) on
``N``³ cells, each drawn translucent in turn, in one run: our surface (every crossing
composited along one ray per pixel), and what a PyVista user draws today, the field
resampled at 1, 2 and 4 samples a cell, ``contour`` + ``add_mesh(opacity=...)`` with depth
peeling, and at 2 samples without peeling (order-dependent blending). Each image is
compared with the CPU reference compositing every root
(:func:`~pv_cubemarch.reference.surfaces.render_surface`): PSNR and the share of pixels
more than 10/255 off.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..api import add_surface
from ..core.camera import Camera
from ..core.progress import progress
from ..reference.surfaces import render_surface
from .layer_rows import LayerRow, draw_rows
from .surfaces import _samples, shape_field

SHAPES = ("blobs", "holey sphere")
#: Each crossing's opacity.
OPACITY = 0.3
OURS = "surface (layers)"
#: Row to how PyVista draws it: samples a cell and whether it peels.
PYVISTA_ROWS = {f"contour {k}/cell, depth peeling": (k, True) for k in (1, 2, 4)}
PYVISTA_ROWS["contour 2/cell, no peeling"] = (2, False)
ROWS = (OURS, *PYVISTA_ROWS)


def _camera(surface) -> Camera:
    """From a corner above, the whole domain in sight (as the surface bench)."""
    lower, upper = (np.asarray(surface.world_bounds()).reshape(3, 2).T)
    centre, size = (lower + upper) / 2, float(np.linalg.norm(upper - lower))
    return Camera(position=tuple(centre + size * np.array([0.75, -0.55, 0.5])),
                  focal_point=tuple(centre), view_up=(0, 0, 1), view_angle=35.0)


def _add(plotter, surface, row: str) -> None:
    if row == OURS:
        add_surface(plotter, surface, shading="unlit", color="white", opacity=OPACITY)
        return
    per_cell, peel = PYVISTA_ROWS[row]
    if peel:
        plotter.enable_depth_peeling(number_of_peels=50, occlusion_ratio=0.0)
    mesh = _samples(surface, per_cell).contour([0.0], scalars="f", method="flying_edges")
    if mesh.n_points:
        plotter.add_mesh(mesh, color="white", opacity=OPACITY, lighting=False)


def run_surface_layers(size: Sequence[int] = (480, 360), grids: Sequence[int] = (32, 64),
                       shapes: Sequence[str] = SHAPES, frames: int = 3,
                       progress_bar: bool | None = None) -> list[LayerRow]:
    """Every row on every shape and grid, frames drawn in turn, with their errors."""
    size = tuple(int(v) for v in size)
    results = []
    cases = [(shape, int(n)) for shape in shapes for n in grids]
    for shape, n in progress(cases, desc="bench surface-layers", enabled=progress_bar):
        surface = shape_field(shape, n)

        def reference(pl, surface=surface):
            return render_surface(surface, Camera.from_pyvista(pl.camera), size,
                                  near=pl.camera.clipping_range[0], opacity=OPACITY)
        rows = {row: (lambda pl, row=row, surface=surface: _add(pl, surface, row))
                for row in ROWS}
        results += draw_rows(f"{shape} {n}^3", rows, size, _camera(surface), frames,
                             reference)
    return results
