"""``add_voxels(..., quality=)``: the exact traversal, with its error measured and reported.

The voxel DDA visits every voxel a ray crosses, so it draws the CPU reference itself; the
settings that trade accuracy for time (fixed steps, level of detail) were not found
cheaper where measured (``bench voxels``: fixed steps 1.3-10x slower than the DDA;
``bench voxel-world``: level of detail no faster on a 256³ terrain), so every target gets
the DDA. Its error is still measured, on a probe frame of the window's size against the
reference over that whole frame (0.4 s at 640x480), and reported as any choice is, so a
drawing that differs from the reference is seen ('exact' too: met only when the
measurement shows it). Translucent labels are measured against the layered reference (the
faces of every translucent material a ray crosses, composited in depth order).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..models.chunk_pool import world_filled_bounds
from ..reference.voxel_layers import render_voxel_layers
from ..voxels.layers import translucent_materials
from .ladders import Rung
from .probe import ProbeCalibration
from .targets import QualityTarget, parse_quality

#: What quality= chooses for voxels; the settings it rules out.
EXACT = {"traversal": "dda"}
#: The most voxels of a world's filled box quality= reads whole for the reference.
WORLD_REFERENCE_VOXELS = 1 << 27


def _filled_box(world) -> tuple[np.ndarray, np.ndarray]:
    """The index-space box of a world's filled voxels (one empty voxel for an empty world)."""
    lower, upper = (np.asarray(v, dtype=np.int64) for v in world_filled_bounds(world))
    return lower, np.maximum(upper, lower + 1)


def check_world_reference(world) -> None:
    """Refuse ``quality=`` for a world whose filled voxels the reference cannot read whole."""
    lower, upper = _filled_box(world)
    count = int(np.prod(upper - lower))
    if count > WORLD_REFERENCE_VOXELS:
        raise ValueError(f"quality= reads a world's filled voxels whole for the CPU reference; "
                         f"this world's filled box holds {count:,} voxels, over "
                         f"{WORLD_REFERENCE_VOXELS:,}: leave quality out (the world is drawn "
                         "by the same exact traversal either way).")


def world_reference_grid(world) -> tuple[np.ndarray, np.ndarray]:
    """A world's labels over the box of its filled voxels, read from its chunks, placed.

    What the reference traces for ``quality=`` on a world: the box's labels and its
    ``world_from_index`` (:func:`check_world_reference` says whether it may).
    """
    check_world_reference(world)
    lower, upper = _filled_box(world)
    labels = world.labels_in(tuple(slice(int(lo), int(hi))
                                   for lo, hi in zip(lower, upper, strict=True)))
    shift = np.eye(4)
    shift[:3, 3] = lower
    return labels, np.asarray(world.world_from_index(), dtype=np.float64) @ shift


def check_voxel_quality(quality, traversal: str, step_scale, lod: bool) -> QualityTarget:
    """Read ``quality=`` for voxels and refuse the settings that would contradict it."""
    target = parse_quality(quality, exact=True)
    if traversal != "dda" or step_scale is not None or lod:
        raise ValueError("quality= draws every voxel a ray crosses (traversal='dda', no lod): "
                         "leave traversal, step_scale and lod out with it.")
    return target


def has_translucent(palette) -> bool:
    """Whether some label's opacity lies strictly between 0 and 1."""
    return translucent_materials(palette.rgba).size > 0


#: The keywords of the layered reference's look.
LAYERED_LOOK = ("shading", "ambient", "diffuse", "specular", "specular_power", "clip_planes")
#: The looks the layered reference (translucent labels) does not draw.
NOT_LAYERED = ("show_edges", "ambient_occlusion")


def check_translucent(model, look: dict) -> None:
    """Refuse ``quality=`` for translucent labels with a look their reference lacks."""
    if has_translucent(model.palette):
        given = [name for name in NOT_LAYERED if look.get(name)]
        if given:
            raise ValueError(f"quality= measures translucent labels against the layered "
                             f"reference, which draws no {' or '.join(given)}: leave "
                             f"{' and '.join(given)} out, or make the labels opaque.")


@dataclass
class VoxelCalibration(ProbeCalibration):
    """``quality=`` of a voxel grid: the DDA, measured over the window's frame.

    ``look`` holds the reference's keywords for the grid's look (shading, edges ...);
    ``bounds_of`` gives its actor's bounds now (what PyVista frames the camera on). A
    world's labels are read from its chunks at each calibration
    (:func:`world_reference_grid`).
    """

    look: dict | None = None
    bounds_of: Callable | None = None
    _grid: tuple | None = field(default=None, init=False, repr=False)
    kind = "voxels"
    samples = 1 << 40   # every pixel of the footprint (the reference traces the frame)

    def tracks(self) -> list[list[Rung]]:
        return [[Rung(dict(EXACT), 1.0)]]

    def traced_grid(self) -> tuple[np.ndarray, np.ndarray]:
        """The labels the reference traces and their ``world_from_index``, as they are now.

        Read when a calibration keys its choice, and kept for its trace.
        """
        if hasattr(self.model, "labels"):
            self._grid = (self.model.labels, self.model.world_from_index())
        else:
            self._grid = world_reference_grid(self.model)
        return self._grid

    def key_parts(self) -> tuple:
        labels, world_from_index = self.traced_grid()
        return (np.asarray(labels), np.asarray(self.model.palette.rgba),
                np.asarray(world_from_index), sorted((k, repr(v)) for k, v in self.keep.items()))

    def bounds(self) -> np.ndarray:
        if self.bounds_of is not None:
            return np.asarray(self.bounds_of(), dtype=np.float64)
        return super().bounds()

    def shading(self) -> str:
        return self.look.get("shading", "unlit")

    def trace(self, camera, size, background, near, pixels) -> np.ndarray:
        labels, world_from_index = self._grid or self.traced_grid()
        look, reference = self.look, self.reference
        if has_translucent(self.model.palette):   # composited in depth order, face by face
            look = {k: v for k, v in look.items() if k in LAYERED_LOOK}
            reference = render_voxel_layers
        frame = reference(labels, world_from_index, self.model.palette.rgba, camera, size,
                          background=background, near=near, lights=self.probe_lights(),
                          **look)
        rows, columns = pixels
        return frame[rows, columns][None]

    def apply(self, binding, setting: dict) -> None:
        """Nothing to change: the grid is drawn by the DDA already."""
