"""CPU references (numpy only, never GL): what the right image of each technique is.

``rays``: the one slab test, trilinear sampling, mesh depth; ``emission_absorption``: the
volume reference; ``lighting``: transmittance toward lights.
"""

from .emission_absorption import render_emission_absorption
from .rays import chord_lengths, mesh_depth, ray_box_interval, trilinear

__all__ = ["chord_lengths", "mesh_depth", "ray_box_interval", "render_emission_absorption",
           "trilinear"]
