"""What the techniques draw, as data (numpy and PyVista's data objects, no GL).

Volumes and their transfer functions, groups of overlapping volumes, lights. The CPU
references and the GPU techniques both read these.
"""
