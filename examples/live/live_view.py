"""
The live view: tuning knobs from a browser or a notebook
========================================================

``pv_cubemarch.live_view(plotter)`` serves the plotter, rendered on the server (where our
GLSL runs), with a panel of every technique's speed/accuracy knobs generated from the
declared options. In a notebook, ``plotter.show()`` shows the served view and
``live_view(plotter)`` displays with its panel (see ``examples/live/live_view.ipynb``);
from a terminal, ``pv-cubemarch view scene.usda`` serves a scene to a browser. Here the
knobs are turned from code, as the panel turns them, and the frame is shown.
"""

import numpy as np
import pyvista as pv

import pv_cubemarch

x, y, z = np.mgrid[-1:1:48j, -1:1:48j, -1:1:48j]
density = np.exp(-4 * (x**2 + y**2 + z**2)) * (1 + 0.3 * np.cos(9 * z))
pl = pv.Plotter(window_size=(480, 360))
pl.set_background("black")
pv_cubemarch.add_volume(pl, density, cmap="inferno", technique="direct", step_scale=0.5)

view = pv_cubemarch.live_view(pl)        # a server on a free localhost port
print("open", view.url)                  # its page carries a secret: only its page connects
print(f"step_scale=2: {view.set('volume', 'step_scale', 2.0):.0f} ms a frame")
print(f"back to 0.5: {view.set('volume', 'step_scale', 0.5):.0f} ms a frame")
print("error against the CPU reference:", view.session.reference_error())
view.close()
pl.show()
