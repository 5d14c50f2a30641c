"""
A material grid: grains, matrix and pores
=========================================

Grains (material 1) in a matrix (material 2) with pores (material 3), cut open by hiding
the matrix, next to a mesh that crosses the grid: every pixel shows the first voxel its ray
meets, lit by the scene's lights with ambient occlusion in the creases. The labels are a
numpy array indexed x, y, z; 0 is empty.
"""

import numpy as np
import pyvista as pv

import pv_cubemarch

rng = np.random.default_rng(0)
n = 64
x, y, z = np.mgrid[0:n, 0:n, 0:n]
labels = np.full((n, n, n), 2, dtype=np.uint8)              # the matrix
for center in rng.uniform(8, n - 8, size=(40, 3)):           # grains
    radius = rng.uniform(3, 7)
    labels[(x - center[0]) ** 2 + (y - center[1]) ** 2 + (z - center[2]) ** 2 < radius**2] = 1
labels[rng.random(labels.shape) < 0.002] = 3                 # isolated pores: one voxel each
labels[:, :, 48:] = 0                                        # an open top

pl = pv.Plotter(window_size=(800, 600))
pl.set_background("white")
actor = pv_cubemarch.add_voxels(pl, labels, palette=["black", "goldenrod", "slategray", "crimson"],
                                ambient_occlusion=True)   # darker creases between grains
actor.cubemarch.set_material(2, opacity=0.0)                 # hide the matrix: no re-upload
pl.add_mesh(pv.Cylinder(center=(32, 32, 24), direction=(1, 1, 0), radius=4, height=110),
            color="teal")
pl.camera_position = [(150, -60, 120), (32, 32, 24), (0, 0, 1)]
pl.renderer.ResetCameraClippingRange()
print(f"({actor.cubemarch.nbytes:,} GPU bytes for {labels.size:,} voxels)")
pl.show()
