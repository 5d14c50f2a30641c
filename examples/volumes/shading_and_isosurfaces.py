"""
Shading, isosurfaces, cropping and lights
=========================================

The same CT-like field four ways: gradient shading by the renderer's lights as VTK's
volume mapper shades (``shade=True`` with ``ambient``, ``diffuse``, ``specular`` and
``specular_power``); VTK's isosurface mode at three levels in data units
(``blending="isosurface"``, ``isosurfaces=``); a crop box with nearest-neighbour
interpolation and a banded, reversed colormap (``crop_box``, ``interpolation``,
``n_colors``, ``flip_scalars``); and the medium lit by the scene's lights through its own
transmittance (``lights="scene"``, a light map of ``light_map_size`` points per axis).
"""

import numpy as np
import pyvista as pv

import pv_cubemarch

x, y, z = np.mgrid[-1:1:72j, -1:1:72j, -1:1:72j]
values = 1000 * (np.exp(-4 * ((x - 0.2) ** 2 + y**2 + z**2))
                 + 0.8 * np.exp(-6 * ((x + 0.35) ** 2 + (y - 0.2) ** 2 + (z + 0.1) ** 2)))
grid = pv.ImageData(dimensions=values.shape, spacing=(1.0, 1.0, 1.0), origin=(-500, 20, 0))
grid.point_data["density"] = values.ravel(order="F")
box = grid.bounds

pl = pv.Plotter(shape=(1, 4), window_size=(1280, 340), border=False)
pl.set_background("white")
pl.subplot(0, 0)
pl.add_text("shade", font_size=9)
pv_cubemarch.add_volume(pl, grid, cmap="copper", opacity="sigmoid", shade=True,
                        ambient=0.2, diffuse=0.8, specular=0.4, specular_power=20.0)
pl.subplot(0, 1)
pl.add_text("isosurface", font_size=9)
pv_cubemarch.add_volume(pl, grid, cmap="viridis", blending="isosurface",
                        isosurfaces=[250.0, 500.0, 800.0], opacity=0.5)
pl.subplot(0, 2)
pl.add_text("crop box, nearest", font_size=9)
pv_cubemarch.add_volume(pl, grid, cmap="coolwarm", n_colors=8, flip_scalars=True,
                        interpolation="nearest", opacity="linear",
                        crop_box=(box[0], box[0] + 50, box[2], box[3], box[4], box[5]))
pl.subplot(0, 3)
pl.add_text("lit by the scene's light", font_size=9)
pl.renderer.remove_all_lights()                            # one light of our own
pl.add_light(pv.Light(position=(-400, 200, 300), focal_point=grid.center,
                      light_type="scene light"))
pv_cubemarch.add_volume(pl, grid, technique="direct", cmap="bone", opacity="linear",
                        lights="scene", light_map_size=24, light_map_ambient=0.15)
pl.link_views()
pl.view_isometric()
pl.show()
