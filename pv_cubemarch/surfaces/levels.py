"""Several levels of one field (``add_surface(isosurfaces=...)``), and the surface's bar.

Each level is its own surface (the field less the level, exactly: a B-spline of a constant
is that constant), drawn opaque at its real depth, so nested and crossing levels occlude
each other as ``contour`` + ``add_mesh`` draws them; without a ``color`` each takes its
value's colour through ``cmap`` over the levels' range, as PyVista colours a contour by its
scalars.
"""

from __future__ import annotations

import numpy as np
import pyvista

from ..core.options import is_count, level_values, spread_levels
from ..core.scalar_bar import attach_scalar_bar
from ..core.user_warnings import warn_user
from ..gl.handle import DrawnBinding
from ..models.volume import box_world_bounds


def surface_levels(isosurfaces, samples: np.ndarray | None) -> tuple[float, ...]:
    """The levels ``isosurfaces=`` asks for, in the data's units.

    A sequence of values, or a count ``n``: ``n`` levels from the samples' smallest to
    largest value, as :meth:`pyvista.DataSetFilters.contour` spreads them (samples only).
    A level at the samples' smallest value or below is left out where others remain: no
    sample lies below it, so ``contour`` draws nothing there (given as a value, that is
    said); where none remains the first is kept, and the field says what it draws there.
    """
    if is_count(isosurfaces):
        if samples is None:
            raise ValueError("isosurfaces as a count spreads levels over the samples' range; "
                             "this field has no samples (a mesh, a cloud or coefficients): "
                             "give the levels as values.")
        levels = spread_levels(isosurfaces, samples)
    else:
        levels = tuple(float(v) for v in level_values(isosurfaces))
    if samples is None or len(levels) < 2:
        return levels
    lowest = float(np.min(samples))
    kept = tuple(v for v in levels if v > lowest)
    if not np.isfinite(lowest) or not kept:   # NaN samples are refused with the field
        return levels if not np.isfinite(lowest) else levels[:1]
    if not is_count(isosurfaces) and len(kept) < len(levels):
        warn_user(f"isosurfaces {[v for v in levels if v <= lowest]} lie at or below the "
                  f"data's smallest value ({lowest:g}): no sample lies below them, so "
                  "PyVista's contour draws nothing there; they are left out.")
    return kept


def level_lookup_table(cmap, levels, clim=None) -> pyvista.LookupTable:
    """``cmap`` over ``clim`` (by default the levels' range), as PyVista colours a contour.

    A single level's default range is one unit wide around it.
    """
    low, high = (float(min(levels)), float(max(levels))) if clim is None else (
        float(clim[0]), float(clim[1]))
    if high <= low:
        low, high = low - 0.5, low + 0.5
    table = pyvista.LookupTable(cmap)
    table.scalar_range = (low, high)
    return table


class SurfaceLevels(DrawnBinding):
    """Several levels' surfaces, returned as one actor: shown, hidden, moved and freed as one.

    ``levels``: each level's :class:`~pv_cubemarch.surfaces.technique.SurfaceBinding`;
    ``values``: the levels, in the data's units.
    """

    technique = "surface"
    needs_single_sample = True
    follows_mapper_planes = True   # the returned prop's mapper planes cut every level

    def __init__(self, levels: list, values):
        first = levels[0]
        self.look_hint = first.look_hint
        super().__init__(first.model, first.bindings, first.recipe)
        self.levels = list(levels)
        self.values = tuple(float(v) for v in values)
        self.drawn = [actor for level in self.levels for actor in level.drawn]
        self.renderer = first.renderer
        for actor in self.drawn:   # the returned prop spans them: reset_camera frames it
            actor.UseBoundsOff()

    def set_clip_planes(self, clip_planes) -> None:
        """Cut every level by planes, or by none (``None``); shown at the next frame."""
        for level in self.levels:
            level.set_clip_planes(clip_planes)

    def follow_mapper_planes(self, actor) -> None:
        """At each frame: the returned prop's mapper's planes cut every level."""
        for level in self.levels:
            level.follow_mapper_planes(actor)

    def note_look(self, terms: dict) -> None:
        """Every level's options say the terms drawn (its colour is its level's own)."""
        for level in self.levels:
            level.note_look({k: v for k, v in terms.items() if k != "color"})

    def look_bindings(self) -> list:
        """Every level's bindings: a term set on the returned prop shades them all."""
        return [level.bindings for level in self.levels]

    @property
    def surfaces(self) -> list:
        """Each level's binding (what a quality choice or a frame budget sets its steps on)."""
        return self.levels

    @property
    def options(self):
        """The levels' options (theirs differ only in colour)."""
        return self.levels[0].options

    @property
    def nbytes(self) -> int:
        """GPU bytes of every level."""
        return sum(level.nbytes for level in self.levels)

    @property
    def cells(self) -> list:
        """Each level's active cells (None for ``technique='full'``)."""
        return [level.cells for level in self.levels]

    def drawn_frame_bounds(self) -> np.ndarray | None:
        """The levels' boxes' bounds in the field's own frame (None: no level has cells).

        Each level's box spans its active cells; the returned prop spans them all, so
        ``reset_camera`` frames the levels as PyVista frames their contours.
        """
        boxes = [pyvista.wrap(level.drawn[0].GetMapper().GetInput()).bounds
                 for level in self.levels if level.cells is None or len(level.cells)]
        if not boxes:
            return None
        boxes = np.reshape(boxes, (-1, 3, 2))
        return box_world_bounds(self.model.grid_from_index, boxes[:, :, 1].max(axis=0),
                                boxes[:, :, 0].min(axis=0))

    def place(self, transform) -> None:
        """Every level follows (the stand-in the camera resets by: ``set_transform``)."""
        for level in self.levels:
            level.set_transform(transform)

    def release_resources(self) -> None:
        """Every level frees its own (their actors leave the renderer by extra_release)."""
        for level in self.levels:
            level.release()


def add_surface_scalar_bar(plotter, actor, table: pyvista.LookupTable, title: str,
                           show: bool, args: dict | None) -> None:
    """Make ``table`` ``plotter.mapper``'s (for ``add_scalar_bar``); add its bar if ``show``."""
    mapper = pyvista.DataSetMapper()
    mapper.lookup_table = table
    mapper.scalar_range = table.scalar_range
    attach_scalar_bar(plotter, actor, mapper, title, show, args)
