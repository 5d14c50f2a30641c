"""Transfer functions: colour and extinction over ``clim``, as PyVista's ``add_volume`` maps them.

The table is built the way PyVista builds a volume's transfer functions
(``LookupTable.to_color_tf`` / ``to_opacity_tf``): ``n_colors`` points spaced evenly over
``clim``, each with the lookup table's colour at that value (linear or logarithmic mapping)
and its opacity (capped at PyVista's 0.998), linear in between. Each row holds linear RGB
emission colour and the extinction coefficient sigma (per unit length of the data: in the
grid's own frame, before its placement, as VTK measures ``opacity_unit_distance``): a
sample of length ``dt`` has opacity ``1 - exp(-sigma * dt)`` whatever the step (VTK's
opacity correction).

What the user asked for is kept beside the table (:class:`TransferSpec`), so the CPU
reference can derive the right colours on its own, from matplotlib, without this table.
"""

from __future__ import annotations

import reprlib
import sys
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import pyvista

from ..core.errors import VolumeDataError, VolumeDataWarning
from ..core.user_warnings import warn_user

#: PyVista's ``to_opacity_tf(max_clip=0.998)``: the most opacity a table row may have.
MAX_OPACITY = 0.998
#: Largest extinction per data unit in a table. A tiny ``opacity_unit_distance`` (say
#: 1e-300) would overflow float32 to infinity, which the GPU's filtering and the
#: reference's interpolation turn into NaN (0 * inf): capped here, a sample is still opaque
#: over any step longer than 1e-28 data units, and sums of four volumes' extinctions and
#: their products with colours stay finite in float32.
MAX_EXTINCTION = 1e30
#: Largest float32: a ``clim`` (its bounds and its width) the GPU can hold.
FLOAT32_MAX = float(np.finfo(np.float32).max)
#: Most colours of a colormap (``n_colors``).
MAX_COLORS = 16384
#: Rows a table is refined to (about): the opacity function is linear between the
#: colormap's points, while the GPU interpolates the table's extinction; on rows this fine
#: the two agree (within 1/255 of opacity even for 16 colours of a ``'geom'`` curve). VTK's
#: own GPU mapper samples the function into a table of 1024 entries or more over the
#: data's range and reads it half to one entry low (docs/pyvista_parity.md).
REFINED_ROWS = 4096


@dataclass(frozen=True)
class TransferSpec:
    """What a transfer function was asked to be, in the data's own units.

    ``cmap`` and ``opacity`` are as the user gave them (a lookup table: its colours and
    opacities as arrays); ``clim`` is in the units of the volume's stored values, the data
    minus ``value_offset`` (so ids near 2**64 stay apart). The CPU reference reads this,
    not the table.
    """

    cmap: object
    opacity: object
    clim: tuple[float, float]
    n_colors: int
    flip_scalars: bool
    log_scale: bool
    opacity_unit_distance: float
    value_offset: int | float = 0

    @property
    def data_clim(self) -> tuple[float, float]:
        """``clim`` in the data's own units (floats: for display)."""
        return tuple(float(v) + float(self.value_offset) for v in self.clim)


@dataclass(frozen=True, eq=False)
class TransferFunction:
    """Colour and extinction as functions of the scalar value.

    Parameters
    ----------
    table : numpy.ndarray
        ``(n, 4)`` float32: RGB in [0, 1] and extinction per data unit, rows at values
        spaced evenly over ``clim``.
    clim : tuple of float
        Scalar values of the first and last row, in the units of the volume's stored
        values (the data minus its ``value_offset``).
    spec : TransferSpec, optional
        What the table was built from (``None`` for a table given as is).
    lookup_table : pyvista.LookupTable, optional
        The user's table it was built from, kept as given (not a copy).
    """

    table: np.ndarray
    clim: tuple[float, float]
    spec: TransferSpec | None = None
    #: The user's own ``pyvista.LookupTable`` it was built from (``cmap=lut``), not a copy:
    #: the returned volume's mapper holds it, as PyVista's, so edits of it recolour.
    lookup_table: object = None

    @classmethod
    def from_colormap(
        cls,
        cmap: str | Sequence | pyvista.LookupTable | None = None,
        opacity: str | float | Sequence[float] = "linear",
        clim: float | Sequence[float] = (0.0, 1.0),
        opacity_unit_distance: float = 1.0,
        n_colors: int = 256,
        flip_scalars: bool = False,
        log_scale: bool = False,
        value_offset: int | float = 0,
    ) -> TransferFunction:
        """Build a table as PyVista's ``add_volume`` builds its transfer functions.

        Parameters
        ----------
        cmap : str, sequence, matplotlib colormap or pyvista.LookupTable, optional
            A colormap name (PyVista's theme colormap by default), a list of colours, or a
            ready lookup table (its colours, opacities, range and log scale are used, as
            PyVista uses them; ``opacity``, ``clim`` and ``log_scale`` are not).
        opacity : str, float or sequence of float
            A PyVista opacity preset (``'linear'``, ``'sigmoid'``, ``'geom'`` ...), a constant,
            or values in [0, 1] resampled over ``clim``.
        clim : float or sequence of float
            Scalar range covered by the table, in data units; one number ``c`` means
            ``(-c, c)``.
        opacity_unit_distance : float
            World length over which a sample of opacity ``o`` absorbs the fraction ``o``.
        n_colors : int
            Rows in the table (colours of the colormap).
        flip_scalars : bool
            Reverse the colormap.
        log_scale : bool
            Map colours over ``clim`` logarithmically (a lower bound at or below 0 becomes
            the smallest positive float, as in PyVista).
        value_offset : int or float
            What the volume subtracted from its data (see :class:`VolumeModel`): the
            table's ``clim`` is stored in those shifted units.

        Examples
        --------
        >>> from pv_cubemarch import TransferFunction
        >>> tf = TransferFunction.from_colormap("viridis", "sigmoid", clim=(0, 2))
        >>> tf.spec.n_colors, tf.table.shape  # rows refined so opacity interpolates as VTK's
        (256, (4081, 4))
        """
        if isinstance(cmap, pyvista.LookupTable):   # as PyVista: the table's own range and scale
            clim, log_scale = tuple(cmap.scalar_range), bool(cmap.log_scale)
        lo, hi = checked_clim(clim)
        if log_scale and hi <= 0:
            raise VolumeDataError(f"log_scale maps colours over the positive part of clim; "
                                  f"clim={(lo, hi)} has none: give an upper bound above 0.")
        if log_scale and lo <= 0:
            lo = sys.float_info.min
        # in the stored values' units, exact for integer bounds and offsets (uint64 ids
        # near 2**64 are one float apart in data units)
        raw = (-clim, clim) if np.ndim(clim) == 0 else tuple(clim)
        shifted = tuple(shift_value(given if float(given) == bound else bound, value_offset)
                        for bound, given in zip((lo, hi), raw, strict=True))
        if shifted[1] < shifted[0]:
            raise VolumeDataError(f"clim must be two finite increasing numbers, got {clim!r}.")
        if shifted[1] == shifted[0]:   # (v, v), e.g. the range of constant data: one unit wide
            shifted, hi = (shifted[0], shifted[0] + 1.0), lo + 1.0
        if opacity_unit_distance <= 0 or not np.isfinite(opacity_unit_distance):
            raise VolumeDataError(
                f"opacity_unit_distance must be a positive length, got {opacity_unit_distance}."
            )
        lut = pyvista_lookup_table(cmap, opacity, n_colors, flip_scalars)
        n = lut.n_values
        # a linear map is the same over the shifted range; a logarithmic one needs the data's
        lut.scalar_range = (lo, hi) if log_scale else shifted
        lut.log_scale = bool(log_scale)
        # PyVista's to_color_tf: a point at each of n values over clim, coloured by the
        # lookup table's own mapping of that value (which is where log_scale acts).
        positions = np.linspace(*lut.scalar_range, n)
        rgb = np.array([lut.map_value(float(p), opacity=False) for p in positions])
        if isinstance(cmap, pyvista.LookupTable) or isinstance(opacity, str) or np.ndim(
                opacity) == 0:
            alpha = np.asarray(lut.values[:, 3], dtype=np.float64) / 255.0
        else:   # a curve in [0, 1], kept at full precision (not as the table's bytes)
            alpha = _resampled(opacity, n)
        spec = TransferSpec(
            cmap=_spec_cmap(cmap, lut), opacity=_spec_opacity(cmap, opacity, lut),
            clim=shifted, n_colors=n, flip_scalars=bool(flip_scalars),
            log_scale=bool(log_scale), opacity_unit_distance=float(opacity_unit_distance),
            value_offset=value_offset)
        made = cls._from_points(rgb, alpha, spec)
        if isinstance(cmap, pyvista.LookupTable):
            made = replace(made, lookup_table=cmap)
        return made

    @classmethod
    def from_points(cls, rgb, alpha, clim, opacity_unit_distance: float = 1.0,
                    value_offset: int | float = 0) -> TransferFunction:
        """A table through colours and opacities at points spread evenly over ``clim``.

        What VTK draws for transfer functions sampled at those points (linear between,
        clamped outside): how a volume property's functions edited by hand are drawn.
        ``rgb`` ``(n, 3)`` and ``alpha`` ``(n,)`` in [0, 1]; ``clim`` in data units.
        """
        rgb = np.clip(np.asarray(rgb, dtype=np.float64).reshape(-1, 3), 0.0, 1.0)
        alpha = np.clip(np.asarray(alpha, dtype=np.float64).ravel(), 0.0, 1.0)
        if not 1 <= len(alpha) <= REFINED_ROWS or len(rgb) != len(alpha) or not (
                np.isfinite(rgb).all() and np.isfinite(alpha).all()):
            raise VolumeDataError(f"from_points takes 1 to {REFINED_ROWS} finite colours and "
                                  f"as many opacities, got {len(rgb)} and {len(alpha)}.")
        lo, hi = checked_clim(clim)
        shifted = (shift_value(lo, value_offset), shift_value(hi, value_offset))
        if shifted[1] <= shifted[0]:
            shifted = (shifted[0], shifted[0] + 1.0)
        if not (opacity_unit_distance > 0 and np.isfinite(opacity_unit_distance)):
            raise VolumeDataError(f"opacity_unit_distance must be a positive length, got "
                                  f"{opacity_unit_distance}.")
        spec = TransferSpec(cmap=rgb, opacity=alpha, clim=shifted, n_colors=len(alpha),
                            flip_scalars=False, log_scale=False,
                            opacity_unit_distance=float(opacity_unit_distance),
                            value_offset=value_offset)
        return cls._from_points(rgb, alpha, spec)

    @classmethod
    def _from_points(cls, rgb: np.ndarray, alpha: np.ndarray, spec: TransferSpec
                     ) -> TransferFunction:
        """The table of ``spec``'s points: opacity capped, rows refined, extinction."""
        alpha = np.minimum(alpha, MAX_OPACITY)
        if len(alpha) == 1:   # one colour and opacity everywhere: two equal rows
            rgb, alpha = np.repeat(rgb, 2, axis=0), np.repeat(alpha, 2)
        rgb, alpha = _refined(rgb, alpha)
        with np.errstate(over="ignore", divide="ignore"):
            sigma = -np.log1p(-alpha) / float(spec.opacity_unit_distance)
        sigma = np.minimum(sigma, MAX_EXTINCTION)
        table = np.column_stack([rgb, sigma]).astype(np.float32)
        return cls(table=table, clim=spec.clim, spec=spec)

    def with_unit_distance(self, length: float) -> TransferFunction:
        """The same colours and opacities over another ``opacity_unit_distance``.

        Extinction is ``-ln(1 - o) / length``, so every row scales by ``old / length``.
        """
        length = float(length)
        if not (length > 0 and np.isfinite(length)) or self.spec is None:
            raise VolumeDataError(f"opacity_unit_distance must be a positive length (of a "
                                  f"table built from a colormap), got {length!r}.")
        table = self.table.astype(np.float64)
        table[:, 3] = np.minimum(table[:, 3] * (self.spec.opacity_unit_distance / length),
                                 MAX_EXTINCTION)
        return TransferFunction(table=table.astype(np.float32), clim=self.clim,
                                spec=replace(self.spec, opacity_unit_distance=length),
                                lookup_table=self.lookup_table)

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
        """The largest extinction in the table (per data unit)."""
        return float(self.table[:, 3].max())


def _refined(rgb: np.ndarray, alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Colours and opacities at ``k (n - 1) + 1`` rows, linear between the ``n`` given.

    Every given row stays a row (``k`` whole), so the colours are exactly VTK's piecewise
    linear function; the opacity is interpolated before it becomes an extinction.
    """
    n = len(alpha)
    k = max(1, (REFINED_ROWS - 1) // (n - 1))
    if k == 1:
        return rgb, alpha
    coarse = np.linspace(0.0, 1.0, n)
    fine = np.linspace(0.0, 1.0, k * (n - 1) + 1)
    rgb = np.column_stack([np.interp(fine, coarse, rgb[:, c]) for c in range(3)])
    return rgb, np.interp(fine, coarse, alpha)


def transfer_for_lookup_table(lut: pyvista.LookupTable, current: TransferFunction,
                              value_offset: int | float, same_colors: bool
                              ) -> TransferFunction:
    """What PyVista's volume draws for ``lut``, over ``current``'s unit distance.

    Only the range or scale changed (``same_colors``): ``current``'s colormap and opacity
    curve at full precision, as ``add_volume(clim=...)`` builds them (a table holds bytes).
    """
    spec = current.spec
    unit = spec.opacity_unit_distance if spec is not None else 1.0
    if same_colors and spec is not None and not isinstance(spec.cmap, np.ndarray):
        return TransferFunction.from_colormap(
            spec.cmap, spec.opacity, clim=tuple(lut.scalar_range), opacity_unit_distance=unit,
            n_colors=spec.n_colors, flip_scalars=spec.flip_scalars,
            log_scale=bool(lut.log_scale), value_offset=value_offset)
    if same_colors and spec is None and not lut.log_scale:   # a table given as is: its rows
        lo, hi = (shift_value(v, value_offset) for v in checked_clim(lut.scalar_range))
        return TransferFunction(table=current.table, clim=(lo, hi if hi > lo else lo + 1.0))
    made = TransferFunction.from_colormap(lut, opacity_unit_distance=unit,
                                          value_offset=value_offset)
    if spec is not None and not lut.log_scale and tuple(
            float(v) for v in lut.scalar_range) == spec.data_clim:
        # the range as drawn, in exact units (ids near 2**64 are one float apart)
        made = replace(made, clim=current.clim, spec=replace(made.spec, clim=spec.clim))
    return made


def checked_clim(clim) -> tuple[float, float]:
    """``clim`` as two finite non-decreasing floats (one number ``c``: ``(-c, c)``).

    Equal floats are let through: two integer bounds a float cannot tell apart (uint64
    near 2**64) are ordered exactly once the volume's offset is taken off.
    """
    if np.ndim(clim) == 0:
        try:
            clim = (-float(clim), float(clim))
        except (TypeError, ValueError):
            raise VolumeDataError(f"clim must be a number or two numbers, got {clim!r}.") from None
    try:
        lo, hi = (float(v) for v in clim)
    except (TypeError, ValueError):
        raise VolumeDataError(f"clim must be two finite increasing numbers, got {clim!r}.") \
            from None
    if not np.isfinite([lo, hi]).all() or hi < lo:
        raise VolumeDataError(f"clim must be two finite increasing numbers, got {tuple(clim)}.")
    if hi - lo > FLOAT32_MAX or max(abs(lo), abs(hi)) > FLOAT32_MAX:
        raise VolumeDataError(f"clim={(lo, hi)} spans more than float32 holds (the GPU draws "
                              f"in float32: bounds and width within {FLOAT32_MAX:.3g}); "
                              "give a narrower range.")
    return lo, hi


def pyvista_lookup_table(cmap, opacity, n_colors, flip_scalars) -> pyvista.LookupTable:
    """PyVista's lookup table for these settings, as ``add_volume`` makes it.

    The transfer function and the volume's scalar bar are both made from it.
    """
    if isinstance(cmap, pyvista.LookupTable):
        if not 1 <= cmap.n_values <= MAX_COLORS:   # one texel a colour: GL's width
            raise VolumeDataError(f"A lookup table of {cmap.n_values} colours cannot be "
                                  f"drawn: give one of 1 to {MAX_COLORS} (n_values).")
        lut = pyvista.LookupTable()
        lut.DeepCopy(cmap)
        return lut
    try:
        n = int(n_colors)
    except (TypeError, ValueError):
        raise VolumeDataError(f"n_colors must be an integer, got {n_colors!r}.") from None
    if not 1 <= n <= MAX_COLORS:
        raise VolumeDataError(f"n_colors must be 1 to {MAX_COLORS}, got {n_colors!r}.")
    from pyvista.plotting.colors import get_cmap_safe

    if cmap is None:
        cmap = pyvista.global_theme.cmap
    try:
        cmap_obj = get_cmap_safe(list(cmap) if isinstance(cmap, tuple) else cmap)
    except Exception as exc:
        raise VolumeDataError(unknown_cmap(cmap, exc)) from exc
    if flip_scalars:
        cmap_obj = cmap_obj.reversed()
    lut = pyvista.LookupTable()
    lut.apply_cmap(cmap_obj, n)
    # apply_opacity, as PyVista's add_volume: the table keeps the curve, and a colormap
    # set on it later (``lut.cmap = ...``) keeps these opacities, as PyVista's does
    if isinstance(opacity, str) or np.ndim(opacity) == 0:
        try:
            lut.apply_opacity(opacity if isinstance(opacity, str) else float(opacity))
        except Exception as exc:
            raise VolumeDataError(f"Unknown opacity {opacity!r}: {exc}") from exc
    else:   # n bytes: PyVista takes n values as they are
        lut.apply_opacity(np.round(_resampled(opacity, lut.n_values) * 255.0))
    return lut


def _resampled(opacity, n: int) -> np.ndarray:
    """Opacity values in [0, 1] at ``n`` points, a curve resampled as PyVista resamples it.

    A curve with values above 1 is read as bytes (0..255), as PyVista reads it.

    An array of exactly ``n`` values is taken as it is (PyVista 0.49 would read such an
    array as bytes, 0..255, and draw it almost transparent).
    """
    values = np.atleast_1d(np.asarray(opacity, dtype=np.float64))
    if values.size == 0:
        raise VolumeDataError("opacity is an empty curve: give at least one value in [0, 1] "
                              "(or a name: 'linear', 'sigmoid', ...).")
    if values.ndim != 1 or not np.isfinite(values).all() or values.min() < 0 or \
            values.max() > 255:
        raise VolumeDataError("opacity values must be finite numbers in [0, 1] (or bytes, "
                              "0 to 255, as PyVista also takes them).")
    if values.max() > 1:   # bytes, as PyVista reads a curve above 1
        values = values / 255.0
    if values.size == 1:
        return np.full(n, values[0])
    if values.size == n:
        return values
    lut = pyvista.LookupTable(n_values=n)
    lut.apply_opacity(values)   # PyVista's add_volume path: its own interpolation
    return np.asarray(lut.values[:, 3], np.float64) / 255.0


def _spec_cmap(cmap, lut: pyvista.LookupTable):
    """The colormap as the reference reads it: a name, or an explicit list of RGB colours."""
    if isinstance(cmap, pyvista.LookupTable):
        return np.asarray(lut.values[:, :3], dtype=np.float64) / 255.0
    return pyvista.global_theme.cmap if cmap is None else cmap


def _spec_opacity(cmap, opacity, lut: pyvista.LookupTable):
    if isinstance(cmap, pyvista.LookupTable):
        return np.asarray(lut.values[:, 3], dtype=np.float64) / 255.0
    return opacity


def shift_value(value, offset: int | float) -> float:
    """A data value (e.g. a clim bound) in the units of a volume's shifted ``values``."""
    if isinstance(offset, (int, np.integer)) and isinstance(value, (int, np.integer)):
        return float(int(value) - int(offset))
    return float(value) - float(offset)


def table_range(cmap, clim, call: str):
    """The range ``cmap`` colours over: a ``pyvista.LookupTable``'s own, else ``clim``.

    A table's range is drawn whatever ``clim`` says, as PyVista draws it (said when they
    differ).
    """
    if not isinstance(cmap, pyvista.LookupTable):
        return clim
    own = tuple(float(v) for v in cmap.scalar_range)
    if clim is not None and not np.allclose(
            np.broadcast_to(np.abs(clim) * [-1, 1] if np.ndim(clim) == 0 else clim, 2),
            own, rtol=1e-6, atol=0.0):
        warn_user(f"clim={clim!r} is not drawn: a pyvista.LookupTable given as cmap colours "
                  f"over its own scalar_range {own}, as PyVista's {call} draws it; set "
                  "lut.scalar_range to change it", VolumeDataWarning)
    return own


def unknown_cmap(cmap, error: Exception, argument: str = "cmap") -> str:
    """What to say of a colormap PyVista does not know: the nearest names, and where to look."""
    import difflib

    import matplotlib

    names = sorted(matplotlib.colormaps)
    near = difflib.get_close_matches(str(cmap), names, n=4) if isinstance(cmap, str) else []
    hint = f"did you mean {', '.join(map(repr, near))}? " if near else ""
    return (f"{argument}={reprlib.repr(cmap)} is not a colormap ({error}); {hint}give a name from "
            "matplotlib.colormaps (e.g. 'viridis', 'magma', 'coolwarm'), colorcet's, or a list "
            "of colours")
