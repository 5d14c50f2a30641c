"""The edits and picks a voxel world takes in world voxel indices, however it is drawn.

A drawn world (:class:`~.world.WorldBinding`, a box per chunk, or
:class:`~.indexed.IndexedWorldBinding`, one traversal) mixes in :class:`WorldEditing` and
says how written labels reach the GPU (``_write``); picks are the CPU traversal of the
world's chunks, as drawn.
"""

from __future__ import annotations

import numpy as np

from ..core.camera import Camera
from ..core.rendering import needs_open_plotter
from ..reference.rays import ray_box_interval
from ..reference.voxels import trace_voxels
from . import editing
from .technique import VoxelPick


class WorldEditing:
    """Edits (``set_voxels``, brushes, ``set_block``, ``set_values``) and ``pick`` of a world.

    The class mixing it in has ``model`` (the :class:`~pv_cubemarch.models.world.VoxelWorld`),
    ``renderer`` and ``_write(box, values)``.
    """

    @needs_open_plotter
    def set_voxels(self, where, material: int) -> None:
        """Set voxels to ``material`` (0 empties them): an index, slices or world mask."""
        value = self._checked_material(material)
        box, mask = editing.box_of(where, self.model.dimensions)
        if any(s.stop <= s.start for s in box):
            return
        if mask is None:
            block = np.full([s.stop - s.start for s in box], value, self._type_for(value))
        else:
            block = self.model.labels_in(box).astype(self._type_for(value), copy=False)
            block[mask] = value
        self._write(box, block)

    def _type_for(self, value: int) -> np.dtype:
        """The labels' type, or uint16 for a label above 255 (the world widens to it)."""
        widens = value > 255 and self.model.dtype == np.uint8
        return np.dtype(np.uint16) if widens else self.model.dtype

    @needs_open_plotter
    def fill_sphere(self, center, radius: float, material: int) -> None:
        """Set the voxels whose centre is within ``radius`` of ``center`` (world indices)."""
        value = self._checked_material(material)
        box, local = editing.sphere_region(center, radius, self.model.dimensions)
        if local is None:
            return
        block = self.model.labels_in(box).astype(self._type_for(value), copy=False)
        block[local] = value
        self._write(box, block)

    @needs_open_plotter
    def fill_box(self, lower, upper, material: int) -> None:
        """Set the voxels ``lower <= (i, j, k) < upper`` to ``material``."""
        self.set_voxels(editing.clipped_box(lower, upper, self.model.dimensions), material)

    @needs_open_plotter
    def set_block(self, where, values) -> None:
        """Write the labels ``values`` into the box ``where`` (a tuple of three slices)."""
        box, mask = editing.box_of(where, self.model.dimensions)
        values = np.asarray(values)
        shape = tuple(s.stop - s.start for s in box)
        if mask is not None or values.shape != shape:
            raise ValueError(f"set_block needs a tuple of slices and values of its shape "
                             f"{shape}, got values of {values.shape}.")
        ids = self.model.ids
        if ids.identity:
            editing.check_labels(values, np.uint16, self.model.palette)
        else:
            values = editing.compacted_rows(ids, values, "values").reshape(values.shape)
        if values.size:
            self._write(box, values)

    @needs_open_plotter
    def set_values(self, labels) -> None:
        """Replace every label (the world's shape)."""
        labels = np.asarray(labels)
        if labels.shape != tuple(self.model.dimensions):
            raise ValueError(f"set_values needs labels of the world's shape "
                             f"{tuple(self.model.dimensions)}, got {labels.shape}.")
        self.set_block(tuple(slice(0, n) for n in self.model.dimensions), labels)

    def _checked_material(self, material) -> int:
        """``material``'s row if the palette has it (a world's labels widen to uint16)."""
        if not self.model.ids.identity:
            return int(editing.compacted_rows(self.model.ids, material, "material")[0])
        return editing.check_material(material, np.uint16, self.model.palette)

    @needs_open_plotter
    def pick(self, x: int, y: int) -> VoxelPick | None:
        """The voxel under pixel ``(x, y)`` (from the top-left), or ``None``.

        The chunks the pixel's ray crosses are traversed near to far on the CPU until one
        is hit (as the GPU draws them); the index is the world's.
        """
        width, height = self.renderer.GetSize()
        if not (0 <= int(x) < width and 0 <= int(y) < height):
            raise ValueError(f"(x, y) must be a pixel of the {width}x{height} renderer, got "
                             f"({x}, {y}).")
        camera = Camera.from_pyvista(self.renderer.GetActiveCamera())
        origins, directions = camera.rays((width, height))
        origin, direction = origins[int(y), int(x)], directions[int(y), int(x)]
        index_from_world = np.linalg.inv(self.model.world_from_index())
        o = (index_from_world @ np.append(origin, 1.0))[:3]
        d = index_from_world[:3, :3] @ direction
        keys = sorted(set(self.model.stored) | set(self.model.uniform))
        boxes = [self.model.chunk_box(key) for key in keys]
        lower = np.array([start for start, _ in boxes], dtype=np.float64).reshape(-1, 3)
        enter, leave = ray_box_interval(o, d, lower, lower + [shape for _, shape in boxes])
        enter = np.maximum(enter, 0.0)
        crossed = np.flatnonzero(enter <= leave)
        for key in [keys[i] for i in crossed[np.argsort(enter[crossed], kind="stable")]]:
            chunk = self.model.chunk_model(key)
            hits = trace_voxels(chunk.labels, chunk.world_from_index(), camera,
                                (width, height), near=camera.clipping_range[0],
                                visible=self.model.palette.visible, crop=(int(x), int(y), 1, 1),
                                clip_planes=self.options.world_planes)
            if hits.material[0, 0] == 0:
                continue
            depth = float(hits.depth[0, 0])
            point = origin + direction * depth
            start, shape = self.model.chunk_box(key)
            if key in self.model.stored:
                index = start + hits.index[0, 0]
            else:   # one stretched voxel: the voxel of the world the ray enters there
                inside = (index_from_world @ np.append(point, 1.0))[:3] + 1e-6 * d / np.abs(
                    d).max()
                index = np.clip(np.floor(inside).astype(int), start,
                                start + np.array(shape) - 1)
            row = int(hits.material[0, 0])
            return VoxelPick(tuple(int(v) for v in index), row, int(hits.face[0, 0]), depth,
                             tuple(float(v) for v in point), self.model.ids.id_of(row))
        return None
