"""
Volumes beyond memory: an OME-Zarr pyramid streamed by bricks
=============================================================

``build_pyramid`` writes an OME-Zarr pyramid of data that has none, out of core with dask.
``add_volume`` of its path never reads it whole: bricks stream into a GPU pool of
``gpu_bytes`` (read on background threads into a host cache of ``host_bytes``), each sample
reading the coarsest level whose points fit one pixel (``lod_bias`` shifts it). The left
view draws the coarsest level only (napari's 3D view of a pyramid); the right one has
converged to the finest levels its pixels need.
"""

import tempfile
from pathlib import Path

import numpy as np
import pyvista as pv

import pv_cubemarch

# a 160 x 128 x 96 field of anisotropic voxels (0.5 x 0.5 x 1 micrometres) in uint16
x, y, z = np.meshgrid(np.linspace(-1, 1, 160), np.linspace(-1, 1, 128), np.linspace(-1, 1, 96),
                      indexing="ij")
shell = np.exp(-60 * (np.sqrt(x**2 + y**2 + z**2) - 0.7) ** 2)
blobs = sum(np.exp(-90 * ((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2))
            for cx, cy, cz in [(0.3, 0.1, 0.0), (-0.3, -0.2, 0.2), (0.0, 0.35, -0.3)])
values = (60000 * np.clip(0.3 * shell + blobs, 0, 1)).astype(np.uint16)
store = Path(tempfile.mkdtemp()) / "cells.ome.zarr"
pv_cubemarch.build_pyramid(values, store, chunk_size=32, scale=(0.5, 0.5, 1.0))

pl = pv.Plotter(shape=(1, 2), window_size=(900, 450), border=False)
pl.set_background("black")
for column, (title, bias) in enumerate([("coarsest level only", 10.0),
                                        ("converged, lod_bias=0", 0.0)]):
    pl.subplot(0, column)
    pl.add_text(title, font_size=9, color="white")
    actor = pv_cubemarch.add_volume(pl, str(store), cmap="magma", clim=(5000, 60000),
                                    opacity="linear", lod_bias=bias, brick_size=16,
                                    gpu_bytes=64 * 2**20, host_bytes=256 * 2**20)
pl.link_views()
pl.view_isometric()
pl.camera.zoom(1.6)
pv_cubemarch.render_image(pl, converge=True)
print(actor.cubemarch.stats())
pl.show()
