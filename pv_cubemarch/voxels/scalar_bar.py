"""The scalar bar of a material grid: a block per material present, or its colormap's table.

``add_voxels(show_scalar_bar=True, annotations={1: "bone"})`` shows it; either way the
plotter's ``mapper`` holds its lookup table, so ``plotter.add_scalar_bar()`` afterwards
shows the materials' colours too.
"""

from __future__ import annotations

import warnings

import numpy as np
import pyvista

from ..core.scalar_bar import attach_scalar_bar


def palette_lookup_table(palette, rows=None) -> pyvista.LookupTable:
    """Materials ``1..n-1`` (or ``rows``) as that many colours over ``(1, count)``, opaque."""
    rgba = np.asarray(palette.rgba, dtype=np.float64)[1:] if rows is None else \
        np.asarray(palette.rgba, dtype=np.float64)[np.asarray(rows, dtype=np.int64)]
    lut = pyvista.LookupTable()
    values = np.ones((max(len(rgba), 1), 4))
    values[:len(rgba), :3] = rgba[:, :3]
    lut.values = values * 255.0
    lut.scalar_range = (1.0, float(max(len(rgba), 2)))
    return lut


#: Compacted ids a scalar bar names one by one (its blocks are rows, not the ids' values).
NAMED_IDS = 32


def _present_lookup_table(palette, present, annotations=None) -> pyvista.LookupTable:
    """One block per present id (its row's colour), named by id.

    Up to :data:`NAMED_IDS` ids are named, or ``annotations`` name them (by id; an id not
    present has no block to name).
    """
    lut = palette_lookup_table(palette, present)
    block = {int(i): k for k, i in enumerate(present, start=1)}
    if annotations:
        lut.annotations = {float(block[int(i)]): str(v) for i, v in annotations.items()
                           if int(i) in block}
    elif len(present) <= NAMED_IDS:
        lut.annotations = {float(k): str(i) for i, k in block.items()}
    return lut


def add_voxel_scalar_bar(plotter, actor, palette, title: str, show: bool, args: dict | None,
                         annotations: dict | None, ids=None, present=None) -> None:
    """Make the grid's lookup table ``plotter.mapper``'s and add its bar when ``show``.

    ``ids``: the grid's :class:`~pv_cubemarch.models.label_ids.LabelIds`. Compacted ids
    are blocks by row, so the bar names them (up to :data:`NAMED_IDS`) instead of
    numbering its blocks; ``annotations`` are by id either way. Labels coloured through a
    colormap (``cmap``, ``categories``) show that colormap's table over its range, as
    ``add_mesh`` does; ids kept as rows of which ``present`` (ascending) are fewer than
    the rows show one block each, as compacted ids do (ids 1000, 2000 and 3000 showed 3000
    blocks, 2997 of them black).
    """
    mapper = pyvista.DataSetMapper()
    compacted = ids is not None and not ids.identity
    if annotations and not compacted:
        unknown = [key for key in annotations if not 0 < int(key) < len(palette.rgba)]
        if unknown:
            raise ValueError(f"annotations name labels {unknown} the grid has no colour for "
                             f"(its labels are 1..{len(palette.rgba) - 1}).")
    if palette.lookup_table is not None:   # by id value, as add_mesh(annotations=) puts them
        mapper.lookup_table = pyvista.LookupTable()
        mapper.lookup_table.DeepCopy(palette.lookup_table)   # annotations on this bar's own
        if annotations:
            mapper.lookup_table.annotations = {float(k): str(v) for k, v in
                                               annotations.items()}
        attach_scalar_bar(plotter, actor, mapper, title, show, args)
        return
    if (not compacted and present is not None and 0 < len(present) < len(palette.rgba) - 1):
        mapper.lookup_table = _present_lookup_table(palette, present, annotations)
        attach_scalar_bar(plotter, actor, mapper, title, show, args, n_labels=0)
        return
    mapper.lookup_table = palette_lookup_table(palette)
    if annotations:
        if compacted:
            known = ids.has(list(annotations))
            unknown = [key for key, ok in zip(annotations, known, strict=True) if not ok]
            if unknown:
                raise ValueError(f"annotations name labels {unknown} the grid has no colour "
                                 "for (actor.cubemarch.label_ids lists its ids).")
        rows = ids.rows_of(list(annotations)) if compacted else list(annotations)
        mapper.lookup_table.annotations = {float(r): str(v) for r, v in
                                           zip(rows, annotations.values(), strict=True)}
    elif compacted and ids.n_labels <= NAMED_IDS:
        mapper.lookup_table.annotations = {float(r): str(i) for r, i in
                                           enumerate(ids.ids.tolist(), start=1)}
    attach_scalar_bar(plotter, actor, mapper, title, show, args,
                      n_labels=0 if compacted else min(len(palette.rgba) - 1, 10))


def warn_translucent(palette, name: str, why: str, ids=None) -> None:
    """Say so when translucent labels are drawn opaque (``why``: what draws them so)."""
    alpha = np.asarray(palette.rgba)[1:, 3]
    translucent = np.nonzero((alpha > 0) & (alpha < 1))[0] + 1
    if translucent.size:
        named = translucent if ids is None else ids.ids_of(translucent[:8])
        warnings.warn(f"Voxels {name!r}: labels {[int(v) for v in named[:8]]} have an "
                      f"opacity between 0 and 1; {why} draws them opaque (a grid or world in "
                      "mode='color', without lod, composites them; opacity 0 hides one).",
                      stacklevel=3)
