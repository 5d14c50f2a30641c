"""
Time against error: the trade-off benchmark
===========================================

``pv-cubemarch bench tradeoff`` sweeps each technique's quality settings on a scene, times
real frames side by side, and measures each image against the CPU reference; PyVista's
stock ``add_volume`` with the same transfer function is a row of the same run. Here it
runs small (320x240, three frames a row) on the shipped smoke scene, from Python. The
rows marked on the Pareto front are those no other row beats on both time and error.
The docs' full tables: :doc:`/speed_accuracy`.
"""

from pathlib import Path

import matplotlib.pyplot as plt

import pv_cubemarch
from pv_cubemarch.bench.harness import format_table, run_tradeoff

DATA = Path(pv_cubemarch.__file__).resolve().parents[1] / "datasets"   # in the clone
scene = pv_cubemarch.load_scene(DATA / "smoke_scene.usda")
rows = run_tradeoff(["direct", "cubemap", "pyvista"], scene, size=(320, 240), frames=3,
                    progress_bar=False)
print(format_table(rows))

# %%
# Error (root-mean-square, in 8-bit levels) against frame time; the Pareto front joined.
fig, ax = plt.subplots(figsize=(6.4, 4.2))
for technique in dict.fromkeys(r.technique for r in rows):
    mine = [r for r in rows if r.technique == technique]
    ax.scatter([r.median_ms for r in mine],
               [255 * 10 ** (-r.errors["psnr"] / 20) for r in mine], label=technique)
front = sorted((r for r in rows if r.pareto), key=lambda r: r.median_ms)
ax.plot([r.median_ms for r in front], [255 * 10 ** (-r.errors["psnr"] / 20) for r in front],
        "k--", linewidth=0.8, label="Pareto front")
ax.set_xlabel("median frame time (ms, this machine)")
ax.set_ylabel("RMS error against the CPU reference (8-bit levels)")
ax.set_yscale("log")
ax.legend()
fig.tight_layout()
plt.show()
