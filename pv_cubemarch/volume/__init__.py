"""Emission/absorption volume techniques on the GPU.

The shared marcher's bindings (``march``), VTK's mapper (``vtk_mapper``), the direct
marcher (``direct``), cube-map imposters (``cubemap``), the per-frame choice between them
(``auto``), the light map, and the options each reads. Each technique module registers
itself in the technique registry.
"""
