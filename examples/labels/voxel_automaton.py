"""
A 3D cellular automaton, uploading only what changed
====================================================

Survival/birth/states/neighbourhood rules (``"4/4/5/M"``, or a preset: 445, clouds,
pyroclastic, amoeba, builder, crystal) stepped in numpy by
``pv_cubemarch.models.automaton.VoxelAutomaton``; after each step
``actor.cubemarch.set_block`` sends only the changed box to the GPU and the frame is drawn.
Cells are coloured by state (alive bright, dying darker); the first and the last frame are
shown side by side.
"""

import sys
import time

import matplotlib.pyplot as plt
import numpy as np

import pv_cubemarch
from pv_cubemarch.models.automaton import VoxelAutomaton


def option(name: str, default: str) -> str:
    """The value after ``--name`` on the command line, or ``default``."""
    return sys.argv[sys.argv.index(name) + 1] if name in sys.argv else default


automaton = VoxelAutomaton((64, 64, 64), rule=option("--rule", "pyroclastic"), seed=2)
states = automaton.rule.states
palette = np.array([[0.0, 0.0, 0.0]] + [[0.25 + 0.75 * s / (states - 1), 0.35 * s / states,
                                          0.9 - 0.6 * s / (states - 1)]
                                         for s in range(1, states)])
pl = pv_cubemarch.offscreen_plotter((600, 600))
pl.set_background("white")
actor = pv_cubemarch.add_voxels(pl, automaton.labels("state"), palette=palette,
                                ambient_occlusion=True)
pl.camera_position = [(150, -90, 120), (32, 32, 32), (0, 0, 1)]
pl.renderer.ResetCameraClippingRange()
first = pv_cubemarch.render_image(pl)
start, steps = time.perf_counter(), int(option("--steps", "20"))
for _ in range(steps):
    box = automaton.step()
    if box is not None:
        actor.cubemarch.set_block(box, automaton.state[box])
    last = pv_cubemarch.render_image(pl)
elapsed = time.perf_counter() - start
pl.close()
plt.imshow(np.concatenate([first, last], axis=1))
plt.axis("off")
plt.title("the first and the last step")
plt.show()
print(f"{steps} steps of {option('--rule', 'pyroclastic')} at 64^3, "
      f"{1e3 * elapsed / steps:.0f} ms per step + upload + frame, "
      f"{int((automaton.state > 0).sum()):,} cells alive or dying")
