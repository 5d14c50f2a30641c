"""A legacy ``.vtk`` file's declared array sizes, checked before VTK's legacy reader reads it.

VTK's legacy reader allocates every array at the size its header declares before reading
a value: a 1 KB file declaring a FIELD array of 10^9 doubles crashed the process (ASCII)
or read 10 GB of nothing (binary). Each declaration (points, cells, attributes, FIELD
arrays, a lookup table, metadata) must fit in the bytes that follow it in the file, and
all of them in the memory budget. The file is scanned mapped, not loaded; in a binary
file the scan jumps over each array's bytes.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

from ..core.errors import SceneLoadError
from ..core.mapped_files import mapped

#: A legacy array type as VTK's reader matches it (by prefix, ``char`` exactly): its bytes
#: a value in a binary file (at least) and in memory.
_TYPES = (("bit", 1 / 8, 1 / 8), ("unsigned_char", 1, 1), ("short", 2, 2),
          ("unsigned_short", 2, 2), ("vtkidtype", 4, 8), ("int", 4, 4), ("unsigned_int", 4, 4),
          ("long", 4, 8), ("unsigned_long", 4, 8), ("vtktypeint64", 8, 8),
          ("vtktypeuint64", 8, 8), ("float", 4, 4), ("double", 8, 8), ("string", 1, 32),
          ("utf8_string", 1, 32), ("variant", 1, 32))

_N = rb"([-+]?\d+)"
_T = rb"([A-Za-z_0-9]+)"
_S = rb"(\S+)"
_W = rb"\s+"
#: The declarations, each a keyword and its tokens (VTK reads tokens, so any whitespace).
_DECLARATION = re.compile(rb"(?<!\S)(?=[A-Za-z])(?:" + b"|".join([   # (a letter first: 4x)
    rb"(?P<points>POINTS)" + _W + _N + _W + _T,
    rb"(?P<coordinates>[XYZ]_COORDINATES)" + _W + _N + _W + _T,
    rb"(?P<cells>VERTICES|LINES|POLYGONS|TRIANGLE_STRIPS|CELLS)" + _W + _N + _W + _N,
    rb"(?P<offsets>OFFSETS|CONNECTIVITY)" + _W + _T,
    rb"(?P<cell_types>CELL_TYPES)" + _W + _N,
    rb"(?P<count>POINT_DATA|CELL_DATA)" + _W + _N,
    rb"(?P<scalars>SCALARS)" + _W + _S + _W + _T + rb"(?:" + _W + _N + rb")?" + _W
    + rb"LOOKUP_TABLE" + _W + _S,
    rb"(?P<colors>COLOR_SCALARS)" + _W + _S + _W + _N,
    rb"(?P<vectors>VECTORS|NORMALS|TENSORS6|TENSORS|GLOBAL_IDS|PEDIGREE_IDS|EDGE_FLAGS)"
    + _W + _S + _W + _T,
    rb"(?P<tcoords>TEXTURE_COORDINATES)" + _W + _S + _W + _N + _W + _T,
    rb"(?P<table>LOOKUP_TABLE)" + _W + _S + _W + _N,
    rb"(?P<field>FIELD)" + _W + _S + _W + _N,
    rb"(?P<metadata>DATA)" + _W + _N,
]) + rb")(?!\S)", re.IGNORECASE)
#: A FIELD's array: its name, components, tuples and type (or ``NULL_ARRAY``).
_FIELD_ARRAY = re.compile(rb"(?<!\S)(?:NULL_ARRAY|" + _S + _W + _N + _W + _N + _W + _T
                          + rb")(?!\S)")
#: Components a value of each keyword's tuples has.
_COMPONENTS = {b"vectors": 3, b"normals": 3, b"tensors6": 6, b"tensors": 9}


def _type(name: bytes) -> tuple[float, float] | None:
    """(bytes a value in a binary file, bytes in memory) of a type name, or None."""
    name = name.lower().decode("latin-1")
    if name in ("char", "signed_char"):
        return (1, 1)
    found = None
    for prefix, file_bytes, memory in _TYPES:   # the longest prefix, as VTK's order picks
        if name.startswith(prefix) and (found is None or len(prefix) > len(found[0])):
            found = (prefix, file_bytes, memory)
    return None if found is None else found[1:]


class _Scan:
    """The running state of one file's scan: its sizes, counts and the total declared."""

    def __init__(self, data, binary: bool, budget: int | None, where: str, shown: str,
                 error):
        self.data, self.binary, self.budget = data, binary, budget
        self.where, self.shown, self.error = where, shown, error
        self.total = 0          # bytes in memory of everything declared so far
        self.count = 0          # the last POINT_DATA / CELL_DATA count
        self.cells = (0, 0)     # the last cell array's (offsets, connectivity) sizes

    def declare(self, what: str, values: int, kind: tuple[float, float] | None,
                after: int) -> int:
        """Check ``values`` values of ``kind`` declared before byte ``after``; their file bytes."""
        if values < 0:
            raise self.error(f"{self.where}: {self.shown!r} declares {what} of {values} "
                             "values, a negative count (damaged or hostile): refused.")
        file_bytes, memory = kind if kind is not None else (1, 8)
        at_least = math.ceil(values * file_bytes) if self.binary else values
        left = len(self.data) - after
        if at_least > left:
            raise self.error(
                f"{self.where}: {self.shown!r} declares {what} of {values:,} values "
                f"({at_least:,} bytes or more), but only {left:,} bytes follow in the file "
                "(damaged or hostile; VTK would allocate them all): refused unread.")
        self.total += math.ceil(values * memory)
        if self.budget is not None and self.total > self.budget:
            raise self.error(
                f"{self.where}: {self.shown!r} declares arrays of {self.total:,} bytes or "
                f"more, more than the {self.budget:,} a grid file may take: refused unread.")
        return at_least if self.binary and kind is not None else 0

    def field(self, name: str, arrays: int, at: int) -> int:
        """Check a FIELD's ``arrays`` arrays from byte ``at``; where its last one ends."""
        self.declare(f"the field {name!r}", arrays, None, at)   # an array a byte at least
        for _ in range(arrays):
            found = _FIELD_ARRAY.search(self.data, at)
            if found is None:
                break
            at = found.end()
            if found.group(1) is None:   # NULL_ARRAY
                continue
            label = found.group(1).decode("latin-1", "replace")
            components, tuples = int(found.group(2)), int(found.group(3))
            if min(components, tuples) < 0:
                self.declare(f"the array {label!r}", min(components, tuples), None, at)
            at += self.declare(f"the array {label!r}", components * tuples,
                               _type(found.group(4)), at)
        return at

    def run(self, at: int) -> None:
        """Check every declaration from byte ``at`` on, in file order."""
        while (found := _DECLARATION.search(self.data, at)) is not None:
            at = found.end() + self._one(found)

    def _one(self, found: re.Match) -> int:
        """Check one declaration; the bytes of binary data that follow it (to jump)."""
        key = next(name for name, value in found.groupdict().items() if value is not None)
        groups = [g for g in found.groups() if g is not None]
        word = groups[0].decode("latin-1").upper()
        end = found.end()
        if key == "points":
            return self.declare("POINTS", 3 * int(groups[1]), _type(groups[2]), end)
        if key == "coordinates":
            return self.declare(word, int(groups[1]), _type(groups[2]), end)
        if key == "cells":
            offsets, size = int(groups[1]), int(groups[2])
            self.cells = (offsets, size)
            following = re.match(rb"\s*OFFSETS", self.data[end:end + 64], re.IGNORECASE)
            if following is not None:   # VTK 5: OFFSETS and CONNECTIVITY arrays follow
                return 0
            return self.declare(word, size, (4, 4), end)
        if key == "offsets":
            values = self.cells[0] if word == "OFFSETS" else self.cells[1]
            return self.declare(word, values, _type(groups[1]), end)
        if key == "cell_types":
            return self.declare(word, int(groups[1]), (4, 4), end)
        if key == "count":
            self.count = int(groups[1])
            return self.declare(word, self.count, (0, 0), end)   # its sign only
        if key == "scalars":
            components = int(groups[3]) if len(groups) == 5 else 1
            return self.declare(f"SCALARS {groups[1].decode('latin-1', 'replace')!r}",
                                self.count * components, _type(groups[2]), end)
        if key == "colors":
            return self.declare(word, self.count * int(groups[2]), (1, 4), end)
        if key == "vectors":
            components = _COMPONENTS.get(word.lower().encode(), 1)
            return self.declare(word, self.count * components, _type(groups[2]), end)
        if key == "tcoords":
            return self.declare(word, self.count * int(groups[2]), _type(groups[3]), end)
        if key == "table":
            return self.declare(word, 4 * int(groups[2]), (1, 4), end)
        if key == "field":
            last = self.field(groups[1].decode("latin-1", "replace"), int(groups[2]), end)
            return last - end
        return self.declare("a metadata DATA block", int(groups[1]), (1, 8), end)


def check_legacy_vtk(path: Path, where: str, shown: str, budget: int | None,
                     error=SceneLoadError) -> None:
    """Raise ``error`` where a legacy ``.vtk`` file declares arrays it cannot hold.

    A declaration (its values at a byte each in ASCII, at its type's size in binary) longer
    than the rest of the file, a negative count, or more bytes in all than ``budget``.
    """
    with mapped(path) as data:
        if data is None:
            return   # empty: VTK says so
        head = data[:1024].split(b"\n", 3)   # version, title (free text), format
        if not head[0].startswith(b"# vtk DataFile") or len(head) < 4:
            return   # not a legacy file: VTK says so
        binary = head[2].strip().lower().startswith(b"binary")
        after_header = sum(len(line) + 1 for line in head[:3])
        _Scan(data, binary, budget, where, shown, error).run(after_header)
