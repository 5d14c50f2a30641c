"""Validated volumes: one place turns user data into what every technique and the reference read."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace

import numpy as np
import pyvista
from matplotlib.colors import ListedColormap

from ..core import vtk_classes as vtk
from ..core.errors import VolumeDataError, VolumeDataWarning
from ..core.user_warnings import warn_user
from .transfer import TransferFunction, shift_value, table_range

NAN_POLICIES = ("raise", "zero")
#: How values are read between grid points (VTK's volume property interpolation types).
INTERPOLATIONS = ("linear", "nearest")
#: The largest finite float32: volumes are drawn (and referenced) in float32.
FLOAT32_MAX = float(np.finfo(np.float32).max)


@dataclass(eq=False)
class VolumeModel:
    """A scalar volume on a uniform grid, placed in the world, with its transfer function.

    ``values`` is a float32 array indexed ``[i, j, k]`` (x, y, z) over the grid's points;
    ``transform`` maps the grid's own coordinates to world coordinates.

    ``interpolation`` is how the values are read between points: ``'linear'`` (trilinear)
    or ``'nearest'`` (the nearest point, PyVista's default for volumes).

    ``value_offset`` is what was subtracted from the data so that float32 keeps apart
    values that are close together but far from 0 (e.g. int64 ``2**40 + k``): a point's
    data value is ``values + value_offset``, and ``transfer.clim`` is in the units of
    ``values``. It is 0 for data that float32 holds as it is.

    ``colors`` is set for a direct-colour (RGBA) volume: a uint8 ``(nx, ny, nz, 4)`` array
    whose first three components are the colour itself and whose fourth, also ``values``,
    goes through the transfer function's opacity, as VTK draws 4 dependent components.
    """

    grid: pyvista.ImageData
    values: np.ndarray
    transfer: TransferFunction
    transform: np.ndarray = field(default_factory=lambda: np.eye(4))
    name: str = "volume"
    value_offset: int | float = 0
    interpolation: str = "linear"
    colors: np.ndarray | None = None
    #: The point array of ``grid`` whose values are drawn (None: not one of its arrays).
    scalars: str | None = None

    def __post_init__(self):
        check_spacing(self.grid.spacing)

    @property
    def dimensions(self) -> tuple[int, int, int]:
        """Number of points along x, y, z."""
        return tuple(int(n) for n in self.values.shape)

    def dataset_from_index(self) -> np.ndarray:
        """4x4 matrix from continuous point indices (i, j, k) to the grid's coordinates."""
        matrix = np.eye(4)
        direction = np.asarray(self.grid.direction_matrix, dtype=np.float64)
        matrix[:3, :3] = direction * np.asarray(self.grid.spacing, dtype=np.float64)
        matrix[:3, 3] = first_point(self.grid)
        return matrix

    def world_from_index(self) -> np.ndarray:
        """4x4 matrix from point indices to world coordinates."""
        return np.asarray(self.transform, dtype=np.float64) @ self.dataset_from_index()

    def world_bounds(self) -> np.ndarray:
        """Axis-aligned world bounds ``(xmin, xmax, ymin, ymax, zmin, zmax)`` of the box."""
        return box_world_bounds(self.world_from_index(),
                                np.array(self.dimensions, dtype=np.float64) - 1.0)


def first_point(grid: pyvista.ImageData) -> np.ndarray:
    """Where an ImageData's first point lies: its origin moved by the extent's start.

    VTK places point ``(i, j, k)`` of the extent at ``origin + direction @ (spacing *
    (i, j, k))``, so a grid whose extent starts below or above 0 (``pyvista.Wavelet()``:
    -10..10) does not start at its origin.
    """
    start = np.asarray(grid.extent, dtype=np.float64)[0::2]
    direction = np.asarray(grid.direction_matrix, dtype=np.float64)
    spacing = np.asarray(grid.spacing, dtype=np.float64)
    return np.asarray(grid.origin, dtype=np.float64) + direction @ (spacing * start)


def box_world_bounds(world_from_index: np.ndarray, upper, lower=(0.0, 0.0, 0.0)) -> np.ndarray:
    """World bounds ``(xmin, xmax, ...)`` of the index-space box ``[lower, upper]`` placed."""
    corners = np.array([[x, y, z, 1.0] for x in (lower[0], upper[0])
                        for y in (lower[1], upper[1]) for z in (lower[2], upper[2])])
    world = corners @ np.asarray(world_from_index).T
    return np.column_stack([world[:, :3].min(axis=0), world[:, :3].max(axis=0)]).ravel()


def as_image_data(data, scalars: str | None = None, nan_policy: str = "raise"):
    """Check ``data`` and return ``(grid, values, scalars_name, value_offset)``.

    Accepts a ``pyvista.ImageData`` / ``vtkImageData``, a uniform ``RectilinearGrid`` or a
    3D numpy array (indexed x, y, z, unit spacing). ``values`` is float32 data minus
    ``value_offset`` (see :func:`checked_values`), or, for an RGBA array (4 uint8
    components; a numpy array ``(x, y, z, 4)``), the uint8 ``(nx, ny, nz, 4)`` colours.
    Raises :class:`VolumeDataError` that says what is wrong and what to do.
    """
    if nan_policy not in NAN_POLICIES:
        raise VolumeDataError(f"nan_policy must be one of {NAN_POLICIES}, got {nan_policy!r}.")
    if isinstance(data, np.ndarray):
        if data.ndim == 4 and is_rgba(data.reshape(-1, data.shape[-1])):
            grid = pyvista.ImageData(dimensions=data.shape[:3])
            grid, rgba = _thicken_flat_axes(grid, data)
            return grid, np.ascontiguousarray(rgba), "values", 0
        if data.ndim != 3:
            raise VolumeDataError(
                f"A numpy volume must be 3D (x, y, z), or 4D (x, y, z, 4) uint8 RGBA, got an "
                f"array of shape {data.shape}."
            )
        values, offset = checked_values(data, "values", nan_policy)
        grid = pyvista.ImageData(dimensions=data.shape)
        grid.point_data["values"] = values.ravel(order="F")
        grid, values = _thicken_flat_axes(grid, values)
        return grid, np.ascontiguousarray(values, dtype=np.float32), "values", offset
    grid = uniform_grid(data)
    if scalars is None:   # the active array, point or cell data, as PyVista draws it
        names = list(grid.point_data.keys()) or list(grid.cell_data.keys())
        if not names:
            raise VolumeDataError("The grid has no scalar arrays; add one to point_data.")
        active = grid.active_scalars_name
        scalars = active if active in grid.point_data or active in grid.cell_data \
            else names[0]
    if scalars not in grid.point_data:
        if scalars in grid.cell_data:
            warn_user(f"scalars={scalars!r} has one value per cell: it is averaged onto the "
                      "points and drawn interpolated (PyVista draws such an array cell by "
                      "cell); pass point values for the exact picture.")
            grid = grid.cell_data_to_point_data(pass_cell_data=False)
        else:
            raise VolumeDataError(
                f"scalars={scalars!r} is not an array of the grid; it has "
                f"{list(grid.point_data.keys()) + list(grid.cell_data.keys())}."
            )
    array = np.asarray(grid.point_data[scalars])
    if array.ndim != 1 and is_rgba(array):
        rgba = array.reshape(tuple(grid.dimensions) + (4,), order="F")
        grid, rgba = _thicken_flat_axes(grid, rgba)
        return grid, np.ascontiguousarray(rgba), scalars, 0
    if array.ndim != 1:
        raise VolumeDataError(
            f"Array {scalars!r} has {array.shape[1]} components of {array.dtype}; pass a "
            "single-component array, or 4 uint8 components (RGBA, PyVista's direct-colour "
            "volume)."
        )
    values, offset = checked_values(array, scalars, nan_policy)
    values = values.reshape(tuple(grid.dimensions), order="F")
    grid, values = _thicken_flat_axes(grid, values)
    return grid, np.ascontiguousarray(values, dtype=np.float32), scalars, offset


def is_rgba(array: np.ndarray) -> bool:
    """Whether a point array is a direct-colour volume: 4 uint8 components, as PyVista takes."""
    return array.ndim == 2 and array.shape[1] == 4 and array.dtype == np.uint8


def _thicken_flat_axes(grid: pyvista.ImageData, values: np.ndarray):
    """Give an axis with a single point the thickness of one voxel, centred on the point.

    A 1-point axis spans no length as point data; drawn as a slab one spacing thick with
    the values constant across it, a 1xNxM grid is a visible sheet and a 1x1x1 grid a cube.
    """
    flat = [axis for axis in range(3) if values.shape[axis] == 1]
    if not flat:
        return grid, values
    spacing = np.array(grid.spacing, dtype=np.float64)
    origin = first_point(grid)
    direction = np.asarray(grid.direction_matrix, dtype=np.float64)
    for axis in flat:
        values = np.repeat(values, 2, axis=axis)
        origin = origin - direction[:, axis] * spacing[axis] / 2.0
    thick = image_data(values.shape[:3], spacing, origin)   # RGBA: 4 components after
    thick.direction_matrix = direction
    return thick, values


def check_spacing(spacing, name: str = "spacing") -> None:
    """Refuse a grid spacing that is zero or not finite on some axis (a flat, lost grid)."""
    spacing = np.asarray(spacing, dtype=np.float64)
    if spacing.shape != (3,) or not np.isfinite(spacing).all() or (spacing == 0).any():
        raise VolumeDataError(
            f"{name} must be three finite, non-zero numbers, got "
            f"{tuple(spacing.tolist()) if spacing.ndim == 1 else spacing}: a zero spacing "
            "puts every point of that axis in one place, and an infinite one places none; "
            "give the grid its real spacing (e.g. grid.spacing = (1.0, 1.0, 1.0)).")


def check_geometry(grid) -> None:
    """Refuse an ImageData that cannot be placed: its spacing, origin or direction.

    A NaN origin drew nothing in silence, and a singular direction failed deep inside as
    ``LinAlgError``; each is said here by name, with what to do.
    """
    check_spacing(grid.spacing, "the grid's spacing")
    origin = np.asarray(grid.origin, dtype=np.float64)
    if not np.isfinite(origin).all():
        raise VolumeDataError(f"the grid's origin must be three finite numbers, got "
                              f"{tuple(origin.tolist())}; set grid.origin to where its first "
                              "point lies.")
    direction = np.asarray(grid.direction_matrix, dtype=np.float64)
    lengths = np.linalg.norm(direction, axis=0)
    if not np.isfinite(direction).all() or (lengths == 0).any() or abs(
            np.linalg.det(direction / np.where(lengths == 0, 1.0, lengths))) < 1e-9:
        raise VolumeDataError(f"the grid's direction_matrix must be invertible (its columns "
                              f"the axes' directions), got {direction.tolist()}; set "
                              "grid.direction_matrix = numpy.eye(3) for an axis-aligned grid.")


def image_data(dimensions, spacing, origin) -> pyvista.ImageData:
    """A ``pyvista.ImageData``, also with a negative spacing (a mirrored axis).

    PyVista's constructor refuses negative spacings; VTK's setter takes them, and every
    technique draws such a grid as the mirror it is.
    """
    grid = pyvista.ImageData(dimensions=dimensions, origin=origin)
    grid.SetSpacing(*(float(s) for s in spacing))
    return grid


def uniform_grid(data) -> pyvista.ImageData:
    """``data`` as an ImageData: itself, a uniform RectilinearGrid's, or a VTK image wrapped."""
    if isinstance(data, pyvista.ImageData):
        check_geometry(data)
        return data
    if isinstance(data, pyvista.RectilinearGrid):
        axes = [np.asarray(a, dtype=np.float64) for a in (data.x, data.y, data.z)]
        steps = [np.diff(a) for a in axes]
        if any(s.size and not np.allclose(s, s[0], rtol=1e-5, atol=0) for s in steps):
            raise VolumeDataError(
                "The RectilinearGrid has non-uniform spacing; resample it to a uniform "
                "pyvista.ImageData first (e.g. grid.sample(pyvista.ImageData(...)))."
            )
        image = image_data(data.dimensions, [s[0] if s.size else 1.0 for s in steps],
                           [a[0] for a in axes])
        image.point_data.update(data.point_data)
        image.cell_data.update(data.cell_data)
        return image
    try:
        wrapped = pyvista.wrap(data)
    except Exception:
        wrapped = None
    if isinstance(wrapped, (pyvista.ImageData, pyvista.RectilinearGrid)):
        return uniform_grid(wrapped)
    raise VolumeDataError(
        f"Cannot render a {type(data).__name__} as a volume: pass a pyvista.ImageData, a uniform "
        "RectilinearGrid or a 3D numpy array (resample other meshes onto an ImageData first)."
    )


def checked_values(array, name: str, nan_policy: str = "raise",
                   offset: int | float | None = None) -> tuple[np.ndarray, int | float]:
    """Check a volume's data; return it as float32 minus an offset, and the offset.

    float32 (what the GPU and the reference draw) keeps about 7 significant digits, so
    values close together but far from 0 (int64 ``2**40 + k``, uint64 near ``2**64``,
    float64 ``1e10 + x``) would merge into one. Their minimum is then subtracted exactly
    first (integers in integer arithmetic), so distinct values stay distinct; ``offset``
    gives the shift to use instead (e.g. a volume's own, when its data is replaced).
    Raises :class:`VolumeDataError` naming ``name`` for data that cannot be drawn.
    """
    array = np.asarray(array)
    if array.dtype.kind not in "biuf":
        raise VolumeDataError(
            f"Array {name!r} has dtype {array.dtype}; volumes need real numbers "
            "(float, int or bool). Convert it, e.g. with .astype(numpy.float32)."
        )
    if array.size == 0:
        raise VolumeDataError(
            f"Array {name!r} has no values (shape {array.shape}); a volume needs at least one "
            "point along each axis."
        )
    if array.dtype.kind == "f":
        bad = ~np.isfinite(array)
        if bad.any():
            if nan_policy == "raise":
                raise VolumeDataError(
                    f"Array {name!r} has {int(bad.sum())} NaN or infinite values; clean them "
                    "(numpy.nan_to_num) or pass nan_policy='zero' to treat them as 0."
                )
            array = np.where(bad, array.dtype.type(0), array)
    if offset is None:
        offset = _float32_offset(array)
    shifted = _minus(array, offset) if offset else array
    if shifted.dtype.kind == "f" and shifted.dtype.itemsize > 4:
        beyond = ~(np.abs(shifted) <= FLOAT32_MAX)
        if beyond.any():
            largest = float(np.max(np.abs(array[beyond]).astype(np.float64)))
            raise VolumeDataError(
                f"Array {name!r} has {int(beyond.sum())} value(s) beyond float32's range "
                f"(magnitude up to {largest:.3g}; float32 holds up to {FLOAT32_MAX:.3g}), and "
                "volumes are drawn in float32. Rescale the data first (e.g. divide it by a "
                "power of ten, and clim with it)."
            )
    return np.asarray(shifted, dtype=np.float32), offset


def _float32_offset(array: np.ndarray) -> int | float:
    """What to subtract from ``array`` so that float32 keeps its distinct values apart.

    0 when float32 holds the values well as they are: integers up to 2**24 in magnitude
    (all exact), floats whose range spans thousands of float32 steps at their magnitude.
    Otherwise the minimum (a Python int for integer data, so the shift is exact).
    """
    kind = array.dtype.kind
    if kind == "b":
        return 0
    if kind in "iu":
        lo, hi = int(array.min()), int(array.max())
        return lo if max(abs(lo), abs(hi)) > 2**24 else 0
    lo, hi = float(array.min()), float(array.max())
    magnitude, span = max(abs(lo), abs(hi)), hi - lo
    if not np.isfinite(span) or magnitude > FLOAT32_MAX:
        return 0.0  # a range beyond float32: no shift brings it in (checked by the caller)
    if span > 0:
        step = float(np.spacing(np.float32(magnitude)))
        return lo if step * 4096 > span else 0.0
    return lo if magnitude >= 2**24 else 0.0  # constant: the default clim needs resolution


def _minus(array: np.ndarray, offset: int | float) -> np.ndarray:
    """``array - offset`` as float64, exact before the final rounding for integer data."""
    if array.dtype.kind in "iu" and isinstance(offset, (int, np.integer)):
        # Split 64-bit integers into high and low 32-bit halves: each difference is exact in
        # int64, and their float64 sum is the correctly rounded ``array - offset``.
        offset = int(offset)
        wide = array.astype(np.uint64 if array.dtype.kind == "u" else np.int64)
        high = (wide >> np.uint64(32) if wide.dtype == np.uint64 else wide >> 32).astype(np.int64)
        low = (wide & wide.dtype.type(0xFFFFFFFF)).astype(np.int64)
        return ((high - (offset >> 32)).astype(np.float64) * 2.0**32
                + (low - (offset & 0xFFFFFFFF)).astype(np.float64))
    return np.asarray(array, dtype=np.float64) - float(offset)


def make_volume(data, scalars: str | None = None, *, cmap=None, opacity="linear",
                clim=None, opacity_unit_distance: float | None = None,
                transfer: TransferFunction | None = None, transform=None,
                nan_policy: str = "raise", name: str = "volume", n_colors: int = 256,
                flip_scalars: bool = False, log_scale: bool = False,
                categories: bool | int = False, interpolation: str = "linear") -> VolumeModel:
    """Validate ``data`` and bundle it with a transfer function into a :class:`VolumeModel`.

    The transfer keywords mean what they mean in ``pyvista.Plotter.add_volume``: ``clim``
    defaults to the data range, ``opacity_unit_distance`` to the grid's diagonal over its
    mean number of points less one, ``categories`` sets ``n_colors`` to the number of
    distinct values (``True``) or to the number given.
    """
    if interpolation not in INTERPOLATIONS:
        raise VolumeDataError(f"interpolation must be one of {INTERPOLATIONS}, got "
                              f"{interpolation!r}.")
    grid, values, scalars, offset = as_image_data(data, scalars, nan_policy)
    colors = None
    if values.ndim == 4:   # RGBA: the colours as they are, the 4th component's opacity
        colors, values = values, values[..., 3].astype(np.float32)
        if clim is None:   # PyVista's range of the whole array, all four components
            clim = _data_range(colors, 0)
        if opacity_unit_distance is None:
            # VTK reads an RGBA volume's unit distance from its 4th component, which
            # PyVista leaves at 1 (its opacity_unit_distance sets the first one).
            opacity_unit_distance = 1.0
    if transfer is None:
        transfer = _transfer(grid, values, offset, cmap=cmap, opacity=opacity, clim=clim,
                             opacity_unit_distance=opacity_unit_distance, n_colors=n_colors,
                             flip_scalars=flip_scalars, log_scale=log_scale,
                             categories=categories)
    elif offset:
        transfer = TransferFunction(table=transfer.table,
                                    clim=_shifted_clim(transfer.clim, offset),
                                    lookup_table=transfer.lookup_table)
    matrix = np.eye(4) if transform is None else checked_transform(transform)
    return VolumeModel(grid=grid, values=values, transfer=transfer, transform=matrix, name=name,
                       value_offset=offset, interpolation=interpolation, colors=colors,
                       scalars=scalars)


#: ``add_volume``'s transfer keywords (what :func:`with_transfer` changes on a made volume).
TRANSFER_KEYWORDS = ("cmap", "opacity", "clim", "opacity_unit_distance", "n_colors",
                     "flip_scalars", "log_scale", "categories")


def with_transfer(model: VolumeModel, **changes) -> VolumeModel:
    """``model`` with some transfer keywords changed, the others as it was made with.

    So ``add_volume(model, cmap=...)`` (the CLI, USD and the live view give a made volume
    their keywords this way) draws what it says instead of ignoring it.
    """
    unknown = set(changes) - set(TRANSFER_KEYWORDS)
    if unknown:
        raise ValueError(f"{sorted(unknown)} are not transfer keywords {TRANSFER_KEYWORDS}.")
    spec = model.transfer.spec
    if spec is None:
        raise VolumeDataError(
            f"Volume {model.name!r} carries a transfer table given as is, so "
            f"{', '.join(sorted(changes))} cannot change it: make the volume from its data "
            "with those keywords (make_volume(grid, cmap=..., ...)).")
    keywords = dict(cmap=_made_cmap(model.transfer), opacity=spec.opacity,
                    clim=_exact_data_clim(spec),
                    opacity_unit_distance=spec.opacity_unit_distance, n_colors=spec.n_colors,
                    flip_scalars=spec.flip_scalars, log_scale=spec.log_scale)
    if isinstance(keywords["cmap"], pyvista.LookupTable):   # its own range, unless given one
        keywords["clim"] = tuple(keywords["cmap"].scalar_range)
    keywords.update(changes)
    return replace(model, transfer=_transfer(model.grid, model.values, model.value_offset,
                                             **keywords))


def _made_cmap(transfer: TransferFunction):
    """The colormap a volume was made with, as ``add_volume`` takes it again.

    The user's own lookup table where it was given one (its later edits still followed);
    colours read from a table or a property's functions as a colormap of those colours.
    """
    if transfer.lookup_table is not None:
        return transfer.lookup_table
    cmap = transfer.spec.cmap
    if isinstance(cmap, np.ndarray):
        return ListedColormap(np.clip(np.asarray(cmap, dtype=np.float64)[:, :3], 0.0, 1.0))
    return cmap


def _transfer(grid, values, offset, *, cmap, opacity, clim, opacity_unit_distance, n_colors,
              flip_scalars, log_scale, categories=False) -> TransferFunction:
    """The table PyVista's keywords make for these values, data-derived defaults included."""
    table_range(cmap, clim, "add_volume")   # a table's own range: clim said, not drawn
    if clim is not None and not isinstance(cmap, pyvista.LookupTable) and _no_width(clim):
        warnings.warn(
            f"clim={clim!r} has no width: it is drawn one unit wide from its value, a step "
            "there (PyVista's add_volume draws such a range as one opaque colour over the "
            "whole box); pass clim=(low, high) around the values to colour",
            VolumeDataWarning, stacklevel=4)
    if clim is None:
        clim = _data_range(values, offset)
        if values.size and float(values.min()) == float(values.max()):
            warnings.warn(
                f"the volume is constant (every value is {float(values.min()) + offset:g}): "
                "clim from its range puts every sample at the first entry of the colormap "
                f"and of opacity={opacity!r}, which draws nothing where that entry is 0; "
                "pass clim=(low, high) around the value to draw it",
                VolumeDataWarning, stacklevel=4)
    if categories is True:
        n_colors = max(int(np.unique(values).size), 2)
    elif categories:
        n_colors = int(categories)
    if opacity_unit_distance is None:
        opacity_unit_distance = pyvista_unit_distance(grid)
    return TransferFunction.from_colormap(
        cmap, opacity, clim, opacity_unit_distance, n_colors=n_colors,
        flip_scalars=flip_scalars, log_scale=log_scale, value_offset=offset)


def _no_width(clim) -> bool:
    """Whether a given ``clim`` spans nothing: ``(v, v)`` exactly, or the number 0."""
    try:
        if np.ndim(clim) == 0:
            return float(clim) == 0.0
        low, high = clim
        return low == high
    except (TypeError, ValueError):
        return False   # refused with its own message after


def _exact_data_clim(spec) -> tuple:
    """A spec's ``clim`` in data units, integers kept exact (ids near 2**64)."""
    offset = spec.value_offset
    if isinstance(offset, (int, np.integer)) and offset and all(
            float(v).is_integer() for v in spec.clim):
        return tuple(int(offset) + int(v) for v in spec.clim)
    return spec.data_clim


def pyvista_unit_distance(grid: pyvista.ImageData) -> float:
    """PyVista's default ``opacity_unit_distance``: the diagonal over mean points less one."""
    points = float(np.mean(grid.dimensions)) - 1.0
    length = float(grid.length)
    if points <= 0 or not length > 0:
        return float(np.mean(np.abs(grid.spacing)))
    return length / points


def _data_range(values: np.ndarray, offset: int | float) -> tuple:
    """The data's range in data units (integers kept exact), widened when constant."""
    lo, hi = float(values.min()), float(values.max())
    if hi <= lo:
        hi = lo + 1.0
    if isinstance(offset, (int, np.integer)) and offset and lo.is_integer() and hi.is_integer():
        return int(offset) + int(lo), int(offset) + int(hi)
    return lo + offset, hi + offset


def _shifted_clim(clim, offset: int | float) -> tuple[float, float]:
    """``clim`` (data units) in the units of the shifted values, checked in data units."""
    try:
        lo, hi = clim
        ordered = bool(np.isfinite([float(lo), float(hi)]).all() and hi > lo)
    except (TypeError, ValueError):
        ordered = False
    if not ordered:
        raise VolumeDataError(f"clim must be two finite increasing numbers, got {clim!r}.")
    return shift_value(lo, offset), shift_value(hi, offset)


def checked_transform(transform, name: str = "transform") -> np.ndarray:
    """``transform`` as a float64 4x4 placement, or a clear error naming ``name``.

    Takes what PyVista's ``user_matrix`` takes: an array, a ``vtkMatrix4x4`` or a
    ``vtkTransform``.
    """
    if hasattr(transform, "GetMatrix"):   # a vtkTransform
        transform = transform.GetMatrix()
    if isinstance(transform, vtk.vtkMatrix4x4):
        transform = [[transform.GetElement(i, j) for j in range(4)] for i in range(4)]
    try:
        matrix = np.asarray(transform, dtype=np.float64)
    except (TypeError, ValueError):
        raise VolumeDataError(f"{name} must be a 4x4 matrix of numbers, got "
                              f"{transform!r}.") from None
    if matrix.shape != (4, 4):
        raise VolumeDataError(f"{name} must be a 4x4 matrix, got shape {matrix.shape}.")
    if not np.isfinite(matrix).all():
        raise VolumeDataError(f"{name} must be finite; it holds "
                              f"{int((~np.isfinite(matrix)).sum())} NaN or infinite entries.")
    if not np.allclose(matrix[3], (0.0, 0.0, 0.0, 1.0), rtol=0.0, atol=1e-12):
        raise VolumeDataError(
            f"{name} must be affine: its last row must be (0, 0, 0, 1), got "
            f"{tuple(float(v) for v in matrix[3])}. A projective matrix cannot place a volume; "
            "pass rotation, scaling and translation only."
        )
    if abs(np.linalg.det(matrix[:3, :3])) < 1e-300:
        raise VolumeDataError(f"{name} must be invertible (its 3x3 part has determinant 0).")
    matrix = matrix.copy()
    matrix[3] = (0.0, 0.0, 0.0, 1.0)
    return matrix
