"""Transfer functions shared by the GPU shaders and the CPU reference.

One table serves both sides, so a difference between the GPU image and the reference
is the renderer's, never the lookup's. Each row holds linear RGB emission colour and the
extinction coefficient sigma (per world unit): a sample of length ``dt`` has opacity
``1 - exp(-sigma * dt)`` whatever the step, which is the exponential correction.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pyvista

from ..core.errors import VolumeDataError

#: Opacity values are clipped below 1 so that the extinction stays finite.
MAX_OPACITY = 1.0 - 1e-6
#: Largest extinction per world unit in a table. A tiny ``opacity_unit_distance`` (say
#: 1e-300) would overflow float32 to infinity, which the GPU's filtering and the
#: reference's interpolation turn into NaN (0 * inf): capped here, a sample is still opaque
#: over any step longer than 1e-28 world units, and sums of four volumes' extinctions and
#: their products with colours stay finite in float32.
MAX_EXTINCTION = 1e30


@dataclass(frozen=True, eq=False)
class TransferFunction:
    """Colour and extinction as functions of the scalar value.

    Parameters
    ----------
    table : numpy.ndarray
        ``(n, 4)`` float32: RGB in [0, 1] and extinction per world unit.
    clim : tuple of float
        Scalar values mapped to the first and last row.
    """

    table: np.ndarray
    clim: tuple[float, float]

    @classmethod
    def from_colormap(
        cls,
        cmap: str | Sequence = "magma",
        opacity: str | float | Sequence[float] = "linear",
        clim: Sequence[float] = (0.0, 1.0),
        opacity_unit_distance: float = 1.0,
        n_colors: int = 256,
    ) -> TransferFunction:
        """Build a table from a matplotlib colormap and a PyVista-style opacity.

        Parameters
        ----------
        cmap : str or sequence
            A matplotlib colormap name, or a list of colours.
        opacity : str, float or sequence of float
            A PyVista opacity preset (``'linear'``, ``'sigmoid'``, ``'geom'`` ...), a constant,
            or values in [0, 1] resampled over ``clim``.
        clim : sequence of float
            Scalar range covered by the table.
        opacity_unit_distance : float
            World length over which a sample of opacity ``o`` absorbs the fraction ``o``.
        n_colors : int
            Rows in the table.

        Examples
        --------
        >>> from pv_cubemarch import TransferFunction
        >>> tf = TransferFunction.from_colormap("viridis", "sigmoid", clim=(0, 2))
        >>> tf.table.shape
        (256, 4)
        """
        lo, hi = (float(v) for v in clim)
        if not np.isfinite([lo, hi]).all() or hi <= lo:
            raise VolumeDataError(f"clim must be two finite increasing numbers, got {tuple(clim)}.")
        if opacity_unit_distance <= 0 or not np.isfinite(opacity_unit_distance):
            raise VolumeDataError(
                f"opacity_unit_distance must be a positive length, got {opacity_unit_distance}."
            )
        n = int(n_colors)
        if n < 2:
            raise VolumeDataError(f"n_colors must be at least 2, got {n_colors}.")
        lut = pyvista.LookupTable(cmap, n_values=n)
        rgb = np.array([lut.map_value(lo + (hi - lo) * i / (n - 1))[:3] for i in range(n)])
        alpha = _opacity_values(opacity, n)
        with np.errstate(over="ignore"):
            sigma = -np.log1p(-np.clip(alpha, 0.0, MAX_OPACITY)) / float(opacity_unit_distance)
        sigma = np.minimum(sigma, MAX_EXTINCTION)
        table = np.column_stack([rgb, sigma]).astype(np.float32)
        return cls(table=table, clim=(lo, hi))

    @property
    def n_colors(self) -> int:
        """Number of rows in the table."""
        return int(self.table.shape[0])

    def lookup(self, scalars: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return ``(rgb, sigma)`` for ``scalars``, interpolating rows as GL filtering does."""
        lo, hi = self.clim
        u = np.clip((np.asarray(scalars, dtype=np.float64) - lo) / (hi - lo), 0.0, 1.0)
        x = u * (self.n_colors - 1)
        i0 = np.minimum(np.floor(x).astype(np.int64), self.n_colors - 2)
        w = (x - i0)[..., None]
        rows = self.table[i0] * (1.0 - w) + self.table[i0 + 1] * w
        return rows[..., :3], rows[..., 3]

    def max_extinction(self) -> float:
        """The largest extinction in the table (per world unit)."""
        return float(self.table[:, 3].max())


def _opacity_values(opacity, n: int) -> np.ndarray:
    if isinstance(opacity, str):
        try:
            return pyvista.opacity_transfer_function(opacity, n).astype(np.float64) / 255.0
        except Exception as exc:
            raise VolumeDataError(f"Unknown opacity preset {opacity!r}: {exc}") from exc
    values = np.atleast_1d(np.asarray(opacity, dtype=np.float64))
    if not np.isfinite(values).all() or values.min() < 0 or values.max() > 1:
        raise VolumeDataError("opacity values must be finite numbers in [0, 1].")
    if values.size == 1:
        return np.full(n, values[0])
    return np.interp(np.linspace(0, 1, n), np.linspace(0, 1, values.size), values)
