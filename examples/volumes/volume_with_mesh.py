"""
A volume cut by an opaque mesh
==============================

A mesh inside a volume occludes it at its real depth, and the volume in front of the mesh
veils it. The GPU image is checked against the CPU reference composited over the same
mesh.
"""

import matplotlib.pyplot as plt
import numpy as np
import pyvista as pv

import pv_cubemarch
from pv_cubemarch.image_metrics import compare_images, to_uint8
from pv_cubemarch.reference import mesh_depth

size = (320, 240)
x, y, z = np.mgrid[-1:1:48j, -1:1:48j, -1:1:48j]
density = np.exp(-3 * (x**2 + y**2 + z**2)) * (1 + 0.3 * np.sin(8 * x) * np.cos(6 * y))
grid = pv.ImageData(dimensions=density.shape, spacing=(2 / 47,) * 3, origin=(-1, -1, -1))
grid.point_data["density"] = density.ravel(order="F")
volume = pv_cubemarch.make_volume(grid, cmap="inferno", opacity="linear", clim=(0, 1.2),
                                  opacity_unit_distance=0.15)

pl = pv.Plotter(window_size=size)
pl.set_background("black")
sphere = pv.Sphere(radius=0.4, center=(0.3, 0.0, 0.4))
pl.add_mesh(sphere, color="teal", lighting=False)
pv_cubemarch.add_volume(pl, volume, technique="direct", step_scale=0.5)
pl.camera_position = [(2.5, 1.5, 3.5), (0, 0, 0), (0, 1, 0)]
pl.renderer.ResetCameraClippingRange()
image = pv_cubemarch.render_image(pl)
camera = pv_cubemarch.Camera.from_pyvista(pl.camera)
pl.show()

# %%
# The CPU reference over the sphere's depth and colour.
depth = mesh_depth(sphere, camera, size)
backdrop = np.where(np.isfinite(depth)[..., None], pv.Color("teal").float_rgb, 0.0)
reference = pv_cubemarch.render_emission_absorption(volume, camera, size, opaque_depth=depth,
                                                    opaque_color=backdrop)
print("GPU against the CPU reference:", compare_images(image, reference).as_dict())
plt.imshow(np.hstack([image, to_uint8(reference)]))
plt.title("GPU (left) and CPU reference (right)")
plt.axis("off")
plt.show()
