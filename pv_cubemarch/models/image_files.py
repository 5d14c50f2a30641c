"""Image files (``.vti``, ``.vtk``, NRRD, MetaImage) checked from their headers before a read.

A header of a hundred bytes can declare 10^15 points (VTK then aborts the process
allocating them) or name a "detached" data file anywhere (``/etc/passwd``, ``/dev/zero``).
The size is read through the VTK reader's own header pass (``UpdateInformation``), which
allocates nothing; a detached data file must be a regular file in the header's folder. A
file VTK cannot read is said so (VTK returns what it read, or nothing, and logs why).
"""

from __future__ import annotations

import base64
import math
import mmap
import os
import re
import stat
import struct
import warnings
from pathlib import Path

import pyvista

from ..core import vtk_classes as vtk
from ..core.budgets import host_budget
from ..core.errors import SceneLoadError
from .nrrd_space import nrrd_placement, placed
from .sandboxed_read import probe_read

#: The image files checked (what ``pyvista.read`` reads through VTK's image readers).
IMAGE_SUFFIXES = (".vti", ".vtk", ".pvtk", ".nrrd", ".nhdr", ".mha", ".mhd")
#: The bytes one grid file's values may take once read (default: 80 % of what the system
#: can give now); its header is checked before anything is read.
ARRAY_BYTES_ENV = "PV_CUBEMARCH_ARRAY_MAX_BYTES"

#: The most header bytes read looking for the data file (headers are a few hundred; VTK
#: reads any length, so a longer one is refused, not half read).
_HEADER_BYTES = 1 << 20


def read_image_file(path, where: str, shown: str | None = None, error=SceneLoadError):
    """``pyvista.read`` of an image file, once its header is checked (:func:`check_image_file`).

    What VTK could not read raises ``error`` naming the file and VTK's first complaint.
    """
    shown = str(path) if shown is None else shown
    check_image_file(Path(path), where, shown, host_budget(ARRAY_BYTES_ENV, error), error)
    placement = nrrd_placement(Path(path), where, shown, error) if Path(
        path).suffix.lower() in (".nrrd", ".nhdr") else None
    try:   # VTK's errors as its log has them, or as PyVista's reader warns of them
        with pyvista.VtkErrorCatcher(send_to_logging=False) as caught, \
                warnings.catch_warnings(record=True) as warned:
            warnings.simplefilter("always")
            grid = pyvista.read(str(path))
    except Exception as exc:
        raise error(f"{where}: could not read {shown!r}: {exc}") from exc
    said = "raised an error while reading"
    errors = _vtk_errors(caught) + [
        str(w.message).split("\n", 1)[-1].strip().strip('"') for w in warned
        if said in str(w.message)]
    for w in warned:   # the others, as they were
        if said not in str(w.message):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if errors:
        raise error(f"{where}: {shown!r} could not be read (VTK: {errors[0]}).")
    if placement is not None and isinstance(grid, pyvista.ImageData):
        placed(grid, placement)   # the header's orientation, which VTK's reader drops
    return grid


def read_data_file(path, where: str, error=SceneLoadError):
    """``pyvista.read`` of any file, once read in a capped child where its reader is trusting.

    An image file as :func:`read_image_file` reads it; any other (a mesh) once
    ``pyvista.read`` has read it in a child process (:func:`probe_read`).
    """
    if Path(path).suffix.lower() in IMAGE_SUFFIXES:
        return read_image_file(path, where, error=error)
    probe_read(Path(path), where, str(path), host_budget(ARRAY_BYTES_ENV, error), error,
               image=False)
    return pyvista.read(str(path))


def _vtk_errors(caught) -> list[str]:
    """The errors VTK logged while ``caught`` (a ``pyvista.VtkErrorCatcher``) listened."""
    return [event.alert for event in caught.events if event.kind == "ERROR"]


def check_image_file(path: Path, where: str, shown: str, budget: int | None,
                     error=SceneLoadError) -> None:
    """Raise ``error`` for an image file that cannot be read safely.

    A detached data file outside the header's folder or not a regular file; a legacy
    ``.vtk`` or NRRD that VTK's reader cannot read within the memory budget, or crashes on
    (:func:`probe_read`, in a child process); a header VTK cannot read; declared
    dimensions or components that are not positive; declared points whose values would
    take more than ``budget`` bytes.
    """
    probe_read(Path(path), where, shown, budget, error,
               _check_data_file(Path(path), where, shown, error))
    reader = pyvista.get_reader(str(path)).reader
    reader.SetFileName(str(path))
    with pyvista.VtkErrorCatcher(send_to_logging=False) as caught:
        reader.UpdateInformation()
    errors = _vtk_errors(caught)
    if errors:
        raise error(f"{where}: {shown!r} could not be read (VTK: {errors[0]}).")
    if isinstance(reader, vtk.vtkNrrdReader) and reader.GetFileDimensionality() < 2:
        raise error(
            f"{where}: {shown!r} has {reader.GetFileDimensionality()} image axes once VTK's "
            "NRRD reader takes a first axis of 9 values or fewer as components, and VTK "
            "crashes reading an image of fewer than two axes: refused. Write it with a first "
            "axis of one value and two axes or more after it (sizes: 1 nx ny ...).")
    info = reader.GetOutputInformation(0)
    extent = info.Get(vtk.vtkStreamingDemandDrivenPipeline.WHOLE_EXTENT())
    if extent is None:   # not an image (a legacy .vtk of another dataset): read as it is
        return
    counts = [int(extent[2 * a + 1]) - int(extent[2 * a]) + 1 for a in range(3)]
    scalars = vtk.vtkDataObject.GetActiveFieldInformation(
        info, vtk.vtkDataObject.FIELD_ASSOCIATION_POINTS, vtk.vtkDataSetAttributes.SCALARS)
    components, size = 1, 8
    if scalars is not None:
        components = int(scalars.Get(vtk.vtkDataObject.FIELD_NUMBER_OF_COMPONENTS()))
        kind = vtk.vtkDataArray.CreateDataArray(
            int(scalars.Get(vtk.vtkDataObject.FIELD_ARRAY_TYPE())))
        size = kind.GetDataTypeSize() if kind is not None else 8
    if min(counts) < 1 or components < 1:
        raise error(f"{where}: {shown!r} declares {counts} points and {components} "
                    "components a point; each must be at least 1 (its header is damaged or "
                    "hostile).")
    nbytes = counts[0] * counts[1] * counts[2] * components * size   # Python ints: no wrap
    if budget is not None and nbytes > budget:
        raise error(
            f"{where}: {shown!r} declares {counts[0]} x {counts[1]} x {counts[2]} points of "
            f"{components:,} component(s) ({nbytes:,} bytes), more than the {budget:,} a "
            f"grid file may take ({ARRAY_BYTES_ENV}, by default 80 % of the memory "
            "available): read a smaller grid, or stream it as a zarr store.")
    if Path(path).suffix.lower() == ".vti":   # every array, and compressed blocks' claims
        check_vtk_xml(Path(path), where, shown, budget, error)


def _check_data_file(path: Path, where: str, shown: str, error=SceneLoadError) -> int:
    """A NRRD or MetaImage header's detached data file: a regular file beside it, or none.

    Returns its bytes (0 for none). Every line of a NRRD header that could name one is
    checked (VTK's reader reads each ``data file: `` line; ours matches more spellings),
    and more than one is refused: VTK reads them all as one image.

    The header is read as VTK's readers read it: lines end at a newline only (a form feed
    or a NEL character ends none), NRRD's at its first empty line, MetaImage's at
    ``ElementDataFile`` (``=`` or ``:``; ``LOCAL``, ``Local`` or ``local`` inline, any
    other value a file name, spaces included). A header longer than
    :data:`_HEADER_BYTES` is refused rather than half read.
    """
    suffix = path.suffix.lower()
    nrrd = suffix in (".nrrd", ".nhdr")
    if suffix not in (".nrrd", ".nhdr", ".mha", ".mhd"):
        return 0
    names: list[str] = []
    detached = 0
    read = 0
    with open(path, "rb") as handle:
        for raw in handle:   # binary lines: split at b"\n" only
            read += len(raw)
            if read > _HEADER_BYTES:
                raise error(f"{where}: {shown!r} has a header longer than {_HEADER_BYTES:,} "
                            "bytes before its data: refused unread (damaged or hostile).")
            line = os.fsdecode(raw).rstrip("\r\n")   # a name as the file system spells it
            if nrrd and not line:
                break   # the header's end: the data follow, attached
            name = _data_file_name(line, nrrd)
            if name is None:
                continue
            if not nrrd and name in ("LOCAL", "Local", "local"):
                return 0
            detached += _check_named_file(path, name, nrrd, where, shown, error)
            names.append(name)
            if not nrrd:
                return detached   # MetaIO reads no field after it
            if len(names) > 1:
                raise error(f"{where}: {shown!r} names {len(names)} data files ({names[0]!r}, "
                            f"{names[1]!r}), which VTK would read as one image: refused.")
    return detached


def _data_file_name(line: str, nrrd: bool) -> str | None:
    """The data file a header line names, or None (not that key)."""
    if nrrd:
        match = re.match(r"^data ?file\s*:=?\s*(.*)$", line, re.IGNORECASE)
    else:
        match = re.match(r"^\s*ElementDataFile\s*[=:]\s*(.*)$", line)
    return None if match is None else match.group(1).strip()


def _check_named_file(path: Path, name: str, nrrd: bool, where: str, shown: str,
                      error) -> int:
    """Refuse ``name`` unless it is one regular file in ``path``'s folder (or below).

    Returns its bytes.
    """
    # as VTK's NRRD reader splits it: a first word LIST, or four words or more (a pattern,
    # its range and step), else the whole value is one name; MetaIO: LIST..., or a pattern
    words = name.split() or [""]
    several = (words[0] == "LIST" or len(words) >= 4) if nrrd else (
        name.startswith("LIST") or "%" in name)
    if several:
        raise error(f"{where}: {shown!r} splits its data over several files ({name!r}), "
                    "which is not read; write it as one file.")
    try:
        folder = path.resolve().parent
        target = (folder / name).resolve()
        inside = folder == target.parent or folder in target.parents
        found = target.stat() if inside and target.exists() else None
        regular = found is not None and stat.S_ISREG(found.st_mode)
    except (OSError, ValueError, RuntimeError) as exc:   # a null byte, a loop, too long
        raise error(f"{where}: {shown!r} names the data file {name!r}, which cannot be "
                    f"followed ({type(exc).__name__}: {exc}): refused.") from exc
    if not (inside and regular):
        raise error(f"{where}: {shown!r} names the data file {name!r}, which "
                    + ("is not a regular file" if inside else "lies outside its folder")
                    + ": refused (a detached header's data file must be a file beside it).")
    return found.st_size


#: Bytes of each VTK XML array type.
_XML_TYPE_BYTES = {"Int8": 1, "UInt8": 1, "Int16": 2, "UInt16": 2, "Int32": 4, "UInt32": 4,
                   "Int64": 8, "UInt64": 8, "Float32": 4, "Float64": 8, "Bit": 1, "String": 1}


def _xml_attributes(tag: bytes) -> dict[str, str]:
    """A tag's attributes (``name="value"``) as text."""
    return {k.decode("latin-1"): v.decode("latin-1")
            for k, v in re.findall(rb'([A-Za-z_]+)="([^"]*)"', tag)}


def check_vtk_xml(path: Path, where: str, shown: str, budget: int | None,
                  error=SceneLoadError) -> None:
    """Raise ``error`` where a VTK XML file declares more than ``budget`` bytes of arrays.

    Every array counts (not only the active scalars): its tuples (``NumberOfTuples``, else
    the piece's points or cells) times its components, and a compressed array what its
    blocks' header says they inflate to (a 2x2x2 file claiming 2^40 blocks aborted the
    process inside VTK). Read from the file mapped, not loaded.
    """
    if budget is None:
        return
    with open(path, "rb") as handle:
        try:
            data = mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ)
        except ValueError:   # empty: VTK says so
            return
        with data:
            root = re.search(rb"<VTKFile\b[^>]*>", data[:1 << 16])
            if root is None:
                return
            file_attributes = _xml_attributes(root.group())
            word = 8 if file_attributes.get("header_type") == "UInt64" else 4
            little = file_attributes.get("byte_order", "LittleEndian") != "BigEndian"
            compressed = "compressor" in file_attributes
            appended = data.find(b"<AppendedData")
            xml_end = appended if appended >= 0 else len(data)
            start = -1
            raw = True
            if appended >= 0:
                tag = re.match(rb"<AppendedData\b[^>]*>", data[appended:appended + 4096])
                raw = tag is not None and b'encoding="base64"' not in tag.group()
                start = data.find(b"_", appended) + 1
            points = cells = 1
            total = 0
            for match in re.finditer(rb"<Piece\b[^>]*>|<DataArray\b[^>]*>", data[:xml_end]):
                attributes = _xml_attributes(match.group())
                if match.group().startswith(b"<Piece"):
                    extent = [int(float(v)) for v in attributes.get("Extent", "0 0 0 0 0 0")
                              .split()[:6]]
                    sides = [extent[2 * a + 1] - extent[2 * a] + 1 for a in range(3)]
                    points = math.prod(max(n, 1) for n in sides)
                    cells = math.prod(max(n - 1, 1) for n in sides)
                    continue
                size = _XML_TYPE_BYTES.get(attributes.get("type", ""), 8)
                components = int(float(attributes.get("NumberOfComponents", "1")))
                tuples = int(float(attributes.get("NumberOfTuples", max(points, cells))))
                declared = max(components, 1) * max(tuples, 0) * size
                if compressed and attributes.get("format") in ("appended", "binary"):
                    header = _block_header(data, attributes, match.end(), start, raw, word,
                                           little)
                    if header is not None:   # what VTK allocates to inflate it, at least
                        blocks, block, last = header
                        declared = max(declared, max(blocks - 1, 0) * block + (last or block))
                total += declared
                if total > budget:
                    raise error(
                        f"{where}: {shown!r} declares arrays of {total:,} bytes or more "
                        f"(their sizes, or what their compressed blocks' header says they "
                        f"inflate to), more than the {budget:,} a grid file may take "
                        f"({ARRAY_BYTES_ENV}): refused before VTK reads it.")


def _block_header(data, attributes: dict, after_tag: int, appended_start: int, raw: bool,
                  word: int, little: bool) -> tuple[int, int, int] | None:
    """A compressed array's ``(blocks, block size, last block size)``, or None."""
    fmt = ("<" if little else ">") + ("Q" if word == 8 else "I") * 3
    if attributes.get("format") == "appended" and appended_start > 0:
        at = appended_start + int(float(attributes.get("offset", "0")))
        if raw:
            head = data[at:at + 3 * word]
        else:
            head = base64.b64decode(data[at:at + 4 * -(-3 * word // 3)] + b"==")[:3 * word]
    else:   # inline binary: the header is base64 at the element's start
        text = data[after_tag:after_tag + 4 * -(-3 * word // 3) + 64].lstrip()
        try:
            head = base64.b64decode(text[:4 * -(-3 * word // 3)] + b"==")[:3 * word]
        except ValueError:
            return None
    if len(head) < 3 * word:
        return None
    return struct.unpack(fmt, head)
