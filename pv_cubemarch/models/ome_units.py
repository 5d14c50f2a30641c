"""OME-Zarr space axes in one length unit: z in millimetres beside x in micrometres.

An OME-Zarr image may give each axis its own unit. Its scales are numbers in those units,
so a z step of 1 millimetre beside x steps of 1 micrometre was drawn 1000 times too thin.
:func:`unit_factors` converts each space axis into the x axis's unit.
"""

from __future__ import annotations

from ..core.user_warnings import warn_user

#: The length units OME-Zarr allows (UDUNITS-2 names), in metres.
LENGTH_UNITS = {
    "angstrom": 1e-10, "attometer": 1e-18, "centimeter": 1e-2, "decimeter": 1e-1,
    "exameter": 1e18, "femtometer": 1e-15, "foot": 0.3048, "gigameter": 1e9,
    "hectometer": 1e2, "inch": 0.0254, "kilometer": 1e3, "megameter": 1e6, "meter": 1.0,
    "micrometer": 1e-6, "mile": 1609.344, "millimeter": 1e-3, "nanometer": 1e-9,
    "parsec": 3.0856775814913673e16, "petameter": 1e15, "picometer": 1e-12,
    "terameter": 1e12, "yard": 0.9144, "yoctometer": 1e-24, "yottameter": 1e24,
    "zeptometer": 1e-21, "zettameter": 1e21,
}


def unit_factors(names: list, kinds: list, units: list, space: tuple) -> list[float]:
    """Factors turning each of the ``space`` axes' scales into the x axis's unit.

    ``names``, ``kinds``, ``units``: every axis's, as the metadata gives them. Raises
    ``ValueError`` for a space axis of another type (``time``, ``channel``); warns, and
    leaves the scales as written, where the units cannot be compared (one given and one
    not, or a unit that is not a length).
    """
    for axis_name in space:
        kind = kinds[names.index(axis_name)]
        if kind not in (None, "space"):
            raise ValueError(f"The image's axis {axis_name!r} is of type {kind!r}: a volume "
                             "draws three axes of type 'space' named x, y and z.")
    given = [units[names.index(axis_name)] for axis_name in space]
    if len(set(given)) <= 1:
        return [1.0, 1.0, 1.0]
    unknown = [u for u in given if u not in LENGTH_UNITS]
    if unknown:
        warn_user(f"The image's space axes x, y, z have the units {given}; "
                  f"{', '.join(map(repr, unknown))} cannot be compared with the others, so "
                  "the scales are drawn as written, each in its own unit.")
        return [1.0, 1.0, 1.0]
    base = LENGTH_UNITS[given[0]]
    return [float(f"{LENGTH_UNITS[u] / base:.15g}") for u in given]   # 1e-3 / 1e-6: 1000
