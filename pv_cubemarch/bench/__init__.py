"""The speed/accuracy instrument: frame time against error versus the CPU reference.

Rows measured side by side in one run (``harness``), and the cube map against viewport
resolution (``resolution``).
"""
