"""The README's quick start: a numpy volume with a mesh in it, rendered offscreen.

Run: python examples/quickstart.py [out.png]
"""

import sys

import numpy as np
import pyvista as pv
from PIL import Image

import pv_cubemarch

out = sys.argv[1] if len(sys.argv) > 1 else "quickstart.png"

x, y, z = np.mgrid[-1:1:64j, -1:1:64j, -1:1:64j]
density = np.exp(-4 * (x**2 + y**2 + z**2))

pl = pv.Plotter(off_screen=True, window_size=(640, 480))
pl.set_background("black")
pv_cubemarch.add_volume(pl, density, cmap="inferno", opacity="linear",
                        opacity_unit_distance=10, step_scale=0.5)
pl.add_mesh(pv.Sphere(radius=12, center=(40, 32, 44)), color="tan")
image = pv_cubemarch.render_image(pl)  # (480, 640, 3) uint8
Image.fromarray(image).save(out)
print("wrote", out)
