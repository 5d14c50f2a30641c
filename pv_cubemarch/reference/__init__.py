"""CPU references (numpy only, never GL): what the right image of each technique is.

``rays``: the one slab test, trilinear sampling, mesh depth; ``emission_absorption``: the
volume reference; ``projections``: its other blend modes; ``volume_shading``: gradient
shading (``shade=True``);
``transfer``: colours and extinction derived from matplotlib alone; ``lighting``:
transmittance toward lights; ``voxels``: exact grid
traversal (first voxel, face and depth per pixel) and the faces' ambient occlusion.
"""

from .emission_absorption import render_emission_absorption
from .projections import render_blended
from .rays import chord_lengths, mesh_depth, ray_box_interval, trilinear
from .volume_shading import ShadeSetup
from .voxels import VoxelHits, id_colors, occlusion_factor, render_voxels, trace_voxels

__all__ = ["ShadeSetup", "VoxelHits", "chord_lengths", "id_colors", "mesh_depth",
           "occlusion_factor",
           "ray_box_interval", "render_emission_absorption", "render_blended",
           "render_voxels", "trace_voxels",
           "trilinear"]
