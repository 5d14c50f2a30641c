"""Render the shipped USD scene (smoke, torus, ground, camera, lights) to a PNG.

Run: python examples/render_usd_scene.py [out.png]
"""

import sys
from pathlib import Path

import pv_cubemarch

HERE = Path(__file__).resolve().parent
out = sys.argv[1] if len(sys.argv) > 1 else "smoke_scene.png"

scene = pv_cubemarch.load_scene(HERE.parent / "datasets" / "smoke_scene.usda")
print(scene.summary())
scene.render(out, size=(800, 600))
print("wrote", out)
