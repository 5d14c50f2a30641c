"""A file read first by VTK's reader in a child process held to a memory limit.

VTK's legacy ``.vtk`` and NRRD readers trust their headers: they allocate what a header
declares before reading a value (a 300-byte file declaring 10^9 doubles crashed the
process, or read 10 GB of nothing), crash on some malformed headers (a NRRD of five axes,
or of one), and tokenise as no scanner of ours could match exactly (a keyword matched by
its prefix, a number cut from the word after it). So the reader itself is the check: it
reads the file in a child process whose address space is capped, and a crash, a refused
allocation or a VTK error there refuses the file here, before this process reads it.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from pathlib import Path

#: The readers whose headers are not trusted, by suffix.
PROBED_READERS = {".vtk": "vtkDataSetReader", ".nrrd": "vtkNrrdReader",
                  ".nhdr": "vtkNrrdReader"}
#: A legacy ``.vtk``'s data in memory is at most this many times its bytes on disk (an
#: ASCII value of 2 bytes, "0 ", read as a double and, for cells, into two buffers).
LEGACY_MEMORY_PER_BYTE = 16
#: Memory any read may take beyond that (VTK's own buffers, small files); the child keeps
#: to two malloc arenas, whose reserved address space the cap counts.
SLACK_BYTES = 64 << 20
_CHILD = Path(__file__).with_name("vtk_read_child.py")


def probe_read(path: Path, where: str, shown: str, budget: int | None, error,
               data_bytes: int = 0) -> None:
    """Raise ``error`` unless VTK's reader reads ``path`` in a child within its limit.

    The limit: ``budget`` bytes (the memory a grid file may take), and for a legacy
    ``.vtk`` at most :data:`LEGACY_MEMORY_PER_BYTE` times the file's size (it holds its
    data uncompressed). ``data_bytes``: a detached data file's size, counted with the
    header's.
    """
    reader = PROBED_READERS.get(path.suffix.lower())
    if reader is None:
        return
    size = path.stat().st_size + data_bytes
    limit = budget if budget is not None else 1 << 62
    if reader == "vtkDataSetReader":
        limit = min(limit, LEGACY_MEMORY_PER_BYTE * size)
    limit += SLACK_BYTES
    try:
        run = subprocess.run([sys.executable, "-I", str(_CHILD), str(path), reader,
                              str(limit), str(-1 if budget is None else budget)],
                             capture_output=True, text=True,
                             env={**os.environ, "MALLOC_ARENA_MAX": "2"},
                             timeout=60 + size / 2e6, errors="replace")
    except subprocess.TimeoutExpired as exc:
        raise error(f"{where}: VTK's reader took more than {exc.timeout:.0f} s over "
                    f"{shown!r} ({size:,} bytes) in a test read: refused (damaged or "
                    "hostile).") from exc
    errors = [_vtk_message(line) for line in run.stderr.splitlines() if "ERR|" in line]
    memory = "bad_alloc" in run.stderr or "MemoryError" in run.stderr or any(
        "allocate" in e for e in errors)
    if run.returncode < 0 and not memory:
        name = signal.Signals(-run.returncode).name
        raise error(f"{where}: VTK's reader crashed ({name}) reading {shown!r} in a test "
                    "read: refused, its header is damaged or hostile"
                    + (f" (VTK said first: {errors[0]})." if errors else "."))
    if memory:
        raise error(f"{where}: {shown!r} declares more data than it can hold: VTK's reader "
                    f"asked for more than {limit:,} bytes reading its {size:,} bytes "
                    f"(VTK: {errors[0] if errors else 'out of memory'}): refused before this "
                    "process reads it.")
    if run.returncode != 0 or errors:
        said = errors[0] if errors else run.stderr.strip().splitlines()[-1:] or ["no reason"]
        raise error(f"{where}: {shown!r} could not be read (VTK: "
                    f"{said if isinstance(said, str) else said[0]}).")
    # {"read": false}: its header passed VTK's header pass in the child, and refuses it;
    # the caller reads that header again here (now known not to crash) and says why


def _vtk_message(line: str) -> str:
    """A VTK log line's message: after ``ERR|`` and the object's ``Name (0x...): ``."""
    text = line.split("ERR|", 1)[-1]
    text = re.sub(r"^\s*\w+ \(0x[0-9a-fA-F]+\): ", "", text)
    return text.replace("\x1b[0m", "").strip()


def detached_size(folder: Path, name: str | None) -> int:
    """The size of a header's detached data file ``name`` in ``folder`` (0 when none)."""
    if not name:
        return 0
    try:
        return os.stat(folder / name).st_size
    except OSError:
        return 0
