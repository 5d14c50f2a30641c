"""
A cell segmentation: uint64 ids, hashed colours, showing only some cells
========================================================================

Cell and organ segmentations come as uint32 or uint64 ids that are neither small nor
contiguous (here 20,000 Voronoi cells with ids near 2^40, as a connectomics export has).
``add_voxels`` takes them as they are: the ids are compacted on upload to dense rows (two
bytes a voxel for 20,000 ids, whatever their width), each id gets a colour hashed from it
(the same in every run and every grid; neighbouring ids differ), and every per-cell
property is one entry of a table by id. Showing only a few cells, recolouring or
highlighting them sends only their entries to the GPU; the labels stay uploaded. A clip
plane cuts the grid open, and ``edge_mode="labels"`` outlines only the boundaries between
cells, on their faces and on the cut.
"""

import numpy as np
import pyvista as pv
from scipy.spatial import cKDTree

import pv_cubemarch

n, cells = 96, 20000
rng = np.random.default_rng(0)
ids = (2**40 + rng.choice(10**9, cells, replace=False)).astype(np.uint64)
centres = np.stack(np.meshgrid(*[np.arange(n) + 0.5] * 3, indexing="ij"), -1).reshape(-1, 3)
labels = ids[cKDTree(rng.random((cells, 3)) * n).query(centres)[1]].reshape(n, n, n)
x, y, z = np.ogrid[:n, :n, :n]
labels[(x - n / 2) ** 2 + (y - n / 2) ** 2 + (z - n / 2) ** 2 > (0.45 * n) ** 2] = 0

pl = pv.Plotter(shape=(1, 3), window_size=(1200, 420))
pl.set_background("white")
actor = pv_cubemarch.add_voxels(pl, labels, shading="flat")
cells_drawn = actor.cubemarch
print(f"{cells_drawn.n_labels} cells: {labels.dtype} ids stored as "
      f"{cells_drawn.model.labels.dtype} rows ({cells_drawn.model.labels.itemsize} bytes a "
      "voxel, plus the occupancy levels)")
pl.add_text("every cell", font_size=10, color="black")
pl.camera_position = [(2.2 * n, -1.3 * n, 1.6 * n), (n / 2, n / 2, n / 2), (0, 0, 1)]

# the middle view: cut open by a clip plane, the boundaries between cells outlined (on the
# cells' faces and on the cut)
pl.subplot(0, 1)
pv_cubemarch.add_voxels(pl, labels, shading="flat", clip_planes=(n / 2, 0, 0, -1, 0, 0),
                        show_edges=True, edge_mode="labels", edge_color="black")
pl.add_text("cut, cell boundaries outlined", font_size=10, color="black")
pl.camera_position = [(2.2 * n, -1.3 * n, 1.6 * n), (n / 2, n / 2, n / 2), (0, 0, 1)]

# the right view: the same ids, only the cells crossing a slab, one highlighted
pl.subplot(0, 2)
actor2 = pv_cubemarch.add_voxels(pl, labels, shading="flat")
slab = np.unique(labels[:, :, n // 2 - 2:n // 2 + 2])
slab = slab[slab != 0]
actor2.cubemarch.show_selected_labels(slab)
picked = int(labels[n // 2, n // 2, n // 2 + 1])   # on the slab's top face
actor2.cubemarch.highlight_labels(picked, color="black")
pl.add_text(f"{slab.size} cells of a slab; cell {picked} in black", font_size=10,
            color="black")
pl.camera_position = [(2.2 * n, -1.3 * n, 1.6 * n), (n / 2, n / 2, n / 2), (0, 0, 1)]
print(f"the slab's cells: {slab.size}; hidden: {actor2.cubemarch.hidden_labels.size}")

# what is under a pixel of the right view: the id itself, its voxel and face
hit = actor2.cubemarch.pick(200, 210)
if hit is not None:
    print(f"pixel (200, 210): cell {hit.label} at voxel {hit.index}, face {hit.face}")
pl.show()
