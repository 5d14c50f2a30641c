"""What PyVista users set on the property of the actor ``add_surface`` / ``add_voxels`` return.

The terms our shaders read (a surface's colour; the lit shading's ``ambient``,
``specular``, ``specular_power``) read back as drawn and are drawn when set; the oracle is
the CPU references given the new terms (they import nothing of the renderer). Terms not
drawn (opacity, a grid's colour, edges, lighting) are said once; a wireframe or points
representation, which would cut the marched box into lines, is set back and said.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import pyvista as pv
from conftest import headlit_plotter

import pv_cubemarch as cm
from pv_cubemarch.core.rendering import read_pixels, render_frame
from pv_cubemarch.image_metrics import compare_images
from pv_cubemarch.reference.surfaces import render_surface
from pv_cubemarch.reference.voxels import render_voxels

SIZE = (160, 120)
TERMS = dict(ambient=0.45, diffuse=0.6, specular=0.8, specular_power=12.0)


def ball() -> np.ndarray:
    x, y, z = np.meshgrid(*(np.linspace(-1.0, 1.0, 20),) * 3, indexing="ij")
    return 0.6 - np.sqrt(x * x + 1.3 * y * y + z * z)


def labelled() -> pv.ImageData:
    rng = np.random.default_rng(4)
    ids = np.where(rng.random((14, 10, 8)) < 0.35, rng.choice([3, 9], (14, 10, 8)), 0)
    grid = pv.ImageData(dimensions=(15, 11, 9), spacing=(0.6, 0.8, 1.1), origin=(-30, 5, 2))
    grid.cell_data["ids"] = ids.astype(np.uint8).ravel(order="F")
    return grid


def _lights(plotter):
    return [cm.VolumeLight.from_pyvista(light, plotter.camera)
            for light in plotter.renderer.GetLights()]


def test_a_surface_s_colour_and_shading_set_after_adding_are_drawn():
    """``actor.prop.color``, ``ambient``, ``specular``, ``specular_power`` set after the
    first frame: the reference's image with those terms; they read back as given at add.

    catches (seen failing): the terms not followed (``ReturnedLook.follow`` leaving the
    uniforms): 20.2 dB; the colour read with VTK's ``GetColor`` (which mixes in the
    ambient and specular colours): the colour said as not drawn.
    """
    plotter = headlit_plotter(SIZE)
    actor = cm.add_surface(plotter, ball(), isovalue=0.0, color="tan", shading="blinn", steps=200,
                           refine_steps=30)
    plotter.view_isometric()
    render_frame(plotter)
    assert actor.prop.color == pv.Color("tan")
    assert actor.prop.ambient == pytest.approx(0.2) and actor.prop.specular_power == 30.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")   # each is drawn: nothing said
        actor.prop.color = "steelblue"
        for name, value in TERMS.items():
            setattr(actor.prop, name, value)
        render_frame(plotter)
    camera = cm.Camera.from_pyvista(plotter.camera)
    field = actor.cubemarch.model
    expected = render_surface(field, camera, SIZE, color=pv.Color("steelblue").float_rgb,
                              background=plotter.background_color.float_rgb,
                              near=plotter.camera.clipping_range[0],
                              lights=_lights(plotter), shading="blinn", **TERMS)
    assert compare_images(read_pixels(plotter), expected).psnr >= 40.0
    plotter.close()


@pytest.mark.parametrize("chunks", [{}, {"chunk_size": 4, "world_traversal": "per_chunk"}],
                         ids=["grid", "world-per-chunk"])
def test_a_grid_s_shading_set_after_adding_is_drawn(chunks):
    """A labelled grid's ``ambient``, ``specular``, ``specular_power`` set after the first
    frame, and a world's drawn chunk by chunk: the voxel reference's image with them.

    catches (seen failing): not followed: 29.8 dB (the world's: only its passes' bindings
    looked at, found by a review: every term said not drawn); the colour read with VTK's
    ``GetColor`` (its ambient colour differs: a change of ``ambient`` said as one of the
    colour).
    """
    plotter = headlit_plotter(SIZE)
    grid = labelled()
    actor = cm.add_voxels(plotter, grid, shading="blinn", **chunks)
    plotter.view_isometric()
    render_frame(plotter)
    assert actor.prop.ambient == pytest.approx(0.2)   # reads what is drawn
    with warnings.catch_warnings():
        warnings.simplefilter("error")   # each is drawn: nothing said
        for name, value in TERMS.items():
            setattr(actor.prop, name, value)
        render_frame(plotter)
    model = cm.add_voxels(pv.Plotter(off_screen=True), grid, shading="blinn").cubemarch.model
    expected = render_voxels(model.labels, model.world_from_index(), model.palette.rgba,
                             cm.Camera.from_pyvista(plotter.camera), SIZE,
                             background=plotter.background_color.float_rgb,
                             near=plotter.camera.clipping_range[0], lights=_lights(plotter),
                             shading="blinn", **TERMS)
    assert compare_images(read_pixels(plotter), expected).psnr >= 40.0
    plotter.close()


@pytest.mark.parametrize(("change", "named"), [
    (lambda prop, value: setattr(prop, "opacity", value), "opacity"),
    (lambda prop, value: setattr(prop, "point_size", 10 * value), "point_size"),
    # off, on a lit surface (found by a review: it read off already, so turning it off
    # was not seen; catches, seen failing: the property's lighting not set as drawn)
    (lambda prop, value: setattr(prop, "lighting", value < 0.5), "lighting"),
    (lambda prop, value: setattr(prop, "style", "wireframe" if value > 0.5 else "points"),
     "representation"),
])
def test_terms_not_drawn_are_said_once_and_a_wireframe_set_back(change, named):
    """Set on a lit surface, these change nothing drawn: said once, naming them and what
    is drawn from the property; a wireframe is set back to a surface (a wireframe box
    draws the marcher on its edges only).

    catches (seen failing): nothing said (each ignored in silence before); the
    representation left as set (the style reads 'Wireframe'); the colour given with VTK's
    setter (PyVista's wireframe style then set it black, and it was drawn so: found by a
    review).
    """
    plotter = headlit_plotter(SIZE)
    actor = cm.add_surface(plotter, ball(), isovalue=0.0, shading="blinn")
    plotter.view_isometric()
    first = cm.render_image(plotter)
    change(actor.prop, 0.9)
    with pytest.warns(UserWarning, match=f"{named}.*not drawn.*drawn from it: ambient"):
        image = cm.render_image(plotter)
    assert actor.prop.style == "Surface" and np.array_equal(image, first)
    with warnings.catch_warnings():
        warnings.simplefilter("error")   # once for each term
        change(actor.prop, 0.3)
        assert np.array_equal(cm.render_image(plotter), first)
    plotter.close()


@pytest.mark.parametrize(("add", "named"), [
    (lambda plotter: cm.add_voxels(plotter, labelled(), shading="blinn"), "set_label_color"),
    (lambda plotter: cm.add_surface(plotter, ball(), isovalue=0.0, shading="blinn",
                                    color_by="curvature"), "add_surface"),
], ids=["grid", "coloured-surface"])
def test_a_colour_from_a_palette_or_colormap_is_not_the_property_s(add, named):
    """A labelled grid (its palette) or a surface coloured by curvature (a colormap):
    ``prop.color`` is said, naming where colours are set, not drawn.

    catches (seen failing): a colormapped surface's colour taken as followed (no warning;
    the uniform set, drawing nothing).
    """
    plotter = headlit_plotter(SIZE)
    actor = add(plotter)
    plotter.view_isometric()
    first = cm.render_image(plotter)
    actor.prop.color = "red"
    with pytest.warns(UserWarning, match=f"color set on.*{named}"):
        assert np.array_equal(cm.render_image(plotter), first)
    plotter.close()


@pytest.mark.parametrize("change", ["update_scalar_bar_range", "lookup_table.cmap"])
@pytest.mark.parametrize("add", [
    lambda plotter: cm.add_voxels(plotter, labelled(), cmap="viridis"),
    lambda plotter: cm.add_surface(plotter, ball(), isovalue=0.0, color_by="curvature"),
], ids=["colormapped-grid", "coloured-surface"])
def test_a_colormap_changed_after_adding_is_said_not_ignored(add, change):
    """PyVista recolours a mesh when its bar's range or its mapper's table changes; ours
    draws the colours as added, and says so (found by a review: both were silent, and
    ``actor.mapper.lookup_table`` was a table nothing read). catches (seen failing): the
    bar's mapper not watched (update_scalar_bar_range silent), the box's mapper not given
    the bar's table (its cmap set on a bare vtkLookupTable, silent)."""
    plotter = headlit_plotter(SIZE)
    actor = add(plotter)
    plotter.view_isometric()
    first = cm.render_image(plotter)
    with pytest.warns(UserWarning, match="colormap set on.*not drawn.*add it again"):
        if change == "update_scalar_bar_range":   # (it draws a frame itself)
            plotter.update_scalar_bar_range((0.0, 50.0))
        else:
            actor.mapper.lookup_table.cmap = "plasma"
        assert np.array_equal(cm.render_image(plotter), first)
    plotter.close()
