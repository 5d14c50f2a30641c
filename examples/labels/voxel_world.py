"""
A chunked voxel world with edits and level of detail
====================================================

A 512 x 512 x 64 terrain drawn in chunks of 32 (``add_voxels(..., chunk_size=32)``):
chunks of air cost nothing, chunks of solid rock are one label each, and one traversal
runs over the chunk index for the whole world, so chunks hidden behind nearer hills are
never read. ``lod=True`` draws distant terrain from coarser occupancy levels where a voxel
is smaller than a pixel. A digger carves a trench through three chunks (``fill_box``), a
ball where the middle pixel's voxel is (``pick``, then ``fill_sphere``) and hides the grass
(``set_material``); each edit is in the next frame.
"""

import numpy as np
import pyvista as pv

import pv_cubemarch
from pv_cubemarch.models.procedural import terrain

labels = terrain((512, 512, 64), feature_size=128.0, seed=7)    # grass, dirt, bedrock
palette = ["black", "forestgreen", "saddlebrown", "dimgray"]

pl = pv.Plotter(window_size=(800, 500))
actor = pv_cubemarch.add_voxels(pl, labels, palette=palette, chunk_size=32, lod=True)
world = actor.cubemarch
print(f"{len(world.model.stored)} stored and {len(world.model.uniform)} uniform chunks, "
      f"{world.model.nbytes / 1e6:.1f} MB of labels on the host, "
      f"{world.nbytes / 1e6:.1f} MB on the GPU")
pl.camera.position = (-150.0, -150.0, 260.0)
pl.camera.focal_point = (256.0, 256.0, 20.0)
pl.camera.up = (0.0, 0.0, 1.0)
pl.reset_camera_clipping_range()

world.fill_box((100, 40, 0), (300, 60, 64), 0)               # a trench across chunks
picked = world.pick(400, 250)                                   # the voxel mid-image
if picked is not None:
    world.fill_sphere(np.add(picked.index, 0.5), 24.0, 0)
    print(f"carved around voxel {picked.index} (material {picked.material})")
world.set_material(1, opacity=0.0)                              # hide the grass
pl.show()
