from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
import pyvista as pv

import pv_cubemarch as cm
from pv_cubemarch.core.registry import techniques

ROOT = Path(__file__).resolve().parents[1]
#: Every volume technique the registry holds: tests take their lists from it, so a new
#: technique is tested by every test that loops over techniques.
VOLUME_TECHNIQUES = tuple(t.name for t in techniques("volume"))
#: Those that march rays themselves (not 'auto', which picks one of them per frame).
MARCHING_TECHNIQUES = tuple(t.name for t in techniques("volume") if not t.chooses_among)
BASELINES = Path(__file__).resolve().parent / "baselines"
SCENE = ROOT / "datasets" / "smoke_scene.usda"
BACKGROUND = (0.1, 0.1, 0.12)
#: The colormap the tests' tolerances were measured with: add_volume's default follows
#: PyVista's theme (as pyvista's add_volume does), so the tests fix the theme's.
#: test_pyvista_parity.py checks the default against PyVista's own under another theme cmap.
pv.global_theme.cmap = "magma"


SYSTEM_PYTHON = "/usr/bin/python3"
VDB_MAKER = Path(__file__).resolve().parent / "tools" / "vdb_reference.py"
MISSING_REFERENCE = (
    f"{SYSTEM_PYTHON} cannot import pyopenvdb, the reference library the OpenVDB tests "
    "compare with: install Debian's python3-openvdb (apt-get install python3-openvdb; "
    "tools/setup.sh does it when run as root)")


def has_pyopenvdb() -> bool:
    """Whether the system python has libopenvdb's bindings (the reader's oracle)."""
    try:
        return subprocess.run([SYSTEM_PYTHON, "-c", "import pyopenvdb"], timeout=60,
                              capture_output=True).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


@pytest.fixture(scope="session")
def ref_dir(tmp_path_factory):
    """Reference files written by OpenVDB itself, with what OpenVDB reads back from them."""
    assert has_pyopenvdb(), MISSING_REFERENCE   # a failure, never a skip
    out = tmp_path_factory.mktemp("vdb")
    subprocess.run([SYSTEM_PYTHON, str(VDB_MAKER), "write", str(out)], check=True,
                   timeout=600)
    return out


def pytest_collection_modifyitems(config, items):
    """Leave the tests marked slow to their own step (``pytest -m slow``).

    Unless a ``-m`` or ``-k`` expression chooses, or test files or ids are named
    (``pytest tests/test_wheel.py``).
    """
    named = any(arg.split("::")[0].endswith(".py") for arg in config.args)
    if config.getoption("markexpr") or config.getoption("keyword") or named:
        return
    slow = [item for item in items if item.get_closest_marker("slow")]
    if slow:
        config.hook.pytest_deselected(items=slow)
        items[:] = [item for item in items if not item.get_closest_marker("slow")]


def pytest_addoption(parser):
    parser.addoption("--update-baselines", action="store_true",
                     help="rewrite tests/baselines/*.png from the current rendering")


@pytest.fixture
def update_baselines(request):
    return request.config.getoption("--update-baselines")


def blob_grid(n=24, shape=None, spacing=None, origin=(-1.0, -1.0, -1.0)):
    shape = shape or (n, n, n)
    spacing = spacing or tuple(2.0 / (s - 1) if s > 1 else 1.0 for s in shape)
    axes = [origin[i] + spacing[i] * np.arange(shape[i]) for i in range(3)]
    x, y, z = np.meshgrid(*axes, indexing="ij")
    d = np.exp(-3 * (x**2 + y**2 + z**2))
    d += 0.4 * np.exp(-25 * ((x - 0.4) ** 2 + (y + 0.3) ** 2 + z**2))
    grid = pv.ImageData(dimensions=shape, spacing=spacing, origin=origin)
    grid.point_data["density"] = d.ravel(order="F").astype(np.float32)
    return grid


@pytest.fixture
def blob():
    return blob_grid()


@pytest.fixture
def plotter_factory():
    made = []

    def make(size=(96, 96)):
        pl = cm.offscreen_plotter(size)
        pl.set_background(BACKGROUND)
        made.append(pl)
        return pl

    yield make
    for pl in made:
        pl.close()


def set_camera(pl, position, focal=(0, 0, 0), up=(0, 1, 0), angle=30.0):
    pl.camera.position = position
    pl.camera.focal_point = focal
    pl.camera.up = up
    pl.camera.view_angle = angle
    pl.renderer.ResetCameraClippingRange()
    return cm.Camera.from_pyvista(pl.camera)


def technique_options(model, technique, step_scale=0.5, pixels=40.0):
    """add_volume options giving ``step_scale``'s samples per ray with any technique.

    The cube map takes its samples from ``max_samples`` and its LOD, not ``step_scale``:
    it gets the same samples along the diagonal, and the ``sample_factor`` (k_c) for which
    the LOD's N_ideal reaches them at a projected edge of about ``pixels``, so the face
    size stays near the projected size (S = sqrt(3) N / k_c) in these small test images.
    """
    if technique != "cubemap":
        return {"technique": technique, "step_scale": step_scale}
    samples = max(1, round((max(model.dimensions) - 1) / step_scale))
    return {"technique": technique, "max_samples": samples,
            "sample_factor": np.sqrt(3.0) * samples / pixels}


def assert_close_to_reference(image, reference, min_psnr, background=BACKGROUND, margin=6.0):
    """``image`` within ``min_psnr`` of ``reference``, a floor the background alone fails.

    The background-only image must score at least ``margin`` dB under the floor, so a
    volume that is not drawn at all can never pass (catches: floors such as 15 dB that a
    blank frame meets).
    """
    from pv_cubemarch.image_metrics import compare_images, to_uint8

    errors = compare_images(image, reference)
    blank = np.broadcast_to(to_uint8(np.asarray(background, dtype=float)), image.shape)
    empty = compare_images(np.ascontiguousarray(blank), reference)
    assert empty.psnr <= min_psnr - margin, f"the floor {min_psnr} dB is too low: {empty}"
    assert errors.psnr >= min_psnr, errors
    return errors


def rotation_y(degrees):
    """4x4 right-handed rotation about +y (USD's ``rotateY``)."""
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    matrix = np.eye(4)
    matrix[0, 0], matrix[0, 2], matrix[2, 0], matrix[2, 2] = c, s, -s, c
    return matrix


def write_voxel_stage(tmp_path, labels, *, attrs=None, field_attrs=None, technique="voxels",
                      file_name="labels.npy", translate=(1.0, -2.0, 0.5), rotate_y=20.0,
                      eye=(17.0, 12.0, 20.0), target=(7.0, 4.0, 5.7), stage_name="vox.usda"):
    """A stage with a camera ``/Cam`` and a Volume ``/Vox`` whose ``field:labels`` prim
    ``/Vox/labels`` names ``labels`` saved as ``file_name`` (``.npy``; pass ``labels=None``
    to write the file yourself). ``attrs``/``field_attrs``: ``{name: (type name, value)}``
    authored on the volume / field prim; ``technique=None`` leaves ``cubemarch:technique``
    out. The volume is placed by ``translate`` then ``rotate_y`` (degrees)."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdVol

    if labels is not None:
        np.save(tmp_path / file_name, labels)
    stage = Usd.Stage.CreateNew(str(tmp_path / stage_name))
    camera = UsdGeom.Camera.Define(stage, "/Cam")
    camera.CreateFocalLengthAttr(20.0)
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.5, 500.0))
    look = Gf.Matrix4d().SetLookAt(Gf.Vec3d(*eye), Gf.Vec3d(*target), Gf.Vec3d(0, 1, 0))
    UsdGeom.Xformable(camera).AddTransformOp().Set(look.GetInverse())
    volume = UsdVol.Volume.Define(stage, "/Vox")
    UsdGeom.Xformable(volume).AddTranslateOp().Set(Gf.Vec3d(*translate))
    UsdGeom.Xformable(volume).AddRotateYOp().Set(float(rotate_y))
    field = stage.DefinePrim("/Vox/labels")
    field.CreateAttribute("filePath", Sdf.ValueTypeNames.Asset).Set(
        Sdf.AssetPath(f"./{file_name}"))
    volume.CreateFieldRelationship("labels", field.GetPath())
    prim = volume.GetPrim()
    if technique is not None:
        prim.CreateAttribute("cubemarch:technique", Sdf.ValueTypeNames.Token).Set(technique)
    for target_prim, given in ((prim, attrs), (field, field_attrs)):
        for name, (kind, value) in (given or {}).items():
            target_prim.CreateAttribute(name, getattr(Sdf.ValueTypeNames, kind)).Set(value)
    stage.GetRootLayer().Save()
    return tmp_path / stage_name


def rotated_mirrored_placement() -> np.ndarray:
    """A placement that rotates 30 degrees about z, mirrors x and stretches y by 1.5."""
    angle = np.radians(30.0)
    rotation = np.eye(4)
    rotation[:2, :2] = [[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]]
    return rotation @ np.diag([-1.0, 1.5, 1.0, 1.0])


def light_with_sun_and_lamp(pl) -> None:
    """Replace the plotter's lights by a directional scene light and a point light."""
    pl.remove_all_lights()
    pl.add_light(pv.Light(position=(1.0, 2.0, 3.0), focal_point=(0, 0, 0),
                          light_type="scene light", intensity=0.8))
    point = pv.Light(position=(-20.0, 30.0, 20.0), light_type="scene light", intensity=0.5,
                     positional=True)
    point.cone_angle = 180.0
    pl.add_light(point)


def draw_at(add, size, position, background="black"):
    """``add(pl)``'s image, the actor it returns and the camera, seen from ``position``."""
    import pyvista as pv

    import pv_cubemarch as cm

    pl = pv.Plotter(off_screen=True, window_size=size)
    pl.set_background(background)
    actor = add(pl)
    pl.camera_position = position
    image = cm.render_image(pl)
    camera = cm.Camera.from_pyvista(pl.camera)
    pl.close()
    return image, actor, camera


@pytest.fixture(scope="module")
def client():
    """A LocalCluster of 2 processes (one thread each) and its client, for a test module."""
    import distributed

    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=":0")
    with distributed.Client(cluster) as started:
        yield started
    cluster.close()


@pytest.fixture
def quality_cache(tmp_path, monkeypatch):
    """quality='s choices kept in a folder of the test's own, none in memory."""
    from pv_cubemarch.quality import cache
    monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path / "cache"))
    cache.forget()
    yield cache
    cache.forget()


def stored_settings() -> list[dict]:
    """The settings quality= stored in the cache file (the quality_cache fixture's)."""
    import json

    from pv_cubemarch.quality import cache
    return [entry["setting"] for entry in json.loads(cache.cache_file().read_text()).values()]


@pytest.fixture
def seen(monkeypatch):
    """The cameras quality= calibrations are run with, in order."""
    from pv_cubemarch.quality import probe
    cameras = []
    calibrate = probe.calibrate

    def spy(tracks, render, reference, camera, *rest, **keywords):
        cameras.append(camera)
        return calibrate(tracks, render, reference, camera, *rest, **keywords)
    monkeypatch.setattr(probe, "calibrate", spy)
    return cameras


def headlit_plotter(size):
    """An offscreen plotter lit by one headlight (the light quality= calibrates with)."""
    from pv_cubemarch.core.rendering import offscreen_plotter
    plotter = offscreen_plotter(size)
    plotter.ren_win.SetMultiSamples(0)
    plotter.remove_all_lights()
    plotter.add_light(pv.Light(light_type="headlight"))
    return plotter
