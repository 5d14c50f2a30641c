"""GLSL snippets of pv_cubemarch, loaded by pv_cubemarch.shaders (shipped inside the wheel)."""
