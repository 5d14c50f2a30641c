"""A NRRD header's placement (``space directions``, ``space origin``), which VTK drops.

VTK's NRRD reader keeps the directions' lengths as the spacing and leaves out their
orientation: a scan whose x axis runs the other way (``(-1,0,0)``) was drawn mirrored, and
swapped or rotated axes as if they were not. :func:`nrrd_placement` reads them from the
header so that the grid is placed as the file says.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..core.errors import SceneLoadError

#: A header longer than this is refused before its placement is read (as its data file's).
HEADER_BYTES = 1 << 20
_VECTOR = re.compile(r"\([^()]*\)|none", re.IGNORECASE)


def nrrd_placement(path: Path, where: str, shown: str, error=SceneLoadError):
    """``(spacing, direction, origin)`` a 3-D NRRD header states, or ``None`` if it states none.

    ``direction``'s columns are the unit axes; ``origin`` is ``None`` without a ``space
    origin``. Raises ``error`` naming the file for directions that are not three finite,
    independent axes (a zero or repeated one: VTK read such a file as 16 components).
    """
    fields = _header_fields(path)
    stated = fields.get("space directions")
    if stated is None:
        return None
    axes = [t for t in _VECTOR.findall(stated) if t.lower() != "none"]
    if len(axes) != 3:   # a 2-D image, or another space: VTK's placement stands
        return None
    try:
        columns = np.array([[float(v) for v in axis.strip("()").split(",")] for axis in axes],
                           dtype=np.float64).T
    except ValueError:
        raise error(f"{where}: {shown!r} has space directions {stated!r} that are not "
                    "vectors of numbers: refused.") from None
    if columns.shape != (3, 3):
        return None
    lengths = np.linalg.norm(columns, axis=0) if np.isfinite(columns).all() else np.zeros(3)
    unit = columns / np.where(lengths > 0, lengths, 1.0)
    if not (lengths > 0).all() or not np.isfinite(lengths).all() or \
            abs(np.linalg.det(unit)) < 1e-6:
        raise error(f"{where}: {shown!r} has space directions {stated!r}: not three finite, "
                    "independent axes (a zero, infinite or repeated one places no grid): "
                    "refused.")
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
    return lengths, unit, origin


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


def placed(grid, placement) -> None:
    """Give ``grid`` (an ImageData read from the file) the header's placement."""
    spacing, direction, origin = placement
    grid.spacing = tuple(float(v) for v in spacing)
    grid.direction_matrix = direction
    if origin is not None:
        grid.origin = tuple(float(v) for v in origin)
