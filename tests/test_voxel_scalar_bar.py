"""A material grid's scalar bar, annotations and translucent materials, as PyVista users ask.

The oracle for the colours is the palette the user gave (each material's block in the bar is
that colour); PyVista's own ``categories=True`` bar shows one block per category the same way.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import pyvista as pv

COLORS = ["black", "tan", "steelblue", "crimson"]


def labels() -> np.ndarray:
    grid = np.zeros((6, 6, 6), np.uint8)
    grid[1:3], grid[3:5], grid[5] = 1, 2, 3
    return grid


def test_scalar_bar_shows_each_material_colour_and_its_annotation():
    """One block per material in its palette colour, and the names given.

    catches (seen failing): the bar's table taken from row 0 (``rgba[:-1]``): every block
    one material off.
    """
    pl = pv.Plotter(off_screen=True)
    pl.cubemarch.add_voxels(labels(), palette=COLORS, show_scalar_bar=True,
                            annotations={1: "bone", 3: "blood"})
    assert len(pl.scalar_bars) == 1
    lut = pl.mapper.lookup_table
    expected = np.array([pv.Color(c).float_rgb for c in COLORS[1:]])
    np.testing.assert_allclose(np.asarray(lut.values)[:, :3] / 255.0, expected, atol=1 / 255)
    named = {lut.GetAnnotatedValue(i).ToDouble(): lut.GetAnnotation(i)
             for i in range(lut.GetNumberOfAnnotatedValues())}   # (PyVista's getter fails)
    assert named == {1.0: "bone", 3.0: "blood"}
    assert tuple(lut.scalar_range) == (1.0, 3.0)
    pl.close()


def test_scalar_bar_afterwards_and_bad_annotations():
    pl = pv.Plotter(off_screen=True)
    pl.cubemarch.add_voxels(labels(), palette=COLORS)
    assert not pl.scalar_bars
    pl.add_scalar_bar()   # PyVista's call reads the grid's table
    assert len(pl.scalar_bars) == 1
    with pytest.raises(ValueError, match=r"labels are 1\.\.3"):
        pl.cubemarch.add_voxels(labels(), palette=COLORS, annotations={7: "none such"})
    pl.close()


def test_translucent_materials_are_said_to_be_drawn_opaque_where_they_are():
    """Not drawn opaque in silence: where a grid cannot composite them (mode='face'), a
    warning names the materials; a single grid, or a world drawn either way, composites
    them and says nothing (tests/test_voxel_translucent.py).

    catches (seen failing): ``warn_translucent`` not called from ``add_voxels``.
    """
    pl = pv.Plotter(off_screen=True)
    palette = {1: "tan", 2: ("steelblue", 0.4), 3: "crimson"}
    with pytest.warns(UserWarning, match=r"labels \[2\].*draws them opaque"):
        pl.cubemarch.add_voxels(labels(), palette=palette, chunk_size=4,
                                world_traversal="per_chunk", mode="face")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        actor = pl.cubemarch.add_voxels(labels(), palette=palette)
        world = pl.cubemarch.add_voxels(labels(), palette=palette, chunk_size=4)
        per_chunk = pl.cubemarch.add_voxels(labels(), palette=palette, chunk_size=4,
                                            world_traversal="per_chunk")
    assert actor.cubemarch.layers is not None and world.cubemarch.layers is not None
    assert any(c.layers is not None for c in per_chunk.cubemarch.chunks.values())
    pl.close()
