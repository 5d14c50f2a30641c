"""
Maximum-intensity projection of a microscopy stack
==================================================

uint16 camera counts with anisotropic voxels, as a light-sheet or confocal stack comes:
``blending="maximum"`` draws the brightest sample along each ray, on a log scale over
the counts. ``"minimum"``, ``"average"`` (with ``average_range`` leaving the background
out of the mean) and ``"additive"`` are the other projections, as VTK draws them.
"""

import numpy as np
import pyvista as pv

import pv_cubemarch

rng = np.random.default_rng(4)
shape = (128, 128, 40)
counts = rng.poisson(100, size=shape).astype(np.float64)          # camera background
x, y, z = np.meshgrid(*(np.arange(s) for s in shape), indexing="ij")
for cx, cy, cz in rng.uniform((10, 10, 5), (118, 118, 35), size=(60, 3)):   # cells
    counts += 3000 * np.exp(-((x - cx) ** 2 + (y - cy) ** 2 + 4 * (z - cz) ** 2) / 8)
for t in np.linspace(0, 1, 400):                                  # a neurite
    px, py, pz = 20 + 90 * t, 64 + 40 * np.sin(5 * t), 20 + 10 * t
    counts[int(px), int(py), int(pz)] += 4000
stack = pv.ImageData(dimensions=shape, spacing=(0.2, 0.2, 0.8))    # micrometres
stack.point_data["counts"] = np.clip(counts, 0, 65535).astype(np.uint16).ravel(order="F")

pl = pv.Plotter(shape=(1, 3), window_size=(1200, 420), border=False)
pl.set_background("black")
for column, (blending, extra) in enumerate([
        ("maximum", {"log_scale": True, "clim": (100, 5000)}),
        ("average", {"average_range": (300, 65535), "clim": (100, 3000)}),
        ("additive", {"clim": (100, 20000)})]):
    pl.subplot(0, column)
    pl.add_text(blending, font_size=10, color="white")
    pv_cubemarch.add_volume(pl, stack, cmap="magma", blending=blending,
                            opacity="linear", **extra)
    pl.view_xy()
pl.link_views()
pl.show()
