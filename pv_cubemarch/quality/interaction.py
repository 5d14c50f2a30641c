"""The frame-time budget: while the view moves, a coarser step keeps frames within it.

VTK's interactors raise the render window's desired update rate while the user drags
(``DesiredUpdateRate``, 15 frames a second by default) and drop it to the still rate when
the drag ends; VTK's own level-of-detail props follow the same signal. Each frame drawn
while it is raised takes the step the cost model predicts will fit the budget (the frame
time scales as the samples, ``1 / step_scale``, from the last frame's measured time: a
fit of a fixed cost plus the samples' was tried, and followed llvmpipe's noise); the
first still frame goes back to the step the error budget chose (or the user gave), so the
image refines to it as soon as the view stops. Only the uniform changes: no shader is
rebuilt and no data moves.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

from .ladders import STEP_SCALES

#: Steps a moving view may take, coarse to fine (the ladder's, and two coarser).
MOVING_STEPS = (16.0, 8.0, *STEP_SCALES)
#: A desired update rate at or above this (frames a second) means the view is moving.
MOVING_RATE = 1.0
#: The share of the budget a predicted frame aims at (room for the prediction's error).
AIM = 0.8


@dataclass
class FrameRecord:
    """One frame: whether the view was moving, the step drawn and its time."""

    moving: bool
    step_scale: float
    ms: float


@dataclass
class FrameBudget:
    """Holds a marched volume's frames within ``budget_ms`` while the view moves.

    ``binding`` is the volume's binding (its ``cm_stepScale`` uniform is set per frame);
    ``still_step`` the step of a still view; ``errors`` the estimated PSNR of steps the
    error budget measured, to report the moving frames' error; ``clock`` seconds.
    """

    binding: object
    window: object
    budget_ms: float
    still_step: float
    errors: dict = field(default_factory=dict)
    clock: Callable[[], float] = time.perf_counter
    frames: list[FrameRecord] = field(default_factory=list)
    step: float = 0.0
    _started: float | None = None

    def __post_init__(self):
        self.step = self.still_step

    @property
    def moving(self) -> bool:
        """Whether the render window is asked for interactive frames now."""
        return self.window.GetDesiredUpdateRate() >= MOVING_RATE

    @property
    def estimated_psnr(self) -> float | None:
        """The error budget's estimate for the step drawn last (None: not measured)."""
        return self.errors.get(self.step)

    def next_step(self, step: float, ms: float) -> float:
        """The finest moving step predicted to fit the budget after ``ms`` at ``step``.

        Frame time taken as proportional to ``1 / step``; never finer than the still step.
        """
        wanted = step * ms / (AIM * self.budget_ms)
        allowed = [s for s in MOVING_STEPS if s >= self.still_step]
        fitting = [s for s in allowed if s >= wanted]
        return min(fitting) if fitting else max(allowed)

    def before_frame(self, *_) -> None:
        """Choose this frame's step, set it, start the clock."""
        if not self.moving:
            self.step = self.still_step
        elif self.frames:
            last = self.frames[-1]
            self.step = self.next_step(last.step_scale, last.ms)
        self.binding.bindings.set_uniform("cm_stepScale", float(self.step))
        self.binding.step_scale = float(self.step)
        self._started = self.clock()

    def after_frame(self, *_) -> None:
        """Record the frame's time."""
        if self._started is None:
            return
        ms = (self.clock() - self._started) * 1e3
        self.frames.append(FrameRecord(self.moving, float(self.step), ms))
        del self.frames[:-1000]        # a long session keeps the last thousand
        self._started = None


def check_frame_budget(budget_ms, technique: str, downsample) -> None:
    """Refuse a budget that is not a positive time, or a technique it cannot steer."""
    if isinstance(budget_ms, bool) or not isinstance(budget_ms, (int, float)) or not (
            0.0 < float(budget_ms) < float("inf")):
        raise ValueError(f"frame_budget_ms must be a positive number of milliseconds, got "
                         f"{budget_ms!r}.")
    if technique not in ("vtk", "direct") or int(downsample) != 1:
        raise ValueError(f"frame_budget_ms steers the step of technique='vtk' or 'direct' at "
                         f"downsample=1, not technique={technique!r} (downsample="
                         f"{downsample}): the cube map's level of detail already follows the "
                         "view.")


def attach_frame_budget(binding, renderer, window, budget_ms: float, errors: dict | None = None,
                        clock: Callable[[], float] = time.perf_counter) -> FrameBudget:
    """Follow ``renderer``'s frames with a :class:`FrameBudget`; removed with the binding."""
    budget = FrameBudget(binding, window, float(budget_ms), float(binding.step_scale),
                         dict(errors or {}), clock)
    tags = [renderer.AddObserver("StartEvent", budget.before_frame),
            renderer.AddObserver("EndEvent", budget.after_frame)]
    binding.frame_budget = budget
    release = binding.release_resources

    def release_and_stop() -> None:
        for tag in tags:
            renderer.RemoveObserver(tag)
        release()
    binding.release_resources = release_and_stop
    return budget
