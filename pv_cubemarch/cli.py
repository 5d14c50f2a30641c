"""The ``pv-cubemarch`` command: render a scene, describe a scene or the GL stack."""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shlex
import sys
import warnings
from pathlib import Path

import numpy as np
from PIL import Image

from .api import add_volume, add_voxels, is_multiscale_input
from .bench import cluster as bench_cluster
from .bench import device as bench_device
from .bench import dial as bench_dial
from .bench import edits as bench_edits
from .bench import harness as bench
from .bench import labels as bench_labels
from .bench import large as bench_large
from .bench import outofcore as bench_outofcore
from .bench import resolution as bench_resolution
from .bench import scene_prims as bench_prims
from .bench import soak as bench_soak
from .bench import sort_last as bench_sort_last
from .bench import surface_layers as bench_surface_layers
from .bench import surfaces as bench_surfaces
from .bench import voxel_layers as bench_layers
from .bench import voxels as bench_voxels
from .bench import world as bench_world
from .bench.layer_rows import format_layer_table
from .bench.voxels import ROWS as VOXEL_ROWS
from .cluster import orbit, render_frames, render_sort_last
from .cluster.frames import local_client
from .cluster.offload import bench_offload
from .cluster.partition_march import LABEL_KEYWORDS, PARTITION_BLENDING, PARTITION_KEYWORDS
from .cluster.sort_last import SplitRenderer, prepare_split
from .core.declared import KINDS, declared, option, options_markdown
from .core.errors import CubemarchError, RefusedOptionsError, SceneWarning, VolumeDataError
from .core.offscreen import gl_info
from .core.registry import get_technique, specific_option_names, techniques
from .core.rendering import offscreen_plotter, render_image
from .models.multiscale import multiscale_source
from .models.surface import SPLINES
from .models.voxels import VoxelModel, count_labels, label_legend
from .models.zarr_store import checked_local_store
from .scene.grids import read_grid
from .scene.io import load_scene
from .scene.model import camera_for_bounds
from .views.app import WINDOW_MODES, serve
from .views.cluster_view import ClusterDisplay, serve_cluster
from .volume.binding import BLEND_MODES
from .volume.options import PAGED_ONLY
from .voxels.options import CALL_ONLY as VOXEL_CALL_ONLY
from .voxels.options import PAGED_LABELS_ONLY, VoxelOptions


def _size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must look like 800x600, got {text!r}") from None
    if width < 1 or height < 1:
        raise argparse.ArgumentTypeError(f"size must be positive, got {text!r}")
    return width, height


def _port(text: str) -> int:
    """A TCP port, 0 (any free one) to 65535."""
    try:
        port = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"port must be a whole number, got {text!r}") from None
    if not 0 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"port must be 0 to 65535, got {port}")
    return port


def _image_path(text: str) -> str:
    """An image file to write (its folder made if missing): an extension PIL writes."""
    from PIL import Image

    path = Path(text).expanduser()
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} is a folder; give an image file in it, "
                                         "e.g. out.png")
    Image.init()
    writes = {ext for ext, kind in Image.registered_extensions().items() if kind in Image.SAVE}
    if path.suffix.lower() not in writes:
        raise argparse.ArgumentTypeError(f"{text!r} has no image extension PIL writes; end "
                                         "it with .png (or .jpg, .tif)")
    return str(path)


def _shape(text: str) -> tuple[int, int, int]:
    """``XxYxZ`` points or voxels of a grid."""
    try:
        shape = tuple(int(v) for v in text.lower().split("x"))
        if len(shape) != 3 or min(shape) < 1:
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(f"a shape looks like 192x128x96, got {text!r}") \
            from None
    return shape


def _partitions(text: str) -> int | tuple[int, int, int]:
    """A count of slabs, or bricks per axis ``NxNxN``."""
    if "x" in text.lower():
        return _shape(text)
    try:
        count = int(text)
        if count < 1:
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(f"partitions are a positive count (4) or bricks per "
                                         f"axis (2x2x2), got {text!r}") from None
    return count


def _sizes(text: str) -> list[tuple[int, int]]:
    return [_size(part) for part in text.split(",") if part.strip()]


def _face_sizes(text: str) -> list[int]:
    if text.strip().lower() == "none":
        return []
    try:
        return [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"face sizes must look like 128,64 (or 'none'), got {text!r}") from None


#: Argument groups of the option flags, by kind.
FLAG_GROUPS = {
    "volume": "volumes (every volume of the scene)",
    "voxels": 'voxels (--technique voxels, or Volume prims with cubemarch:technique = '
              '"voxels")',
    "surface": 'surfaces (--isovalue on a grid file, or Volume prims with '
               'cubemarch:technique = "surface")'}


def add_option_flags(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    """A flag for every declared option that has one (:mod:`pv_cubemarch.core.declared`).

    A flag several kinds declare (``--ambient``, ``--shading`` ...) is added once and
    goes to each of them; its help lists each meaning. Returns the actions by flag.
    """
    actions: dict[str, argparse.Action] = {}
    for kind in KINDS:
        group = parser.add_argument_group(FLAG_GROUPS[kind])
        for item in declared(kind):
            if item.flag is None:
                continue
            where = f"{kind}" + (f" ({', '.join(item.techniques)})" if item.techniques
                                 else "")
            default = "" if item.default is None else f"; default {item.default}"
            text = f"{where}: {item.doc}{default}"
            if item.flag in actions:   # one flag, every kind's choices (each checks its own)
                shared = actions[item.flag]
                shared.help += f"; {text}"
                if shared.choices and item.choices:
                    shared.choices = tuple(dict.fromkeys((*shared.choices, *item.choices)))
                continue
            settings = flag_settings(item, text)
            if item.name == "technique" and kind == "volume":
                settings.pop("type", None)
                settings["choices"] = [t.name for t in _techniques()]
                settings["help"] = "how every volume is drawn: " + "; ".join(
                    f"{t.name}: {t.summary}" for t in _techniques()) + \
                    ". With voxels every volume must hold integer labels"
            actions[item.flag] = group.add_argument(item.flag, **settings)
    return actions


def flag_settings(item, text: str, choices=None) -> dict:
    """``add_argument`` settings of a declared option's flag (``choices``: a subset)."""
    settings: dict = {"dest": item.dest, "default": None, "help": text}
    if item.parse is not None:
        settings["type"] = item.parse
    elif item.type is bool:
        settings["action"] = argparse.BooleanOptionalAction
    elif item.type is tuple:
        settings.update(type=float, nargs="+")
    elif item.choices:
        settings["choices"] = choices or item.choices
    else:
        settings["type"] = {int: int, float: float}.get(item.type, str)
    return settings


def given_options(args, kind: str) -> dict:
    """The options of ``kind`` given on the command line (their flags' values).

    A numbers flag given one number passes that number (``--clim 3``: ``clim=3``, which a
    volume reads as -3..3, as in Python).
    """
    given = {item.name: getattr(args, item.dest) for item in declared(kind)
             if item.flag is not None and item.name != "technique"
             and getattr(args, item.dest, None) is not None}
    return {name: value[0] if isinstance(value, list) and len(value) == 1 else value
            for name, value in given.items()}


def _reference_flags(command) -> None:
    """A bench's flags for computing its CPU references on a cluster."""
    command.add_argument("--scheduler", help="compute the CPU references on this Dask "
                                             "scheduler's workers (tcp://host:8786); the "
                                             "rows are still timed here, side by side")
    command.add_argument("--workers", type=int,
                         help="compute the CPU references on a local cluster of this many "
                              "processes, before any row is timed")


def _cluster_flags(command) -> None:
    """The flags every command rendering a batch on a cluster takes."""
    command.add_argument("--size", type=_size, default=(800, 600),
                         help="WxH (default 800x600)")
    command.add_argument("--workers", type=int,
                         help="processes of the local cluster started for the run (default 2)")
    command.add_argument("--scheduler", help="address of a running Dask scheduler to use "
                                             "instead (tcp://host:8786)")
    command.add_argument("--fps", type=float, default=24.0, help="a movie's frame rate")
    command.add_argument("--no-progress", action="store_true", help="hide the progress bar")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (exposed for tests and documentation)."""
    parser = argparse.ArgumentParser(prog="pv-cubemarch", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)
    render = commands.add_parser("render", help="render a scene file to a PNG image")
    render.add_argument("scene", help="USD stage, mesh file (OBJ, STL, PLY, OFF, GLB, glTF), "
                                      "grid file (.vti, .vtk, .npy, .npz) or .zarr source "
                                      "(an OME-Zarr pyramid or zarr array, streamed by "
                                      "bricks; with --technique voxels, labels)")
    render.add_argument("--out", "-o", required=True, type=_image_path,
                        help="output PNG path")
    render.add_argument("--size", type=_size, default=(800, 600), help="WxH (default 800x600)")
    render.add_argument("--camera", help="name (prim path) of the scene camera to use")
    add_option_flags(render)
    render.add_argument("--chunk-size", type=int,
                        help="draw each voxel grid in chunks of this edge (a voxel world)")
    render.add_argument("--isovalue", type=float,
                        help="draw a grid file's field as its implicit surface at this level "
                             "(a quadratic B-spline through its samples)")
    render.add_argument("--spline", choices=SPLINES,
                        help="with --isovalue: interpolating (through the samples, the "
                             "default) or approximating (never overshooting them)")
    for flag, axis in (("--channel", "channel"), ("--timepoint", "time")):
        render.add_argument(flag, type=int,
                            help=f"an OME-Zarr source's {axis} index to draw (default 0)")
    render.add_argument("--no-progress", action="store_true", help="hide progress bars")
    frames = commands.add_parser("render-frames", help="render an orbit of a scene on a Dask "
                                                       "cluster (PNG frames or a movie)")
    frames.add_argument("scene", help="scene file, as for render")
    frames.add_argument("--out", "-o", required=True,
                        help="folder for frame_00000.png ..., or a movie (.mp4, .gif)")
    frames.add_argument("--orbit", type=int, default=64,
                        help="frames turning once around the scene camera's focal point "
                             "(default 64)")
    frames.add_argument("--camera", help="name of the scene camera the orbit starts from")
    _cluster_flags(frames)
    split = commands.add_parser(
        "render-sort-last", help="render an orbit of a volume split across a Dask cluster's "
                                 "workers (each reads and marches its slab; sort-last)")
    split.add_argument("volume", help="grid file (.vti, .vtk, .nrrd, .npy, .npz) or zarr "
                                      "array (a folder: each worker reads its slab)")
    split.add_argument("--out", "-o",
                       help="folder for frame_00000.png ..., or a movie (.mp4, .gif)")
    split.add_argument("--live", action="store_true",
                       help="instead of writing an orbit, serve a live view whose frames the "
                            "cluster draws as the mouse turns the camera (trame)")
    split.add_argument("--port", type=_port, default=8080, help="the live view's port")
    split.add_argument("--host", default="127.0.0.1",
                       help="address the live view listens on (default: this machine only)")
    split.add_argument("--partitions", type=_partitions,
                       help="slabs to cut the volume into along the axis (default: a zarr "
                            "array's chunks along it, else 2), or bricks per axis as 2x2x2")
    split.add_argument("--axis", choices=("x", "y", "z"),
                       help="axis the slabs are cut along (default: the one with most "
                            "points)")
    split.add_argument("--spacing", type=float, nargs=3, help="a zarr array's point spacing")
    split.add_argument("--origin", type=float, nargs=3, help="a zarr array's origin")
    split.add_argument("--orbit", type=int, default=64,
                       help="frames turning once around the volume (default 64)")
    _cluster_flags(split)
    split.add_argument("--technique", choices=("direct", "voxels"), default="direct",
                       help="direct: a volume (default); voxels: a label grid, each slab's "
                            "nearest voxel kept")
    flags: set = set()
    for kind, names in (("volume", PARTITION_KEYWORDS), ("voxels", LABEL_KEYWORDS)):
        for item in declared(kind):   # the look a split volume or label grid can take
            if item.name in names and item.flag is not None and item.flag not in flags:
                flags.add(item.flag)
                split.add_argument(item.flag, **flag_settings(
                    item, f"{kind}: {item.doc}",
                    PARTITION_BLENDING if item.name == "blending" else None))
    commands.add_parser("options", help="print every option's table (docs/options.md): its "
                                         "flag, USD attribute and live-view control")
    info = commands.add_parser("info", help="describe a scene, or the OpenGL stack with --gl")
    info.add_argument("scene", nargs="?", help="scene file to describe")
    for command in (render, info):
        command.add_argument("--time", type=float,
                             help="USD time code to read animated values at (default: the "
                                  "stage's start time when it is animated)")
        command.add_argument("--strict", action="store_true",
                             help="fail at the first prim that cannot be read, instead of "
                                  "leaving it out with a note")
    info.add_argument("--gl", action="store_true", help="report the window class and GL strings")
    info.add_argument("--json", action="store_true", help="print JSON instead of text")
    view = commands.add_parser("view", help="serve a live view of a scene with its techniques' "
                                            "knobs (a trame app on localhost)")
    view.add_argument("scene", nargs="?", help="scene file (default: the shipped "
                                               "datasets/smoke_scene.usda)")
    view.add_argument("--port", type=_port, default=8080, help="port (default 8080)")
    view.add_argument("--host", default="127.0.0.1",
                      help="address to listen on (default 127.0.0.1: this machine only; "
                           "any other address warns: the view is then reachable by anyone "
                           "holding its URL, which carries a fresh secret)")
    view.add_argument("--size", type=_size, default=(800, 600),
                      help="view size WxH (default 800x600)")
    view.add_argument("--window", choices=WINDOW_MODES, default="auto",
                      help="where the app opens: app (a desktop window, needs pywebview), "
                           "browser (the default browser), none (serve only); auto "
                           "(default): browser where a display exists, else none")
    bench = commands.add_parser("bench", help="speed/accuracy measurements")
    bench_commands = bench.add_subparsers(dest="bench_command", required=True)
    tradeoff = bench_commands.add_parser(
        "tradeoff", help="sweep a technique's quality settings: frame time against error")
    tradeoff.add_argument("technique", nargs="+",
                          help="technique(s) to sweep side by side: vtk, direct, cubemap, pyvista")
    tradeoff.add_argument("--scene", default=None,
                          help="scene file (default: the shipped datasets/smoke_scene.usda)")
    tradeoff.add_argument("--size", type=_size, default=(640, 480), help="WxH (default 640x480)")
    tradeoff.add_argument("--frames", type=int, default=3, help="timed frames per setting (>= 3)")
    tradeoff.add_argument("--blending", nargs="+", choices=BLEND_MODES, default=["composite"],
                          help="blend modes to measure, each against its CPU reference and "
                               "PyVista's own add_volume (default: composite)")
    tradeoff.add_argument("--json", dest="json_path", help="write the rows as JSON here")
    tradeoff.add_argument("--plot", help="write the error-against-time plot (PNG) here")
    tradeoff.add_argument("--no-stock", action="store_true",
                          help="leave out PyVista's stock add_volume rows")
    resolution = bench_commands.add_parser(
        "resolution", help="frame time of cube map, direct and stock PyVista "
                           "at 1080p, 1440p and 4K, with errors on crops")
    resolution.add_argument("--scene", default=None,
                            help="scene file (default: the shipped datasets/smoke_scene.usda)")
    resolution.add_argument("--sizes", type=_sizes, default=None,
                            help="comma-separated WxH list (default 1920x1080,2560x1440,"
                                 "3840x2160)")
    resolution.add_argument("--frames", type=int, default=3,
                            help="timed frames per row (>= 3)")
    resolution.add_argument("--crop", type=int, default=128,
                            help="side of the 3 crops compared with the CPU reference")
    resolution.add_argument("--comparable-face-sizes", type=_face_sizes, default=None,
                            help="smaller cube maps timed at the largest size, to compare "
                                 "with direct at comparable error (default 128,64; 'none')")
    resolution.add_argument("--json", dest="json_path", help="write the rows as JSON here")
    for command in (tradeoff, resolution):
        _reference_flags(command)
    voxels = bench_commands.add_parser(
        "voxels", help="material grids: fixed step, DDA with occupancy levels and "
                       "distance fields, PyVista's paths, timed side by side, wrong pixels "
                       "against the CPU traversal, the voxel report's measurements as ratios")
    voxels.add_argument("--sizes", type=_sizes, default=((1000, 1000), (400, 400)),
                        help="comma-separated WxH (default 1000x1000,400x400)")
    voxels.add_argument("--frames", type=int, default=3, help="timed frames per row")
    voxels.add_argument("--large", type=int, default=256,
                        help="side of the empty and sphere grids (default 256)")
    voxels.add_argument("--scenes", default=None,
                        help="comma-separated scene names to run (default: all)")
    voxels.add_argument("--rows", default=None,
                        help="comma-separated rows (default: all of " + ", ".join(VOXEL_ROWS)
                             + ")")
    voxels.add_argument("--json", dest="json_path", help="write the rows as JSON here")
    edits = bench_commands.add_parser(
        "voxel-edits", help="voxel edits (latency to the next correct frame, bytes uploaded) "
                            "and 3D automata (steps per second)")
    edits.add_argument("--size", type=int, default=128, help="edge of the edited grid")
    edits.add_argument("--repeats", type=int, default=3, help="timed edits of each kind")
    edits.add_argument("--automaton-sizes", type=lambda t: [int(v) for v in t.split(",")],
                       default=[64, 128], help="comma-separated automaton edges (64,128)")
    edits.add_argument("--world", type=int, default=0, metavar="COUNT",
                       help="also edit a terrain of COUNT x COUNT chunks of --size^3 (e.g. 10)")
    edits.add_argument("--json", dest="json_path", help="write the rows as JSON here")
    soak = bench_commands.add_parser(
        "soak", help="memory per 100 frames of each technique under random cameras, edits "
                     "and re-adds (flat: no leak)")
    soak.add_argument("--frames", type=int, default=500, help="frames per technique")
    soak.add_argument("--techniques", type=lambda t: [v.strip() for v in t.split(",")],
                      default=None, help=f"comma list of {', '.join(bench_soak.TECHNIQUES)}")
    soak.add_argument("--size", type=_size, default=(160, 120), help="WxH (default 160x120)")
    soak.add_argument("--json", dest="json_path", help="write the rows as JSON here")
    prims = bench_commands.add_parser(
        "scene-prims", help="USD stages of many Cube prims: load and first-frame time, beside "
                            "PyVista's one add_mesh per prim")
    prims.add_argument("--counts", type=lambda t: [int(v) for v in t.split(",")],
                       default=[500, 2000, 20000], help="prim counts (default 500,2000,20000)")
    prims.add_argument("--pyvista-max", type=int, default=4000,
                       help="largest count timed with PyVista's per-prim path (quadratic)")
    prims.add_argument("--json", dest="json_path", help="write the rows as JSON here")
    outofcore = bench_commands.add_parser(
        "outofcore", help="multiscale volumes streamed by bricks (a procedural 2 TiB "
                          "pyramid, a small one drawn whole too, the smoke as OME-Zarr): "
                          "first frame, converged, bytes read, RSS, against the coarsest "
                          "level only and the whole array in memory")
    outofcore.add_argument("--size", type=_size, default=(320, 240), help="WxH (default "
                           "320x240: every sample of a streamed volume reads a page table)")
    outofcore.add_argument("--scenes", default=",".join(bench_outofcore.SCENES),
                           help=f"comma-separated, of {', '.join(bench_outofcore.SCENES)}")
    outofcore.add_argument("--views", default=",".join(bench_outofcore.VIEWS),
                           help="comma-separated, of far, mid, close")
    outofcore.add_argument("--shape", type=_shape,
                           default=(16384, 16384, 4096),
                           help="the procedural scene's points, XxYxZ (default "
                                "16384x16384x4096: 2 TiB of uint16)")
    outofcore.add_argument("--timeout", type=float, default=120.0,
                           help="seconds a row may take to converge")
    outofcore.add_argument("--json", dest="json_path", help="write the rows as JSON here")
    cluster = bench_commands.add_parser(
        "cluster", help="an orbit of a shipped scene on a Dask LocalCluster of 1, 2 ... "
                        "processes against the serial loop and a multiprocessing.Pool "
                        "building the scene per frame: fps, speed-up, overhead, equality")
    cluster.add_argument("--scenes", default="smoke",
                         help=f"comma-separated, of {', '.join(bench_cluster.SCENES)}")
    cluster.add_argument("--frames", type=int, default=64, help="frames of the orbit")
    cluster.add_argument("--size", type=_size, default=(320, 240), help="WxH (default 320x240)")
    cluster.add_argument("--workers", default="1,2",
                         help="comma-separated LocalCluster sizes (default 1,2)")
    cluster.add_argument("--json", dest="json_path", help="write the rows as JSON here")
    sortlast = bench_commands.add_parser(
        "sortlast", help="a volume and a label grid split in 2, 4, 8 slabs over a Dask "
                         "LocalCluster (render_sort_last) against one plotter drawing the "
                         "whole: s per frame, compositing ms, MB sent, error")
    sortlast.add_argument("--shape", type=_shape, default=(192, 128, 96),
                          help="points (volume) and voxels (labels), XxYxZ")
    sortlast.add_argument("--frames", type=int, default=16, help="frames of the orbit")
    sortlast.add_argument("--size", type=_size, default=(320, 240),
                          help="WxH (default 320x240)")
    sortlast.add_argument("--partitions", default="2,4,8,2x2x2",
                          help="comma-separated slab counts along x, or bricks per axis "
                               "(default 2,4,8,2x2x2)")
    sortlast.add_argument("--workers", default="2",
                          help="comma-separated LocalCluster sizes (default 2)")
    sortlast.add_argument("--json", dest="json_path", help="write the rows as JSON here")
    labels = bench_commands.add_parser(
        "labels", help="segmentations of many uint32/uint64 ids: ours against threshold + "
                       "add_mesh, contour_labels and a volume ray cast; setup, frames, bytes, "
                       "wrong ids, recolouring and hiding")
    labels.add_argument("--size", type=_size, default=(1000, 1000),
                        help="WxH (default 1000x1000)")
    labels.add_argument("--scenes", default=",".join(bench_labels.SCENES),
                        help=f"comma-separated, of {', '.join(bench_labels.SCENES)}")
    labels.add_argument("--voxels", type=int, default=160,
                        help="cells scene: voxels a side (default 160; the issue's 512 needs "
                             "a larger machine for the PyVista rows)")
    labels.add_argument("--cells", type=int, default=20000,
                        help="cells scene: Voronoi cells (default 20000)")
    labels.add_argument("--million-voxels", type=int, default=192,
                        help="million scene: voxels a side (default 192)")
    labels.add_argument("--million-sites", type=int, default=2_200_000,
                        help="million scene: Voronoi sites (default 2.2M: about 10^6 cells "
                             "inside its ball)")
    labels.add_argument("--stride", type=int, default=2,
                        help="frog scene: keep every n-th voxel (default 2)")
    labels.add_argument("--frames", type=int, default=3, help="timed frames per row")
    labels.add_argument("--no-reference", action="store_true",
                        help="skip the CPU traversal (wrong-id pixels not counted)")
    labels.add_argument("--no-pyvista", action="store_true",
                        help="only our rows (the PyVista rows hold ~45 bytes a voxel)")
    labels.add_argument("--json", dest="json_path", help="write the rows as JSON here")
    large = bench_commands.add_parser(
        "voxel-large", help="a sparse 2048x2048x512 label volume: chunks, bytes, exactness")
    large.add_argument("--size", type=_size, default=(800, 600), help="WxH (default 800x600)")
    large.add_argument("--scale", type=float, default=1.0,
                       help="shrink the volume by this factor (default 1: 2048x2048x512)")
    large.add_argument("--frames", type=int, default=3, help="timed frames after the first")
    large.add_argument("--scene", choices=("labels", "terrain"), default="labels",
                       help="labels: sparse 2048x2048x512 segmentation (default); terrain: "
                            "4096x4096x256 FBM terrain made chunk by chunk")
    large.add_argument("--no-reference", action="store_true",
                       help="skip the CPU traversal (at full size: minutes, ~10 GB)")
    large.add_argument("--world-traversal", choices=("index", "per_chunk"),
                       help="how the chunks are drawn (default: index where its pool fits "
                            "one texture)")
    large.add_argument("--json", dest="json_path", help="write the result as JSON here")
    surfaces = bench_commands.add_parser(
        "surfaces", help="polynomial surfaces against their reference and today's tools "
                         "(time against error)")
    surfaces.add_argument("--size", type=_size, default=(720, 720),
                          help="WxH (default 720x720)")
    surfaces.add_argument("--grids", type=_face_sizes, default=[32, 128],
                          help="cells per side, comma-separated (default 32,128; 512 takes "
                               "minutes and gigabytes)")
    surfaces.add_argument("--steps", type=_face_sizes, default=[50, 500, 5000],
                          help="samples along the domain's diagonal, comma-separated "
                               "(default 50,500,5000)")
    surfaces.add_argument("--shapes", default=",".join(bench_surfaces.SHAPES),
                          help="comma-separated among " + ", ".join(bench_surfaces.SHAPES))
    surfaces.add_argument("--frames", type=int, default=3, help="timed frames per row")
    surfaces.add_argument("--json", dest="json_path", help="write the rows as JSON here")
    for command in (voxels, surfaces):
        _reference_flags(command)
    layers = bench_commands.add_parser(
        "voxel-layers", help="translucent voxel materials against PyVista's depth-peeled "
                             "meshes of the same cells")
    layers.add_argument("--size", type=_size, default=(640, 480), help="WxH (default 640x480)")
    layers.add_argument("--grids", type=_face_sizes, default=[64, 128],
                        help="voxels per side, comma-separated (default 64,128)")
    layers.add_argument("--frames", type=int, default=3, help="timed frames per row")
    layers.add_argument("--json", dest="json_path", help="write the rows as JSON here")
    surface_layers = bench_commands.add_parser(
        "surface-layers", help="translucent surfaces against PyVista's depth-peeled contours "
                               "of the same field")
    surface_layers.add_argument("--size", type=_size, default=(480, 360),
                                help="WxH (default 480x360)")
    surface_layers.add_argument("--grids", type=_face_sizes, default=[32, 64],
                                help="cells per side, comma-separated (default 32,64)")
    surface_layers.add_argument("--shapes", default=",".join(bench_surface_layers.SHAPES),
                                help="comma-separated among "
                                     + ", ".join(bench_surface_layers.SHAPES))
    surface_layers.add_argument("--frames", type=int, default=3, help="timed frames per row")
    surface_layers.add_argument("--json", dest="json_path", help="write the rows as JSON here")
    world = bench_commands.add_parser(
        "voxel-world", help="chunked voxel worlds against one grid")
    world.add_argument("--size", type=_size, default=(640, 480), help="WxH (default 640x480)")
    world.add_argument("--chunk", type=int, default=128, help="chunk edge (default 128)")
    world.add_argument("--count", type=int, default=10, help="chunks per side (default 10)")
    world.add_argument("--frames", type=int, default=3, help="timed frames per row")
    world.add_argument("--json", dest="json_path", help="write the rows as JSON here")
    dial = bench_commands.add_parser(
        "dial", help="quality=: per scene and technique, the whole ladder timed side by side "
                     "against the CPU reference, then the setting quality= chooses for each "
                     "target, its error, its cost against the cheapest that meets it, and "
                     "the calibration's time")
    dial.add_argument("--size", type=_size, default=(320, 240), help="WxH (default 320x240)")
    dial.add_argument("--frames", type=int, default=3, help="timed frames per rung")
    dial.add_argument("--scenes", default=",".join(bench_dial.SCENES),
                      help=f"comma-separated, of {', '.join(bench_dial.SCENES)}")
    dial.add_argument("--techniques", default=",".join(bench_dial.TECHNIQUES),
                      help=f"comma-separated, of {', '.join(bench_dial.TECHNIQUES)} (active: "
                           "the implicit surfaces)")
    dial.add_argument("--surface-scenes", default=",".join(bench_dial.SURFACE_SCENES),
                      help=f"comma-separated, of {', '.join(bench_dial.SURFACE_SCENES)}")
    dial.add_argument("--targets", default="30,40,50", help="dB, comma-separated")
    dial.add_argument("--orbit-size", type=_size, default=(800, 600),
                      help="WxH of the frame_budget_ms orbits (default 800x600)")
    dial.add_argument("--budget-ms", type=float, default=20.0,
                      help="frame_budget_ms of the orbits (default 20, on llvmpipe tighter "
                           "than the still frames)")
    dial.add_argument("--orbit-frames", type=int, default=32,
                      help="moving frames of each orbit (0: no orbits)")
    dial.add_argument("--orbit-techniques", default=",".join(bench_dial.ORBIT_TECHNIQUES),
                      help=f"comma-separated, of {', '.join(bench_dial.ORBIT_TECHNIQUES)}")
    dial.add_argument("--json", dest="json_path", help="write the rows as JSON here")
    device = bench_commands.add_parser(
        "device", help="the headline benches at GPU scale, each in its own process within a "
                       "time budget, and the rows Mesa measured (docs/bench_results) compared "
                       "error for error; one device.json (tools/device_check.sh runs it)")
    device.add_argument("--out", default="device_out", help="folder for device.json and the "
                                                            "sections' files")
    device.add_argument("--plan", choices=sorted(bench_device.PLANS), default="gpu",
                        help="gpu: the GPU machine's plan; quick: two small sections, to try "
                             "the script on a CPU")
    device.add_argument("--budget", type=float, default=420.0,
                        help="seconds for the whole plan (default 420)")
    device.add_argument("--report", default=None,
                        help="where to write device.json (default: in --out)")
    device.add_argument("--sections", default=None,
                        help="comma-separated section names to run (default: all)")
    return parser


#: The shipped scene the bench and the viewer use when none is given.
DEFAULT_SCENE = Path(__file__).resolve().parents[1] / "datasets" / "smoke_scene.usda"


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pv-cubemarch``; returns the process exit code."""
    args = build_parser().parse_args(argv)
    try:
        if args.command == "render":
            return _render(args)
        if args.command == "render-frames":
            return _render_frames(args)
        if args.command == "render-sort-last":
            return _render_sort_last(args)
        if args.command == "bench":
            code = _bench(args)
            _record_command(getattr(args, "json_path", None), argv)
            return code
        if args.command == "options":
            print(options_markdown(), end="")
            return 0
        if args.command == "view":
            serve(args.scene or DEFAULT_SCENE, port=args.port, host=args.host, size=args.size,
                  window=args.window)
            return 0
        return _info(args)
    except (CubemarchError, OSError, KeyError, ValueError, ImportError) as exc:
        # OSError: a port in use, a file that cannot be read; ImportError: an extra missing
        print(f"pv-cubemarch: error: {exc}", file=sys.stderr)
        return 2


def _record_command(path: str | None, argv: list[str] | None) -> None:
    """Write into a bench's JSON the command that made it (the docs' tables quote it)."""
    if not path or not Path(path).is_file():
        return
    payload = json.loads(Path(path).read_text())
    words = sys.argv[1:] if argv is None else argv
    # the environment that changes how Mesa draws (llvmpipe's threads), as the run had it
    setting = [f"{name}={os.environ[name]}" for name in ("LP_NUM_THREADS",)
               if name in os.environ]
    payload["command"] = " ".join(setting + [shlex.join(["pv-cubemarch", *words])])
    Path(path).write_text(json.dumps(payload, indent=1))


def _techniques() -> list:
    """What ``--technique`` offers: the volume techniques, then the voxel one."""
    return techniques("volume") + techniques("voxels")


def _warn(flag: str, what: str) -> None:
    print(f"pv-cubemarch: warning: --{flag.replace('_', '-')} does not apply to {what}; left "
          "out for it", file=sys.stderr)


def _render_frames(args) -> int:
    """An orbit of the scene's camera rendered on a cluster (render_frames)."""
    if args.orbit < 1:
        raise ValueError(f"--orbit must be a positive number of frames, got {args.orbit}.")
    scene = load_scene(args.scene, progress_bar=False)
    start = scene.cameras.get(args.camera) if args.camera else scene.camera
    if args.camera and start is None:
        raise KeyError(f"No camera named {args.camera!r}; the scene has {list(scene.cameras)}.")
    start = start or scene.default_camera(args.size[0] / args.size[1])
    return _written_on_cluster(args, lambda client: render_frames(
        args.scene, orbit(start, args.orbit), args.size, client=client, workers=args.workers,
        out=args.out, fps=args.fps, progress_bar=False if args.no_progress else None))


def _written_on_cluster(args, render) -> int:
    """Run ``render(client)`` on ``--scheduler``'s client or None; say what it wrote."""
    client = _cluster_client(args)
    try:
        written = render(client)
    finally:
        if client is not None:
            client.close()
    where = f"{len(written)} frames to {args.out}" if isinstance(written, list) else \
        f"{args.orbit} frames to {written}"
    print(f"wrote {where}")
    return 0


def _cluster_client(args):
    """The client of ``--scheduler``, or None (a local cluster of ``--workers``)."""
    if args.scheduler is not None and args.workers is not None:
        raise ValueError("--workers sizes the local cluster started for the run; a "
                         "--scheduler brings its own workers: give one of them.")
    if args.scheduler is None:
        return None
    from distributed import Client

    return Client(args.scheduler)


def _render_sort_last(args) -> int:
    """An orbit of a volume split across the cluster's workers (render_sort_last)."""
    if args.orbit < 1:
        raise ValueError(f"--orbit must be a positive number of frames, got {args.orbit}.")
    path = Path(args.volume)
    if not path.exists():
        raise FileNotFoundError(f"volume {args.volume!r} does not exist.")
    labels = args.technique == "voxels"
    given = {**given_options(args, "volume"), **given_options(args, "voxels")}
    allowed = LABEL_KEYWORDS if labels else PARTITION_KEYWORDS
    other = [name for name in given if name not in allowed]
    if other:
        flags = ", ".join(f"--{name.replace('_', '-')}" for name in other)
        raise ValueError(f"{flags} {'does' if len(other) == 1 else 'do'} not apply to "
                         f"--technique {args.technique}.")
    look = given if labels else {"cmap": "magma", "opacity": "linear", **given}
    if path.is_dir():   # a zarr array: read slab by slab on the workers
        import zarr

        shape = zarr.open_array(store=checked_local_store(path), mode="r").shape
        spacing = np.asarray(args.spacing or (1.0, 1.0, 1.0), float)
        origin = np.asarray(args.origin or (0.0, 0.0, 0.0), float)
        far = origin + spacing * (np.asarray(shape[:3], float) - 1.0)
        bounds = [v for pair in zip(origin, far, strict=True) for v in pair]
        volume, placed = str(path), {"spacing": spacing, "origin": origin}
    else:
        if args.spacing or args.origin:
            raise ValueError("--spacing and --origin place a zarr array; a grid file has "
                             "its own.")
        volume, placed = read_grid(path, f"volume file {args.volume}", cells=labels), {}
        bounds = volume.bounds
    if args.live:
        if args.out is not None:
            raise ValueError("--out writes an orbit and --live serves a view: give one.")
        return _live_sort_last(args, volume, camera_for_bounds(bounds), placed, look)
    if args.out is None:
        raise ValueError("give --out (a folder or a movie for the orbit) or --live.")
    cameras = orbit(camera_for_bounds(bounds), args.orbit)
    return _written_on_cluster(args, lambda client: render_sort_last(
        volume, cameras, args.size, partitions=args.partitions,
        axis=None if args.axis is None else "xyz".index(args.axis), client=client,
        workers=args.workers, out=args.out, fps=args.fps, technique=args.technique,
        progress_bar=False if args.no_progress else None, **placed, **look))


def _live_sort_last(args, volume, camera, placed: dict, look: dict) -> int:
    """Serve the live view of a split grid, its frames drawn by the cluster."""
    split, blending, background = prepare_split(
        volume, partitions=args.partitions,
        axis=None if args.axis is None else "xyz".index(args.axis),
        technique=args.technique, **placed, **look)
    with local_client(_cluster_client(args), args.workers) as client:
        display = ClusterDisplay(SplitRenderer(split, client, args.size, blending, background),
                                 camera)
        try:
            serve_cluster(display, port=args.port, host=args.host)
        finally:
            display.close()
    return 0


def _render(args) -> int:
    progress_bar = False if args.no_progress else None
    as_voxels = args.technique in {t.name for t in techniques("voxels")}
    given = {**given_options(args, "volume"), **given_options(args, "voxels")}
    if given.get("lights") == "none":
        given["lights"] = None
    reads = {f.name for f in dataclasses.fields(VoxelOptions)} | set(VOXEL_CALL_ONLY) \
        | streamed_only("voxels")
    other = [name for name in given if name not in reads]
    if as_voxels and other:   # the user asked for both: refused before loading anything
        flags = ", ".join(f"--{name.replace('_', '-')}" for name in other)
        one = len(other) == 1
        raise ValueError(f"{flags} {'is not an option' if one else 'are not options'} of "
                         f"--technique voxels; leave {'it' if one else 'them'} out.")
    if as_voxels and args.isovalue is not None:
        raise ValueError("--isovalue draws the grid as a surface, --technique voxels as "
                         "material labels: leave one out.")
    if is_multiscale_input(args.scene):
        return _render_streamed(args, as_voxels, progress_bar)
    for flag, value in (("--channel", args.channel), ("--timepoint", args.timepoint)):
        if value is not None:   # said, not ignored
            raise ValueError(f"{flag} picks an index of an OME-Zarr source's axes; "
                             f"{args.scene} is not a .zarr source: leave it out.")
    try:
        scene = _load(args, progress_bar=progress_bar, as_voxels=as_voxels,
                      isovalue=args.isovalue, spline=args.spline or "interpolating")
        for entry in (s for s in scene.skipped if s.problem):
            print(f"pv-cubemarch: note: {entry.path}: {entry.reason}", file=sys.stderr)
    except VolumeDataError as exc:
        if not as_voxels:
            raise
        raise VolumeDataError(
            f"{exc} --technique voxels draws every volume of the scene as a material grid; "
            "draw this scene with a volume technique, or leave --technique out and set "
            'cubemarch:technique = "voxels" on its labelled Volume prims only.') from exc
    given = _without_streamed_only(scene, given, as_voxels)
    _volume_options(scene, args, {k: v for k, v in given.items()
                                  if k not in streamed_only("volume")}, as_voxels)
    _voxel_options(scene, as_voxels, given)
    _surface_options(scene, args, given)
    if args.chunk_size is not None:
        grids = [grid for grid in scene.voxels if isinstance(grid, VoxelModel)]
        if not grids:   # said, not ignored
            raise ValueError("--chunk-size draws label grids in chunks; this scene has none "
                             "(give --technique voxels to draw its grids as labels, or leave "
                             "--chunk-size out).")
        for grid in grids:   # worlds keep their own chunks
            scene.voxel_options.setdefault(grid.name, {})["chunk_size"] = args.chunk_size
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", SceneWarning)
        scene.render(args.out, size=args.size, camera=args.camera, progress_bar=progress_bar)
    for warning in caught:
        if issubclass(warning.category, SceneWarning):
            print(f"pv-cubemarch: note: {warning.message}", file=sys.stderr)
        else:
            warnings.warn_explicit(warning.message, warning.category, warning.filename,
                                   warning.lineno)
    print(f"wrote {args.out} ({args.size[0]}x{args.size[1]})")
    return 0


#: How long ``render`` waits for a streamed source's bricks before writing what it has.
STREAM_TIMEOUT_S = 600.0


def streamed_only(kind: str) -> set[str]:
    """The options of ``kind`` read only for a source streamed by bricks (a ``.zarr``)."""
    reason = (PAGED_ONLY if kind == "volume" else PAGED_LABELS_ONLY)["usd"]
    return {o.name for o in declared(kind) if o.without.get("usd") == reason}


def _without_streamed_only(scene, given: dict, as_voxels: bool) -> dict:
    """``given`` less the options that only a streamed source reads, each said.

    ``--lod-bias`` stays for the scene's voxel grids (their level of detail); the volumes
    never get it (:func:`_render` leaves it out for them).
    """
    kept = dict(given)
    for name in sorted(kept.keys() & (streamed_only("volume") | streamed_only("voxels"))):
        read_by_grids = name not in streamed_only("voxels") and (as_voxels or scene.voxels)
        if not read_by_grids:
            _warn(name, "this scene's grids (read whole: only a .zarr source given to "
                        "render is streamed by bricks)")
        if name in streamed_only("voxels"):
            kept.pop(name)
    return kept


def _render_streamed(args, as_voxels: bool, progress_bar) -> int:
    """A ``.zarr`` source (an OME-Zarr pyramid, a zarr array) streamed by bricks, one image.

    The volume's flags (with ``--technique voxels``, a label grid's) go to ``add_volume``
    (``add_voxels``) as their keywords; the camera frames the source; bricks are read until
    the view has every one it wants (at most :data:`STREAM_TIMEOUT_S`, then the image says
    what is missing in a note).
    """
    for flag, value in (("--camera", args.camera), ("--isovalue", args.isovalue),
                        ("--spline", args.spline),
                        ("--chunk-size", args.chunk_size), ("--time", args.time),
                        ("--strict", args.strict or None)):
        if value is not None:
            raise ValueError(f"{flag} does not apply to a .zarr source ({args.scene}): it is "
                             "streamed by bricks as one "
                             f"{'label grid' if as_voxels else 'volume'}; leave it out.")
    kind = "voxels" if as_voxels else "volume"
    own = {o.flag for o in declared(kind)} | {"--technique"}
    stray = sorted({o.flag for o in declared() if o.flag is not None and o.flag not in own
                    and getattr(args, o.dest, None) is not None})
    if stray:
        raise ValueError(f"{', '.join(stray)}: not {'an option' if len(stray) == 1 else 'options'}"
                         f" of a {'label grid' if as_voxels else 'volume'} streamed from a "
                         f".zarr source; leave {'it' if len(stray) == 1 else 'them'} out.")
    keywords = given_options(args, kind)
    if keywords.get("lights") == "none":
        keywords["lights"] = None
    if args.technique and not as_voxels:
        keywords["technique"] = args.technique
    source = _chosen_indices(args)
    plotter = offscreen_plotter(args.size)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                (add_voxels if as_voxels else add_volume)(plotter, source, **keywords)
            except RefusedOptionsError as exc:   # said with the flags that gave them
                flags = ", ".join(_flag_of(name, kind) for name in exc.names)
                one = len(exc.names) == 1
                raise ValueError(f"{flags}: not for a {'label grid' if as_voxels else 'volume'}"
                                 f" streamed from a .zarr source ({exc.why}); leave "
                                 f"{'it' if one else 'them'} out, or render a level that "
                                 "fits in memory as a grid file.") from exc
            try:
                image = render_image(plotter, converge=True, timeout=STREAM_TIMEOUT_S,
                                     progress_bar=progress_bar)
            except RuntimeError as exc:   # a brick's read failed (a codec, a store)
                raise VolumeDataError(f"{args.scene}: a brick could not be read "
                                      f"({type(exc).__name__}: {exc}); the store is damaged "
                                      "or unreadable there.") from exc
    finally:
        plotter.close()
    for warning in caught:
        print(f"pv-cubemarch: note: {warning.message}", file=sys.stderr)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(image).save(str(args.out))
    print(f"wrote {args.out} ({args.size[0]}x{args.size[1]})")
    return 0


def _flag_of(given: str, kind: str) -> str:
    """An option of ``kind`` as its declared flag gives it: ``--blending maximum``."""
    name, _, value = given.partition("=")
    flag = next((o.flag for o in declared(kind) if o.name == name and o.flag),
                f"--{name.replace('_', '-')}")
    return f"{flag} {value.strip(chr(39))}" if value else flag


def _chosen_indices(args):
    """The ``.zarr`` source with its time and channel axes read at the indices asked for.

    A flag naming an axis the source lacks is refused; an axis of several entries read at
    index 0 because no flag chose another is said on stderr.
    """
    source = multiscale_source(args.scene, time=args.timepoint or 0,
                               channel=args.channel or 0)
    kinds = {kind for _, _, kind in source.others.values()}
    for flag, value, kind in (("--channel", args.channel, "channel"),
                              ("--timepoint", args.timepoint, "time")):
        if value is not None and kind not in kinds:
            axes = ", ".join(["x", "y", "z", *source.others])
            raise ValueError(f"{flag} {value}: {args.scene} has no {kind} axis (its axes: "
                             f"{axes}); leave {flag} out.")
    chosen = {"channel": args.channel, "time": args.timepoint}
    unchosen = [f"{name}={index} of {entries}" for name, (index, entries, kind)
                in source.others.items() if entries > 1 and chosen[kind] is None]
    if unchosen:
        print(f"pv-cubemarch: note: {args.scene} is drawn at {', '.join(unchosen)}; choose "
              "others with --channel and --timepoint.", file=sys.stderr)
    return source


def _volume_options(scene, args, given: dict, as_voxels: bool) -> None:
    """Put the volume options given on the command line into the scene's volumes' options.

    A technique chosen here drops the scene's options of other techniques. An option given
    here that a volume's technique does not read is left out for that volume, with a
    warning (with --technique, add_volume refuses it: the user asked for both); so is
    each volume flag for a scene without volumes. Voxel-only options are for the voxel
    grids, never volumes.
    """
    specific = specific_option_names("volume")
    if not scene.volumes:
        if not as_voxels:   # --technique voxels took them all as voxel grids
            for name in (["technique"] if args.technique else []) + [
                    n for n in given if n in specific]:
                _warn(name, "this scene (it has no volumes)")
        return
    # every option no technique's options hold (quality too: add_volume reads it)
    common = {o.name for o in declared("volume") if o.name not in specific} - {"technique"}
    given = {k: v for k, v in given.items() if k in specific | common}
    if args.technique:
        given["technique"] = args.technique
    for volume in scene.volumes:
        options = scene.volume_options.setdefault(volume.name, {})
        shaded = given.get("shade", options.get("shade", False))
        used = {k: v for k, v in given.items() if shaded or k not in SHADE_TERMS}
        for name in given.keys() - used.keys():   # --ambient ... may be the voxels' too
            if option("volume", name).flag not in _other_kinds_flags():
                _warn(name, f"volume {volume.name!r} (shade is off: give --shade)")
        if args.technique:
            kept = get_technique("volume", args.technique).option_names
            for name in specific - set(kept):
                options.pop(name, None)
            options.update(used)
            continue
        reads = get_technique("volume", options.get("technique", "vtk")).option_names
        for name, value in used.items():
            if name in specific and name not in reads:
                _warn(name, f"volume {volume.name!r} (technique="
                            f"{options.get('technique', 'vtk')!r})")
            else:
                options[name] = value


#: Volume options read only with shade=True (their flags may be the voxels' too).
SHADE_TERMS = ("ambient", "diffuse", "specular", "specular_power")


def _other_kinds_flags() -> set[str]:
    """Flags the voxel and surface options declare."""
    return {o.flag for kind in ("voxels", "surface") for o in declared(kind)}


def _shared_with_voxels() -> set[str]:
    """Surface options whose flag the voxel options declare too (``--shading`` ...)."""
    flags = {o.flag for o in declared("voxels")}
    return {o.name for o in declared("surface") if o.flag in flags}


def _surface_options(scene, args, given: dict) -> None:
    """Put the surface options given on the command line into the scene's surfaces' options.

    The surface flags go to every surface (a warning when the scene has none); the shading
    flags given go to them too.
    """
    flags = given_options(args, "surface")
    if args.surface_technique is not None:
        flags["technique"] = args.surface_technique
    if not scene.surfaces:
        volume_flags = {o.flag for o in declared("volume")}
        for name in [n for n in flags if n not in _shared_with_voxels()
                     and option("surface", n).flag not in volume_flags]:
            _warn(option("surface", name).dest, "this scene (it has no surfaces: give a grid "
                                                "file --isovalue)")
        return
    for surface in scene.surfaces:
        scene.surface_options.setdefault(surface.name, {}).update(flags)


def _voxel_options(scene, as_voxels: bool, given: dict) -> None:
    """Put the voxel options given on the command line into the scene's voxel grids' options.

    With ``--technique voxels`` every option given goes to every grid (``_render`` refused
    the others); otherwise one a grid does not read is left out for it, with a warning
    (``--step-scale`` is read only with the fixed traversal).
    """
    reads = {f.name for f in dataclasses.fields(VoxelOptions)} | set(VOXEL_CALL_ONLY)
    voxel_only = reads - {o.name for o in declared("volume")}
    if not scene.voxels:
        surfaces_read = _shared_with_voxels() if scene.surfaces else set()
        for name in given:
            if name in voxel_only and name not in surfaces_read:
                _warn(name, "this scene (it has no voxel grids)")
        return
    shared = _shared_with_voxels() if scene.surfaces else set()
    for grid in scene.voxels:
        options = scene.voxel_options.setdefault(grid.name, {})
        fixed = given.get("traversal", options.get("traversal")) == "fixed"
        for name, value in given.items():
            choices = option("voxels", name).choices if name in shared else None
            if name in shared and choices and value not in choices:
                # a surface's value (--shading normals): the grid keeps its own
                _warn(name, f"voxel grid {grid.name!r} (it takes {', '.join(choices)})")
            elif as_voxels or (name in reads and (name != "step_scale" or fixed)):
                options[name] = value
            else:
                _warn(name, f"voxel grid {grid.name!r}"
                            + (" (traversal='dda')" if name == "step_scale" else ""))


def _bench(args) -> int:
    if args.bench_command == "dial":
        words = [[w.strip() for w in text.split(",") if w.strip()]
                 for text in (args.scenes, args.techniques, args.targets,
                              args.surface_scenes, args.orbit_techniques)]
        sweep, dials = bench_dial.run_dial(args.size, args.frames, words[0], words[1],
                                           [float(t) for t in words[2]], words[3])
        print(f"{args.size[0]}x{args.size[1]}, median of {args.frames} frames; PSNR: whole "
              "frame against the CPU reference; est.: what the calibration estimated; x "
              "cost: the chosen rung's time over the cheapest rung meeting the target")
        print(bench_dial.format_dial(sweep, dials))
        orbits = []
        if args.orbit_frames > 0:
            orbits = bench_dial.run_interaction(
                args.orbit_size, args.budget_ms, args.orbit_frames, words[0], words[4],
                surface_scenes=words[3])
            print(f"\nframe_budget_ms={args.budget_ms:g} at {args.orbit_size[0]}x"
                  f"{args.orbit_size[1]}, quality=40, an orbit of {args.orbit_frames} "
                  "moving frames then the stop; within: moving frames (after the first) "
                  "within the budget; still ms: the frame after the stop")
            print(bench_dial.format_interaction(orbits))
        _write_rows(args.json_path, sweep, dials=[vars(d) for d in dials],
                    orbits=[vars(o) for o in orbits], size=list(args.size),
                    frames=args.frames)
        return 0
    if args.bench_command == "device":
        names = None if args.sections is None else [
            s.strip() for s in args.sections.split(",") if s.strip()]
        path = Path(args.report) if args.report else Path(args.out) / "device.json"
        report = bench_device.run_device_check(Path(args.out), args.plan, args.budget, names,
                                               report_path=path)
        print(f"wrote {path} ({report['seconds']:.0f} s)")
        return 0
    if args.bench_command == "soak":
        return _bench_soak(args)
    if args.bench_command == "scene-prims":
        rows = bench_prims.run_prims(args.counts, args.pyvista_max)
        print("a stage of N Cube prims in two colours, 320x240; load: load_scene; first "
              "frame: adding the meshes and drawing once")
        print(bench_prims.format_prims(rows))
        if args.json_path:
            Path(args.json_path).write_text(json.dumps({
                "rows": [vars(r) for r in rows], "gl_renderer": gl_info()["renderer"]},
                indent=1))
            print(f"wrote {args.json_path}")
        return 0
    if args.bench_command == "voxels":
        return _bench_voxels(args)
    if args.bench_command == "voxel-edits":
        return _bench_voxel_edits(args)
    if args.bench_command == "voxel-world":
        return _bench_voxel_world(args)
    if args.bench_command == "voxel-layers":
        rows = bench_layers.run_layers(args.size, args.grids, args.frames)
        print(f"median of {args.frames} frames at {args.size[0]}x{args.size[1]}, rows drawn "
              "in turn; x ours: over our row on the same grid; PSNR and wrong (> 10/255): "
              "against the plane-crossing CPU reference")
        print(format_layer_table(rows, bench_layers.ROWS[0]))
        _write_rows(args.json_path, rows, size=list(args.size), grids=list(args.grids))
        return 0
    if args.bench_command == "surfaces":
        return _bench_surfaces(args)
    if args.bench_command == "surface-layers":
        shapes = [s.strip() for s in args.shapes.split(",") if s.strip()]
        rows = bench_surface_layers.run_surface_layers(args.size, args.grids, shapes,
                                                       args.frames)
        print(f"median of {args.frames} frames at {args.size[0]}x{args.size[1]}, rows drawn "
              "in turn; x ours: over our row on the same shape and grid; PSNR and wrong "
              "(> 10/255): against the CPU reference compositing every root")
        print(format_layer_table(rows, bench_surface_layers.OURS))
        _write_rows(args.json_path, rows, size=list(args.size), grids=list(args.grids))
        return 0
    if args.bench_command == "cluster":
        workers = [int(w) for w in args.workers.split(",") if w.strip()]
        if not workers or min(workers) < 1 or args.frames < 1:
            raise ValueError("--workers takes positive counts (1,2) and --frames a positive "
                             "count.")
        rows = bench_cluster.run_cluster([s.strip() for s in args.scenes.split(",")
                                          if s.strip()], args.frames, args.size, workers)
        print(f"{args.size[0]}x{args.size[1]}, {args.frames} frames; +ms/frame: time per "
              "frame beyond a perfect split of the serial loop's; equal: every frame the "
              "serial loop's, pixel for pixel")
        print(bench_cluster.format_cluster(rows))
        _write_rows(args.json_path, rows, size=list(args.size), frames=args.frames)
        return 0
    if args.bench_command == "sortlast":
        try:
            counts = [[_partitions(v.strip()) for v in args.partitions.split(",") if v.strip()],
                      [int(v) for v in args.workers.split(",") if v.strip()]]
        except (argparse.ArgumentTypeError, ValueError):
            counts = [[], []]
        if not all(counts) or min(counts[1]) < 1 or args.frames < 1:
            raise ValueError("--partitions takes positive counts or bricks per axis "
                             "(2,4,8,2x2x2), --workers positive counts (2) and --frames a "
                             "positive count.")
        rows = bench_sort_last.run_sort_last(args.shape, args.frames, args.size, *counts)
        print(f"{args.size[0]}x{args.size[1]}, {args.frames} frames after one that reads and "
              "uploads; comp. ms: the client's compositing per frame; sent MB: what the "
              "workers sent per frame; PSNR min: the orbit's lowest against one plotter "
              "drawing the whole volume; wrong: label pixels unlike the whole grid's, away from "
              "voxel edges; edge: those whose ray grazes an edge (CPU traversal)")
        print(bench_sort_last.format_sort_last(rows))
        _write_rows(args.json_path, rows, size=list(args.size), frames=args.frames,
                    shape=list(args.shape))
        return 0
    if args.bench_command == "outofcore":
        rows = bench_outofcore.run_outofcore(
            [s.strip() for s in args.scenes.split(",") if s.strip()],
            [v.strip() for v in args.views.split(",") if v.strip()], args.size,
            shape=args.shape, timeout=args.timeout)
        print(f"{args.size[0]}x{args.size[1]}; first: add to the first frame; conv.: to the "
              "frame with every wanted brick (within the pool); max ms: the longest frame "
              "while bricks streamed; read: bytes read from the source; held: bytes of the "
              "bricks in the pool at the end; RSS: peak growth of this process; PSNR: "
              "against the whole array drawn in memory")
        print(bench_outofcore.format_outofcore(rows))
        _write_rows(args.json_path, rows, size=list(args.size), shape=list(args.shape))
        return 0
    if args.bench_command == "labels":
        scenes = [s.strip() for s in args.scenes.split(",") if s.strip()]
        rows = bench_labels.run_labels(
            scenes, args.size, n=args.voxels, cells=args.cells, million=args.million_sites,
            million_n=args.million_voxels, stride=args.stride, frames=args.frames,
            reference=not args.no_reference, pyvista_rows=not args.no_pyvista)
        print(f"{args.size[0]}x{args.size[1]}, median of {args.frames} frames; changes: ms "
              "from the call to the finished next frame / KB uploaded; wrong: pixels whose "
              "id differs from the CPU traversal's, away from voxel edges")
        print(bench_labels.format_labels(rows))
        _write_rows(args.json_path, rows, size=list(args.size), voxels=args.voxels,
                    cells=args.cells, million_voxels=args.million_voxels,
                    million_sites=args.million_sites, stride=args.stride)
        return 0
    if args.bench_command == "voxel-large":
        result = bench_large.run_large(args.size, args.scale, args.frames,
                                       reference=not args.no_reference, scene=args.scene,
                                       world_traversal=args.world_traversal)
        print(bench_large.format_large(result))
        if args.json_path:
            Path(args.json_path).write_text(json.dumps(
                {**dataclasses.asdict(result), "gl_renderer": gl_info()["renderer"]},
                indent=1))
            print(f"wrote {args.json_path}")
        return 0
    scene_path = args.scene or str(DEFAULT_SCENE)
    if not Path(scene_path).exists():
        raise FileNotFoundError(f"Scene {scene_path!r} not found; pass --scene.")
    scene = load_scene(scene_path, progress_bar=False)
    if args.bench_command == "resolution":
        return _bench_resolution(args, scene, scene_path)
    with bench_offload(args.scheduler, args.workers) as offload:
        results = bench.run_tradeoff(args.technique, scene, size=args.size,
                                     frames=args.frames, include_stock=not args.no_stock,
                                     blending=args.blending, offload=offload)
    print(f"scene {scene_path}, {args.size[0]}x{args.size[1]}, median of {args.frames} frames; "
          "error against the CPU reference (0.1 voxel steps)")
    print(bench.format_table(results))
    if args.json_path:
        info = gl_info()
        bench.write_json(results, args.json_path, {
            "scene": scene_path, "size": list(args.size), "frames": args.frames,
            "technique": args.technique, "gl_renderer": info["renderer"]})
        print(f"wrote {args.json_path}")
    if args.plot:
        bench.plot_pareto(results, args.plot,
                          title=f"{', '.join(args.technique)} on {Path(scene_path).name}")
        print(f"wrote {args.plot}")
    return 0


def _bench_voxels(args) -> int:
    rows = args.rows.split(",") if args.rows else tuple(VOXEL_ROWS)
    only = args.scenes.split(",") if args.scenes else None
    with bench_offload(args.scheduler, args.workers) as offload:
        results = bench_voxels.run_voxels(args.sizes, frames=args.frames, large=args.large,
                                          rows=rows, only=only, offload=offload)
    print(f"median of {args.frames} frames, rows drawn in turn; wrong: pixels showing "
          "another material than the CPU traversal (unlit colours), away from voxel edges; "
          "edge px: differing pixels whose ray passes within 1e-4 voxel of an edge; GPU MB "
          "of PyVista's meshes estimated from what VTK uploads (positions, cell colours, "
          "indices)")
    print(bench_voxels.format_voxel_table(results))
    for size in args.sizes:
        print()
        print(bench_voxels.format_seed_ratios(results, size))
    if args.json_path:
        bench_voxels.write_voxel_json(results, args.json_path, {
            "sizes": [list(s) for s in args.sizes], "frames": args.frames,
            "large": args.large, "gl_renderer": gl_info()["renderer"]})
        print(f"wrote {args.json_path}")
    return 0


def _bench_voxel_edits(args) -> int:
    edits = bench_edits.run_edits(args.size, repeats=args.repeats)
    print(f"{args.size}^3 FBM terrain, 800x600, id mode; latency: edit call to the next frame "
          "read back; frame: a frame without edit; wrong: pixels of that frame off the CPU "
          "traversal of the edited labels")
    print(bench_edits.format_edit_table(edits))
    if args.world:
        world = bench_edits.run_world_edits(args.size, args.world, repeats=args.repeats)
        print(f"\n{args.world}x{args.world} chunks of {args.size}^3 (FBM terrain), 640x480, "
              "face mode; wrong: the last frame against the CPU traversal of the edited world")
        print(bench_edits.format_edit_table(world))
        edits += world
    automata = bench_edits.run_automata(args.automaton_sizes)
    print()
    print("automata: numpy steps per second; step+frame: step, upload of the changed box "
          f"and a 600x600 frame, at {min(args.automaton_sizes)}^3")
    print(bench_edits.format_automaton_table(automata))
    if args.json_path:
        Path(args.json_path).write_text(json.dumps({
            "edits": [vars(r) for r in edits], "automata": [vars(r) for r in automata],
            "size": args.size, "gl_renderer": gl_info()["renderer"]}, indent=1))
        print(f"wrote {args.json_path}")
    return 0


def _bench_soak(args) -> int:
    unknown = set(args.techniques or ()) - set(bench_soak.TECHNIQUES)
    if unknown:
        raise SystemExit(f"bench soak: unknown techniques {sorted(unknown)}; choose from "
                         f"{', '.join(bench_soak.TECHNIQUES)}")
    rows = bench_soak.run_soak(args.frames, args.techniques, args.size)
    print(f"{args.frames} frames per technique at {args.size[0]}x{args.size[1]}, a random "
          f"camera each frame, an edit every {bench_soak.EDIT_EVERY} frames, the actor removed "
          f"and added again every {bench_soak.WINDOW}; resident MiB of this process after "
          "each 100 frames (the slope leaves out the first 100)")
    print(bench_soak.format_soak(rows))
    if args.json_path:
        Path(args.json_path).write_text(json.dumps({
            "rows": [{**vars(r), "growth_mib_per_100": r.growth_mib_per_100} for r in rows],
            "frames": args.frames, "size": list(args.size),
            "gl_renderer": gl_info()["renderer"]}, indent=1))
        print(f"wrote {args.json_path}")
    return 0


def _write_rows(path: str | None, rows: list, **run) -> None:
    """A bench's rows (dataclasses; ``median_ms`` where they have it) and settings as JSON."""
    if not path:
        return
    Path(path).write_text(json.dumps({
        "rows": [{**vars(r), **({"median_ms": r.median_ms} if hasattr(r, "median_ms")
                                else {})} for r in rows], **run,
        "gl_renderer": gl_info()["renderer"]}, indent=1))
    print(f"wrote {path}")


def _bench_surfaces(args) -> int:
    shapes = [s.strip() for s in args.shapes.split(",") if s.strip()]
    with bench_offload(args.scheduler, args.workers) as offload:
        rows = bench_surfaces.run_surfaces(args.size, args.grids, args.steps, shapes,
                                           frames=args.frames, offload=offload)
    print(f"median of up to {args.frames} frames at {args.size[0]}x{args.size[1]}, rows drawn "
          "in turn; x full: the full-domain march's time at the same M over the row's; "
          "errors against the CPU reference's first roots (depth in cells; later: pixels "
          "more than half a cell behind the reference)")
    print(bench_surfaces.format_surfaces(rows))
    _write_rows(args.json_path, rows, size=list(args.size))
    return 0


def _bench_voxel_world(args) -> int:
    rows = bench_world.run_world(args.size, chunk=args.chunk, count=args.count,
                                 frames=args.frames)
    print(f"median of {args.frames} frames at {args.size[0]}x{args.size[1]}, rows drawn in "
          "turn as if the view turned; x one: over the one-grid scene's same row; wrong: "
          "pixels off the CPU traversal of the whole grid, away from voxel edges")
    print(bench_world.format_world_table(rows))
    _write_rows(args.json_path, rows, size=list(args.size), chunk=args.chunk,
                count=args.count)
    return 0


def _bench_resolution(args, scene, scene_path) -> int:
    sizes = args.sizes or bench_resolution.SIZES
    face_sizes = args.comparable_face_sizes
    if face_sizes is None:
        face_sizes = bench_resolution.COMPARABLE_FACE_SIZES
    with bench_offload(args.scheduler, args.workers) as offload:
        rows = bench_resolution.run_resolution(scene, sizes=sizes, frames=args.frames,
                                               crop=args.crop,
                                               comparable_face_sizes=face_sizes,
                                               offload=offload)
    print(f"scene {scene_path}; median of {args.frames} frames drawn to completion, the rows "
          f"drawn in turn; error (PSNR) on three {args.crop}px crops against the CPU reference "
          "(0.1 voxel steps)")
    print(bench_resolution.format_resolution_table(rows))
    if args.json_path:
        bench_resolution.write_resolution_json(rows, args.json_path, {
            "scene": scene_path, "sizes": [list(s) for s in sizes], "frames": args.frames,
            "crop": args.crop, "gl_renderer": gl_info()["renderer"]})
        print(f"wrote {args.json_path}")
    return 0


def _load(args, **options):
    """The scene of ``args.scene``; its problems are printed as notes, not warnings."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneWarning)
        # every volume forced into labels: one that is not is an error, as asked
        strict = args.strict or options.get("as_voxels", False)
        return load_scene(args.scene, time=args.time, strict=strict, **options)


def _info(args) -> int:
    if not args.gl and not args.scene:
        print("pv-cubemarch info: give a SCENE, --gl, or both", file=sys.stderr)
        return 2
    report = {}
    if args.gl:
        report["gl"] = gl_info()
    if args.scene:
        report["scene"] = _load(args, progress_bar=False)
    if args.json:
        out = dict(report)
        if "scene" in out:
            s = out["scene"]
            out["scene"] = {
                "source": s.source, "up_axis": s.up_axis, "meters_per_unit": s.meters_per_unit,
                "meshes": [m.name for m in s.meshes], "volumes": [v.name for v in s.volumes],
                "voxels": [g.name for g in s.voxels],
                "labels": {g.name: {"count": count_labels(g), "legend": label_legend(g, 64)}
                           for g in s.voxels},
                "surfaces": [f.name for f in s.surfaces], "time": s.time,
                "cameras": list(s.cameras), "lights": [li.name for li in s.lights],
                "skipped": [{"path": k.path, "reason": k.reason} for k in s.skipped]}
        print(json.dumps(out, indent=2))
        return 0
    if "gl" in report:
        for key, value in report["gl"].items():
            print(f"{key}: {value}")
    if "scene" in report:
        print(report["scene"].summary())
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
