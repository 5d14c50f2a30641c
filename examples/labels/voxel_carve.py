"""
Click to carve: picking and editing voxels
==========================================

An FBM terrain with a torus of ore in it; each click picks the voxel drawn under the
pixel (``actor.cubemarch.pick``, the same traversal as the image) and carves a ball of
radius 5 around it (``fill_sphere(..., 0)``): only the touched labels, the occupancy cells
above them and the brick shell's new faces are uploaded. Here five clicks along the
image's middle row stand in for the mouse; run the script with ``--window`` to click
yourself.
"""

import sys

import numpy as np

import pv_cubemarch
from pv_cubemarch.models.procedural import terrain, torus

n = 96
labels = terrain((n, n, 48), feature_size=48.0, seed=3)           # grass, dirt, bedrock
torus((48, 48, 14), 20, 4).voxels(labels.shape, material=4, into=labels)   # ore
palette = ["black", "forestgreen", "saddlebrown", "dimgray", "gold"]


def carve(actor, x: int, y: int, radius: float = 5.0) -> bool:
    """Carve a ball around the voxel under pixel (x, y) (from the top-left)."""
    picked = actor.cubemarch.pick(x, y)
    if picked is None:
        return False
    actor.cubemarch.fill_sphere(np.add(picked.index, 0.5), radius, 0)
    return True


if "--window" in sys.argv:
    import pyvista as pv

    pl = pv.Plotter()
    actor = pv_cubemarch.add_voxels(pl, labels, palette=palette, ambient_occlusion=True)

    def on_click(position):
        height = pl.renderer.GetSize()[1]
        if carve(actor, int(position[0]), height - 1 - int(position[1])):
            pl.render()

    pl.track_click_position(on_click, side="left")
    pl.show()
else:
    import pyvista as pv

    pl = pv.Plotter(window_size=(800, 600))
    pl.set_background("lightskyblue")
    actor = pv_cubemarch.add_voxels(pl, labels, palette=palette, ambient_occlusion=True)
    pl.camera_position = [(170, -80, 120), (48, 48, 16), (0, 0, 1)]
    pl.renderer.ResetCameraClippingRange()
    carved = sum(carve(actor, x, 300) for x in range(250, 551, 75))
    print(f"{carved} carves, {actor.cubemarch.labels.uploaded_bytes:,} label bytes "
          "uploaded in all")
    pl.show()
