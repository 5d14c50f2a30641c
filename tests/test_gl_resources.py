"""Textures, per-draw binding and render-to-texture, checked through the pixels they produce."""

from __future__ import annotations

import numpy as np
import pytest

import pv_cubemarch as cm
from pv_cubemarch.gl.debug_view import add_texture_view
from pv_cubemarch.gl.passes import RenderToTexturePass
from pv_cubemarch.gl.shaders import ShaderRecipe
from pv_cubemarch.gl.textures import Texture

SIZE = (32, 32)


def view(plotter_factory, texture, **kwargs):
    pl = plotter_factory(SIZE)
    pl.camera.position = (0, 0, 5)
    pl.camera.focal_point = (0, 0, 0)
    pl.camera.up = (0, 1, 0)
    add_texture_view(pl, texture, **kwargs)
    pl.renderer.ResetCameraClippingRange()
    return pl, cm.render_image(pl).astype(float) / 255.0


def test_2d_float_texture(plotter_factory):
    # A horizontal ramp in red and a vertical ramp in green, sampled at pixel centres.
    u = (np.arange(SIZE[0]) + 0.5) / SIZE[0]
    v = (np.arange(SIZE[1]) + 0.5) / SIZE[1]
    data = np.zeros((SIZE[1], SIZE[0], 3), np.float32)
    data[..., 0] = u[None, :]
    data[..., 1] = v[:, None]
    texture = Texture(data, kind="2d")
    pl, image = view(plotter_factory, texture)
    image = image[::-1]  # rows bottom to top, as GL stores them
    assert np.allclose(image[..., 0], data[..., 0], atol=1.5 / 255)
    assert np.allclose(image[..., 1], data[..., 1], atol=1.5 / 255)
    assert texture.upload_count == 1
    assert pl.cubemarch.memory["texture view"] == data.nbytes


def test_3d_uint8_texture_slice(plotter_factory):
    nx, ny, nz = 4, 4, 3
    data = np.zeros((nx, ny, nz), np.uint8)
    data[..., 0], data[..., 1], data[..., 2] = 50, 150, 250
    texture = Texture(data, kind="3d", interpolate=False)
    for k, level in enumerate((50, 150, 250)):
        _, image = view(plotter_factory, texture, slice_position=(k + 0.5) / nz)
        assert np.allclose(image[..., 0], level / 255, atol=1 / 255)


def test_3d_float_texture_axis_order(plotter_factory):
    # Indexed (x, y, z): value = x index along the window's x, so columns step.
    data = np.zeros((4, 2, 2), np.float32)
    data[:, :, :] = np.arange(4)[:, None, None] / 4.0
    texture = Texture(data, kind="3d", interpolate=False)
    _, image = view(plotter_factory, texture)
    columns = image[SIZE[1] // 2, :, 0]
    expected = np.repeat(np.arange(4) / 4.0, SIZE[0] // 4)
    assert np.allclose(columns, expected, atol=1 / 255)


def test_texture_buffer(plotter_factory):
    values = np.linspace(0.0, 1.0, 8).astype(np.float32)
    texture = Texture(values, kind="buffer")
    _, image = view(plotter_factory, texture)
    row = image[5, :, 0]
    assert np.allclose(row, np.repeat(values, SIZE[0] // 8), atol=1 / 255)


def test_reupload_after_set_data(plotter_factory):
    texture = Texture(np.full((2, 2), 0.25, np.float32), kind="2d")
    pl, image = view(plotter_factory, texture)
    assert np.allclose(image[..., 0], 0.25, atol=1 / 255)
    texture.set_data(np.full((2, 2), 0.75, np.float32))
    image = cm.render_image(pl).astype(float) / 255
    assert np.allclose(image[..., 0], 0.75, atol=1 / 255)
    assert texture.upload_count == 2


def test_textures_released_when_plotter_closes(plotter_factory):
    texture = Texture(np.ones((2, 2), np.float32), kind="2d")
    pl, _ = view(plotter_factory, texture)
    assert texture.gl_object is not None
    pl.close()
    assert texture.gl_object is None


def test_bad_texture_input():
    with pytest.raises(ValueError, match="kind"):
        Texture(np.ones(3), kind="cube")
    with pytest.raises(ValueError, match="axes"):
        Texture(np.ones((2, 2, 2, 2, 2)), kind="3d")


@pytest.mark.parametrize("targets", [1, 6])
def test_render_to_texture_pass_writes_texels(plotter_factory, targets):
    pl = plotter_factory(SIZE)
    recipe = ShaderRecipe(standalone="rtt_gradient_pattern", defines={"CM_TARGETS": targets})
    rtt = RenderToTexturePass(pl.renderer, recipe, size=(16, 8), targets=targets)
    rtt.uniforms["cm_value"] = 0.375
    pl.ren_win.Render()
    assert rtt.runs == 1
    pl.ren_win.Render()
    assert rtt.runs == 1  # nothing asked for it again: the pass does not run
    pl.ren_win.MakeCurrent()
    u = (np.arange(16) + 0.5) / 16
    v = (np.arange(8) + 0.5) / 8
    for index in range(targets):
        texels = rtt.read(index)
        assert np.allclose(texels[..., 0], u[None, :], atol=1e-6)
        assert np.allclose(texels[..., 1], v[:, None], atol=1e-6)
        assert np.allclose(texels[..., 2], 0.375)
        assert np.allclose(texels[..., 3], index)
    rtt.release()


def test_render_target_formats_hold_what_they_promise(plotter_factory):
    """Half-float colour keeps ~3 decimal digits, a one-channel float32 target keeps 7."""
    pl = plotter_factory(SIZE)
    recipe = ShaderRecipe(standalone="rtt_gradient_pattern", defines={"CM_TARGETS": 2})
    rtt = RenderToTexturePass(pl.renderer, recipe, size=(16, 8), targets=("rgba16f", "r32f"))
    rtt.uniforms["cm_value"] = 0.1234567
    pl.ren_win.Render()
    pl.ren_win.MakeCurrent()
    half, single = rtt.read(0), rtt.read(1)
    assert half.shape == (8, 16, 4) and single.shape == (8, 16, 1)
    assert np.allclose(half[..., 2], 0.1234567, atol=1e-4)
    assert not np.allclose(half[..., 2], 0.1234567, atol=1e-6)  # it is half precision
    assert np.allclose(single[..., 0], ((np.arange(16) + 0.5) / 16)[None, :], atol=1e-7)
    assert rtt.nbytes == 16 * 8 * (8 + 4)
    rtt.release()
    with pytest.raises(ValueError, match="rgba16f"):
        RenderToTexturePass(pl.renderer, recipe, size=(4, 4), targets=("rgb8",))


def test_render_to_texture_sampled_in_same_frame(plotter_factory):
    """An actor samples what a pass wrote earlier in the same frame."""
    pl = plotter_factory(SIZE)
    pl.camera.position = (0, 0, 5)
    pl.camera.focal_point = (0, 0, 0)
    pl.camera.up = (0, 1, 0)
    recipe = ShaderRecipe(standalone="rtt_gradient_pattern", defines={"CM_TARGETS": 1})
    rtt = RenderToTexturePass(pl.renderer, recipe, size=SIZE, targets=1)
    rtt.uniforms["cm_value"] = 0.5
    add_texture_view(pl, rtt.output(0))
    pl.renderer.ResetCameraClippingRange()
    image = cm.render_image(pl).astype(float)[::-1] / 255
    u = (np.arange(SIZE[0]) + 0.5) / SIZE[0]
    assert np.allclose(image[..., 0], u[None, :], atol=1.5 / 255)
    assert np.allclose(image[..., 2], 0.5, atol=1.5 / 255)
    assert rtt.runs == 1
    rtt.release()


def test_frame_inputs_made_during_a_draw_never_share_a_frame_serial():
    # catches (seen failing in full runs: test_3d_float_texture_axis_order drew zeros): a
    # FrameInputs made during a draw had serial 0 until its next frame, as every such one
    # had; ProgramUniforms keys by the program's and renderer's addresses and that serial,
    # so a new program at a freed one's address skipped uniforms the freed one held
    import pyvista as pv

    from pv_cubemarch.gl.frame_inputs import FrameInputs

    serials = set()
    for _ in range(3):
        renderer = pv.Renderer(pv.Plotter(off_screen=True))
        serials.add(FrameInputs(renderer).serial)
    assert len(serials) == 3 and 0 not in serials
