"""GLSL snippets of pv_cubemarch (shipped inside the wheel), one folder per technique.

``common/``: shared by every technique (pass header, box vertex, screen rays, slab test);
``volume/``: emission/absorption marching; ``cubemap/``: the cube-map imposter passes.
Snippets are found by name (:func:`pv_cubemarch.gl.shaders.snippet_source`); names are unique.
"""
