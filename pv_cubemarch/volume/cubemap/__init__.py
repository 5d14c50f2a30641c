"""Cube-map imposter marching (000): the formulas (``lod``) and the passes (``technique``)."""
