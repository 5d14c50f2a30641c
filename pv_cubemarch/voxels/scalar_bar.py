"""The scalar bar of a material grid: one colour block per material, as PyVista's categories.

``add_voxels(show_scalar_bar=True, annotations={1: "bone"})`` shows it; either way the
plotter's ``mapper`` holds its lookup table, so ``plotter.add_scalar_bar()`` afterwards
shows the materials' colours too.
"""

from __future__ import annotations

import warnings

import numpy as np
import pyvista

from ..core.scalar_bar import attach_scalar_bar


def palette_lookup_table(palette) -> pyvista.LookupTable:
    """Materials ``1..n-1`` as ``n-1`` colours over the range ``(1, n-1)``, opaque."""
    rgba = np.asarray(palette.rgba, dtype=np.float64)[1:]
    lut = pyvista.LookupTable()
    values = np.ones((max(len(rgba), 1), 4))
    values[:len(rgba), :3] = rgba[:, :3]
    lut.values = values * 255.0
    lut.scalar_range = (1.0, float(max(len(rgba), 2)))
    return lut


def add_voxel_scalar_bar(plotter, actor, palette, title: str, show: bool, args: dict | None,
                         annotations: dict | None) -> None:
    """Make the grid's lookup table ``plotter.mapper``'s and add its bar when ``show``."""
    mapper = pyvista.DataSetMapper()
    mapper.lookup_table = palette_lookup_table(palette)
    if annotations:
        unknown = [key for key in annotations if not 0 < int(key) < len(palette.rgba)]
        if unknown:
            raise ValueError(f"annotations name materials {unknown} the grid has no colour "
                             f"for (its materials are 1..{len(palette.rgba) - 1}).")
        mapper.lookup_table.annotations = {float(k): str(v) for k, v in annotations.items()}
    attach_scalar_bar(plotter, actor, mapper, title, show, args,
                      n_labels=min(len(palette.rgba) - 1, 10))


def warn_translucent(palette, name: str, why: str) -> None:
    """Say so when translucent materials are drawn opaque (``why``: what draws them so)."""
    alpha = np.asarray(palette.rgba)[1:, 3]
    translucent = np.nonzero((alpha > 0) & (alpha < 1))[0] + 1
    if translucent.size:
        warnings.warn(f"Voxels {name!r}: materials {translucent.tolist()[:8]} have an "
                      f"opacity between 0 and 1; {why} draws them opaque (a single grid in "
                      "mode='color' composites them; opacity 0 hides one).", stacklevel=3)
