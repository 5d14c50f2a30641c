"""``pv-cubemarch render`` of a ``.zarr`` source: streamed by bricks, as ``add_volume`` and
``add_voxels`` stream it in Python.

The oracles share no code with the renderer's streaming: the volume's image is held to
the in-memory render of the pyramid's finest level read whole with zarr; the labels' ids
to the CPU voxel traversal of the label grid the pyramid was built from.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest
import pyvista as pv
from PIL import Image
from test_paged_labels import BRICK, EDGE, ball
from test_paged_volume import CLIM, ORIGIN, SCALE, field, finest_grid

import pv_cubemarch as cm
from pv_cubemarch.cli import main
from pv_cubemarch.image_metrics import compare_images
from pv_cubemarch.reference.voxels import id_colors, trace_voxels

SIZE = (160, 120)
FLAGS = ["--cmap", "viridis", "--clim", *map(str, CLIM), "--opacity", "linear",
         "--opacity-unit-distance", "1", "--lod-bias", "-30", "--brick-size", "8",
         "--size", f"{SIZE[0]}x{SIZE[1]}", "--no-progress"]


@pytest.fixture(scope="module")
def volume_pyramid(tmp_path_factory):
    path = tmp_path_factory.mktemp("cli_paged") / "blob.ome.zarr"
    cm.build_pyramid(field(), path, chunk_size=8, scale=SCALE, translation=ORIGIN,
                     progress_bar=False)
    return path


@pytest.fixture(scope="module")
def label_pyramid(tmp_path_factory):
    path = tmp_path_factory.mktemp("cli_labels") / "ball.ome.zarr"
    cm.build_pyramid(ball(), path, levels=3, chunk_size=16, method="mode", progress_bar=False)
    return path


def test_render_streams_a_zarr_volume_as_the_whole_volume_draws(volume_pyramid, tmp_path,
                                                               capsys):
    # The finest level everywhere (--lod-bias -30): the CLI's image is the in-memory
    # volume's, both framed by PyVista's camera reset on the same bounds.
    # A coarse level asked for (--lod-bias 3) draws another image (45 dB off).
    # catches (seen failing): the flags left out of add_volume (viridis and the clim lost:
    # 22.6 dB); --lod-bias not reaching the pager (the coarse image drawn as the finest)
    out = tmp_path / "volume.png"
    assert main(["render", str(volume_pyramid), "-o", str(out), *FLAGS]) == 0
    assert "wrote" in capsys.readouterr().out
    drawn = np.asarray(Image.open(out).convert("RGB"))
    plotter = cm.offscreen_plotter(SIZE)
    cm.add_volume(plotter, finest_grid(volume_pyramid), technique="direct", cmap="viridis",
                  clim=CLIM, opacity="linear", opacity_unit_distance=1.0)
    expected = cm.render_image(plotter)
    plotter.close()
    assert np.abs(expected.astype(int) - expected[0, 0]).max(axis=-1).mean() > 5  # in view
    assert compare_images(drawn, expected).psnr >= 50.0
    coarse = tmp_path / "coarse.png"
    flags = [*FLAGS]
    flags[flags.index("-30")] = "3"
    assert main(["render", str(volume_pyramid), "-o", str(coarse), *flags]) == 0
    assert compare_images(np.asarray(Image.open(coarse).convert("RGB")), expected).psnr < 48


def test_render_streams_a_zarr_label_pyramid_with_technique_voxels(label_pyramid, tmp_path):
    # Every voxel's id against the CPU traversal of the grid the pyramid was built from,
    # for the camera PyVista frames the source with (pixels on a voxel's edge left out);
    # the pixels no voxel covers are the plotter's background.
    # catches (seen failing): --technique voxels adding the source as a volume (its
    # --mode refused by add_volume)
    out = tmp_path / "labels.png"
    assert main(["render", str(label_pyramid), "-o", str(out), "--technique", "voxels",
                 "--mode", "id", "--lod-bias", "-64", "--brick-size", str(BRICK),
                 "--size", f"{SIZE[0]}x{SIZE[1]}", "--no-progress"]) == 0
    drawn = np.asarray(Image.open(out).convert("RGB")).astype(int)
    plotter = cm.offscreen_plotter(SIZE)
    actor = cm.add_voxels(plotter, str(label_pyramid), mode="id", lod_bias=-64,
                          brick_size=BRICK)
    camera = cm.Camera.from_pyvista(plotter.camera)
    near = plotter.camera.clipping_range[0]
    background = np.round(np.asarray(plotter.background_color.float_rgb) * 255).astype(int)
    labels = ball()
    hits = trace_voxels(labels, actor.cubemarch.model.world_from_index(), camera, SIZE,
                        near=near, tie_tolerance=EDGE)
    plotter.close()
    expected = id_colors(hits, labels.shape).astype(int)
    filled = expected.any(axis=-1)
    expected[~filled] = background
    wrong = np.any(drawn != expected, axis=-1) & ~hits.near_edge
    assert filled.sum() > 1000 and wrong.sum() == 0, (wrong.sum(), filled.sum())


def test_render_says_when_the_pool_is_too_small_and_fails_cleanly_on_a_damaged_store(
        volume_pyramid, tmp_path, capsys):
    # A pool of a few bricks draws coarser levels where it has no room: said on stderr.
    # A store whose finest chunks are garbage: exit 2 with the source named, no image.
    # catches (seen failing, found by a review): the coarser image written with nothing
    # said; the codec's RuntimeError raised as a traceback (exit 1)
    out = tmp_path / "small.png"
    assert main(["render", str(volume_pyramid), "-o", str(out), *FLAGS,
                 "--gpu-bytes", "8000"]) == 0
    assert "holds too few bricks" in capsys.readouterr().err
    damaged = tmp_path / "damaged.ome.zarr"
    shutil.copytree(volume_pyramid, damaged)
    for chunk in (damaged / "0").rglob("*"):
        if chunk.is_file() and chunk.name != "zarr.json" and not chunk.name.startswith("."):
            chunk.write_bytes(b"garbage")
    out = tmp_path / "damaged.png"
    assert main(["render", str(damaged), "-o", str(out), *FLAGS]) == 2
    err = capsys.readouterr().err
    assert "damaged.ome.zarr: a brick could not be read" in err and "Traceback" not in err
    assert not out.exists()


@pytest.mark.parametrize("flags, message", [
    (["--time", "1"], "--time does not apply to a .zarr source"),
    (["--strict"], "--strict does not apply to a .zarr source"),
    (["--camera", "/Main"], "--camera does not apply to a .zarr source"),
    (["--isovalue", "3"], "--isovalue does not apply"),
    (["--chunk-size", "16"], "--chunk-size does not apply"),
    (["--mode", "id", "--surface-opacity", "0.5"], "--mode, --surface-opacity: not options"),
    # what add_volume refuses of a streamed source, said with the flags that gave it
    (["--shade"], "--shade: not for a volume streamed from a .zarr source"),
    (["--blending", "maximum", "--downsample", "2"],
     "--downsample, --blending maximum: not for a volume streamed"),
    (["--technique", "voxels", "--show-edges"],
     "--show-edges: not for a label grid streamed from a .zarr source"),
])
def test_render_of_a_zarr_source_refuses_what_does_not_apply(volume_pyramid, tmp_path,
                                                              capsys, flags, message):
    # catches (seen failing): voxel and surface flags dropped in silence for a volume (the
    # image written, exit 0); add_volume's refusal passed on in Python's words (shade=,
    # "add the finest level alone")
    out = tmp_path / "x.png"
    assert main(["render", str(volume_pyramid), "-o", str(out), "--no-progress",
                 *flags]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_streamed_only_flags_on_a_grid_file_are_said_and_left_out(tmp_path, capsys):
    # A grid file is read whole: --gpu-bytes and --lod-bias (no voxel grid here to read
    # it) are said and left out, and the volume is drawn. catches (seen failing): the
    # flags passed on to add_volume, which refuses them ("for multiscale sources")
    grid = pv.ImageData(dimensions=(12, 10, 8))
    grid.point_data["density"] = np.linspace(0.0, 1.0, grid.n_points)
    path = tmp_path / "density.vti"
    grid.save(path)
    out = tmp_path / "grid.png"
    assert main(["render", str(path), "-o", str(out), "--gpu-bytes", "1000000",
                 "--lod-bias", "1", "--no-progress", "--size", "64x48"]) == 0
    err = capsys.readouterr().err
    assert "--gpu-bytes does not apply to this scene's grids" in err
    assert "--lod-bias does not apply to this scene's grids" in err
    assert out.exists()


def test_render_image_shows_the_bricks_it_waits_for(volume_pyramid, capsys):
    plotter = cm.offscreen_plotter(SIZE)
    cm.add_volume(plotter, str(volume_pyramid), lod_bias=-30, brick_size=8, clim=CLIM)
    cm.render_image(plotter, converge=True, progress_bar=True)
    plotter.close()
    assert "streaming bricks" in capsys.readouterr().err


def test_channel_and_timepoint_pick_an_ome_zarr_source_s_indices(tmp_path, capsys):
    # A 5D image (t, c, z, y, x): the flags draw the indices asked for, as the Python
    # source read at them draws (test_multiscale checks that source against the arrays);
    # left out, t=0 and c=0 are drawn and said. A flag naming an axis the source lacks,
    # an index past the axis, or a flag on a file that is no .zarr source, are refused.
    # catches (seen failing): the flags not passed to the source (t=0, c=0 drawn); the
    # note left out.
    import zarr
    from test_multiscale import _v04_image

    path = tmp_path / "tc.zarr"
    _v04_image(path, (2, 3, 10, 12, 14), [[1, 1, 1.0, 1.0, 1.0], [1, 1, 2.0, 2.0, 2.0]],
               [[0, 0, 0.0, 0.0, 0.0], [0, 0, 0.5, 0.5, 0.5]])
    flags = ["--cmap", "viridis", "--clim", "0", "60000", "--size", "64x48", "--no-progress"]
    picked, first = tmp_path / "picked.png", tmp_path / "first.png"
    assert main(["render", str(path), "-o", str(picked), "--timepoint", "1", "--channel",
                 "2", *flags]) == 0
    assert "note" not in capsys.readouterr().err
    assert main(["render", str(path), "-o", str(first), *flags]) == 0
    assert "drawn at t=0 of 2, c=0 of 3" in capsys.readouterr().err
    plotter = cm.offscreen_plotter((64, 48))
    cm.add_volume(plotter, cm.multiscale_source(str(path), time=1, channel=2),
                  cmap="viridis", clim=(0, 60000))
    expected = cm.render_image(plotter, converge=True)
    plotter.close()
    drawn = np.asarray(Image.open(picked).convert("RGB"))
    assert np.array_equal(drawn, expected)
    assert compare_images(np.asarray(Image.open(first).convert("RGB")), expected).psnr < 40
    out = str(tmp_path / "x.png")
    assert main(["render", str(path), "-o", out, "--channel", "3", *flags]) == 2
    assert "outside its 3 entries" in capsys.readouterr().err
    plain = tmp_path / "plain.zarr"
    zarr.create_array(str(plain), data=np.zeros((4, 4, 4), np.float32))
    assert main(["render", str(plain), "-o", out, "--timepoint", "1", *flags]) == 2
    assert "has no time axis (its axes: x, y, z)" in capsys.readouterr().err
    grid = tmp_path / "grid.npy"
    np.save(grid, np.zeros((4, 4, 4), np.float32))
    assert main(["render", str(grid), "-o", out, "--channel", "1", *flags]) == 2
    assert "is not a .zarr source" in capsys.readouterr().err
