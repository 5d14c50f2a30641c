"""A scalar bar lives as long as what it colours, as PyVista's does, in Python and the live view.

The oracle is PyVista itself, in the same run: ``add_volume(show_scalar_bar=True)`` then
``remove_actor`` takes the bar away; two actors under one title share the bar until the
last leaves.
"""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv

from pv_cubemarch.core.rendering import render_image
from pv_cubemarch.views.session import TuningSession

VALUES = np.linspace(0.0, 800.0, 12 ** 3, dtype=np.float32).reshape(12, 12, 12)


def _field() -> np.ndarray:
    x, y, z = np.mgrid[-1:1:12j, -1:1:12j, -1:1:12j]
    return x ** 2 + y ** 2 + z ** 2


def _labels() -> np.ndarray:
    labels = np.zeros((8, 8, 8), np.uint8)
    labels[2:6, 2:6, 2:6] = 1
    labels[3:5, 3:5, 6:] = 2
    return labels


ADDERS = {
    "pyvista add_volume": lambda pl, **kw: pl.add_volume(pv.wrap(VALUES), **kw),
    "volume vtk": lambda pl, **kw: pl.cubemarch.add_volume(VALUES, technique="vtk", **kw),
    "volume direct": lambda pl, **kw: pl.cubemarch.add_volume(VALUES, technique="direct",
                                                              **kw),
    "voxels": lambda pl, **kw: pl.cubemarch.add_voxels(_labels(), **kw),
    "voxel world": lambda pl, **kw: pl.cubemarch.add_voxels(_labels(), chunk_size=4, **kw),
    "surface": lambda pl, **kw: pl.cubemarch.add_surface(_field(), 0.5, color_by="curvature",
                                                         **kw),
}


def _plotter() -> pv.Plotter:
    return pv.Plotter(off_screen=True, window_size=(120, 90))


@pytest.mark.parametrize("kind", list(ADDERS))
def test_removing_the_actor_takes_its_scalar_bar_as_pyvista_does(kind):
    """The bar and its actor leave the renderer with the item, whichever technique drew it.

    catches (seen failing): ``release_removed`` not dropping the followed mapper: the bar
    stays on screen after ``remove_actor`` (every kind but PyVista's own row).
    """
    pl = _plotter()
    actor = ADDERS[kind](pl, show_scalar_bar=True, scalar_bar_args={"title": "t"},
                         name="item")
    render_image(pl)
    bar = pl.scalar_bars["t"]
    assert pl.renderer.HasViewProp(bar)
    pl.remove_actor(actor)
    render_image(pl)      # ours leave at the next frame (or at once by cubemarch.remove)
    assert "t" not in pl.scalar_bars
    assert not pl.renderer.HasViewProp(bar)
    pl.close()


@pytest.mark.parametrize("kind", ["pyvista add_volume", "volume direct", "voxels"])
def test_a_shared_title_keeps_its_bar_until_the_last_actor_leaves(kind):
    """Two items under one title share one bar; it goes with the second, not the first.

    catches (seen failing): dropping by title (``remove_scalar_bar(title)``) instead of by
    mapper: the bar goes with the first actor while the second still shows its colours.
    """
    pl = _plotter()
    first = ADDERS[kind](pl, show_scalar_bar=True, scalar_bar_args={"title": "t"}, name="a")
    second = ADDERS[kind](pl, show_scalar_bar=True, scalar_bar_args={"title": "t"}, name="b")
    render_image(pl)
    pl.remove_actor(first)
    render_image(pl)
    assert "t" in pl.scalar_bars
    pl.remove_actor(second)
    render_image(pl)
    assert "t" not in pl.scalar_bars
    pl.close()


def test_the_live_view_switch_shows_and_hides_the_bar_and_keeps_its_keywords():
    """The ``show_scalar_bar`` knob adds and takes away the bar; a bar added in Python keeps
    its title through any other knob's change.

    catches (seen failing): the adopted item's bar keywords not read back
    (``scalar_bar_keywords``): turning the cmap knob took the user's bar away.
    """
    pl = _plotter()
    pl.cubemarch.add_volume(VALUES, technique="direct", show_scalar_bar=True,
                            scalar_bar_args={"title": "density"}, name="v")
    render_image(pl)
    session = TuningSession.from_plotter(pl)
    assert "show_scalar_bar" in [knob.name for knob in session.knobs("volume")]
    assert session.value("volume", "show_scalar_bar") is True
    session.set("volume", "cmap", "magma")
    assert list(pl.scalar_bars.keys()) == ["density"]
    session.set("volume", "show_scalar_bar", False)
    assert list(pl.scalar_bars.keys()) == []
    session.set("volume", "show_scalar_bar", True)
    assert len(pl.scalar_bars) == 1
    pl.close()
