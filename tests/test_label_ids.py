"""Segmentations: label ids of every integer type and value, drawn exactly and restyled by id.

The expected images come from :func:`pv_cubemarch.reference.label_ids.trace_ids`, which
makes the ids dense with its own ``np.unique`` (nothing of the renderer's compaction), and
from colours the test itself picks per id; never from the renderer's tables.
"""

from __future__ import annotations

import numpy as np
import pytest
import pyvista as pv
from conftest import draw_at

import pv_cubemarch as cm
from pv_cubemarch.models.label_colors import hashed_colors
from pv_cubemarch.models.label_ids import label_rows
from pv_cubemarch.reference.label_ids import trace_ids
from pv_cubemarch.reference.voxels import id_colors
from pv_cubemarch.voxels.label_state import palette_runs

SIZE = (120, 100)
SHAPE = (24, 20, 16)


def plotter(size=SIZE):
    pl = cm.offscreen_plotter(size)
    pl.disable_anti_aliasing()
    pl.ren_win.SetMultiSamples(0)   # an id is a pixel's, never a blend of two
    pl.set_background("black")
    return pl


def aim(pl, eye=(40.0, 30.0, 35.0), focal=(12.0, 10.0, 8.0)):
    pl.camera.position = eye
    pl.camera.focal_point = focal
    pl.renderer.ResetCameraClippingRange()
    return cm.Camera.from_pyvista(pl.camera)


def scattered(ids, fill=0.3, seed=3, background=0, shape=SHAPE):
    """A grid of ``ids`` at random voxels (``fill`` of them), the rest ``background``."""
    rng = np.random.default_rng(seed)
    ids = np.asarray(ids)
    values = rng.choice(ids, shape)
    return np.where(rng.random(shape) < fill, values, ids.dtype.type(background))


def wrong_ids(pl, actor, labels, camera, shown=None, background=0, near=None):
    """Pixels whose voxel (``mode='id'``) differs from the reference traversal's, and hits."""
    image = cm.render_image(pl).astype(int)
    hits, hit = trace_ids(labels, actor.cubemarch.model.world_from_index(), camera, SIZE,
                          near=pl.camera.clipping_range[0] if near is None else near,
                          shown=shown, background=background)
    expected = id_colors(hits, labels.shape).astype(int)
    return int(np.any(image != expected, axis=-1).sum()), int(hit.sum()), hits, hit


U64 = np.uint64
CASES = {
    # name: (ids, dtype, background)
    "uint32 scattered": (np.random.default_rng(0).choice(2**32 - 1, 400, replace=False) + 1,
                         np.uint32, 0),
    "uint64 near 2^40": (2**40 + np.random.default_rng(1).choice(10**7, 300, replace=False),
                         np.uint64, 0),
    "uint64 extremes": ([1, 2**32 - 1, 2**63, 2**64 - 2, 2**64 - 1], np.uint64, 0),
    "int32 negative": ([-2**31, -7, -1, 5, 2**31 - 1], np.int32, 0),
    "int64 background -1": ([0, 3, -2**62, 2**62], np.int64, -1),
    "one id 2^32-1": ([2**32 - 1], np.uint32, 0),
    "uint8 identity": ([1, 2, 7], np.uint8, 0),
}


@pytest.mark.parametrize("case", list(CASES))
def test_every_id_type_is_drawn_voxel_exactly(case):
    """Every id width and sign, against the reference traversal, then coloured by a dict.

    catches (seen failing): 4-byte rows read times iinfo.max (label_scale for uint32); rows
    off by one in compaction (searchsorted into the ids without the background row).
    """
    ids, dtype, background = CASES[case]
    ids = np.asarray(ids, dtype=dtype)
    labels = scattered(ids[ids != background], background=background).astype(dtype)
    labels[0, 0, 0] = background   # the background is present too
    pl = plotter()
    actor = cm.add_voxels(pl, labels, mode="id", background=background)
    camera = aim(pl)
    wrong, hit, hits, seen = wrong_ids(pl, actor, labels, camera, background=background)
    assert hit > 1000 and wrong == 0, (wrong, hit)
    pl.close()
    # colours from the test's own table, keyed by id: the pixels show the hit id's colour
    rng = np.random.default_rng(5)
    present = [int(v) for v in np.unique(labels) if v != background]
    colours = {v: rng.integers(0, 256, 3) / 255.0 for v in present}
    pl = plotter()
    cm.add_voxels(pl, labels, palette={k: tuple(v) for k, v in colours.items()},
                  shading="unlit", background=background)
    aim(pl)
    image = cm.render_image(pl).astype(int)
    expected = np.zeros(image.shape, int)
    for value, colour in colours.items():
        expected[seen & (hits.material == value)] = np.round(colour * 255)
    assert np.abs(image - expected).max() <= 1
    pl.close()


def test_only_background_draws_nothing_without_error():
    # 0 only, and a background of 7 in a grid of 7s: nothing drawn, no error.
    # catches (seen failing): the background compacted as a label.
    for labels, background in ((np.zeros(SHAPE, np.uint64), 0),
                               (np.full(SHAPE, 7, np.int16), 7)):
        pl = plotter()
        actor = cm.add_voxels(pl, labels, background=background)
        aim(pl)
        assert actor.cubemarch.n_labels == (0 if background else 1)   # palette rows
        assert not cm.render_image(pl).any()
        pl.close()


def test_a_million_ids_in_a_small_grid():
    """10^6 distinct uint64 ids, not sorted in the grid: 4-byte rows, exact, picked by id.

    catches (seen failing): a palette as wide as the ids (one row of 10^6 texels, past
    GL's 2D limit).
    """
    shape = (100, 100, 100)
    rng = np.random.default_rng(3)
    labels = rng.permutation(np.arange(1, 10**6 + 1, dtype=np.uint64) * 4099 + 2**33)
    labels = labels.reshape(shape)
    labels[:, :, :3] = 0
    pl = plotter()
    actor = cm.add_voxels(pl, labels, mode="id")
    model = actor.cubemarch.model
    assert model.labels.dtype == np.uint32 and actor.cubemarch.n_labels == 970000
    camera = aim(pl, (-60.0, 150.0, -50.0), (50.0, 50.0, 50.0))
    image = cm.render_image(pl).astype(int)
    hits, hit = trace_ids(labels, model.world_from_index(), camera, SIZE,
                          near=pl.camera.clipping_range[0])
    assert hit.sum() > 5000
    assert not np.any(image != id_colors(hits, shape).astype(int), axis=-1).any()
    y, x = np.argwhere(hit)[len(np.argwhere(hit)) // 2]
    picked = actor.cubemarch.pick(int(x), int(y))
    assert picked.label == int(hits.material[y, x]) == int(labels[picked.index])
    pl.close()


def test_storage_follows_the_number_of_ids_not_their_width():
    """uint64 ids cost 1, 2 or 4 bytes a voxel by how many there are, never 8.

    catches: the ids uploaded as they are (uint64 converted to float32: 4 bytes a voxel).
    """
    few = scattered(2**40 + np.arange(200, dtype=np.uint64)).astype(np.uint64)
    some = scattered(2**50 + np.arange(300, dtype=np.uint64)).astype(np.uint64)
    many = np.arange(70000, dtype=np.uint64).reshape(70, 100, 10) + 2**60
    for labels, itemsize in ((few, 1), (some, 2), (many, 4)):
        pl = plotter()
        actor = cm.add_voxels(pl, labels, mip_levels=0, distance_field=0, proxy="box")
        assert actor.cubemarch.labels.nbytes == labels.size * itemsize
        pl.close()


def test_label_state_changes_are_drawn_and_send_only_their_entries():
    """Hide, show only some, recolour, highlight, by id: the next frame is the reference's,
    the labels are never uploaded again, and the palette upload is a few entries.

    catches (seen failing): the whole palette re-uploaded at each change (4800 bytes for
    one id); hidden ids still drawn (the opaque palette not following); show_labels()
    leaving the ids hidden by show_selected_labels.
    """
    ids = (2**40 + np.random.default_rng(2).choice(10**6, 300, replace=False)).astype(U64)
    labels = scattered(ids).astype(np.uint64)
    pl = plotter()
    actor = cm.add_voxels(pl, labels, mode="id")
    binding = actor.cubemarch
    camera = aim(pl)
    assert wrong_ids(pl, actor, labels, camera)[0] == 0
    labels_sent = binding.uploaded_bytes
    palette_sent = binding.palette_texture.uploaded_bytes
    binding.hide_labels(int(ids[7]))
    wrong, _, hits, seen = wrong_ids(pl, actor, labels, camera, shown=np.delete(ids, 7))
    assert wrong == 0
    assert binding.palette_texture.uploaded_bytes - palette_sent == 16   # one RGBA float
    binding.show_selected_labels(ids[:5])
    assert wrong_ids(pl, actor, labels, camera, shown=ids[:5])[0] == 0
    assert set(binding.hidden_labels.tolist()) == set(ids[5:].tolist())
    binding.show_labels()
    assert wrong_ids(pl, actor, labels, camera)[0] == 0
    assert binding.uploaded_bytes == labels_sent
    assert binding.palette_texture.uploaded_bytes - palette_sent < 300 * 16 * 3
    pl.close()


def test_recolour_and_highlight_by_id_in_colour():
    # catches (seen failing): highlight drawn in the id's own colour (rows not redrawn)
    ids = np.array([-5, 3, 2**40], dtype=np.int64)
    labels = scattered(ids).astype(np.int64)
    pl = plotter()
    actor = cm.add_voxels(pl, labels, palette={-5: "red", 3: "lime", 2**40: "blue"},
                          shading="unlit")
    camera = aim(pl)
    hits, seen = trace_ids(labels, actor.cubemarch.model.world_from_index(), camera, SIZE,
                           near=pl.camera.clipping_range[0])

    def colours(table):
        out = np.zeros((*SIZE[::-1], 3), int)
        for value, rgb in table.items():
            out[seen & (hits.material == value)] = rgb
        return out

    red, lime, blue, white = (255, 0, 0), (0, 255, 0), (0, 0, 255), (255, 255, 255)
    assert np.array_equal(cm.render_image(pl), colours({-5: red, 3: lime, 2**40: blue}))
    actor.cubemarch.set_label_color([3, 2**40], np.array([[1.0, 1.0, 0.0], [0.0, 1.0, 1.0]]))
    assert np.array_equal(cm.render_image(pl),
                          colours({-5: red, 3: (255, 255, 0), 2**40: (0, 255, 255)}))
    actor.cubemarch.highlight_labels(-5)
    assert np.array_equal(cm.render_image(pl),
                          colours({-5: white, 3: (255, 255, 0), 2**40: (0, 255, 255)}))
    actor.cubemarch.clear_highlight()
    assert np.array_equal(cm.render_image(pl),
                          colours({-5: red, 3: (255, 255, 0), 2**40: (0, 255, 255)}))
    pl.close()


def test_a_translucent_id_is_composited_as_peeled_meshes():
    """One uint64 id at opacity 0.4 inside another: against PyVista's depth-peeled
    ``threshold`` + ``add_mesh`` of the two, unlit.

    catches (seen failing): per-id opacity lost from a dict on compacted ids (20.5 dB).
    """
    outer, inner = 2**40 + 11, 2**63 + 5
    labels = np.zeros((16, 16, 16), np.uint64)
    labels[2:14, 2:14, 2:14] = outer
    labels[5:11, 5:11, 5:11] = inner
    labels[2:14, 2:14, 2:6] = 0   # an open side: the inner box seen through the outer
    grid = pv.ImageData(dimensions=np.array(labels.shape) + 1)
    grid.cell_data["labels"] = labels.ravel(order="F")
    position = [(40.0, 30.0, -25.0), (8.0, 8.0, 8.0), (0.0, 0.0, 1.0)]

    def shot(add):
        return draw_at(add, SIZE, position)[0]

    def theirs(pl):
        pl.ren_win.SetMultiSamples(0)
        pl.enable_depth_peeling(number_of_peels=50, occlusion_ratio=0.0)
        for value, colour, opacity in ((outer, "tomato", 0.4), (inner, "steelblue", 1.0)):
            pl.add_mesh(grid.threshold([float(value), float(value)], scalars="labels"),
                        color=colour, opacity=opacity, lighting=False)

    palette = {outer: ("tomato", 0.4), inner: "steelblue"}
    reference = shot(theirs)
    ours = shot(lambda pl: pl.cubemarch.add_voxels(labels, palette=palette, shading="unlit"))
    opaque = shot(lambda pl: pl.cubemarch.add_voxels(labels, palette={
        outer: "tomato", inner: "steelblue"}, shading="unlit"))
    from test_pyvista_parity import psnr
    assert psnr(ours, reference) >= 40.0, psnr(ours, reference)
    assert psnr(opaque, reference) < 30.0


def test_edits_write_ids_and_refuse_new_ones():
    ids = np.array([2**40, 2**41, 2**42], dtype=np.uint64)
    labels = scattered(ids).astype(np.uint64)
    pl = plotter()
    actor = cm.add_voxels(pl, labels, mode="id")
    camera = aim(pl)
    actor.cubemarch.fill_box((0, 0, 0), (10, 10, 10), 2**41)
    labels[:10, :10, :10] = 2**41
    assert wrong_ids(pl, actor, labels, camera)[0] == 0
    with pytest.raises(ValueError, match="compacted when it was made"):
        actor.cubemarch.set_voxels((1, 1, 1), 2**43)
    pl.close()


def test_hashed_colours_are_stable_and_differ_between_neighbours():
    # by hand: the hash depends on the id alone, not on the grid or on which ids are present
    first = hashed_colors(np.array([41, 42, 2**40], np.uint64))
    again = hashed_colors(np.array([2**40, 42], np.uint64))
    assert np.array_equal(first[2], again[0]) and np.array_equal(first[1], again[1])
    neighbours = hashed_colors(np.arange(1, 10001))
    step = np.abs(np.diff(neighbours[:, :3], axis=0)).max(axis=1)
    assert (step > 0.05).mean() > 0.95
    assert neighbours[:, :3].max(axis=1).min() >= 0.69   # none near black
    # signed ids hash their 64-bit pattern: -1 is 2^64 - 1
    assert np.array_equal(hashed_colors(np.array([-1], np.int64)),
                          hashed_colors(np.array([2**64 - 1], np.uint64)))


def test_palette_runs_by_hand():
    # width 8: rows 1, 2, 3 one span; 30 in another texture row; 9 and 15 apart by 6
    assert palette_runs([1, 2, 3, 30], width=8, gap=2) == [(0, 1, 4), (3, 6, 7)]
    assert palette_runs([9, 15], width=8, gap=2) == [(1, 1, 2), (1, 7, 8)]
    assert palette_runs([9, 15], width=8, gap=8) == [(1, 1, 8)]
    assert palette_runs([], width=8) == []


def test_clear_errors_for_ids():
    labels = scattered(np.array([2**40, 2**41], np.uint64)).astype(np.uint64)
    pl = plotter()
    actor = cm.add_voxels(pl, labels)
    with pytest.raises(ValueError, match="label 5 is not in the grid"):
        actor.cubemarch.hide_labels([2**40, 5])
    with pytest.raises(ValueError, match="background"):
        actor.cubemarch.hide_labels(0)
    with pytest.raises(cm.VolumeDataError, match="compacted"):
        cm.add_voxels(pl, labels, palette=["red", "blue", "green"])
    with pytest.raises(ValueError, match="outside"):
        cm.add_voxels(pl, labels.astype(np.uint8), background=-1)
    with pytest.raises(ValueError, match="integer label ids"):
        actor.cubemarch.set_label_color(["a"], "red")
    pl.close()


@pytest.mark.parametrize("coherent", [True, False])
@pytest.mark.parametrize("slab", [None, 97])
@pytest.mark.parametrize("order", ["C", "F"])
def test_compaction_matches_numpy_unique_on_every_path(monkeypatch, coherent, slab, order):
    """Rows from runs (coherent cells) and from sorts (scattered ids), in one slab or many,
    C or Fortran order, equal the ranks ``np.unique`` gives, past a non-zero background.

    catches (seen failing): a run's row taken from the run before it (heads off by one).
    """
    from pv_cubemarch.models import label_ids

    if slab is not None:   # many slabs, not a multiple of the runs' length
        monkeypatch.setattr(label_ids, "SLAB_VOXELS", slab)
    rng = np.random.default_rng(5)
    ids = (2**40 + rng.choice(10**6, 60, replace=False)).astype(np.int64)
    if coherent:            # runs of 1-9 equal ids along the fastest axis, as cells make
        lengths = rng.integers(1, 10, 3000)
        flat = np.repeat(rng.choice(ids, lengths.size), lengths)[:18 * 14 * 11]
    else:
        flat = rng.choice(ids, 18 * 14 * 11)
    flat[rng.random(flat.size) < 0.2] = 2**40 + 10**7          # the background
    values = np.asarray(flat.reshape((18, 14, 11), order=order), order=order)
    rows, table = label_ids.compact_labels(values, background=2**40 + 10**7)
    present, rank = np.unique(values, return_inverse=True)
    background_rank = int(np.searchsorted(present, 2**40 + 10**7))
    expected = rank.reshape(values.shape) + 1
    expected[expected - 1 == background_rank] = 0
    expected[expected - 1 > background_rank] -= 1
    assert np.array_equal(rows, expected)
    assert table.ids.tolist() == [v for v in present.tolist() if v != 2**40 + 10**7]


def test_block_occupancy_of_any_block_size_by_direct_scan():
    # catches (seen failing): a block's strided slices started at the wrong offset (a
    # filled voxel missed)
    from pv_cubemarch.models.voxel_levels import block_any

    mask = np.random.default_rng(2).random((13, 10, 7)) < 0.02
    for block in (1, 2, 3, 4, 8):
        got = block_any(mask, block)
        assert got.shape == tuple(-(-n // block) for n in mask.shape)
        for index in np.ndindex(got.shape):
            cell = mask[tuple(slice(i * block, (i + 1) * block) for i in index)]
            assert got[index] == cell.any(), (block, index)


def test_identity_grids_keep_their_rows():
    # labels 0..65535 with background 0 are their own rows (palettes by material number)
    rows, ids = label_rows(np.array([[[0, 3, 300]]], np.int64))
    assert ids.identity and rows.dtype == np.uint16 and rows.tolist() == [[[0, 3, 300]]]
    rows, ids = label_rows(np.array([[[0, 3, 70000]]], np.int64))
    assert not ids.identity and rows.tolist() == [[[0, 1, 2]]]


def test_the_live_view_lists_and_hides_label_ids():
    """The session's label knob lists a uint64 grid's ids (past 2^53 as strings) and hides
    one: the frame is the reference traversal without it.

    catches (seen failing): the knob listing palette rows 1..n instead of the ids.
    """
    from pv_cubemarch.views.session import TuningSession

    ids = np.array([2**40 + 1, 2**40 + 9, 2**60 + 3], dtype=np.uint64)
    labels = scattered(ids).astype(np.uint64)
    pl = plotter()
    actor = cm.add_voxels(pl, labels, mode="id", name="cells")
    camera = aim(pl)
    session = TuningSession.from_plotter(pl)
    listed = session.value("voxels", "materials")
    assert listed == [2**40 + 1, 2**40 + 9, str(2**60 + 3)]
    session.set("voxels", "materials", [2**40 + 1, str(2**60 + 3)])
    assert wrong_ids(pl, actor, labels, camera, shown=ids[[0, 2]])[0] == 0
    session.set("voxels", "materials", listed)
    assert wrong_ids(pl, actor, labels, camera)[0] == 0
    pl.close()


def test_usd_and_openvdb_bring_wide_ids(tmp_path):
    """uint64 ids from a USD stage's numpy field and int64 ids from an OpenVDB grid (with a
    non-zero background), drawn voxel-exactly; a per-number USD palette is refused.

    catches (seen failing): the USD per-number palette applied to compacted rows (no
    refusal), and the VDB background kept as a label.
    """
    from conftest import write_voxel_stage
    from tools.vdb_writer import write_vdb

    from pv_cubemarch.scene.openvdb.image import vdb_image

    ids = np.array([2**40 + 1, 2**40 + 9, 2**62], dtype=np.uint64)
    labels = scattered(ids, shape=(12, 10, 8)).astype(np.uint64)
    path = write_voxel_stage(tmp_path, labels, attrs={"cubemarch:mode": ("Token", "id")})
    scene = cm.load_scene(path)
    scene.background = (0.0, 0.0, 0.0)
    pl = plotter()
    scene.add_to(pl)
    actor = next(a for a in pl.actors.values() if hasattr(a, "cubemarch"))
    camera = scene.cameras["/Cam"]
    wrong, hit, _, _ = wrong_ids(pl, actor, labels, camera, near=camera.clipping_range[0])
    assert hit > 500 and wrong == 0
    pl.close()
    stage = write_voxel_stage(tmp_path, labels, stage_name="palette.usda", attrs={
        "cubemarch:palette": ("Color3fArray", [(0, 0, 0), (1, 0, 0)])})
    with pytest.warns(UserWarning, match="one entry per label number"):
        refused = cm.load_scene(stage)
    assert refused.voxels == [] and len(refused.skipped) == 1   # skipped, and said
    # OpenVDB: an int64 grid, background 5 (its inactive voxels), ids near 2^40 and below 0
    rng = np.random.default_rng(4)
    choices = np.array([2**40 + 3, 2**40 + 77, -2**35, 5], dtype=np.int64)
    leaves = {}
    for origin in [(0, 0, 0), (8, 0, 0), (0, 8, 8)]:
        active = rng.random(512) < 0.5
        values = rng.choice(choices, 512)
        values[~active] = 5
        leaves[origin] = (values, active)
    write_vdb(tmp_path / "ids.vdb", [{
        "name": "ids", "type": "Tree_int64_5_4_3", "dtype": "<i8", "compression": 0,
        "background": np.array(5, "<i8"), "leaves": leaves,
        "map": ("UniformScaleMap", [1.0] * 6 + [1.0] * 3 + [1.0] * 3 + [1.0] * 3)}])
    image = vdb_image(tmp_path / "ids.vdb", cells=True)
    values = np.asarray(image.cell_data["ids"]).reshape(
        [n - 1 for n in image.dimensions], order="F")
    pl = plotter()
    actor = cm.add_voxels(pl, image, mode="id", background=5)
    assert actor.cubemarch.n_labels == 3
    camera = aim(pl, (-20.0, 30.0, -25.0), (8.0, 8.0, 8.0))
    wrong, hit, _, _ = wrong_ids(pl, actor, values, camera, background=5)
    assert hit > 500 and wrong == 0
    pl.close()


def test_info_gives_the_label_count_and_a_legend(tmp_path, capsys):
    # catches (seen failing): the legend listing palette rows (1, 2, 3) in place of the ids
    import json

    from conftest import write_voxel_stage

    from pv_cubemarch import cli

    ids = np.array([2**40 + 1, 2**40 + 9, 2**62], dtype=np.uint64)
    path = write_voxel_stage(tmp_path, scattered(ids, shape=(12, 10, 8)).astype(np.uint64))
    assert cli.main(["info", str(path), "--json"]) == 0
    labels = json.loads(capsys.readouterr().out)["scene"]["labels"]["/Vox"]
    assert labels["count"] == 3 and [e["id"] for e in labels["legend"]] == ids.tolist()
    assert cli.main(["info", str(path)]) == 0
    text = capsys.readouterr().out
    assert "3 label ids 1099511627777..4611686018427387904 (uint64)" in text
    assert f"    {2**62}: #" in text


def test_a_metaimage_of_uint32_ids_loads_as_a_scene(tmp_path):
    """A ``.mha`` (any file PyVista reads as an ImageData) of uint32 ids past 2^31, placed
    off the origin: ``load_scene(as_voxels=True)`` and the CLI draw it, ids intact.

    catches: the image suffixes missing from the grid readers (refused as unknown).
    """
    import vtk

    from pv_cubemarch import cli

    ids = np.array([0, 2**31 + 5, 4_000_000_000, 7], np.uint32)
    values = scattered(ids[1:], fill=0.6, shape=(12, 10, 8)).astype(np.uint32)
    image = pv.ImageData(dimensions=values.shape, spacing=(0.5, 1.0, 2.0), origin=(3, 4, 5))
    image.point_data["labels"] = values.ravel(order="F")
    writer = vtk.vtkMetaImageWriter()
    writer.SetFileName(str(tmp_path / "cells.mha"))
    writer.SetCompression(False)
    writer.SetInputData(image)
    writer.Write()
    scene = cm.load_scene(tmp_path / "cells.mha", as_voxels=True)
    model = scene.voxels[0]
    assert model.ids.ids.tolist() == [7, 2**31 + 5, 4_000_000_000]
    assert np.array_equal(model.ids.ids_of(model.labels), values)
    out = tmp_path / "cells.png"
    assert cli.main(["render", str(tmp_path / "cells.mha"), "--technique", "voxels",
                     "--out", str(out), "--size", "96x80"]) == 0
    from PIL import Image
    assert np.asarray(Image.open(out))[..., :3].std() > 5   # something drawn


class CountingSource:
    """An array source that records the boxes read (zarr underneath)."""

    def __init__(self, array):
        self.array, self.shape, self.dtype, self.reads = array, array.shape, array.dtype, []
        self.threads = set()

    def __getitem__(self, box):
        import threading

        block = self.array[box]
        self.reads.append(block.size)
        self.threads.add(threading.get_ident())
        return block


def test_a_zarr_array_is_drawn_by_chunks_never_read_whole(tmp_path):
    """uint64 ids in a zarr store drawn as a chunked world: exact, picked and hidden by id;
    every read one chunk's box; 73,728 ids in 4-byte rows.

    catches (seen failing): the second pass writing ids instead of rows (uint64 values
    truncated into the world's uint16 chunks: wrong ids everywhere).
    """
    import zarr

    rng = np.random.default_rng(0)
    ids = (2**40 + rng.choice(10**6, 3000, replace=False)).astype(np.uint64)
    labels = scattered(ids, fill=0.3, shape=(48, 40, 32)).astype(np.uint64)
    store = zarr.create_array(store=str(tmp_path / "cells.zarr"), shape=labels.shape,
                              chunks=(16, 16, 16), dtype="uint64")
    store[...] = labels
    source = CountingSource(zarr.open_array(str(tmp_path / "cells.zarr"), mode="r"))
    pl = plotter()
    actor = cm.add_voxels(pl, source, chunk_size=16, mode="id")
    assert max(source.reads) <= 16**3 and len(source.reads) == 2 * 3 * 3 * 2
    assert len(source.threads) == 1   # a reader not known to be thread-safe: one thread
    from pv_cubemarch.models.array_sources import thread_safe
    assert thread_safe(source.array) and not thread_safe(source)   # zarr: several threads
    camera = aim(pl, (80.0, 70.0, 60.0), (24.0, 20.0, 16.0))
    wrong, hit, hits, seen = wrong_ids(pl, actor, labels, camera)
    assert hit > 2000 and wrong == 0
    y, x = np.argwhere(seen)[len(np.argwhere(seen)) // 3]
    assert actor.cubemarch.pick(int(x), int(y)).label == int(hits.material[y, x])
    actor.cubemarch.hide_labels(ids[:1500])
    assert wrong_ids(pl, actor, labels, camera, shown=ids[1500:])[0] == 0
    many = zarr.create_array(store=str(tmp_path / "many.zarr"), shape=(48, 48, 32),
                             chunks=(16, 16, 16), dtype="uint32")
    many[...] = np.arange(48 * 48 * 32, dtype=np.uint32).reshape(48, 48, 32) + 70000
    world = cm.add_voxels(pl, many, chunk_size=16).cubemarch   # 4-byte rows by chunks
    assert world.model.dtype == np.uint32 and world.n_labels == 48 * 48 * 32
    pl.close()


def test_an_array_of_absurd_shape_is_refused_before_its_chunks_are_listed(tmp_path):
    # A header of 100000³ voxels (nothing written): 478 million chunks of 128³. Refused
    # by the count, naming the streamed way, before any box is listed or read.
    # catches (seen failing; found by a review): every box listed first (the review: 71 s,
    # 4.4 GB, then a bare MemoryError; here the test ran past 150 s).
    import zarr

    store = zarr.create_array(str(tmp_path / "huge.zarr"), shape=(100000,) * 3,
                              chunks=(512, 512, 512), dtype=np.uint16)
    pl = pv.Plotter(off_screen=True, window_size=(32, 24))
    with pytest.raises(cm.VolumeDataError, match=r"478,211,768 chunks.*\[array\]"):
        cm.add_voxels(pl, store)
    pl.close()


def test_a_world_past_its_host_budget_stops_reading_and_says_how_to_stream(tmp_path,
                                                                         monkeypatch):
    """A chunked array whose chunks would not fit the host memory a world may keep stops
    being read once they pass it, with an error naming the streamed way; that way draws it
    (ids exact against the CPU traversal). A sparse one under the same budget is drawn
    whole: chunks of one label keep no array.

    catches (seen failing): no budget (every chunk read and kept: 18 of 18 chunks read, no
    error).
    """
    import zarr

    rng = np.random.default_rng(3)
    labels = rng.integers(1, 200, (48, 40, 32)).astype(np.uint16)   # no chunk of one label
    store = zarr.create_array(store=str(tmp_path / "dense.zarr"), shape=labels.shape,
                              chunks=(16, 16, 16), dtype="uint16")
    store[...] = labels
    source = CountingSource(zarr.open_array(str(tmp_path / "dense.zarr"), mode="r"))
    monkeypatch.setenv("PV_CUBEMARCH_WORLD_BYTES", str(5 * 16**3))   # five 1-byte chunks
    pl = plotter()
    with pytest.raises(cm.VolumeDataError, match=r"more than the 20,480 bytes.*"
                       r"add_voxels\(plotter, \[array\]\).*PV_CUBEMARCH_WORLD_BYTES"):
        cm.add_voxels(pl, source, chunk_size=16, mode="id")
    assert len(source.reads) < 2 * 3 * 3 * 2 - 6, len(source.reads)
    actor = cm.add_voxels(pl, [source.array], mode="id")   # what the error says: streamed
    camera = aim(pl, (80.0, 70.0, 60.0), (24.0, 20.0, 16.0))
    for _ in range(40):   # the bricks arrive over a few frames
        cm.render_image(pl)
        if not actor.cubemarch.pager.stats()["missing"]:
            break
    wrong, hit, _, _ = wrong_ids(pl, actor, labels, camera)
    assert hit > 2000 and wrong == 0
    sparse = zarr.create_array(store=str(tmp_path / "sparse.zarr"), shape=labels.shape,
                               chunks=(16, 16, 16), dtype="uint16")
    sparse[:16, :16, :16] = labels[:16, :16, :16]   # one stored chunk; the rest empty
    sparse[32:, 16:32, 16:] = 7                     # or one label
    world = cm.add_voxels(pl, sparse, chunk_size=16, mode="id").cubemarch.model
    assert len(world.stored) == 1 and len(world.uniform) == 1
    pl.close()


def test_a_numpy_grid_over_one_texture_goes_by_chunks_without_a_whole_copy(monkeypatch):
    """A numpy array of coherent uint64 ids larger than one texture (the limit lowered) is
    read into a world chunk by chunk, never compacted whole: drawn exact, picked by id.

    catches (seen failing): a run's row looked up from the run before it's id, and the whole
    grid compacted first (compact_labels called).
    """
    from pv_cubemarch import api
    from pv_cubemarch.models import label_ids

    monkeypatch.setattr(api, "fits_one_texture", lambda shape, dtype: False)
    monkeypatch.setattr(api, "DEFAULT_CHUNK_SIZE", 8)
    rng = np.random.default_rng(8)
    ids = (2**40 + rng.choice(10**6, 90, replace=False)).astype(np.uint64)[::-1].copy()
    lengths = rng.integers(1, 12, 2000)
    labels = np.repeat(rng.choice(ids, lengths.size), lengths)[:24 * 20 * 16].reshape(SHAPE)
    labels[rng.random(SHAPE) < 0.4] = 0

    def refused(*args, **kwargs):
        raise AssertionError("the whole grid compacted")

    monkeypatch.setattr(label_ids, "compact_labels", refused)
    pl = plotter()
    actor = cm.add_voxels(pl, labels, mode="id")
    assert actor.cubemarch.model.stored   # a world of chunks
    camera = aim(pl)
    wrong, hit, hits, seen = wrong_ids(pl, actor, labels, camera)
    assert hit > 2000 and wrong == 0
    y, x = np.argwhere(seen)[len(np.argwhere(seen)) // 2]
    assert actor.cubemarch.pick(int(x), int(y)).label == int(hits.material[y, x])
    pl.close()


def test_the_live_view_says_how_many_ids_it_lists():
    # catches: the label knob silent about ids past the 64 listed
    from pv_cubemarch.views.session import TuningSession

    labels = np.arange(1, 201, dtype=np.uint32).reshape(10, 5, 4) + 2**31
    pl = plotter()
    cm.add_voxels(pl, labels, name="cells")
    knob = next(k for k in TuningSession.from_plotter(pl).knobs("voxels")
                if k.name == "materials")
    assert knob.label == "labels shown (200 ids; the first 64 listed)"
    assert len(knob.choices) == 64 and knob.choices[0] == 2**31 + 1
    pl.close()


@pytest.mark.parametrize(("traversal", "mode"), [("index", "id"), ("per_chunk", "face")])
def test_a_chunked_world_of_more_than_65535_ids(traversal, mode):
    """115,000 uint64 ids drawn in chunks (4-byte rows in the chunk pool): exact against
    the reference, hidden by id, edited and picked.

    catches (seen failing): world edits narrowing 4-byte rows to uint16 (the type a label
    above 255 widened a uint8 world to); per chunk, a palette table per chunk (every
    recolour sent to each: 115,000 ids' table times the chunks), and a recolour scanning
    the whole world for its solid bricks (4 s a change at 1024³).
    """
    rng = np.random.default_rng(0)
    shape = (64, 64, 48)
    labels = rng.permutation(np.prod(shape)).reshape(shape).astype(np.uint64) + 2**40
    labels[rng.random(shape) < 0.4] = 0
    labels[:16, :16, :16] = 2**40 + 5   # a uniform chunk
    pl = plotter()
    actor = cm.add_voxels(pl, labels, chunk_size=16, mode=mode, world_traversal=traversal)
    world = actor.cubemarch
    assert world.model.dtype == np.uint32 and world.n_labels > 65536
    camera = aim(pl, (120.0, 110.0, 90.0), (32.0, 32.0, 24.0))

    def wrong(shown=None):
        image = cm.render_image(pl).astype(int)
        hits, hit = trace_ids(labels, np.eye(4), camera, SIZE,
                              near=pl.camera.clipping_range[0], shown=shown)
        expected = id_colors(hits, shape) if mode == "id" else np.stack(
            [np.where(hit, 32 * (hits.face + 2), 0), 0 * hit, 0 * hit], axis=-1)
        assert hit.sum() > 5000
        return int((np.any(image != expected, axis=-1) & ~hits.near_edge).sum())

    assert wrong() == 0
    ids = world.label_ids
    world.hide_labels(ids[::2])
    assert wrong(shown=ids[1::2]) == 0
    world.show_labels()
    world.fill_box((20, 20, 20), (30, 30, 30), int(ids[70000]))
    labels[20:30, 20:30, 20:30] = ids[70000]
    assert wrong() == 0
    picked = world.pick(60, 50)
    assert picked.label == int(labels[picked.index])
    if traversal == "per_chunk":   # one palette for every chunk, changed entries only
        palette = world.palette_texture
        before, size = palette.uploaded_bytes, palette.nbytes
        rebuilt = []
        world.occluders.rebuild = lambda: rebuilt.append(1)   # a scan of the whole world
        world.set_label_color(ids[5], "red")
        cm.render_image(pl)
        assert palette.uploaded_bytes - before == 16 and not rebuilt   # a colour: no scan
        world.hide_labels(ids[5])
        assert rebuilt == [1]   # what is shown changed: the solid bricks again
        assert sum(c.palette_texture is palette for c in world.chunks.values()) == len(
            world.chunks) > 10
        assert world.nbytes < sum(c.labels.nbytes for c in world.chunks.values()) + 3 * size
    pl.close()
