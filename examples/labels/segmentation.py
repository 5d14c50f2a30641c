"""
A segmentation: a legend, hidden labels and picking
===================================================

PyVista's shipped frog tissue segmentation (uint8 ids of 25 tissues; 0 is empty), drawn
exactly, voxel by voxel: every pixel shows the first labelled voxel its ray meets, here
cut in half by a clip plane (a voxel the cut crosses is drawn on the plane). Labels
are hidden or recoloured by changing only the palette (a few bytes per label go to the
GPU; the labels stay uploaded), and ``pick`` returns the id, voxel and face under a pixel.
The dataset carries no tissue names, so the legend names labels by id.
"""

import numpy as np
import pyvista as pv
from pyvista import examples

import pv_cubemarch

tissues = examples.load_frog_tissues()                 # 500 x 470 x 136, spacing 1, 1, 1.5
ids, counts = np.unique(tissues["MetaImage"], return_counts=True)
ids, counts = ids[1:], counts[1:]                      # 0 is empty
largest = int(ids[np.argmax(counts)])
print(f"{ids.size} labels; the largest, id {largest}, has {counts.max():,} voxels")

pl = pv.Plotter(window_size=(800, 560))
pl.set_background("white")
# a clip plane through the body (z = 100, the side below kept): the cut shows the insides
actor = pv_cubemarch.add_voxels(pl, tissues, cmap="turbo", categories=True,
                                shading="blinn", ambient_occlusion=True,
                                clip_planes=(0, 0, 100, 0, 0, -1))
voxels = actor.cubemarch
voxels.hide_labels(largest)                            # hide the largest tissue
voxels.set_label_color(int(ids[np.argsort(counts)[-2]]), "gold")   # recolour the next
pl.camera_position = "yx"                              # a dorsal view, as PyVista's example
pl.camera.Elevation(-35)
pl.reset_camera()
pl.camera.zoom(1.3)

# a legend of the ten largest labels still shown, in the colours they are drawn with
rgba = voxels.model.palette.rgba
hidden = set(voxels.hidden_labels.tolist())
shown = [int(i) for i in ids[np.argsort(counts)[::-1]] if int(i) not in hidden][:10]
pl.add_legend([[f"id {i}", rgba[i, :3]] for i in shown], bcolor="white", size=(0.14, 0.36),
              loc="upper right")

# what is under the middle of the image
picked = voxels.pick(400, 280)
if picked is not None:
    print(f"pixel (400, 280): id {picked.label}, voxel {picked.index}, face "
          f"{picked.face}, at {np.round(picked.point, 1)}")
    pl.add_mesh(pv.Sphere(radius=5, center=picked.point), color="red")
print(f"{voxels.nbytes / 1e6:.1f} MB on the GPU for {tissues.n_cells:,} voxels")
pl.show()
