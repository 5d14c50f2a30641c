"""Validated volumes: one place turns user data into what every technique and the reference read."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pyvista

from ..core.errors import VolumeDataError
from .transfer import TransferFunction

NAN_POLICIES = ("raise", "zero")


@dataclass(eq=False)
class VolumeModel:
    """A scalar volume on a uniform grid, placed in the world, with its transfer function.

    ``values`` is a float32 array indexed ``[i, j, k]`` (x, y, z) over the grid's points;
    ``transform`` maps the grid's own coordinates to world coordinates.
    """

    grid: pyvista.ImageData
    values: np.ndarray
    transfer: TransferFunction
    transform: np.ndarray = field(default_factory=lambda: np.eye(4))
    name: str = "volume"

    @property
    def dimensions(self) -> tuple[int, int, int]:
        """Number of points along x, y, z."""
        return tuple(int(n) for n in self.values.shape)

    def dataset_from_index(self) -> np.ndarray:
        """4x4 matrix from continuous point indices (i, j, k) to the grid's coordinates."""
        matrix = np.eye(4)
        direction = np.asarray(self.grid.direction_matrix, dtype=np.float64)
        matrix[:3, :3] = direction * np.asarray(self.grid.spacing, dtype=np.float64)
        matrix[:3, 3] = self.grid.origin
        return matrix

    def world_from_index(self) -> np.ndarray:
        """4x4 matrix from point indices to world coordinates."""
        return np.asarray(self.transform, dtype=np.float64) @ self.dataset_from_index()

    def world_bounds(self) -> np.ndarray:
        """Axis-aligned world bounds ``(xmin, xmax, ymin, ymax, zmin, zmax)`` of the box."""
        hi = np.array(self.dimensions, dtype=np.float64) - 1.0
        corners = np.array([[x, y, z, 1.0] for x in (0, hi[0]) for y in (0, hi[1])
                            for z in (0, hi[2])])
        world = corners @ self.world_from_index().T
        lo, up = world[:, :3].min(axis=0), world[:, :3].max(axis=0)
        return np.column_stack([lo, up]).ravel()


def as_image_data(data, scalars: str | None = None, nan_policy: str = "raise"):
    """Check ``data`` and return ``(grid, values, scalars_name)``.

    Accepts a ``pyvista.ImageData`` / ``vtkImageData``, a uniform ``RectilinearGrid`` or a
    3D numpy array (indexed x, y, z, unit spacing). Raises :class:`VolumeDataError` that
    says what is wrong and what to do.
    """
    if nan_policy not in NAN_POLICIES:
        raise VolumeDataError(f"nan_policy must be one of {NAN_POLICIES}, got {nan_policy!r}.")
    if isinstance(data, np.ndarray):
        if data.ndim != 3:
            raise VolumeDataError(
                f"A numpy volume must be 3D (x, y, z), got an array of shape {data.shape}."
            )
        grid = pyvista.ImageData(dimensions=data.shape)
        grid.point_data["values"] = checked_values(data, "values", nan_policy).ravel(order="F")
        data, scalars = grid, "values"
    grid = _as_uniform_grid(data)
    if scalars is None:
        names = list(grid.point_data.keys()) or list(grid.cell_data.keys())
        if not names:
            raise VolumeDataError("The grid has no scalar arrays; add one to point_data.")
        scalars = grid.active_scalars_name if grid.active_scalars_name in names else names[0]
    if scalars not in grid.point_data:
        if scalars in grid.cell_data:
            grid = grid.cell_data_to_point_data(pass_cell_data=False)
        else:
            raise VolumeDataError(
                f"scalars={scalars!r} is not an array of the grid; it has "
                f"{list(grid.point_data.keys()) + list(grid.cell_data.keys())}."
            )
    array = np.asarray(grid.point_data[scalars])
    if array.ndim != 1:
        raise VolumeDataError(
            f"Array {scalars!r} has {array.shape[1]} components; pass a single-component array."
        )
    values = checked_values(array, scalars, nan_policy)
    values = values.reshape(tuple(grid.dimensions), order="F")
    grid, values = _thicken_flat_axes(grid, values)
    return grid, np.ascontiguousarray(values, dtype=np.float32), scalars


def _thicken_flat_axes(grid: pyvista.ImageData, values: np.ndarray):
    """Give an axis with a single point the thickness of one voxel, centred on the point.

    A 1-point axis spans no length as point data; drawn as a slab one spacing thick with
    the values constant across it, a 1xNxM grid is a visible sheet and a 1x1x1 grid a cube.
    """
    flat = [axis for axis in range(3) if values.shape[axis] == 1]
    if not flat:
        return grid, values
    spacing = np.array(grid.spacing, dtype=np.float64)
    origin = np.array(grid.origin, dtype=np.float64)
    direction = np.asarray(grid.direction_matrix, dtype=np.float64)
    for axis in flat:
        values = np.repeat(values, 2, axis=axis)
        origin = origin - direction[:, axis] * spacing[axis] / 2.0
    thick = pyvista.ImageData(dimensions=values.shape, spacing=spacing, origin=origin)
    thick.direction_matrix = direction
    return thick, values


def _as_uniform_grid(data) -> pyvista.ImageData:
    if isinstance(data, pyvista.ImageData):
        return data
    if isinstance(data, pyvista.RectilinearGrid):
        axes = [np.asarray(a, dtype=np.float64) for a in (data.x, data.y, data.z)]
        steps = [np.diff(a) for a in axes]
        if any(s.size and not np.allclose(s, s[0], rtol=1e-5, atol=0) for s in steps):
            raise VolumeDataError(
                "The RectilinearGrid has non-uniform spacing; resample it to a uniform "
                "pyvista.ImageData first (e.g. grid.sample(pyvista.ImageData(...)))."
            )
        image = pyvista.ImageData(
            dimensions=data.dimensions,
            spacing=[s[0] if s.size else 1.0 for s in steps],
            origin=[a[0] for a in axes],
        )
        image.point_data.update(data.point_data)
        image.cell_data.update(data.cell_data)
        return image
    try:
        wrapped = pyvista.wrap(data)
    except Exception:
        wrapped = None
    if isinstance(wrapped, (pyvista.ImageData, pyvista.RectilinearGrid)):
        return _as_uniform_grid(wrapped)
    raise VolumeDataError(
        f"Cannot render a {type(data).__name__} as a volume: pass a pyvista.ImageData, a uniform "
        "RectilinearGrid or a 3D numpy array (resample other meshes onto an ImageData first)."
    )


def checked_values(array: np.ndarray, name: str, nan_policy: str) -> np.ndarray:
    if array.dtype.kind not in "biuf":
        raise VolumeDataError(
            f"Array {name!r} has dtype {array.dtype}; volumes need real numbers "
            "(float, int or bool). Convert it, e.g. with .astype(numpy.float32)."
        )
    values = np.asarray(array, dtype=np.float32)
    bad = ~np.isfinite(values)
    if bad.any():
        if nan_policy == "raise":
            raise VolumeDataError(
                f"Array {name!r} has {int(bad.sum())} NaN or infinite values; clean them "
                "(numpy.nan_to_num) or pass nan_policy='zero' to treat them as 0."
            )
        values = np.where(bad, np.float32(0.0), values)
    return values


def make_volume(data, scalars: str | None = None, *, cmap="magma", opacity="linear",
                clim=None, opacity_unit_distance: float | None = None,
                transfer: TransferFunction | None = None, transform=None,
                nan_policy: str = "raise", name: str = "volume") -> VolumeModel:
    """Validate ``data`` and bundle it with a transfer function into a :class:`VolumeModel`."""
    grid, values, scalars = as_image_data(data, scalars, nan_policy)
    if transfer is None:
        if clim is None:
            lo, hi = float(values.min()), float(values.max())
            clim = (lo, hi if hi > lo else lo + 1.0)
        if opacity_unit_distance is None:
            opacity_unit_distance = float(np.mean(grid.spacing))
        transfer = TransferFunction.from_colormap(cmap, opacity, clim, opacity_unit_distance)
    matrix = np.eye(4) if transform is None else checked_transform(transform)
    return VolumeModel(grid=grid, values=values, transfer=transfer, transform=matrix, name=name)


def checked_transform(transform) -> np.ndarray:
    """``transform`` as a float64 4x4 placement, or a clear error."""
    matrix = np.asarray(transform, dtype=np.float64)
    if matrix.shape != (4, 4) or not np.isfinite(matrix).all():
        raise VolumeDataError(f"transform must be a finite 4x4 matrix, got shape {matrix.shape}.")
    if abs(np.linalg.det(matrix[:3, :3])) < 1e-300:
        raise VolumeDataError("transform must be invertible (its 3x3 part has determinant 0).")
    return matrix
