"""Per-label colour, opacity, visibility and highlight, by label id, without re-uploading labels.

Every change writes only the rows of the per-label table it touches (the palette); a single
grid sends only those texels to the GPU (:func:`upload_palette_rows`), so hiding one id of
a million costs a few bytes, and the labels, occupancy levels and distance field stay as
they are.
"""

from __future__ import annotations

import numpy as np
import pyvista

from ..core.rendering import needs_open_plotter
from ..gl.textures import Texture
from ..models.label_ids import sorted_unique
from ..models.voxels import PALETTE_WIDTH, palette_texels
from .scalar_bar import warn_translucent

#: Texels between two changed entries of a palette row below which one upload spans both.
RUN_GAP = 32

#: Uploads per change beyond which the whole palette goes up instead.
MAX_RUNS = 4096


def palette_runs(rows: np.ndarray, width: int = PALETTE_WIDTH,
                 gap: int = RUN_GAP) -> list[tuple[int, int, int]]:
    """Spans of a wrapped palette covering ``rows``: ``(texture row, first, end column)``.

    Entries less than ``gap`` apart in the same texture row share a span.
    """
    rows = sorted_unique(rows)
    if rows.size == 0:
        return []
    line, column = rows // width, rows % width
    breaks = np.flatnonzero((np.diff(line) != 0) | (np.diff(column) > gap)) + 1
    starts = np.concatenate([[0], breaks])
    ends = np.concatenate([breaks, [rows.size]]) - 1
    return [(int(line[s]), int(column[s]), int(column[e]) + 1)
            for s, e in zip(starts, ends, strict=True)]


def upload_palette_rows(texture: Texture, rgba: np.ndarray, rows: np.ndarray | None) -> None:
    """Send the palette entries ``rows`` of ``rgba`` (all of them for ``None``) to ``texture``.

    Each span of :func:`palette_runs` goes up as one region; where the spans are many or
    cover most of the table, or the table's shape changed, the whole table goes.
    """
    width = texture.array.shape[1] if texture.array is not None else None
    runs = palette_runs(rows, width) if rows is not None and width else None
    whole = (runs is None or len(runs) > MAX_RUNS
             or texture.array.shape[0] * width < len(rgba)
             or 2 * sum(end - first for _, first, end in runs) > len(rgba))
    if whole:
        texture.set_data(palette_texels(rgba))
        return
    table = np.asarray(rgba, dtype=np.float32)
    for line, first, end in runs:
        start = line * width
        texture.update_region((line, first), table[start + first:start + end][None])


def label_colours(color, count: int, labels) -> tuple[np.ndarray | None, np.ndarray | None]:
    """``color`` for ``count`` ids as ``(count, 3)`` RGB in [0, 1], and opacities if given.

    One colour (a name, hex, 0-1 floats or 0-255 ints, RGB or RGBA) for all, or one per id:
    a list of colours or an ``(n, 3|4)`` array (floats in [0, 1] or integers 0-255).
    """
    if color is None:
        return None, None
    try:
        one = pyvista.Color(color)
    except (ValueError, TypeError):
        one = None
    if one is not None:
        rgb = np.tile(np.asarray(one.float_rgb, np.float64), (count, 1))
        alpha = None if not _has_alpha(color) else np.full(count, one.float_rgba[3])
        return rgb, alpha
    if isinstance(color, np.ndarray) and color.ndim == 2 and color.shape[1] in (3, 4):
        array = color.astype(np.float64) / (255.0 if color.dtype.kind in "iu" else 1.0)
        if len(array) != count or not np.isfinite(array).all() or array.min() < 0 \
                or array.max() > 1:
            raise ValueError(f"color: an array gives one colour per label ({count} here), "
                             "RGB or RGBA, floats in [0, 1] or integers 0-255; got shape "
                             f"{color.shape} with values {array.min():g}..{array.max():g}.")
        return array[:, :3], (array[:, 3] if array.shape[1] == 4 else None)
    if isinstance(color, (list, tuple)) and len(color) == count:
        try:
            each = [pyvista.Color(c) for c in color]
        except (ValueError, TypeError) as error:
            raise ValueError(f"color: {error}") from None
        return np.array([c.float_rgb for c in each]), None
    raise ValueError(f"color {color!r} for labels {_shown(labels)} is not a colour: give a "
                     "name ('tomato'), a hex string ('#ff6347'), RGB in [0, 1] or 0-255, or "
                     f"one colour per label ({count} here).")


def _has_alpha(color) -> bool:
    if isinstance(color, str):
        return color.startswith("#") and len(color) == 9
    return hasattr(color, "__len__") and len(color) == 4


def _shown(labels) -> str:
    values = np.atleast_1d(np.asarray(labels, dtype=object)).ravel().tolist()
    return str(values[:5])[:-1] + (", ...]" if len(values) > 5 else "]")


class LabelState:
    """Per-label methods of a grid's binding, by label id (what the user's array holds).

    A grid of compacted ids knows exactly the ids present; a grid of small ids kept as rows
    (0..65535, background 0) knows every row of its palette, so there ``label_ids`` lists
    1..n-1 and an id the palette covers but the grid lacks is accepted. Hiding is its own
    state (``hidden_labels``, undone by ``show_labels``); an id at opacity 0 (left out of a
    dict palette, or ``set_label_color(id, opacity=0)``) is not drawn either, and comes back
    with an opacity above 0. The binding gives ``model`` (its ``palette`` and ``ids``) and
    ``follow_palette_rows``, which sends the changed rows to the GPU.
    """

    #: Why this binding draws translucent labels opaque (``None``: it composites them).
    opaque_because: str | None = None
    _said_opaque = False

    def say_drawn_opaque(self) -> None:
        """Warn when labels turn translucent where this binding draws them opaque.

        Once, until none is translucent again: at ``add_voxels`` and at any later change.
        """
        if self.opaque_because is None:
            return
        alpha = np.asarray(self.model.palette.rgba)[1:, 3]
        some = bool(((alpha > 0) & (alpha < 1)).any())
        if some and not self._said_opaque:
            warn_translucent(self.model.palette, self.model.name, self.opaque_because,
                             self.model.ids)
        self._said_opaque = some

    @property
    def label_ids(self) -> np.ndarray:
        """The grid's label ids other than the background, one per row of its tables."""
        return self.model.ids.ids

    @property
    def n_labels(self) -> int:
        """How many label ids (other than the background) the grid's tables hold.

        A compacted grid's: the ids present; labels kept as rows: the palette's entries.
        """
        return int(self.model.n_labels)

    def material_row(self, material) -> int:
        """The palette row of label id ``material`` (the id itself unless compacted)."""
        if self.model.ids.identity:
            return material
        return int(self._rows(material, "material")[0])

    def _rows(self, labels, name: str = "labels") -> np.ndarray:
        rows = self.model.ids.rows_of(labels, name)
        if (rows == 0).any():
            raise ValueError(f"{name}: the background ({self.model.ids.background}) is never "
                             "drawn; give label ids other than it.")
        if rows.size and rows.max() >= self.model.palette.n_materials:
            raise ValueError(f"{name}: label {self.model.ids.id_of(rows.max())} has no entry "
                             "in the palette.")
        return rows

    @needs_open_plotter
    def set_label_color(self, labels, color=None, opacity=None) -> None:
        """Change the colour and/or opacity of one label id or many (0 hides).

        ``color``: one colour (a name, hex, RGB or RGBA) for all, or one per id (a list of
        colours, an ``(n, 3|4)`` array of floats in [0, 1] or integers 0-255; an alpha
        column sets the opacity); ``opacity``: one value or one per id. Only the changed
        entries of the per-label table go to the GPU.

        Examples
        --------
        >>> actor.cubemarch.set_label_color([17, 2**40 + 3], "red")        # doctest: +SKIP
        >>> actor.cubemarch.set_label_color(ids, opacity=0.3)              # doctest: +SKIP
        """
        rows = self._rows(labels)
        rgb, alpha = label_colours(color, rows.size, labels)
        opacity = alpha if opacity is None else opacity   # checked by the palette
        self.model.palette.set_rows(rows, rgb, opacity)
        self.follow_palette_rows()

    @needs_open_plotter
    def hide_labels(self, labels) -> None:
        """Hide label ids (drawn as empty); their colour and opacity are kept."""
        self.model.palette.set_hidden(self._rows(labels), True)
        self.follow_palette_rows()

    @needs_open_plotter
    def show_labels(self, labels=None) -> None:
        """Show hidden label ids again (every hidden one for ``None``)."""
        palette = self.model.palette
        rows = np.flatnonzero(palette.hidden) if labels is None else self._rows(labels)
        palette.set_hidden(rows, False)
        self.follow_palette_rows()

    @needs_open_plotter
    def show_selected_labels(self, labels) -> None:
        """Show only these label ids, every other one hidden (``show_labels()`` undoes it).

        Only the entries whose visibility changes go to the GPU.
        """
        palette = self.model.palette
        hide = np.ones(palette.n_materials, bool)
        hide[self._rows(labels)] = False
        hide[0] = False
        changed = np.flatnonzero(hide != palette.hidden)
        palette.set_hidden(changed[hide[changed]], True)
        palette.set_hidden(changed[~hide[changed]], False)
        self.follow_palette_rows()

    @needs_open_plotter
    def highlight_labels(self, labels, color="white") -> None:
        """Draw label ids in ``color`` (white) until :meth:`clear_highlight`."""
        self.model.palette.set_highlighted(self._rows(labels), True, color)
        self.follow_palette_rows()

    @needs_open_plotter
    def clear_highlight(self, labels=None) -> None:
        """Draw highlighted label ids (all of them for ``None``) in their own colour again."""
        palette = self.model.palette
        rows = np.flatnonzero(palette.highlighted) if labels is None else self._rows(labels)
        palette.set_highlighted(rows, False)
        self.follow_palette_rows()

    @property
    def hidden_labels(self) -> np.ndarray:
        """The label ids hidden by :meth:`hide_labels` or :meth:`show_selected_labels`."""
        return self.model.ids.ids_of(np.flatnonzero(self.model.palette.hidden))
