"""Cube-map imposter marching: the formulas (``lod``) and the passes (``technique``)."""
