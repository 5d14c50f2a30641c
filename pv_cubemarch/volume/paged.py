"""Multiscale volumes beyond memory: the direct marcher reading a brick pool.

The volume's levels (:mod:`~pv_cubemarch.models.multiscale`) are cut into bricks streamed
into a GPU pool (:mod:`.brick_pager`). The shader (``paged_sample.glsl``, reading
the pool through ``paged_bricks.glsl``) reads each
sample from the coarsest level whose point spacing fits one pixel there (shifted by
``lod_bias``), or from the nearest coarser resident one: the coarsest level is loaded
before the first frame and never evicted, so there is no hole. When nothing wanted is
missing the image has converged. Here: the volume's model, its binding and its shader's
inputs.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pyvista

from ..core import vtk_classes as vtk
from ..core.errors import VolumeDataWarning
from ..core.frame_errors import observe
from ..core.user_warnings import warn_user
from ..gl.bindings import ShaderBindings
from ..gl.box import bind_camera, box_actor
from ..gl.textures import Texture
from ..models.multiscale import MultiscaleSource
from ..models.transfer import TransferFunction
from ..models.volume import box_world_bounds
from .binding import VolumeSetup, bind_marching, march_defines, world_from_texture
from .brick_pager import BrickPager, FiniteBricks, bind_pool
from .clipping import ClipState
from .direct import DirectBinding
from .stop_depth import follow_stop_depth, rays_can_stop


@dataclass(eq=False)
class PagedVolume:
    """A multiscale volume placed in the world with its transfer function; no data held.

    Its index space is the finest level's points; ``transform`` places the physical frame
    of the source's metadata in the world.
    """

    source: MultiscaleSource
    transfer: TransferFunction
    transform: np.ndarray = field(default_factory=lambda: np.eye(4))
    name: str = "volume"
    interpolation: str = "linear"
    #: The streaming keywords it was added with (lod_bias, gpu_bytes, host_bytes,
    #: brick_size), kept when it is added again.
    paging: dict = field(default_factory=dict)
    #: ``add_volume``'s ``nan_policy``, applied to each brick as it is read.
    nan_policy: str = "raise"
    colors = None
    value_offset = 0

    @property
    def dimensions(self) -> tuple[int, int, int]:
        """Points along x, y, z of the finest level."""
        return self.source.shape

    def dataset_from_index(self) -> np.ndarray:
        """4x4 from finest-level point indices to the source's physical coordinates."""
        return self.source.levels[0].physical_from_index()

    def world_from_index(self) -> np.ndarray:
        """4x4 from finest-level point indices to world coordinates."""
        return np.asarray(self.transform, float) @ self.dataset_from_index()

    def world_from_point(self) -> np.ndarray:
        """The same: a volume's index space is its finest level's points (the pager's name)."""
        return self.world_from_index()

    def world_bounds(self) -> np.ndarray:
        """World bounds ``(xmin, xmax, ...)`` of the finest level's box."""
        return box_world_bounds(self.world_from_index(), np.asarray(self.dimensions) - 1.0)


class PagedData:
    """What the marcher's bindings read of a paged volume: its tables, planes and pool."""

    def __init__(self, model: PagedVolume, pager: BrickPager):
        self.model = model
        self.pager = pager
        self.tables = [Texture(model.transfer.table.reshape(1, -1, 4), kind="2d")]
        self.clip = ClipState()
        self.brick_builds = 0
        # a brick the planes cut away is not read; a moved plane plans again
        pager.clip_planes = lambda: self.clip.planes
        pager.drawn_state = lambda: self.clip.planes

    @property
    def nbytes(self) -> int:
        """GPU bytes of the pool, its tables and the transfer table."""
        return self.pager.nbytes + self.tables[0].nbytes

    def release(self) -> None:
        """The transfer table and the pager's textures and reads."""
        self.tables[0].release()
        self.pager.release()


class FollowsPager:
    """What any binding streamed by bricks answers (mixed in first; ``pager``: its pager)."""

    pager: BrickPager

    @property
    def converged(self) -> bool:
        """Whether the last frame had every brick it wanted."""
        return self.pager.converged

    def wait_for_bricks(self, timeout: float) -> bool:
        """Wait until a requested brick arrives (or ``timeout`` s); True if one did."""
        return self.pager.cache.wait(timeout)

    def stats(self) -> dict:
        """Resident, missing and read bricks and bytes (:meth:`BrickPager.stats`)."""
        return self.pager.stats()

    def place(self, transform) -> None:
        """The box follows, and the levels' world steps (a pixel is compared with them)."""
        super().place(transform)
        self.pager.follow_placement()

    def release_resources(self) -> None:
        """Stop the per-frame choice, then what its technique frees."""
        stop_following(self)
        super().release_resources()


class Streamed(FollowsPager):
    """What a volume streamed by bricks adds to its technique's binding (mixed in first)."""

    @property
    def pager(self) -> BrickPager:
        """The pool, page table and reads of this volume."""
        return self.data.pager

    def set_interpolation(self, interpolation: str) -> None:
        """Read the bricks ``'linear'`` or ``'nearest'`` from the next frame (no upload)."""
        if interpolation not in ("linear", "nearest"):
            raise ValueError(f"interpolation must be 'linear' or 'nearest', got "
                             f"{interpolation!r}.")
        self.model.interpolation = interpolation
        self.data.pager.pool.set_interpolation(interpolation == "linear")

    def set_values(self, values, member: str | None = None) -> None:
        """Refused: a streamed volume's values are its source's (write to the store)."""
        raise ValueError("A volume streamed from a multiscale source reads its values from "
                         "the source; write them there and add the volume again.")

    def set_opacity_unit_distance(self, length: float) -> None:
        """Refused: add the streamed volume again with ``opacity_unit_distance=``."""
        raise ValueError("A streamed volume's transfer function is set when it is added: "
                         "add it again with opacity_unit_distance=.")

    def set_transfer(self, transfer) -> None:
        """Colour the streamed volume by ``transfer`` from the next frame.

        The table goes up again; the bricks marked as drawing nothing are found again
        (:meth:`BrickPager.recolour`): read again from the host cache, not the store.
        """
        rows = self.__dict__.get("table_rows", self.model.transfer.n_colors)
        self.model.transfer = transfer
        self.data.tables[0].set_data(transfer.table.reshape(1, -1, 4))
        skips = self.data.pager.recolour()
        changes = {"CM_SKIP_EMPTY": skips} | (
            {"CM_TABLE_SIZE": transfer.n_colors} if transfer.n_colors != rows else {})
        self.set_march_defines(changes)
        self.table_rows = transfer.n_colors   # the size compiled (see VolumeBinding)

    def set_shade(self, shading) -> None:
        """Only unshaded (the brick pool's marcher reads no gradient)."""
        if shading is not None:
            raise ValueError("shade=True: a volume streamed from a multiscale source is "
                             "drawn unshaded.")

    def set_blending(self, blending: str) -> None:
        """Only 'composite' (what the brick pool's marcher draws)."""
        if blending != "composite":
            raise ValueError(f"blending={blending!r}: a volume streamed from a multiscale "
                             "source is drawn with blending='composite' only.")


class PagedBinding(Streamed, DirectBinding):
    """A paged volume on its box: the direct marcher reading the brick pool."""


def follow_pager(plotter, binding, pager: BrickPager) -> None:
    """Choose and upload bricks at the start of each frame of the plotter's renderer.

    Before any pass reads the pool; nothing while ``binding`` is hidden. An interactive
    window redraws by itself while bricks arrive (:func:`refine_while_shown`).
    """
    binding._pager_renderer = plotter.renderer
    binding._pager_tags = [observe(plotter.renderer, vtk.vtkCommand.StartEvent, pager.frame,
                                   4.0)]
    if pager.cull_hidden and pager.depth_before_plan is None:
        # the frame's depth, once drawn, for the next frame's choice
        binding._pager_tags.append(observe(plotter.renderer, vtk.vtkCommand.EndEvent,
                                           pager.keep_depth))
    pager.shown = lambda: binding.shown
    refine_while_shown(plotter, binding)


def stop_following(binding) -> None:
    """Undo :func:`follow_pager` (once)."""
    for tag in getattr(binding, "_pager_tags", ()):
        binding._pager_renderer.RemoveObserver(tag)
    binding._pager_tags = []


#: Milliseconds between the redraws of a window whose streamed volume still misses bricks.
REFINE_MS = 100


def refine_while_shown(plotter, binding) -> None:
    """In an interactive window, redraw while bricks arrive: the image refines by itself.

    A repeating timer of the window's interactor (it runs while ``plotter.show()`` does)
    renders again whenever the volume is shown and not converged; offscreen plotters have
    none (``render_image(converge=True)`` waits there).
    """
    interactor = getattr(plotter, "iren", None)
    if interactor is None or getattr(plotter, "off_screen", True):
        return

    def refine(*_):
        if binding.shown and not binding.converged:
            plotter.render()

    tag = interactor.add_observer("TimerEvent", refine)
    timer = interactor.create_timer(REFINE_MS, repeating=True)

    def stop():
        interactor.remove_observer(tag)
        interactor.destroy_timer(timer)

    binding.extra_release.append(stop)


def bind_paged_sampling(target, data: PagedData, step_scale: float,
                        stop_opacity: float) -> dict:
    """Give ``target`` what the marcher reads of a paged volume; returns its switches."""
    model, pager = data.model, data.pager
    bind_marching(target, data, step_scale, stop_opacity)
    target.add_texture("cm_transferTable", data.tables[0])
    target.set_uniform("cm_clim", lambda: model.transfer.clim)   # follows set_transfer
    bind_pool(target, pager, model.world_from_point)
    return {**march_defines(model, pager.empty_value is not None), **data.clip.defines,
            "CM_PAGED_LEVELS": len(pager.levels)}


def build_paged_actor(plotter, data: PagedData, setup: VolumeSetup) -> PagedBinding:
    """The direct marcher's box actor reading ``data``'s brick pool; returns its binding."""
    options, shading = setup.options, setup.shading
    model = data.model
    renderer = plotter.renderer
    actor = box_actor([n - 1.0 for n in model.dimensions], model.world_from_index())
    step_scale = float(options.step_scale)
    bindings = ShaderBindings(actor.GetMapper(), renderer)
    defines = bind_paged_sampling(bindings, data, step_scale, shading.stop_opacity)
    bind_camera(bindings, renderer, lambda: world_from_texture(model))
    binding = PagedBinding(model, data, bindings, None, step_scale, shading.stop_opacity,
                           window=plotter.ren_win, sampling=("paged_bricks", "paged_sample"),
                           defines=defines)
    binding.drawn = [actor]
    binding.renderer = renderer
    binding.follow_multisampling()
    binding._tag = observe(renderer, vtk.vtkCommand.StartEvent,
                           binding.follow_multisampling, 5.0)
    if rays_can_stop(model, shading.stop_opacity):   # bricks behind where rays stop: unread
        follow_stop_depth(binding, lambda target: bind_paged_sampling(
            target, data, step_scale, shading.stop_opacity))
    follow_pager(plotter, binding, data.pager)
    pyvista.set_new_attribute(actor, "cubemarch", binding)
    return binding


def check_paging(given: dict) -> None:
    """Refuse streaming keywords out of their range, naming them (None: the default)."""
    for name, low, high in (("gpu_bytes", 1, None), ("host_bytes", 1, None),
                            ("brick_size", 1, 1024)):
        value = given.get(name)
        if value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low \
                or (high is not None and value > high):
            raise ValueError(f"{name} must be an integer of at least {low}"
                             + (f" and at most {high}" if high else "") + f", got {value!r}.")
    bias = given.get("lod_bias")
    if bias is not None and not (isinstance(bias, (int, float, np.number))
                                 and not isinstance(bias, bool) and -64 <= float(bias) <= 64):
        raise ValueError(f"lod_bias must be a number from -64 to 64 (levels added to the one "
                         f"whose points fit a pixel), got {bias!r}.")


def paged_transfer(source: MultiscaleSource, cmap, opacity, clim, opacity_unit_distance,
                   n_colors, flip_scalars, log_scale,
                   nan_policy: str = "raise") -> TransferFunction:
    """The transfer table for a multiscale source, with defaults it can afford.

    ``clim`` defaults to the coarsest level's range (the finest would mean reading all of
    it), its NaN and infinite values refused or read as 0 (``nan_policy``);
    ``opacity_unit_distance`` to PyVista's, the finest level's diagonal over its mean
    number of points less one.
    """
    if clim is None:
        coarsest = source.levels[-1]
        values = FiniteBricks(nan_policy, source.name)(
            (len(source.levels) - 1, 0, 0, 0), coarsest.read(
                tuple(slice(0, n) for n in coarsest.shape)))
        low, high = float(values.min()), float(values.max())
        if not high > low:   # one unit wide, or wider where one unit is below the rounding
            width = max(1.0, abs(low) * 2.0 ** -20)
            low, high = (low, low + width) if low + width < 3e38 else (low - width, low)
            warn_user(f"the coarsest level is constant (every value is {values.max():g}): clim "
                      "from its range puts every sample at the first entry of the colormap "
                      "and of the opacity, which draws nothing where that entry is 0; pass "
                      "clim=(low, high) around the value to draw it (a store whose chunks "
                      "are absent, or not where its metadata says, reads as its fill value)",
                      VolumeDataWarning)
        clim = (low, high)
    if opacity_unit_distance is None:
        finest = source.levels[0]
        diagonal = float(np.linalg.norm((np.asarray(finest.shape) - 1) * finest.scale))
        points = float(np.mean(finest.shape)) - 1.0
        opacity_unit_distance = diagonal / points if points > 0 and diagonal > 0 else float(
            np.mean(finest.scale))
    return TransferFunction.from_colormap(cmap, "linear" if opacity is None else opacity, clim,
                                          opacity_unit_distance, n_colors=n_colors or 256,
                                          flip_scalars=bool(flip_scalars),
                                          log_scale=bool(log_scale))
