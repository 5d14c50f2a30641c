"""Voxel edits and automata: edit latency and bytes uploaded, automaton steps per second.

``pv-cubemarch bench voxel-edits``: on an FBM terrain grid, each edit (one voxel, a brush of
32³, a whole replacement) is timed from the edit call to the end of the next frame (read
back), its uploaded bytes counted, and that frame checked against the CPU traversal of the
edited labels; a frame without an edit is timed beside them. Automata: numpy steps per second
at the given sizes, and at the smallest, step + upload of the changed box + frame.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..api import add_voxels
from ..core.camera import Camera
from ..core.progress import progress
from ..core.rendering import offscreen_plotter, read_pixels, render_frame
from ..models.automaton import VoxelAutomaton
from ..models.procedural import terrain
from ..reference.voxels import face_colors, id_colors, trace_voxels

#: Edits measured on an ``n``³ grid: name and what it does to the binding.
EDITS: dict[str, Callable] = {
    "1 voxel": lambda b, n, k: b.set_voxels((k % n, (3 * k) % n, n - 1), 1 + k % 3),
    "brush 32^3": lambda b, n, k: b.fill_sphere((n / 2 + 4 * k % 16, n / 2, n / 2), 16.0,
                                               k % 4),
    "replace all": lambda b, n, k: b.set_values(terrain((n, n, n), seed=k + 1)),
}


@dataclass
class EditRow:
    """One kind of edit: median latency to a finished frame, bytes uploaded, wrong pixels."""

    edit: str
    latency_ms: float
    frame_ms: float
    uploaded_bytes: int
    wrong_pixels: int


@dataclass
class AutomatonRow:
    """Steps per second of a rule at a size; with ``frame_ms``, step + upload + frame."""

    rule: str
    size: int
    steps_per_second: float
    frame_ms: float | None = None


def _uploaded(binding) -> int:
    return binding.uploaded_bytes


def _wrong(pl, binding, camera) -> int:
    near = pl.camera.clipping_range[0]
    hits = trace_voxels(binding.model.labels, binding.model.world_from_index(), camera,
                        pl.window_size, near=near, tie_tolerance=1e-4)
    image = read_pixels(pl).astype(int)
    wrong = np.any(image != id_colors(hits, binding.model.dimensions).astype(int), axis=-1)
    return int((wrong & ~hits.near_edge).sum())


def run_edits(size: int = 128, image: Sequence[int] = (800, 600), repeats: int = 3,
              progress_bar: bool | None = None) -> list[EditRow]:
    """Time each of :data:`EDITS` ``repeats`` times on a ``size``³ terrain (id mode)."""
    pl = offscreen_plotter(tuple(image))
    pl.disable_anti_aliasing()
    pl.ren_win.SetMultiSamples(0)
    pl.set_background("black")
    try:
        actor = add_voxels(pl, terrain((size,) * 3, seed=0), mode="id",
                           palette=["black", "green", "saddlebrown", "gray"])
        binding = actor.cubemarch
        n = float(size)
        camera = Camera(position=(n * 1.6, -n * 0.7, n * 1.4), focal_point=(n / 2,) * 3,
                        view_up=(0, 0, 1), view_angle=35.0)
        camera.apply_to(pl.camera)
        pl.renderer.ResetCameraClippingRange()
        render_frame(pl)
        read_pixels(pl)
        rows = []
        for name, edit in progress(EDITS.items(), total=len(EDITS), desc="edits",
                                   enabled=progress_bar):
            latencies, frames, sent, wrong = [], [], [], 0
            for k in range(repeats):
                start = time.perf_counter()
                render_frame(pl)
                read_pixels(pl)
                frames.append((time.perf_counter() - start) * 1e3)
                before = _uploaded(binding)
                start = time.perf_counter()
                edit(binding, size, k)
                render_frame(pl)
                read_pixels(pl)
                latencies.append((time.perf_counter() - start) * 1e3)
                sent.append(_uploaded(binding) - before)
                wrong = max(wrong, _wrong(pl, binding, Camera.from_pyvista(pl.camera)))
            rows.append(EditRow(name, float(np.median(latencies)), float(np.median(frames)),
                                int(np.median(sent)), wrong))
        return rows
    finally:
        pl.close()


#: Edits measured on a world of ``(nx, ny, nz)`` voxels: name and what it does to it.
WORLD_EDITS: dict[str, Callable] = {
    "world 1 voxel": lambda b, d, k: b.set_voxels((d[0] // 2 + 5 * k, d[1] // 3,
                                                   3 * d[2] // 4 - 1), 1 + k % 3),
    "world brush 32^3": lambda b, d, k: b.fill_sphere((d[0] / 2 + 8 * k, d[1] / 2, d[2] / 2),
                                                      16.0, 0),
}


def run_world_edits(chunk: int = 128, count: int = 10, image: Sequence[int] = (640, 480),
                    repeats: int = 3) -> list[EditRow]:
    """Edit latency on a terrain of ``count x count`` chunks of ``chunk``³ (face mode).

    Timed as on one grid; the last frame is checked against the CPU traversal of the
    edited world (once: the world is large).
    """
    side = chunk * count
    labels = terrain((side, side, chunk), feature_size=side / 8, seed=1)
    pl = offscreen_plotter(tuple(image))
    pl.disable_anti_aliasing()
    pl.ren_win.SetMultiSamples(0)
    pl.set_background("black")
    try:
        world = add_voxels(pl, labels, mode="face", chunk_size=chunk).cubemarch
        n = np.array(labels.shape, dtype=float)
        Camera(position=tuple(n / 2 + side * np.array([0.75, -0.55, 0.7])),
               focal_point=tuple(n / 2), view_up=(0, 0, 1), view_angle=40.0).apply_to(pl.camera)
        pl.renderer.ResetCameraClippingRange()
        render_frame(pl)
        read_pixels(pl)
        rows = []
        for name, edit in WORLD_EDITS.items():
            latencies, frames, sent = [], [], []
            for k in range(repeats):
                start = time.perf_counter()
                render_frame(pl)
                read_pixels(pl)
                frames.append((time.perf_counter() - start) * 1e3)
                before = _uploaded(world)
                start = time.perf_counter()
                edit(world, labels.shape, k)
                render_frame(pl)
                read_pixels(pl)
                latencies.append((time.perf_counter() - start) * 1e3)
                sent.append(_uploaded(world) - before)
            rows.append(EditRow(name, float(np.median(latencies)), float(np.median(frames)),
                                int(np.median(sent)), -1))
        edited = world.model.labels_in(tuple(slice(0, v) for v in labels.shape))
        hits = trace_voxels(edited, np.eye(4), Camera.from_pyvista(pl.camera), pl.window_size,
                            near=pl.camera.clipping_range[0], tie_tolerance=1e-4)
        wrong = np.any(read_pixels(pl).astype(int) != face_colors(hits).astype(int), axis=-1)
        rows[-1].wrong_pixels = int((wrong & ~hits.near_edge).sum())
        return rows
    finally:
        pl.close()


def run_automata(sizes: Sequence[int] = (64, 128), rules: Sequence[str] = ("445",
                 "clouds", "pyroclastic"), steps: int = 10, image: Sequence[int] = (600, 600),
                 progress_bar: bool | None = None) -> list[AutomatonRow]:
    """Steps per second of each rule at each size; at the smallest size also step + frame."""
    rows = []
    for rule in progress(rules, total=len(rules), desc="automata", enabled=progress_bar):
        for size in sizes:
            automaton = VoxelAutomaton((size,) * 3, rule=rule, seed=1)
            start = time.perf_counter()
            for _ in range(steps):
                automaton.step()
            rate = steps / (time.perf_counter() - start)
            rows.append(AutomatonRow(rule, int(size), rate))
        rows[-len(sizes)].frame_ms = _automaton_frames(rule, min(sizes), steps, image)
    return rows


def _automaton_frames(rule: str, size: int, steps: int, image: Sequence[int]) -> float:
    """Median ms of step + upload of the changed box + a frame, drawn by add_voxels."""
    automaton = VoxelAutomaton((size,) * 3, rule=rule, seed=1)
    states = automaton.rule.states
    palette = [(0.0, 0.0, 0.0)] + [(0.3 + 0.7 * s / states, 0.4, 1.0 - 0.7 * s / states)
                                   for s in range(1, states)]
    pl = offscreen_plotter(tuple(image))
    try:
        actor = add_voxels(pl, automaton.labels(), palette=palette)
        pl.camera_position = "iso"
        pl.reset_camera()
        render_frame(pl)
        times = []
        for _ in range(steps):
            start = time.perf_counter()
            box = automaton.step()
            if box is not None:
                actor.cubemarch.set_block(box, automaton.state[box])
            render_frame(pl)
            read_pixels(pl)
            times.append((time.perf_counter() - start) * 1e3)
        return float(np.median(times))
    finally:
        pl.close()


def format_edit_table(rows: list[EditRow]) -> str:
    """The edit rows as a text table."""
    lines = ["edit               latency ms  frame ms  uploaded B  wrong px", "-" * 61]
    lines += [f"{r.edit:17s} {r.latency_ms:11.1f} {r.frame_ms:9.1f} {r.uploaded_bytes:11d} "
              f"{r.wrong_pixels if r.wrong_pixels >= 0 else '-':>9}" for r in rows]
    return "\n".join(lines)


def format_automaton_table(rows: list[AutomatonRow]) -> str:
    """The automaton rows as a text table."""
    lines = ["rule          size  steps/s  step+frame ms", "-" * 42]
    lines += [f"{r.rule:12s} {r.size:5d} {r.steps_per_second:8.1f} "
              f"{'' if r.frame_ms is None else f'{r.frame_ms:14.1f}'}" for r in rows]
    return "\n".join(lines)
