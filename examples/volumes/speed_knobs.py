"""
Trading speed for accuracy: each technique's knobs
==================================================

Every volume technique draws the same integral; its knobs trade time for error. This
example draws one volume with each technique and a few settings, and prints each frame's
time and its error against the CPU reference (PSNR in dB: higher is closer). The
benchmarks (``pv-cubemarch bench tradeoff``) do this properly, frames drawn in turn; see
:doc:`/speed_accuracy`.
"""

import time

import matplotlib.pyplot as plt
import numpy as np
import pyvista as pv

import pv_cubemarch
from pv_cubemarch.image_metrics import compare_images

size = (240, 180)
x, y, z = np.mgrid[-1:1:64j, -1:1:64j, -1:1:64j]
field = np.exp(-3 * (x**2 + y**2 + z**2)) * (1 + 0.4 * np.sin(9 * x) * np.cos(7 * z))
volume = pv_cubemarch.make_volume(field, cmap="plasma", opacity="sigmoid",
                                  opacity_unit_distance=4.0)
view = [(150, 110, 140), (32, 32, 32), (0, 0, 1)]

settings = {
    "vtk, step_scale=0.5": dict(technique="vtk", step_scale=0.5),
    "vtk, step_scale=2": dict(technique="vtk", step_scale=2.0),
    "direct, stop_opacity=0.9": dict(technique="direct", stop_opacity=0.9),
    "direct, downsample=2": dict(technique="direct", downsample=2),
    "direct, skip_empty=False": dict(technique="direct", skip_empty=False),
    "cubemap, face_size=128": dict(technique="cubemap", face_size=128),
    "cubemap, max_samples=32": dict(technique="cubemap", max_samples=32),
    "cubemap, upscale=2": dict(technique="cubemap", upscale=2.0, sample_factor=1.0),
    "cubemap, sample_factor=2": dict(technique="cubemap", sample_factor=2.0,
                                     occlusion_sharpness=0.5),
    "auto": dict(technique="auto"),
}
reference = None
fig, axes = plt.subplots(2, 5, figsize=(12, 4.4))
for ax, (name, options) in zip(axes.ravel(), settings.items(), strict=True):
    pl = pv.Plotter(window_size=size)
    pl.set_background("black")
    pv_cubemarch.add_volume(pl, volume, **options)
    pl.camera_position = view
    pl.reset_camera_clipping_range()
    pv_cubemarch.render_image(pl)                        # compile and upload
    start = time.perf_counter()
    image = pv_cubemarch.render_image(pl)
    milliseconds = 1e3 * (time.perf_counter() - start)
    if reference is None:
        camera = pv_cubemarch.Camera.from_pyvista(pl.camera)
        reference = pv_cubemarch.render_emission_absorption(
            volume, camera, size, near=pl.camera.clipping_range[0])
    psnr = compare_images(image, reference).psnr
    pl.close()
    ax.imshow(image)
    ax.set_title(f"{name}\n{milliseconds:.0f} ms, {psnr:.1f} dB", fontsize=8)
    ax.axis("off")
fig.tight_layout()
plt.show()
