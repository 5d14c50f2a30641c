"""A file read first as ``pyvista.read`` reads it, in a child process held to a memory cap.

VTK's readers trust their headers: the legacy ``.vtk`` reader allocates what a header
declares before reading a value (a 300-byte file declaring 10^9 doubles crashed the
process, or read 10 GB of nothing), the NRRD reader crashes on some headers (five axes,
one axis, a malformed ``dimension:``), and no scanner of ours tokenises as VTK does (a
keyword matched by its prefix, a number cut from the word after it). So the reader itself
is the check: ``pyvista.read`` reads the file in a child process whose address space is
capped, and a crash, a refused allocation or a VTK error there refuses the file here,
before this process reads it.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

#: Files whose readers are known to trust their headers, read first in a child when they
#: are images (the others that ``pyvista.read`` reads are meshes, all read so).
PROBED_IMAGE_SUFFIXES = (".vtk", ".pvtk", ".nrrd", ".nhdr")
#: Files that hold their data uncompressed: what they hold in memory is at most this many
#: times their bytes (an ASCII "0 " read as a double into two buffers; a one-value array's
#: or a short string's objects: 100,000 one-value field arrays took 49 times).
UNCOMPRESSED_SUFFIXES = (".vtk", ".pvtk")
MEMORY_PER_FILE_BYTE = 64
#: Memory any read may take beyond that (VTK's own buffers, small files); the child keeps
#: to two malloc arenas, whose reserved address space the cap counts.
SLACK_BYTES = 64 << 20
_CHILD = Path(__file__).with_name("vtk_read_child.py")
#: Runs the child script without putting its folder (or the working one) on sys.path.
_RUN = "import runpy, sys; sys.path.pop(0); sys.argv = sys.argv[1:]; " \
       "runpy.run_path(sys.argv[0], run_name='__main__')"


def probe_read(path: Path, where: str, shown: str, budget: int | None, error,
               data_bytes: int = 0, image: bool = True) -> None:
    """Raise ``error`` unless ``pyvista.read`` reads ``path`` in a child within its cap.

    The cap: ``budget`` bytes (what a grid file may take), and for an uncompressed legacy
    file :data:`MEMORY_PER_FILE_BYTE` times its size, plus :data:`SLACK_BYTES`.
    ``data_bytes``: a detached data file's size. ``image``: only the image files of
    :data:`PROBED_IMAGE_SUFFIXES` are read first (a mesh file always is).
    """
    suffix = path.suffix.lower()
    if image and suffix not in PROBED_IMAGE_SUFFIXES:
        return
    size = path.stat().st_size + data_bytes
    limit = budget if budget is not None else 1 << 62
    if suffix in UNCOMPRESSED_SUFFIXES:
        limit = min(limit, MEMORY_PER_FILE_BYTE * size)
    limit += SLACK_BYTES
    command = [sys.executable, "-c", _RUN, str(_CHILD), str(path), str(limit),
               str(-1 if budget is None else budget)]
    try:
        run = subprocess.run(command, capture_output=True, text=True, errors="replace",
                             timeout=60 + size / 2e6,
                             env={**os.environ, "MALLOC_ARENA_MAX": "2"})
    except subprocess.TimeoutExpired as exc:
        raise error(f"{where}: reading {shown!r} ({size:,} bytes) took more than "
                    f"{exc.timeout:.0f} s in a test read: refused (damaged or hostile).") from exc
    except OSError as exc:   # no interpreter to run: say so rather than read unchecked
        raise error(f"{where}: {shown!r} is read first in a child process "
                    f"({sys.executable!r}), which could not start ({exc}): not read.") from exc
    _judge(run, where, shown, size, limit, error)


def _judge(run, where: str, shown: str, size: int, limit: int, error) -> None:
    """Raise ``error`` unless the child's run read the file (or its header refused it)."""
    errors = [_vtk_message(line) for line in run.stderr.splitlines() if "ERR|" in line]
    tail = [line for line in run.stderr.splitlines() if line.strip()][-2:]
    memory = any(re.search(r"allocate|bad_alloc", e) for e in errors) or any(
        line.startswith(("MemoryError", "terminate called after throwing an instance of "
                         "'std::bad_alloc'", "cannot allocate memory")) for line in tail)
    if memory:
        raise error(f"{where}: reading {shown!r} ({size:,} bytes) needs more than "
                    f"{limit:,} bytes (the memory budget, PV_CUBEMARCH_ARRAY_MAX_BYTES, and "
                    f"for a legacy .vtk {MEMORY_PER_FILE_BYTE} times its bytes): its header "
                    "declares more data than it holds (damaged or hostile), or more than "
                    f"the budget allows (VTK: {errors[0] if errors else tail[-1]}). Refused "
                    "before this process read it.")
    if run.returncode < 0:
        name = signal.Signals(-run.returncode).name
        raise error(f"{where}: VTK's reader crashed ({name}) reading {shown!r} in a test "
                    "read: refused, a damaged or hostile file or one VTK cannot read (a "
                    "NRRD of five axes)" + (f"; VTK said first: {errors[0]}." if errors else "."))
    if run.returncode != 0 or errors:
        said = errors[0] if errors else (tail[-1] if tail else f"exit {run.returncode}")
        raise error(f"{where}: {shown!r} could not be read (VTK: {said}).")
    lines = run.stdout.strip().splitlines()
    try:
        json.loads(lines[-1])["read"]
    except (IndexError, ValueError, KeyError, TypeError):
        raise error(f"{where}: {shown!r} is read first in a child process, which did not "
                    f"say it read it ({sys.executable!r} may not be Python): not read.") from None
    # {"read": false}: its header passed VTK's header pass in the child and refuses it; the
    # caller reads that header again here (now known not to crash) and says why


def _vtk_message(line: str) -> str:
    """A VTK log line's message: after ``ERR|`` and the object's ``Name (0x...): ``."""
    text = line.split("ERR|", 1)[-1]
    text = re.sub(r"^\s*\w+ \(0x[0-9a-fA-F]+\): ", "", text)
    return text.replace("\x1b[0m", "").strip()
