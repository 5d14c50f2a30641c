"""The voxel grids of ``bench dial``'s frame-budget orbits, and their CPU reference."""

from __future__ import annotations

import numpy as np
import pyvista

from ..core.camera import Camera
from ..quality.voxels import world_reference_grid
from ..reference.voxels import render_voxels
from .sort_last import segmentation
from .voxels import scenes

#: Voxel grids the orbits drive: a segmentation of uint32 balls, and terrain (whole, as a
#: world of 32³ chunks drawn by one traversal over its chunk index, and by a box per chunk).
VOXEL_SCENES = ("segmentation", "waves", "waves world", "waves per chunk")
#: The keywords each scene is added with.
VOXEL_KEYWORDS = {"waves world": {"chunk_size": 32},
                  "waves per chunk": {"chunk_size": 32, "world_traversal": "per_chunk"}}


def voxel_scene(name: str) -> pyvista.ImageData:
    """A label grid on cells, placed away from the origin with anisotropic spacing."""
    labels = segmentation((128, 96, 64)) if name == "segmentation" else \
        scenes()["waves 128x128x64"].astype(np.uint16)
    grid = pyvista.ImageData(dimensions=np.asarray(labels.shape) + 1,
                             spacing=(0.8, 0.8, 1.2), origin=(-120.0, 40.0, 300.0))
    grid.cell_data["labels"] = labels.ravel(order="F")
    return grid


def voxel_reference(plotter, actor, size) -> np.ndarray:
    """The CPU reference of the unlit grid's frame (the plotter's camera and near plane).

    A world's filled voxels are read back whole from its chunks, as ``quality=`` reads them.
    """
    model = actor.cubemarch.model
    labels, world_from_index = (model.labels, model.world_from_index()) if hasattr(
        model, "labels") else world_reference_grid(model)
    return render_voxels(labels, world_from_index, model.palette.rgba,
                         Camera.from_pyvista(plotter.camera), size,
                         background=plotter.background_color.float_rgb,
                         near=plotter.camera.clipping_range[0], shading="unlit")
