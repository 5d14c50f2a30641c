"""Stages of many prims: load and first-frame time against PyVista's one ``add_mesh`` per mesh.

``pv-cubemarch bench scene-prims``: a USD stage of N ``Cube`` prims (a grid of cubes in
two colours) is written to a temporary folder, loaded with :func:`load_scene` and drawn
once (our path: parts that draw alike merged into few actors); beside it, the same loaded
meshes added one by one with ``plotter.add_mesh(mesh, color=..., name=...)``, as a PyVista
user would (each add looks its name up among all actors: quadratic, so only up to
``pyvista_max`` prims).
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from ..core.rendering import offscreen_plotter, render_frame
from ..scene.io import load_scene

#: The colours of the cubes, alternating.
COLORS = ((0.9, 0.3, 0.2), (0.2, 0.4, 0.9))


@dataclass
class PrimsRow:
    """One path at one prim count: seconds to load, to add and draw a first frame."""

    path: str
    prims: int
    load_s: float
    first_frame_s: float
    actors: int


def cube_stage(count: int, path: Path) -> Path:
    """Write a stage of ``count`` cubes of side 0.5 on a grid, in two colours."""
    from pxr import Gf, Usd, UsdGeom

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.Xform.Define(stage, "/World")
    side = max(int(round(count ** (1 / 3))) + 1, 1)
    for i in range(count):
        cube = UsdGeom.Cube.Define(stage, f"/World/C{i}")
        cube.CreateSizeAttr(0.5)
        cube.CreateDisplayColorAttr([COLORS[i % 2]])
        cube.AddTranslateOp().Set(Gf.Vec3d(i % side, (i // side) % side, i // side ** 2))
    stage.GetRootLayer().Save()
    return path


def run_prims(counts, pyvista_max: int = 4000, size=(320, 240)) -> list[PrimsRow]:
    """Time our path at each count, and PyVista's per-mesh path up to ``pyvista_max``."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="cubemarch_prims") as folder:
        for count in counts:
            path = cube_stage(int(count), Path(folder) / f"cubes_{count}.usda")
            start = time.perf_counter()
            scene = load_scene(path, progress_bar=False)
            loaded = time.perf_counter()
            plotter = offscreen_plotter(size)
            try:
                actors = scene.add_to(plotter, progress_bar=False)
                render_frame(plotter)
                drawn = time.perf_counter()
                rows.append(PrimsRow("pv_cubemarch load_scene + add_to", int(count),
                                     loaded - start, drawn - loaded,
                                     len({id(a) for a in actors.values()})))
            finally:
                plotter.close()
            if count <= pyvista_max:
                rows.append(_pyvista_row(scene, int(count), loaded - start, size))
    return rows


def _pyvista_row(scene, count: int, load_s: float, size) -> PrimsRow:
    """The same meshes, one ``add_mesh`` each (named, as a scene's prims are)."""
    plotter = offscreen_plotter(size)
    try:
        start = time.perf_counter()
        for part in scene.meshes:
            plotter.add_mesh(part.mesh, color=part.color, name=part.name,
                             smooth_shading=True, split_sharp_edges=True)
        render_frame(plotter)
        return PrimsRow("PyVista add_mesh per prim", count, load_s,
                        time.perf_counter() - start, len(plotter.renderer.actors))
    finally:
        plotter.close()


def format_prims(rows: list[PrimsRow]) -> str:
    """The table, one row per path and count."""
    lines = [f"{'path':<36}{'prims':>8}{'load s':>9}{'first frame s':>15}{'actors':>8}"]
    for r in rows:
        lines.append(f"{r.path:<36}{r.prims:>8}{r.load_s:>9.2f}{r.first_frame_s:>15.2f}"
                     f"{r.actors:>8}")
    return "\n".join(lines)
