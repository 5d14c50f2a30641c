"""
Multichannel volumes: each channel its own transfer function
============================================================

Two to four components are independent channels, each with its own colormap (a colour
name ramps from black to it), opacity and range, as fluorescence microscopy channels
are. ``channel_blending="additive"`` adds each channel's light, as napari adds channels;
``"composite"`` marches them as one medium. Integer labels drawn as a volume take
``categories=True``: as many colours as distinct values.
"""

import numpy as np
import pyvista as pv

import pv_cubemarch

x, y, z = np.mgrid[-1:1:64j, -1:1:64j, -1:1:48j]
nuclei = (np.exp(-30 * ((x - 0.3) ** 2 + y**2 + z**2))
          + np.exp(-30 * ((x + 0.3) ** 2 + (y - 0.2) ** 2 + z**2)))
membrane = np.exp(-80 * (np.sqrt(x**2 + y**2 + z**2) - 0.7) ** 2)
cells = pv.ImageData(dimensions=nuclei.shape, spacing=(0.3, 0.3, 0.5))   # micrometres
cells.point_data["stains"] = np.stack([nuclei.ravel(order="F"), membrane.ravel(order="F")],
                                      axis=1).astype(np.float32)          # two components

pl = pv.Plotter(shape=(1, 3), window_size=(1200, 400), border=False)
pl.set_background("black")
for column, mode in enumerate(["additive", "composite"]):
    pl.subplot(0, column)
    pl.add_text(f"channel_blending={mode!r}", font_size=9, color="white")
    pv_cubemarch.add_volume(pl, cells, independent_components=True, channel_blending=mode,
                            cmap=["cyan", "magenta"], opacity=["linear", "sigmoid"],
                            clim=[(0, 1), (0, 1)], opacity_unit_distance=2.0)
pl.subplot(0, 2)
pl.add_text("categories=True", font_size=9, color="white")
labels = (np.round(3 * nuclei + 2 * membrane)).astype(np.uint8)
pv_cubemarch.add_volume(pl, labels, categories=True, cmap="tab10", opacity="linear",
                        interpolation="nearest")
pl.link_views()
pl.view_isometric()
pl.show()
