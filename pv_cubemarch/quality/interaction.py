"""The frame-time budget: while the view moves, a coarser setting keeps frames within it.

VTK's interactors raise the render window's desired update rate while the user drags
(``DesiredUpdateRate``, 15 frames a second by default) and drop it to the still rate when
the drag ends; VTK's own level-of-detail props follow the same signal. Each frame drawn
while it is raised takes the setting the cost model predicts will fit the budget, from the
costliest of the last three frames' measured times (a finer setting only with room to
spare): the marchers' step (time as ``1 / step_scale``: the samples; ``'vtk'`` and a
downsampled ``'direct'`` past their coarsest step at 1/2-1/4 the pixels) or the cube
map's ``upscale`` (time as ``1 / upscale**2``: the texels marched). A fit of a fixed cost
plus the samples' was tried, and followed llvmpipe's noise. The first still frame goes
back to the still setting (what the error budget chose, or the user gave), so the image
refines to it as soon as the view stops. Nothing is rebuilt and no data move: a uniform
(the step), a reduced target's size or the cube map's level of detail (upscale) changes.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from vtkmodules.vtkCommonCore import vtkCommand

from ..core.frame_errors import observe
from ..core.user_warnings import warn_user
from ..gl.reduced_draw import ReducedDraw
from .ladders import STEP_SCALES

#: A desired update rate at or above this (frames a second) means the view is moving.
MOVING_RATE = 1.0
#: The share of the budget a predicted frame aims at (room for the prediction's error).
AIM = 0.8
#: The share of the budget a finer value than the last must be predicted to fit.
REFINE_AIM = 0.6
#: A moving frame's value is predicted from the costliest of this many last frames (each
#: frame's time at its own value, brought to the last value by the cost model): one fast
#: frame does not send the next to a finer value that then misses.
PREDICT_FROM = 3


@dataclass(frozen=True)
class BudgetKnob:
    """What a budget moves: its values (coarse to fine), how the cost follows it, how set.

    Cost goes as ``value ** -power``; ``read`` / ``write`` get and set it on a binding.
    """

    name: str
    values: tuple[float, ...]
    power: float
    read: Callable
    write: Callable
    #: How a value reads in a panel or a table, given the still value (default
    #: ``name=value``).
    label: Callable[[float, float], str] | None = None
    #: The values for a still value, where they depend on it (default ``values``).
    ladder_of: Callable[[float], tuple[float, ...]] | None = None
    #: Whether a value draws on a binding now (default: every value does).
    drawable: Callable[[object, float], bool] | None = None

    def ladder(self, still: float, binding=None) -> tuple[float, ...]:
        """The values a budget with this still value moves among (on ``binding`` now)."""
        values = self.values if self.ladder_of is None else self.ladder_of(still)
        if self.drawable is None or binding is None:
            return values
        return tuple(v for v in values if self.drawable(binding, v))

    def describe(self, value: float, still: float) -> str:
        """``value`` as the panel and the bench say it."""
        return self.label(value, still) if self.label is not None else \
            f"{self.name}={value:g}"


def _write_step(binding, value: float) -> None:
    # every pass that marches: the box, a reduced-resolution pass, a stop-depth pass
    for target in getattr(binding, "targets", [binding.bindings]):
        if "cm_stepScale" in target.uniforms:
            target.set_uniform("cm_stepScale", float(value))
    binding.step_scale = float(value)


#: Below this many steps (or the still steps, if fewer), a surface's moving frames draw
#: fewer pixels instead of fewer steps: its knob's values are then those steps over the
#: pixels' reduction, squared.
REDUCED_STEPS = 100.0
#: A surface's steps knob, coarse to fine (the still steps added).
SURFACE_STEPS = (10.0, 25.0, 50.0, 100.0, 200.0, 400.0, 800.0, 1600.0, 3200.0, 6400.0,
                 12800.0, 25000.0)


def _steps_floor(still: float) -> float:
    return min(REDUCED_STEPS, float(still))


def _steps_ladder(still: float) -> tuple[float, ...]:
    """The steps from ``min(100, still)`` up, then that many at 1/2, 1/3, 1/4 the size."""
    floor = _steps_floor(still)
    return (floor / 16.0, floor / 9.0, floor / 4.0,
            *sorted({floor, *(v for v in SURFACE_STEPS if v >= floor)}))


def steps_drawn(value: float, still: float) -> tuple[int, int]:
    """``(steps, reduction)`` a surface's knob value draws (reduction 1: full size)."""
    floor = _steps_floor(still)
    if value >= floor * (1.0 - 1e-9):
        return int(round(value)), 1
    return int(round(floor)), int(round(math.sqrt(floor / value)))


def _steps_label(steps: int, reduction: int) -> str:
    return f"steps={steps}" + ("" if reduction == 1 else f" at 1/{reduction} size")


def surface_parts(binding) -> list:
    """The surfaces a binding draws: several opaque levels' own, else itself."""
    return list(getattr(binding, "surfaces", [binding]))


def _read_steps(binding) -> float:
    return float(surface_parts(binding)[0].options.steps)


def _set_steps(binding, steps: float) -> None:
    for part in surface_parts(binding):
        part.options = dataclasses.replace(part.options, steps=int(round(steps)))
        part.bindings.set_uniform("cm_stepLength",
                                  part.options.step_length(part.model))


def set_still_steps(binding, steps: float) -> None:
    """Draw ``steps`` at full size (a calibration's choice, not a moving frame's)."""
    _set_steps(binding, steps)
    for part in surface_parts(binding):
        reduce_pixels(part, 1)


def _write_steps(binding, value: float) -> None:
    budget = getattr(binding, "frame_budget", None)
    steps, factor = steps_drawn(value, budget.still if budget is not None else value)
    _set_steps(binding, steps)
    for part in surface_parts(binding):   # each level drawn reduced by its own draw
        reduce_pixels(part, factor)


def reduce_pixels(binding, factor: int) -> None:
    """Draw ``binding``'s actor at 1/``factor`` of the viewport (made at the first need)."""
    reduced = getattr(binding, "reduced", None)
    if reduced is None and factor > 1:
        make = getattr(binding, "make_reduced_draw", None)
        if make is not None:   # many actors drawn as one (a world's chunks): its own
            reduced = binding.reduced = make()
        else:
            # a translucent actor (a surface, a directly marched volume) is drawn reduced
            # after the opaque props, from the overlay (ReducedDraw)
            reduced = binding.reduced = ReducedDraw(binding.renderer, binding.drawn[0])
            binding.extra_release.append(reduced.release)
    if reduced is not None:
        reduced.factor = int(factor)
        layers = getattr(binding, "layers", None)   # translucent labels: drawn as reduced
        if layers is not None:
            layers.reduce_as(reduced)


#: The coarsest step of ``'vtk'`` and of a downsampled ``'direct'`` (or the still step,
#: where coarser); coarser frames draw it at 1/2, 1/3, 1/4 the pixels across.
STEP_FLOOR = 16.0


def _step_floor(still: float) -> float:
    return max(STEP_FLOOR, float(still))


def steps_then_pixels(still: float) -> tuple[float, ...]:
    """A stepped knob's values, coarse to fine, for a still step.

    The coarsest step (16, or the still step where coarser) at 1/4-1/2 the pixels across
    (the step times the reduction squared), then the steps.
    """
    floor = _step_floor(still)
    steps = sorted({floor, *(v for v in (STEP_FLOOR, 8.0, *STEP_SCALES) if v <= floor)},
                   reverse=True)
    return (*(floor * r * r for r in (4, 3, 2)), *steps)


def step_drawn(value: float, still: float = STEP_FLOOR) -> tuple[float, int]:
    """``(step_scale, reduction)`` a step-then-pixels knob value draws.

    Past the coarsest step (16, or the still step where coarser) the value is that step
    times the pixels' reduction squared (``'vtk'``: VTK's ``ImageSampleDistance``;
    ``'direct'``: the downsample times it).
    """
    floor = _step_floor(still)
    if value <= floor * (1.0 + 1e-9):
        return float(value), 1
    return floor, int(round(math.sqrt(value / floor)))


def _still_of(binding, value: float) -> float:
    """The still value of the budget on ``binding`` (``value`` itself before one is on)."""
    return float(getattr(getattr(binding, "frame_budget", None), "still", value))


def _read_vtk_step(binding) -> float:
    distances = binding.sample_distances
    reduction = distances.budget / distances.user if distances.budget > 1.0 else 1.0
    return float(binding.step_scale) * reduction ** 2


def _write_vtk_step(binding, value: float) -> None:
    """The step, and past the coarsest step the user's sample distance times the reduction.

    Relative to the user's ``ImageSampleDistance``: a volume the user draws at 1/2 size is
    drawn at 1/4 for a reduction of 2, so the pixels fall as the cost model says.
    """
    step, reduction = step_drawn(value, _still_of(binding, value))
    _write_step(binding, step)
    distances = binding.sample_distances
    distances.ask(1.0 if reduction == 1 else reduction * distances.user)


def _vtk_step_drawable(binding, value: float) -> bool:
    """A reduced size draws only where the mapper may take a sample distance now."""
    return step_drawn(value, _still_of(binding, value))[1] == 1 or \
        not binding.sample_distances.full_only


def _vtk_step_label(binding) -> Callable[[float, float], str]:
    def label(value: float, still: float) -> str:
        step, reduction = step_drawn(value, still)
        user = binding.sample_distances.user
        size = reduction * user
        return f"step_scale={step:g}" + ("" if size == 1 else f" at 1/{size:g} size")
    return label


def _read_step_downsample(binding) -> float:
    reduction = binding.low_size.factor / binding.downsample
    return float(binding.step_scale) * reduction ** 2


def _write_step_downsample(binding, value: float) -> None:
    step, reduction = step_drawn(value, _still_of(binding, value))
    _write_step(binding, step)
    binding.low_size.factor = int(binding.downsample) * reduction


def _step_downsample_label(binding) -> Callable[[float, float], str]:
    def label(value: float, still: float) -> str:
        step, reduction = step_drawn(value, still)
        return f"step_scale={step:g}, downsample={int(binding.downsample) * reduction}"
    return label


def _write_reduction(binding, value: float) -> None:
    reduce_pixels(binding, int(value))


def _write_upscale(binding, value: float) -> None:
    frame = binding.frame
    frame.options = dataclasses.replace(frame.options, upscale=float(value))


def _read_step_pixels(binding) -> float:
    reduced = getattr(binding, "reduced", None)
    return float(binding.step_scale) * (1 if reduced is None else reduced.factor) ** 2


def _write_step_pixels(binding, value: float) -> None:
    step, reduction = step_drawn(value, _still_of(binding, value))
    _write_step(binding, step)
    reduce_pixels(binding, reduction)


def _step_pixels_label(value: float, still: float) -> str:
    step, reduction = step_drawn(value, still)
    return f"step_scale={step:g}" + ("" if reduction == 1 else f" at 1/{reduction} size")


#: The knob of each technique a budget steers.
KNOBS = {
    # 'direct': the step, then the coarsest step at fewer pixels (its box drawn at 1/2-1/4
    # of the viewport after the scene's opaque props, composited from the overlay)
    "step": BudgetKnob("step_scale", steps_then_pixels(STEP_FLOOR), 1.0, _read_step_pixels,
                       _write_step_pixels, label=_step_pixels_label,
                       ladder_of=steps_then_pixels),
    # 'vtk': the step, then the coarsest step at fewer pixels (VTK's ImageSampleDistance:
    # its mapper draws into a framebuffer 1/2-1/4 the size and stretches it): time as
    # the samples, the step's or the pixels'
    "step_pixels": BudgetKnob("step_scale", steps_then_pixels(STEP_FLOOR), 1.0,
                              _read_vtk_step, _write_vtk_step,
                              ladder_of=steps_then_pixels, drawable=_vtk_step_drawable),
    # 'direct' with downsample > 1: the step, then the coarsest step at 2-4 times the
    # downsample (its low-resolution pass 1/2-1/4 as many pixels across)
    "step_downsample": BudgetKnob("step_scale", steps_then_pixels(STEP_FLOOR), 1.0,
                                  _read_step_downsample, _write_step_downsample,
                                  ladder_of=steps_then_pixels),
    "upscale": BudgetKnob("upscale", (8.0, 6.0, 4.0, 3.0, 2.0, 1.5, 1.0, 0.75, 0.5), 2.0,
                          lambda b: float(b.frame.options.upscale), _write_upscale),
    # a surface's samples along the diagonal: time as the samples (finer is larger); below
    # REDUCED_STEPS (or the still steps), that many steps over the pixels' reduction
    # squared (2, 3, 4 times fewer across): the steps alone leave a floor, the walk
    # through the active cells
    "steps": BudgetKnob("steps", SURFACE_STEPS, -1.0, _read_steps, _write_steps,
                        lambda v, still: _steps_label(*steps_drawn(v, still)),
                        _steps_ladder),
    # a voxel grid's pixels, 1/reduction of the viewport across: time as the pixels
    "pixels": BudgetKnob("reduction", (4.0, 3.0, 2.0, 1.0), 2.0,
                         lambda b: float(getattr(getattr(b, "reduced", None), "factor", 1)),
                         _write_reduction,
                         lambda v, still: "full size" if v == 1 else f"1/{v:g} size"),
}
TECHNIQUE_KNOBS = {"vtk": "step_pixels", "direct": "step", "cubemap": "upscale", "active": "steps",
                   "full": "steps", "voxels": "pixels"}


@dataclass
class FrameRecord:
    """One frame: whether the view was moving, the knob's value drawn and its time."""

    moving: bool
    value: float
    ms: float


@dataclass
class FrameBudget:
    """Holds a volume's frames within ``budget_ms`` while the view moves.

    ``binding`` is the volume's binding; ``knob`` what is moved (:data:`KNOBS`);
    ``still`` the knob's value for a still view; ``errors`` the estimated PSNR of values
    the error budget measured, to report a moving frame's error; ``clock`` in seconds.
    """

    binding: object
    window: object
    budget_ms: float
    knob: BudgetKnob
    still: float
    errors: dict = field(default_factory=dict)
    clock: Callable[[], float] = time.perf_counter
    frames: list[FrameRecord] = field(default_factory=list)
    value: float = 0.0
    _started: float | None = None
    _depth: int = 0
    _written: float | None = None
    _said_over: bool = False

    def __post_init__(self):
        self.value = self.still

    @property
    def moving(self) -> bool:
        """Whether the render window is asked for interactive frames now."""
        return self.window.GetDesiredUpdateRate() >= MOVING_RATE

    @property
    def estimated_psnr(self) -> float | None:
        """The error budget's estimate for the value drawn last (None: not measured)."""
        return self.errors.get(self.value)

    def describe(self, value: float) -> str:
        """What ``value`` draws, as the panel and the bench say it."""
        return self.knob.describe(value, self.still)

    def next_value(self, value: float, ms: float) -> float:
        """The finest value predicted to fit the budget after ``ms`` at ``value``.

        Never finer than the still value; the coarsest when nothing fits. A finer value
        than ``value`` is taken only where it is predicted to fit :data:`REFINE_AIM` of the
        budget (a change of size costs a frame new targets, and the cost model errs more
        the further it reaches). A knob's coarseness is its value, or its inverse where
        cost grows with it (``power < 0``).
        """
        coarseness = self._coarseness
        allowed = self._allowed()

        def finest_fitting(aim: float) -> float:
            wanted = value * (ms / (aim * self.budget_ms)) ** (1.0 / self.knob.power)
            fitting = [v for v in allowed if coarseness(v) >= coarseness(wanted)]
            return min(fitting, key=coarseness) if fitting else max(allowed, key=coarseness)
        chosen = finest_fitting(AIM)
        if coarseness(chosen) < coarseness(value):   # finer: only with room to spare
            cautious = finest_fitting(REFINE_AIM)
            chosen = cautious if coarseness(cautious) < coarseness(value) else value
        return chosen

    def _coarseness(self, value: float) -> float:
        return value if self.knob.power > 0 else -value

    def _allowed(self) -> list[float]:
        """The values a moving frame may take: the ladder's, none finer than the still."""
        values = {*self.knob.ladder(self.still, self.binding), float(self.still)}
        return sorted((v for v in values
                       if self._coarseness(v) >= self._coarseness(self.still)),
                      key=self._coarseness)

    def _say_if_over(self) -> None:
        """Warn once when the last moving frames, all at the coarsest value, missed the budget.

        Nothing coarser is left: the budget cannot be held by this knob (a cost it does not
        move: a world's chunks, a slow device). ``binding.budget_hint``, if any, says what
        would help.
        """
        last = self.frames[-PREDICT_FROM:]
        if self._said_over or len(last) < PREDICT_FROM or not all(
                f.moving and f.ms > self.budget_ms for f in last):
            return   # the ladder is read only for frames over the budget
        coarsest = max(self._allowed(), key=self._coarseness)
        if any(f.value != coarsest for f in last):
            return
        self._said_over = True
        hint = getattr(self.binding, "budget_hint", "")
        warn_user(f"frame_budget_ms={self.budget_ms:g}: moving frames take "
                  f"{min(f.ms for f in last):.0f} ms or more at the coarsest setting "
                  f"({self.describe(coarsest)}); nothing coarser is left to hold the budget."
                  + (f" {hint}" if hint else ""))

    def predicted_ms(self, value: float) -> float:
        """A frame's time at ``value``: the costliest of the last :data:`PREDICT_FROM`."""
        power = self.knob.power
        return max(f.ms * (f.value / value) ** power for f in self.frames[-PREDICT_FROM:])

    def before_frame(self, *_) -> None:
        """Choose this frame's value, set it, start the clock.

        A render nested in a frame (a frame VTK drew without our bindings, drawn again at
        its end) is part of that frame: it keeps the value and the clock.
        """
        self._depth += 1
        if self._depth > 1:
            return
        if not self.moving:
            self.value = self.still
        elif self.frames:
            last = self.frames[-1]
            self.value = self.next_value(last.value, self.predicted_ms(last.value))
        if self.value != self._written:   # a still view sets nothing frame after frame
            self.knob.write(self.binding, self.value)
            self._written = self.value
        self._started = self.clock()

    def after_frame(self, *_, record: bool = True) -> FrameRecord | None:
        """Record the frame's time (the outermost render's, nested ones included).

        ``record=False``: the frame ends without a record (another path drew it); the
        recorded frame is returned.
        """
        self._depth = max(self._depth - 1, 0)
        if self._depth > 0 or self._started is None:
            return None
        ms = (self.clock() - self._started) * 1e3
        self._started = None
        if not record:
            return None
        self.frames.append(FrameRecord(self.moving, float(self.value), ms))
        del self.frames[:-1000]        # a long session keeps the last thousand
        self._say_if_over()
        return self.frames[-1]


@dataclass
class PathBudgets:
    """``technique='auto'``: each path's own budget, fed only the frames that path drew.

    Each frame, both paths set the value their own last frame predicts (one of them will
    draw: the choice is made after the frame starts); the frame's time then goes to the
    path that drew it. ``frames`` holds every frame; ``knob`` and ``estimated_psnr`` are
    the last drawn path's.
    """

    binding: object
    paths: dict
    budget_ms: float
    frames: list = field(default_factory=list)
    _last: str = "direct"

    @property
    def knob(self) -> BudgetKnob:
        return self.paths[self._last].knob

    @property
    def moving(self) -> bool:
        return self.paths[self._last].moving

    @property
    def estimated_psnr(self) -> float | None:
        return self.paths[self._last].estimated_psnr

    def describe(self, value: float) -> str:
        """What ``value`` draws on the last drawn path."""
        return self.paths[self._last].describe(value)

    def before_frame(self, *_) -> None:
        for budget in self.paths.values():
            budget.before_frame()

    def after_frame(self, *_) -> None:
        drawn = self.binding.choice
        for name, budget in self.paths.items():
            record = budget.after_frame(record=name == drawn)
            if record is not None:
                self._last = name
                self.frames.append(record)
                del self.frames[:-1000]


def check_frame_budget(budget_ms, technique: str) -> None:
    """Refuse a budget that is not a positive time, or a technique it cannot steer."""
    if isinstance(budget_ms, (bool, np.bool_)) or not isinstance(budget_ms, numbers.Real) \
            or not 0.0 < float(budget_ms) < float("inf"):
        raise ValueError(f"frame_budget_ms must be a positive number of milliseconds, got "
                         f"{budget_ms!r}.")
    if technique not in TECHNIQUE_KNOBS and technique != "auto":
        raise ValueError(f"frame_budget_ms steers a volume's technique='vtk', 'direct', "
                         f"'cubemap' or 'auto', or a surface's steps, not "
                         f"technique={technique!r}.")


def attach_frame_budget(binding, technique: str, window, budget_ms: float,
                        errors: dict | None = None,
                        clock: Callable[[], float] = time.perf_counter
                        ) -> FrameBudget | PathBudgets:
    """Follow ``window``'s frames with a :class:`FrameBudget`; removed with the binding.

    The window's, not the renderer's: the cube map marches in a pass before the renderer
    starts (timed from the renderer, its frames took 2 ms of their 50). ``'auto'``: a
    budget on each path (:class:`PathBudgets`), ``errors`` keyed by path name.
    """
    if technique == "auto":
        paths = {}
        for name in ("direct", "cubemap"):
            path = getattr(binding, name)
            knob = KNOBS[TECHNIQUE_KNOBS[name]]
            path.frame_budget = FrameBudget(path, window, float(budget_ms), knob,
                                            knob.read(path),
                                            dict((errors or {}).get(name, {})), clock)
            paths[name] = path.frame_budget
        budget = PathBudgets(binding, paths, float(budget_ms))
    else:
        name = TECHNIQUE_KNOBS[technique]
        knob = KNOBS[name]
        if name == "step" and getattr(binding, "downsample", 1) > 1:
            knob = dataclasses.replace(KNOBS["step_downsample"],
                                       label=_step_downsample_label(binding))
        elif name == "step_pixels":   # its sizes read against the user's sample distance
            knob = dataclasses.replace(knob, label=_vtk_step_label(binding))
        budget = FrameBudget(binding, window, float(budget_ms), knob, knob.read(binding),
                             dict(errors or {}), clock)
    # the end observed last: after any redraw the frame's other observers make
    tags = [observe(window, vtkCommand.StartEvent, budget.before_frame),
            observe(window, vtkCommand.EndEvent, budget.after_frame, -10.0)]
    binding.frame_budget = budget
    release = binding.release_resources

    def release_and_stop() -> None:
        for tag in tags:
            window.RemoveObserver(tag)
        release()
    binding.release_resources = release_and_stop
    return budget
