"""A NRRD header's placement (``space directions``, ``space origin``), which VTK drops.

VTK's NRRD reader keeps the directions' lengths as the spacing and leaves out their
orientation: a scan whose x axis runs the other way (``(-1,0,0)``) was drawn mirrored, and
swapped or rotated axes as if they were not. :func:`nrrd_placement` reads them from the
header and :func:`placed` gives them to the grid VTK read, on the axes it read as space
(a first axis of 9 values or fewer it reads as components).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.errors import SceneLoadError

#: A header longer than this is refused before its placement is read (as its data file's).
HEADER_BYTES = 1 << 20
_VECTOR = re.compile(r"\([^()]*\)|none", re.IGNORECASE)


@dataclass
class NrrdPlacement:
    """Each axis's size and direction (None: not a space axis), and the space origin."""

    sizes: list
    directions: list
    origin: np.ndarray | None
    where: str
    shown: str
    error: type


def nrrd_placement(path: Path, where: str, shown: str, error=SceneLoadError):
    """The placement a NRRD header states (None: no ``space directions``, or a 2-D space).

    Raises ``error`` naming the file for a direction that is not finite and nonzero, or an
    origin that is not three finite numbers.
    """
    fields = _header_fields(path)
    stated = fields.get("space directions")
    if stated is None:
        return None
    tokens = _VECTOR.findall(stated)
    directions = []
    for token in tokens:
        if token.lower() == "none":
            directions.append(None)
            continue
        try:
            vector = np.array([float(v) for v in token.strip("()").split(",")], np.float64)
        except ValueError:
            raise error(f"{where}: {shown!r} has space directions {stated!r} that are not "
                        "vectors of numbers: refused.") from None
        if vector.shape != (3,):
            return None   # a 2-D space: VTK's placement stands
        if not np.isfinite(vector).all() or not np.any(vector):   # VTK: 16 components
            raise error(f"{where}: {shown!r} has space directions {stated!r}: not finite, "
                        "independent axes (a zero, infinite or NaN one places no grid): "
                        "refused.")
        directions.append(vector)
    try:
        sizes = [int(v) for v in fields.get("sizes", "").split()]
    except ValueError:
        return None   # VTK refuses the header itself
    if len(sizes) != len(directions):
        raise error(f"{where}: {shown!r} has {len(directions)} space directions for "
                    f"{len(sizes)} axes: refused (damaged or hostile).")
    origin = None
    if "space origin" in fields:
        found = re.fullmatch(r"\s*\(([^()]*)\)\s*", fields["space origin"])
        try:
            origin = np.array([float(v) for v in found.group(1).split(",")], np.float64)
        except (AttributeError, ValueError):
            origin = None
        if origin is None or origin.shape != (3,) or not np.isfinite(origin).all():
            raise error(f"{where}: {shown!r} has space origin {fields['space origin']!r}: "
                        "not three finite numbers: refused.")
    return NrrdPlacement(sizes, directions, origin, where, shown, error)


def placed(grid, placement: NrrdPlacement) -> None:
    """Give ``grid`` (the ImageData VTK read from the file) the header's placement.

    The space axes are those whose sizes VTK's grid has, in order; two of them (a slab, or
    a first axis VTK read as components) are completed by their cross product. Raises the
    placement's error for axes that are not finite and independent.
    """
    dims = [int(n) for n in grid.dimensions]
    axes = [i for i, d in enumerate(placement.directions) if d is not None]
    if [placement.sizes[i] for i in axes] + [1] * (3 - len(axes)) != dims:
        axes = axes[1:]   # VTK read the first axis as components
        if [placement.sizes[i] for i in axes] + [1] * (3 - len(axes)) != dims:
            return   # axes VTK read otherwise: its placement stands
    columns = [placement.directions[i] for i in axes]
    if len(columns) == 2:
        columns.append(np.cross(columns[0], columns[1]))
    if len(columns) != 3:
        return
    columns = np.column_stack(columns)
    finite = np.isfinite(columns).all()
    lengths = np.linalg.norm(columns, axis=0) if finite else np.zeros(3)
    unit = columns / np.where(lengths > 0, lengths, 1.0)
    if not finite or not (lengths > 0).all() or abs(np.linalg.det(unit)) < 1e-6:
        raise placement.error(
            f"{placement.where}: {placement.shown!r} has space directions "
            f"{[None if d is None else d.tolist() for d in placement.directions]}: not "
            "finite, independent axes (a zero, infinite or repeated one places no grid): "
            "refused.")
    if len(axes) == 2:
        lengths[2] = 1.0   # a slab's thickness, as VTK spaces its one layer
    grid.spacing = tuple(float(v) for v in lengths)
    grid.direction_matrix = unit
    if placement.origin is not None:
        grid.origin = tuple(float(v) for v in placement.origin)


def _header_fields(path: Path) -> dict:
    """The header's ``field: value`` lines by lower-case field (key-value ``:=`` pairs left)."""
    fields, read = {}, 0
    with open(path, "rb") as handle:
        for raw in handle:
            read += len(raw)
            if read > HEADER_BYTES:
                break
            line = raw.decode("latin-1").rstrip("\r\n")
            if not line:   # the header's end
                break
            key, colon, value = line.partition(":")
            if colon and not value.startswith("=") and not line.startswith("#"):
                fields[key.strip().lower()] = value.strip()
    return fields
