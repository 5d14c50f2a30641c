"""
Ask for an error, not for settings: ``quality=``
================================================

Instead of choosing ``step_scale`` or ``face_size`` by hand, ask for a PSNR against the
CPU reference (or ``'fast'``, ``'balanced'``, ``'best'``: 30, 40, 50 dB). The volume is
drawn at a few settings from the camera the view will have, a sample of the frame's pixels
is traced on the CPU, and the cheapest setting whose error meets the target is kept.
``actor.cubemarch.quality`` says what was chosen and what was tried; here each choice is
checked against the reference over the whole frame. ``frame_budget_ms=`` keeps frames
within a time while the view moves. See :doc:`/speed_accuracy`.
"""

import matplotlib.pyplot as plt
import numpy as np
import pyvista as pv

import pv_cubemarch
from pv_cubemarch.image_metrics import compare_images

# a CT-like phantom in Hounsfield units, on an anisotropic grid away from the origin
x, y, z = np.meshgrid(*(np.linspace(-1, 1, n) for n in (64, 48, 40)), indexing="ij")
radius = np.sqrt(x**2 + (y / 0.8) ** 2 + (z / 0.7) ** 2)
hu = np.where(radius < 0.9, 40.0, -1000.0)
hu = np.where((radius > 0.75) & (radius < 0.85), 1200.0, hu)
grid = pv.ImageData(dimensions=hu.shape, spacing=(0.8, 1.0, 1.3), origin=(-100, 20, 5))
grid.point_data["hu"] = hu.ravel(order="F")

size = (240, 180)
fig, axes = plt.subplots(1, 3, figsize=(10, 3.4))
for ax, (technique, quality) in zip(axes, [("direct", "fast"), ("direct", 45),
                                           ("cubemap", "balanced")], strict=True):
    pl = pv.Plotter(window_size=size)
    pl.set_background("black")
    # frame_budget_ms: while the view moves (an interactor's drag), the step coarsens to
    # keep frames within 33 ms; the still view draws what quality chose again
    budget = {"frame_budget_ms": 33} if technique == "direct" else {}
    actor = pv_cubemarch.add_volume(pl, grid, technique=technique, quality=quality,
                                    cmap="bone", opacity="sigmoid", clim=(-200, 1500),
                                    **budget)
    choice = actor.cubemarch.quality
    print(choice)
    image = pv_cubemarch.render_image(pl)
    camera = pv_cubemarch.Camera.from_pyvista(pl.camera)
    reference = pv_cubemarch.render_emission_absorption(
        actor.cubemarch.model, camera, size, near=pl.camera.clipping_range[0])
    psnr = compare_images(image, reference).psnr
    pl.close()
    setting = ", ".join(f"{k}={v:g}" for k, v in choice.setting.items())
    ax.imshow(image)
    ax.set_title(f"{technique}, quality={quality!r}\n{setting}: {psnr:.1f} dB", fontsize=8)
    ax.axis("off")
fig.tight_layout()
plt.show()
