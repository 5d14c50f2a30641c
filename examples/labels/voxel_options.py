"""
Voxel drawing options: traversal, shading, edges, level of detail
=================================================================

One label grid drawn with the options a material grid takes. ``traversal="dda"`` visits
every voxel a ray crosses (exact); ``"fixed"`` samples every ``step_scale`` voxels and may
miss thin ones. ``mip_levels`` and ``distance_field`` let rays leave empty space in big
steps (exact either way); ``proxy`` says where rays start. ``mode="id"`` and ``"face"``
show what each pixel hit; edges, a scalar bar of the materials, ambient occlusion and
level of detail complete the set.
"""

import numpy as np
import pyvista as pv

import pv_cubemarch

rng = np.random.default_rng(5)
n = 48
x, y, z = np.mgrid[0:n, 0:n, 0:n]
labels = np.zeros((n, n, n), np.uint8)
labels[(x - 24) ** 2 + (y - 24) ** 2 + (z - 24) ** 2 < 18**2] = 1
labels[(rng.random(labels.shape) < 0.01) & (labels == 0)] = 2      # sparse dust
labels[:, :, :6][labels[:, :, :6] > 0] = 3
palette = ["black", "steelblue", "orange", "seagreen"]
grid_options = [
    ("dda, mip_levels=3", dict(traversal="dda", mip_levels=3, distance_field=2,
                               proxy="bricks")),
    ("fixed, step_scale=0.5", dict(traversal="fixed", step_scale=0.5, proxy="box")),
    ("mode='face'", dict(mode="face")),
    ("edges", dict(show_edges=True, edge_color="black", line_width=1.0, edge_opacity=0.6,
                   shading="flat")),
    ("ambient occlusion, blinn", dict(ambient_occlusion=True, occlusion_strength=0.8,
                                      shading="blinn", ambient=0.3, specular=0.5,
                                      specular_power=40.0)),
    ("lod, scalar bar", dict(lod=True, lod_bias=1.0, shading="unlit", show_scalar_bar=True,
                             scalar_bar_args={"title": "material"},
                             annotations={1: "ball", 2: "dust", 3: "floor"})),
]
pl = pv.Plotter(shape=(2, 3), window_size=(1050, 640), border=False)
pl.set_background("white")
for k, (title, options) in enumerate(grid_options):
    pl.subplot(k // 3, k % 3)
    pl.add_text(title, font_size=9)
    pv_cubemarch.add_voxels(pl, labels, palette=palette, **options)
    pl.camera_position = [(110, -60, 90), (24, 24, 20), (0, 0, 1)]
pl.show()

# %%
# Worlds of chunks choose their traversal too: one traversal over a chunk index
# (``"index"``) or one per chunk (``"per_chunk"``).
world = pv.Plotter(window_size=(480, 360))
world.set_background("white")
pv_cubemarch.add_voxels(world, np.tile(labels, (2, 2, 1)), palette=palette, chunk_size=32,
                        world_traversal="index")
world.camera_position = [(220, -120, 160), (48, 48, 20), (0, 0, 1)]
world.show()
