"""Implicit surfaces as uniform quadratic B-spline fields: f(x) = 0, positive inside.

A field on ``N = (nx, ny, nz)`` cells holds ``(nx + 2, ny + 2, nz + 2)`` coefficients
``c[a, b, c]`` (``c_{ijk}`` with ``i = a - 1`` from -1 to ``nx``); cell ``(i, j, k)``
spans ``[i, i+1] x [j, j+1] x [k, k+1]`` of cell space and its field depends on the 27
coefficients ``c[i:i+3, j:j+3, k:k+3]`` only. Per axis, at ``u`` in [0, 1] across the cell,
``f = c[i] (1-u)^2 / 2 + c[i+1] (1/2 + u - u^2) + c[i+2] u^2 / 2`` (the quadratic B-spline
basis: that of coefficient ``i`` peaks at the centre of cell ``i``); in Bernstein form the
three are ``((c[i] + c[i+1]) / 2, c[i+1], (c[i+1] + c[i+2]) / 2)`` against ``(1-u)^2``,
``2u(1-u)``, ``u^2``. Each cell is evaluated in these local coordinates: powers ``x^p y^q z^r``
of global coordinates lose all precision in float32 (errors of 1e3 to 1e10 at 32³ to 512³).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..core.errors import VolumeDataError
from .volume import box_world_bounds
from .voxels import PlacedGrid

#: Per axis, the three coefficients of a cell to its three Bernstein coefficients.
TO_BERNSTEIN = np.array([[0.5, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.5, 0.5]])
#: The three axes' maps at once: a cell's 27 coefficients (x, y, z order) to its 27
#: Bernstein coefficients.
_TO_BERNSTEIN_3D = np.kron(np.kron(TO_BERNSTEIN, TO_BERNSTEIN), TO_BERNSTEIN)
#: Active-cell tests: exact from the Bernstein coefficients, or sampling the cell.
ACTIVE_TESTS = ("bernstein", "sample")


def bernstein_basis(u: np.ndarray) -> np.ndarray:
    """``(..., 3)``: the quadratic Bernstein basis ``(1-u)^2, 2u(1-u), u^2`` at ``u``."""
    u = np.asarray(u, dtype=np.float64)
    return np.stack([(1.0 - u) ** 2, 2.0 * u * (1.0 - u), u * u], axis=-1)


def bernstein_derivative(u: np.ndarray) -> np.ndarray:
    """``(..., 3)``: the derivatives of :func:`bernstein_basis` at ``u``."""
    u = np.asarray(u, dtype=np.float64)
    return np.stack([-2.0 * (1.0 - u), 2.0 - 4.0 * u, 2.0 * u], axis=-1)


@dataclass(eq=False)
class SplineField(PlacedGrid):
    """A quadratic B-spline field on a grid of cells, placed in the world.

    ``coefficients``: ``(nx + 2, ny + 2, nz + 2)`` float64; ``grid_from_index`` maps cell
    space (cell ``(i, j, k)`` spans ``[i, i+1]`` per axis) to the grid's frame and
    ``transform`` that frame to the world, as for voxel grids. Call it on world points for
    the field, :meth:`gradient` for its gradient; :meth:`save` / :meth:`load` keep it.
    """

    coefficients: np.ndarray
    grid_from_index: np.ndarray = field(default_factory=lambda: np.eye(4))
    transform: np.ndarray = field(default_factory=lambda: np.eye(4))
    name: str = "surface"
    #: Coefficients of a second field on the same cells (the same shape), whose value at
    #: the surface colours it (``add_surface(..., color_by=values)``), or None.
    color_values: np.ndarray | None = None
    #: The part of cell space the surface is drawn in, ``(2, 3)``: lower and upper corners
    #: (None: every cell). Samples at an image's points are its cells' centres, so their
    #: hull, where PyVista's contour stops, lies half a cell inside the grid
    #: (:func:`point_hull`).
    domain: np.ndarray | None = None

    def __post_init__(self):
        c = np.asarray(self.coefficients, dtype=np.float64)
        if c.ndim != 3 or min(c.shape) < 3:
            raise VolumeDataError(f"Spline coefficients are an (nx + 2, ny + 2, nz + 2) array "
                                  f"with at least one cell per axis, got shape {c.shape}.")
        if not np.isfinite(c).all():
            raise VolumeDataError(f"Spline coefficients hold {int((~np.isfinite(c)).sum())} "
                                  "NaN or infinite values; fill or crop them first.")
        self.coefficients = c
        if self.color_values is not None:
            values = np.asarray(self.color_values, dtype=np.float64)
            if values.shape != c.shape or not np.isfinite(values).all():
                raise VolumeDataError(f"Colour values must be finite coefficients of the "
                                      f"field's shape {c.shape}, got {values.shape}.")
            self.color_values = values
        if self.domain is not None:
            box = np.asarray(self.domain, dtype=np.float64)
            dims = np.asarray(self.dimensions, dtype=np.float64)
            if (box.shape != (2, 3) or not np.isfinite(box).all() or (box[0] < 0).any()
                    or (box[1] > dims).any() or not (box[0] < box[1]).all()):
                raise VolumeDataError(f"A field's domain is its lower and upper corners in "
                                      f"cell space, within [0, {tuple(int(n) for n in dims)}] "
                                      f"and lower below upper; got {self.domain!r}.")
            self.domain = box

    def domain_corners(self) -> tuple[np.ndarray, np.ndarray]:
        """The lower and upper corners (cell space) of the part of the grid drawn."""
        if self.domain is None:
            return np.zeros(3), np.asarray(self.dimensions, dtype=np.float64)
        return self.domain[0].copy(), self.domain[1].copy()

    def world_bounds(self) -> np.ndarray:
        """Axis-aligned world bounds ``(xmin, xmax, ...)`` of the domain drawn."""
        lower, upper = self.domain_corners()
        return box_world_bounds(self.world_from_index(), upper, lower)

    def frame_bounds(self) -> np.ndarray:
        """The domain's bounds in the field's own frame, before ``transform``."""
        lower, upper = self.domain_corners()
        return box_world_bounds(self.grid_from_index, upper, lower)

    @property
    def dimensions(self) -> tuple[int, int, int]:
        """Cells along x, y, z."""
        return tuple(int(n) - 2 for n in self.coefficients.shape)

    @property
    def nbytes(self) -> int:
        """Host bytes of the coefficients."""
        return int(self.coefficients.nbytes)

    def cell_bernstein(self, cells: np.ndarray | None = None,
                       coefficients: np.ndarray | None = None) -> np.ndarray:
        """``(n, 3, 3, 3)`` Bernstein coefficients of ``cells`` (``(n, 3)`` ints; all: None).

        Cell-local: ``f = sum beta[a, b, c] B_a(u) B_b(v) B_c(w)`` with ``(u, v, w)`` in
        [0, 1]³ across the cell. ``coefficients``: another spline on the same cells (e.g.
        :attr:`color_values`) instead of the field's.
        """
        if cells is None:
            cells = np.argwhere(np.ones(self.dimensions, bool))
        cells = np.asarray(cells, dtype=np.int64).reshape(-1, 3)
        values = self.coefficients if coefficients is None else coefficients
        # the cells' 27 coefficients read through flat indices, mapped by one product (an
        # einsum per call cost 17 times as much, mostly finding its path)
        strides = np.array([values.shape[1] * values.shape[2], values.shape[2], 1])
        offsets = (np.indices((3, 3, 3)).reshape(3, -1).T @ strides)
        local = np.ravel(values)[(cells @ strides)[:, None] + offsets[None, :]]
        return (local @ _TO_BERNSTEIN_3D.T).reshape(-1, 3, 3, 3)

    def _cells_of(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Cell-space points to (cell, local coordinates); points outside clamp to a cell."""
        x = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        dims = np.asarray(self.dimensions)
        cell = np.clip(np.floor(x).astype(np.int64), 0, dims - 1)
        return cell, x - cell

    def _to_cells(self, points) -> np.ndarray:
        """World points to cell space."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        inverse = np.linalg.inv(self.world_from_index())
        return p @ inverse[:3, :3].T + inverse[:3, 3]

    def at_cells(self, x: np.ndarray, coefficients: np.ndarray | None = None) -> np.ndarray:
        """The field (or the spline ``coefficients``) at cell-space points ``x`` (``(n, 3)``).

        Points outside the grid take their nearest cell's polynomial.
        """
        cell, u = self._cells_of(x)
        beta = self.cell_bernstein(cell, coefficients)
        bu, bv, bw = (bernstein_basis(u[:, a]) for a in range(3))
        return np.einsum("nabc,na,nb,nc->n", beta, bu, bv, bw)

    def gradient_at_cells(self, x: np.ndarray) -> np.ndarray:
        """``(n, 3)`` gradient per cell unit at cell-space points ``x``."""
        cell, u = self._cells_of(x)
        beta = self.cell_bernstein(cell)
        b = [bernstein_basis(u[:, a]) for a in range(3)]
        d = [bernstein_derivative(u[:, a]) for a in range(3)]
        return np.stack([np.einsum("nabc,na,nb,nc->n", beta, d[0], b[1], b[2]),
                         np.einsum("nabc,na,nb,nc->n", beta, b[0], d[1], b[2]),
                         np.einsum("nabc,na,nb,nc->n", beta, b[0], b[1], d[2])], axis=-1)

    def hessian_at_cells(self, x: np.ndarray) -> np.ndarray:
        """``(n, 3, 3)`` second derivatives per cell unit squared at cell-space points."""
        cell, u = self._cells_of(x)
        beta = self.cell_bernstein(cell)
        b = [bernstein_basis(u[:, a]) for a in range(3)]
        d = [bernstein_derivative(u[:, a]) for a in range(3)]
        second = np.broadcast_to(np.array([2.0, -4.0, 2.0]), (len(u), 3))
        out = np.empty((len(u), 3, 3))
        for i in range(3):
            for j in range(i, 3):
                factors = [b[0], b[1], b[2]]
                if i == j:
                    factors[i] = second
                else:
                    factors[i], factors[j] = d[i], d[j]
                out[:, i, j] = out[:, j, i] = np.einsum("nabc,na,nb,nc->n", beta, *factors)
        return out

    def mean_curvature_at_cells(self, x: np.ndarray) -> np.ndarray:
        """Mean curvature (per world unit) of the level set through cell-space points ``x``.

        Positive where the surface bends like a ball's outside (the field positive inside):
        ``-(|g|^2 tr H - g.H.g) / (2 |g|^3)`` with the world gradient ``g`` and Hessian ``H``.
        """
        inverse = np.linalg.inv(self.world_from_index()[:3, :3])
        g = self.gradient_at_cells(x) @ inverse
        h = np.einsum("ai,nab,bj->nij", inverse, self.hessian_at_cells(x), inverse)
        norm = np.maximum(np.linalg.norm(g, axis=1), 1e-300)
        trace = np.trace(h, axis1=1, axis2=2)
        along = np.einsum("ni,nij,nj->n", g, h, g)
        return -(norm ** 2 * trace - along) / (2.0 * norm ** 3)

    def __call__(self, points) -> np.ndarray:
        """The field at world ``points`` (``(..., 3)``).

        Outside the grid, its nearest cell's polynomial extended.
        """
        shape = np.shape(points)[:-1]
        return self.at_cells(self._to_cells(points)).reshape(shape)

    def gradient(self, points) -> np.ndarray:
        """The field's gradient (per world unit) at world ``points`` (``(..., 3)``)."""
        shape = np.shape(points)
        per_cell = self.gradient_at_cells(self._to_cells(points))
        inverse = np.linalg.inv(self.world_from_index()[:3, :3])
        return (per_cell @ inverse).reshape(shape)

    def on_lattice(self, per_cell: int = 1, centred: bool = False) -> np.ndarray:
        """The field on a regular lattice of cell space, per axis at once (any grid size).

        ``per_cell`` points per cell edge: at ``m / per_cell`` for ``m`` in ``0 ..
        per_cell * n`` (corners included: ``per_cell * n + 1`` a side), or with
        ``centred`` at ``(m + 1/2) / per_cell`` (``per_cell = 1``: the cell centres).
        """
        per_cell = int(per_cell)
        if per_cell < 1:
            raise ValueError(f"per_cell must be at least 1, got {per_cell}.")
        values = self.coefficients
        for axis, n in enumerate(self.dimensions):
            m = np.arange(per_cell * n + (0 if centred else 1), dtype=np.float64)
            values = _spline_along(values, axis, (m + (0.5 if centred else 0.0)) / per_cell)
        return values

    def save(self, path) -> None:
        """Write the field (coefficients, placement, name) to an ``.npz`` file."""
        extra = {} if self.color_values is None else {"color_values": self.color_values}
        if self.domain is not None:
            extra["domain"] = self.domain
        np.savez_compressed(Path(path), coefficients=self.coefficients,
                            grid_from_index=self.grid_from_index, transform=self.transform,
                            name=np.array(self.name), **extra)

    @classmethod
    def load(cls, path) -> SplineField:
        """Read a field :meth:`save` wrote."""
        with np.load(Path(path)) as data:
            missing = {"coefficients", "grid_from_index", "transform", "name"} - set(data.files)
            if missing:
                raise VolumeDataError(f"{path} is not a saved SplineField: it lacks "
                                      f"{sorted(missing)}.")
            return cls(data["coefficients"], np.asarray(data["grid_from_index"]),
                       np.asarray(data["transform"]), str(data["name"]),
                       data["color_values"] if "color_values" in data.files else None,
                       data["domain"] if "domain" in data.files else None)


def point_hull(dimensions) -> np.ndarray:
    """``(2, 3)``: the hull of samples at the centres of ``dimensions`` cells.

    Half a cell in from each face; an axis of one sample keeps its whole cell (a flat
    image's sheet).
    """
    dims = np.asarray(dimensions, dtype=np.float64)
    inset = np.where(dims > 1, 0.5, 0.0)
    return np.stack([inset, dims - inset])


def _spline_along(c: np.ndarray, axis: int, positions: np.ndarray) -> np.ndarray:
    """Along ``axis``: the spline of coefficients ``c`` at cell-space ``positions``."""
    n = c.shape[axis] - 2
    cell = np.clip(np.floor(positions).astype(np.int64), 0, n - 1)
    u = positions - cell
    shape = [1] * c.ndim
    shape[axis] = -1
    weights = (0.5 * (1.0 - u) ** 2, 0.5 + u - u * u, 0.5 * u * u)   # the quadratic B-spline basis
    return sum(w.reshape(shape) * np.take(c, cell + k, axis=axis)
               for k, w in enumerate(weights))


#: How samples become a spline's coefficients: ``'interpolating'`` (the field passes
#: through every sample) or ``'approximating'`` (the samples are the coefficients).
SPLINES = ("interpolating", "approximating")


def spline_coefficients(samples: np.ndarray, spline: str = "interpolating") -> np.ndarray:
    """``samples``' coefficients by ``spline`` (one of :data:`SPLINES`).

    ``'approximating'``: the samples themselves, with the mirror ends of
    :func:`interpolating_coefficients`. The field at each cell lies within its 27
    neighbouring samples' range, so it crosses a level only where they do (no overshoot
    where samples step sharply); at a cell's centre it is the samples blurred by
    ``(1, 6, 1) / 8`` along each axis.
    """
    if spline not in SPLINES:
        raise ValueError(f"spline must be one of {SPLINES}, got {spline!r}.")
    if spline == "interpolating":
        return interpolating_coefficients(samples)
    c = np.asarray(samples, dtype=np.float64)
    flat = [n == 1 for n in c.shape]   # one sample: a constant field along that axis
    c = np.pad(c, [(0, 0) if one else (1, 1) for one in flat], mode="reflect")
    return np.pad(c, [(1, 1) if one else (0, 0) for one in flat], mode="edge")


def interpolating_coefficients(samples: np.ndarray) -> np.ndarray:
    """Coefficients whose field equals ``samples`` at the cell centres (one sample per cell).

    Solves, per axis, ``f(i + 1/2) = (c[i] + 6 c[i+1] + c[i+2]) / 8 = samples[i]`` with the
    mirror ends ``c[0] = c[2]`` and ``c[n+1] = c[n-1]`` (a tridiagonal system, solved
    directly; numpy only). Returns ``(nx + 2, ny + 2, nz + 2)`` float64.
    """
    c = np.asarray(samples, dtype=np.float64)
    for axis in range(3):
        c = _interpolate_axis(np.moveaxis(c, axis, 0))
        c = np.moveaxis(c, 0, axis)
    return c


def _interpolate_axis(values: np.ndarray) -> np.ndarray:
    """Along axis 0: ``n`` samples to ``n + 2`` coefficients (see above)."""
    n = values.shape[0]
    if n == 1:   # one cell: a constant field
        return np.repeat(values, 3, axis=0)
    # Unknowns c[1..n] (c[i+1] centred on sample i); c[0] = c[2], c[n+1] = c[n-1] fold the
    # mirror ends into the first and last rows: (6 c1 + 2 c2) / 8 and (2 c[n-1] + 6 c[n]) / 8.
    lower = np.full(n, 1.0 / 8.0)
    diagonal = np.full(n, 6.0 / 8.0)
    upper = np.full(n, 1.0 / 8.0)
    upper[0] = 2.0 / 8.0
    lower[-1] = 2.0 / 8.0
    inner = _solve_tridiagonal(lower, diagonal, upper, values)
    return np.concatenate([inner[1:2], inner, inner[-2:-1]], axis=0)


def _solve_tridiagonal(lower, diagonal, upper, rhs: np.ndarray) -> np.ndarray:
    """Thomas algorithm along axis 0 of ``rhs`` (diagonally dominant: no pivoting needed).

    Row ``i`` is ``lower[i] x[i-1] + diagonal[i] x[i] + upper[i] x[i+1] = rhs[i]``.
    """
    n = len(diagonal)
    c = np.zeros(n)
    d = np.zeros_like(rhs, dtype=np.float64)
    c[0] = upper[0] / diagonal[0]
    d[0] = rhs[0] / diagonal[0]
    for i in range(1, n):
        m = diagonal[i] - lower[i] * c[i - 1]
        c[i] = upper[i] / m if i < n - 1 else 0.0
        d[i] = (rhs[i] - lower[i] * d[i - 1]) / m
    x = np.empty_like(d)
    x[-1] = d[-1]
    for i in range(n - 2, -1, -1):
        x[i] = d[i] - c[i] * x[i + 1]
    return x


def active_cells(surface: SplineField, test: str = "bernstein", samples: int = 4,
                 batch: int = 65536) -> np.ndarray:
    """``(n, 3)`` cells the surface f = 0 may cross, in x-fastest order.

    ``'bernstein'``: a cell whose 27 Bernstein coefficients are all of one sign (none 0)
    cannot hold a zero (the field is their convex combination): exact, no crossed cell is
    ever missed, a few uncrossed ones kept. ``'sample'``: the field at a
    ``samples``³ lattice over the cell (corners included) changes sign: its cost grows as
    ``samples``³, and it misses features thinner than the lattice's spacing.
    """
    if test not in ACTIVE_TESTS:
        raise ValueError(f"active_test must be one of {ACTIVE_TESTS}, got {test!r}.")
    if test == "sample" and int(samples) < 2:
        raise ValueError(f"samples must be at least 2 (the cell's corners), got {samples}.")
    if test == "bernstein":
        return _bernstein_active(surface.coefficients)
    dims = surface.dimensions
    cells = np.argwhere(np.ones(dims[::-1], bool))[:, ::-1]   # x fastest
    batch = max(1, min(int(batch), 4_000_000 // int(samples) ** 3))   # ~4 M values at once
    keep = []
    lattice = np.linspace(0.0, 1.0, int(samples))
    basis = bernstein_basis(lattice)
    for start in range(0, len(cells), batch):
        part = cells[start:start + batch]
        values = np.einsum("nabc,ia,jb,kc->nijk", surface.cell_bernstein(part), basis, basis,
                           basis, optimize=True)
        low, high = values.min(axis=(1, 2, 3)), values.max(axis=(1, 2, 3))
        keep.append(part[(low <= 0.0) & (high >= 0.0)])
    return np.concatenate(keep) if keep else np.zeros((0, 3), np.int64)


def level_cells(surface: SplineField, offsets, test: str = "bernstein",
                samples: int = 4) -> np.ndarray:
    """:func:`active_cells` of every level ``f = offset`` drawn together, x fastest.

    One offset of 0 is the surface's own cells.
    """
    offsets = tuple(float(v) for v in offsets)
    if offsets == (0.0,):
        return active_cells(surface, test, samples)
    cells = np.unique(np.concatenate([active_cells(
        replace(surface, coefficients=surface.coefficients - offset), test, samples)
        for offset in offsets]), axis=0)
    return cells[np.lexsort(cells.T)]


def _bernstein_rows(c: np.ndarray, axis: int) -> np.ndarray:
    """Along ``axis``: ``n + 2`` coefficients to each cell's 3 Bernstein ones, stacked first."""
    n = c.shape[axis] - 2
    first, middle, last = (np.take(c, np.arange(k, k + n), axis=axis) for k in range(3))
    return np.stack([0.5 * (first + middle), middle, 0.5 * (middle + last)])


def _bernstein_active(coefficients: np.ndarray, budget: int = 1 << 28) -> np.ndarray:
    """The ``'bernstein'`` test, by slabs of cells along z (about ``budget`` bytes each).

    Each cell's 27 Bernstein coefficients come from per-axis averages of the grid's
    coefficients (:data:`TO_BERNSTEIN` along x, then y, then z), whole slabs at a time.
    """
    nx, ny, nz = (int(n) - 2 for n in coefficients.shape)
    slab = max(1, min(nz, budget // (27 * 8 * nx * ny)))
    keep = []
    for k0 in range(0, nz, slab):
        k1 = min(nz, k0 + slab)
        beta = _bernstein_rows(coefficients[:, :, k0:k1 + 2], 0)    # (3, nx, ny+2, s+2)
        beta = _bernstein_rows(beta, 2)                             # (3, 3, nx, ny, s+2)
        beta = _bernstein_rows(beta, 4)                             # (3, 3, 3, nx, ny, s)
        crossed = (beta.min(axis=(0, 1, 2)) <= 0.0) & (beta.max(axis=(0, 1, 2)) >= 0.0)
        cells = np.argwhere(crossed.transpose(2, 1, 0))[:, ::-1]   # x fastest
        cells[:, 2] += k0
        keep.append(cells)
    return np.concatenate(keep) if keep else np.zeros((0, 3), np.int64)
