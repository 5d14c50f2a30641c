"""
Several overlapping volumes, unlit and lit
==========================================

Two interpenetrating volumes are marched jointly, as one medium (``add_volumes``), here
by the cube map (``technique="cubemap"``), whose cost barely grows with the viewport. The
same pair lit by a directional light: one light map is marched through the joint medium,
so each volume shades the other; it runs once, not per frame. The CPU reference of the
same pair is drawn beside the GPU image.
"""

import matplotlib.pyplot as plt
import numpy as np
import pyvista as pv

import pv_cubemarch
from pv_cubemarch.image_metrics import compare_images, to_uint8

size = (320, 240)
x, y, z = np.mgrid[-1:1:48j, -1:1:48j, -1:1:48j]
grid = pv.ImageData(dimensions=x.shape, spacing=(2 / 47,) * 3, origin=(-1, -1, -1))
grid.point_data["smoke"] = (np.exp(-3 * (x**2 + y**2 + z**2))
                            * (1 + 0.3 * np.sin(8 * x) * np.cos(6 * y))).ravel(order="F")
grid.point_data["glow"] = np.exp(-6 * (x**2 + y**2 + z**2)).ravel(order="F")
first = pv_cubemarch.make_volume(grid, "smoke", cmap="inferno", clim=(0, 1.2),
                                 opacity_unit_distance=0.2, name="smoke")
shift = np.eye(4)
shift[:3, 3] = (0.8, 0.4, 0.0)
second = pv_cubemarch.make_volume(grid, "glow", cmap="viridis", clim=(0, 1),
                                  opacity_unit_distance=0.2, name="glow", transform=shift)
view = [(2.5, 1.5, 3.5), (0.3, 0.1, 0), (0, 1, 0)]

pl = pv.Plotter(window_size=size)
pl.set_background("black")
(actor,) = pv_cubemarch.add_volumes(pl, [first, second], technique="cubemap", face_size=256)
pl.camera_position = view
pl.renderer.ResetCameraClippingRange()
image = pv_cubemarch.render_image(pl)
print("level of detail this frame:", actor.cubemarch.lod)
print("GPU memory (bytes):", actor.cubemarch.memory)

# The CPU reference (numpy only, sharing no code with the renderer) of the same pair.
camera = pv_cubemarch.Camera.from_pyvista(pl.camera)
reference = pv_cubemarch.render_emission_absorption([first, second], camera, size,
                                                    near=pl.camera.clipping_range[0])
print("cube map against the CPU reference:", compare_images(image, reference).as_dict())
pl.close()

# %%
# Lit by a directional light.
lit = pv.Plotter(window_size=size)
lit.set_background("black")
sun = pv_cubemarch.VolumeLight("directional", direction=(-1.0, -1.0, -0.5))
(lit_actor,) = pv_cubemarch.add_volumes(lit, [first, second], technique="cubemap",
                                        lights=[sun], light_map_size=32,
                                        light_map_ambient=0.25)
lit.camera_position = view
lit.renderer.ResetCameraClippingRange()
lit_image = pv_cubemarch.render_image(lit)
print("light-map passes after one frame:", lit_actor.cubemarch.light_map.render_pass.runs)
lit.close()

fig, axes = plt.subplots(1, 3, figsize=(9.6, 2.6))
for ax, picture, title in zip(axes, [image, to_uint8(reference), lit_image],
                              ["cube map", "CPU reference", "lit"], strict=True):
    ax.imshow(picture)
    ax.set_title(title)
    ax.axis("off")
fig.tight_layout()
plt.show()
