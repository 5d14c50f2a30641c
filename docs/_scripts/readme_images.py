"""Render the README's three pictures (one per technique) into docs/images/.

Run after a change that alters how they look: ``.venv/bin/python docs/_scripts/readme_images.py``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyvista as pv
from PIL import Image
from pyvista import examples

import pv_cubemarch

OUT = Path(__file__).resolve().parents[1] / "images"
SIZE = (360, 270)


def volume() -> np.ndarray:
    """The shipped smoke plume with its torus: emission/absorption beside a mesh."""
    scene = pv_cubemarch.load_scene(Path(__file__).resolve().parents[2] / "datasets"
                                    / "smoke_scene.usda")
    return scene.render(size=SIZE)


def labels() -> np.ndarray:
    """PyVista's frog tissue segmentation, its largest label hidden."""
    pl = pv_cubemarch.offscreen_plotter(SIZE)
    pl.set_background("white")
    frog = examples.load_frog_tissues()
    ids, counts = np.unique(frog["MetaImage"], return_counts=True)
    actor = pv_cubemarch.add_voxels(pl, frog, cmap="turbo", categories=True,
                                    ambient_occlusion=True)
    actor.cubemarch.set_material(int(ids[1:][np.argmax(counts[1:])]), opacity=0.0)
    pl.camera_position = "yx"
    pl.camera.Elevation(-35)
    pl.reset_camera()
    pl.camera.zoom(1.3)
    return pv_cubemarch.render_image(pl)


def surface() -> np.ndarray:
    """PyVista's nut mesh as the zero set of its signed-distance spline field."""
    pl = pv_cubemarch.offscreen_plotter(SIZE)
    pl.set_background("white")
    nut = pv.read(Path(examples.__file__).parent / "nut.ply")
    pv_cubemarch.add_surface(pl, nut, cells=48, color_by="curvature", cmap="coolwarm")
    pl.view_isometric()
    return pv_cubemarch.render_image(pl)


if __name__ == "__main__":
    OUT.mkdir(exist_ok=True)
    for name, draw in [("volume", volume), ("labels", labels), ("surface", surface)]:
        Image.fromarray(draw()[..., :3]).save(OUT / f"readme_{name}.png", optimize=True)
        print("wrote", OUT / f"readme_{name}.png")
