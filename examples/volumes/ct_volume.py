"""
A CT volume in Hounsfield units, with a scalar bar and a clip plane
===================================================================

A synthetic head phantom in its real units: int16 Hounsfield units (air -1000, soft
tissue about 40, bone 1000 and more), millimetre voxels, and an origin far from 0, as a
scanner writes it. The transfer function is given in those units (``clim``), the scalar
bar is titled and annotated, and a clip plane cuts the skull open.
"""

import numpy as np
import pyvista as pv

import pv_cubemarch

n = 96
x, y, z = np.mgrid[-1:1:n * 1j, -1:1:n * 1j, -1:1:80j]
head = x**2 / 0.8 + y**2 / 1.0 + z**2 / 0.9
outer = 0.5 * (1 - np.tanh((head - 0.85) / 0.015))           # inside the skull's outside
inner = 0.5 * (1 - np.tanh((head - 0.75) / 0.015))           # inside its inside
lesion = np.exp(-((x - 0.25) ** 2 + (y + 0.2) ** 2 + z**2) / 0.004)
hu = (-1000 + 2300 * outer - 1265 * inner + 400 * lesion).astype(np.int16)   # air, bone, brain
ct = pv.ImageData(dimensions=hu.shape, spacing=(0.9, 0.9, 1.5), origin=(-110.0, 75.0, -300.0))
ct.point_data["HU"] = hu.ravel(order="F")

pl = pv.Plotter(window_size=(640, 480))
pl.set_background("black")
center = np.array(ct.center)
pv_cubemarch.add_volume(
    pl, ct, cmap="bone", clim=(-1000, 1500),
    opacity=[0.0, 0.0, 0.03, 0.06, 0.8, 0.95],              # air clear, tissue faint, bone opaque
    opacity_unit_distance=3.0,
    clip_planes=[(*center, 0.0, 1.0, 0.0)],                 # keep the back half (+y)
    show_scalar_bar=True,
    scalar_bar_args={"title": "Hounsfield units", "n_labels": 3, "fmt": "%.0f",
                     "position_x": 0.2, "width": 0.6},
    annotations={-1000: "air", 40: "tissue", 1000: "bone"},
)
pl.camera_position = "xz"
pl.camera.Azimuth(30)
pl.camera.Elevation(20)
view = pl.camera_position
pl.show()

# %%
# The same data through PyVista's own ``add_volume``, for comparison: the same keywords
# give the same colours (without the clip plane, which PyVista sets by a widget).
theirs = pv.Plotter(window_size=(640, 480))
theirs.set_background("black")
theirs.add_volume(ct, cmap="bone", clim=(-1000, 1500),
                  opacity=[0.0, 0.0, 0.03, 0.06, 0.8, 0.95],
                  opacity_unit_distance=3.0, show_scalar_bar=False)
theirs.camera_position = view
theirs.show()
