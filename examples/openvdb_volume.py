"""Read an OpenVDB smoke grid with our numpy reader and draw it two ways.

Left, the grid as PyVista data (``pv_cubemarch.read_vdb``, also ``pyvista.read``) through
``add_volume``'s cube map; right, the shipped mixed USD scene, where the same file is an
``OpenVDBAsset`` field among textured meshes, voxels and an implicit surface.

Run: python examples/openvdb_volume.py [out.png]
"""

import sys
import warnings
from pathlib import Path

import numpy as np
from PIL import Image

import pv_cubemarch
from pv_cubemarch.scene.openvdb import list_grids

HERE = Path(__file__).resolve().parent
DATA = HERE.parent / "datasets"
out = sys.argv[1] if len(sys.argv) > 1 else "openvdb_volume.png"

for info in list_grids(DATA / "mixed_smoke.vdb"):
    print(f"{info.name}: {info.value_type}, half={info.stored_as_half}, "
          f"{info.voxel_count} active voxels, map {info.map_type}")
smoke = pv_cubemarch.read_vdb(DATA / "mixed_smoke.vdb")      # ImageData in its world space
print(smoke)

pl = pv_cubemarch.offscreen_plotter((400, 400))
pl.set_background("black")
pv_cubemarch.add_volume(pl, smoke, cmap="inferno", opacity="linear",
                        opacity_unit_distance=0.3, technique="cubemap")
pl.view_isometric()
left = pv_cubemarch.render_image(pl)
pl.close()

with warnings.catch_warnings():
    warnings.simplefilter("ignore", pv_cubemarch.SceneWarning)   # the report is printed
    scene = pv_cubemarch.load_scene(DATA / "mixed_scene.usda")
print(scene.summary())
right = scene.render(size=(640, 400))
Image.fromarray(np.hstack([left, np.asarray(Image.fromarray(right).resize((640, 400)))[
    :, :, :3]])).save(out)
print("wrote", out)
