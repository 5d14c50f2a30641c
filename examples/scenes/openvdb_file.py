"""
An OpenVDB file, alone and inside a USD scene
=============================================

``pv_cubemarch.read_vdb`` (also ``pyvista.read("smoke.vdb")``) reads one grid of an
OpenVDB file with our own numpy reader into an ``ImageData`` in its world space, every
voxel holding what OpenVDB's tree returns there. Left: the grid through ``add_volume``'s
cube map. Right: the shipped mixed USD scene, where the same file is an ``OpenVDBAsset``
field among textured meshes, voxels and an implicit surface.
"""

import warnings
from pathlib import Path

import matplotlib.pyplot as plt
import pyvista as pv

import pv_cubemarch
from pv_cubemarch.scene.openvdb import list_grids

DATA = Path(pv_cubemarch.__file__).resolve().parents[1] / "datasets"   # in the clone

for info in list_grids(DATA / "mixed_smoke.vdb"):
    print(f"{info.name}: {info.value_type}, half={info.stored_as_half}, "
          f"{info.voxel_count} active voxels, map {info.map_type}")
smoke = pv_cubemarch.read_vdb(DATA / "mixed_smoke.vdb")
print(smoke)

pl = pv.Plotter(window_size=(400, 400))
pl.set_background("black")
pv_cubemarch.add_volume(pl, smoke, cmap="inferno", opacity="linear",
                        opacity_unit_distance=0.3, technique="cubemap")
pl.view_isometric()
pl.show()

# %%
# The mixed scene: the stage's report says what was loaded and what was skipped.
with warnings.catch_warnings():
    warnings.simplefilter("ignore", pv_cubemarch.SceneWarning)   # the report is printed
    scene = pv_cubemarch.load_scene(DATA / "mixed_scene.usda")
print(scene.summary())
plt.imshow(scene.render(size=(640, 400)))
plt.axis("off")
plt.show()
