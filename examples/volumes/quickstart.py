"""
Quick start: a volume with a mesh in it
=======================================

A numpy array drawn as a volume beside a mesh, with PyVista's keywords. This is the
README's first example.
"""

import numpy as np
import pyvista as pv

import pv_cubemarch

x, y, z = np.mgrid[-1:1:64j, -1:1:64j, -1:1:64j]
density = np.exp(-4 * (x**2 + y**2 + z**2))

pl = pv.Plotter(window_size=(640, 480))
pl.set_background("black")
pv_cubemarch.add_volume(pl, density, cmap="inferno", opacity="linear",
                        opacity_unit_distance=10, step_scale=0.5)
pl.add_mesh(pv.Sphere(radius=12, center=(40, 32, 44)), color="tan")
image = pv_cubemarch.render_image(pl)  # the frame as a numpy array, for scripts and tests
print(image.shape, image.dtype)
pl.show()
