"""
A USD scene: smoke, a torus, ground, camera and lights
======================================================

The shipped stage ``datasets/smoke_scene.usda`` loaded with ``load_scene``: its meshes
drawn with their UsdPreviewSurface materials, its volume with the transfer function its
``cubemarch:*`` attributes give, its camera and lights. ``summary()`` reports what was
loaded and what was skipped, and why.
"""

from pathlib import Path

import matplotlib.pyplot as plt

import pv_cubemarch

DATA = Path(pv_cubemarch.__file__).resolve().parents[1] / "datasets"   # in the clone

scene = pv_cubemarch.load_scene(DATA / "smoke_scene.usda")
print(scene.summary())
image = scene.render(size=(800, 600))
plt.imshow(image)
plt.axis("off")
plt.show()
