"""Voxel DDA blocks: material grids drawn exactly by Amanatides & Woo traversal.

``options`` (what the user sets), ``technique`` (the box actor, its bindings and the per-grid
state behind ``actor.cubemarch``; registers itself as kind ``'voxels'``).
"""
