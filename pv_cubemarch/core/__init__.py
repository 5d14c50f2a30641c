"""What every part of pv_cubemarch stands on; imports nothing from the other subpackages.

Errors, offscreen windows, the camera, drawing frames, progress bars, shader-error
reporting and the technique registry.
"""
