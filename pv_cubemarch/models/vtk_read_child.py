"""Run as a script (not imported): read one file as ``pyvista.read`` does, under a memory cap.

Run by :mod:`.sandboxed_read` with ``PATH LIMIT BUDGET``: imports PyVista (not this
package), caps the process's address space at what it has mapped plus ``LIMIT`` bytes
(within the limit it inherited), reads ``PATH`` with the reader and settings
``pyvista.read`` uses, and prints ``{"read": true}``; VTK logs its errors to stderr. It
stops after the header pass, printing ``{"read": false}``, where the caller refuses the
file from its header (an image whose points' values exceed ``BUDGET`` bytes, -1 for none;
a NRRD of fewer than two image axes, which VTK crashes on). A crash or an allocation past
the cap ends this process, not the caller's.
"""

import json
import resource
import sys

import pyvista
from vtkmodules.vtkCommonCore import vtkDataArray
from vtkmodules.vtkCommonDataModel import vtkDataObject, vtkDataSetAttributes
from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline


def _mapped_bytes() -> int:
    """The process's address space now (VmSize), in bytes."""
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    return 0


def _cap(limit: int) -> None:
    """Cap the address space at what is mapped plus ``limit``, within the inherited limit."""
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    cap = min(_mapped_bytes() + limit, (1 << 62))
    if hard != resource.RLIM_INFINITY:
        cap = min(cap, hard)
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))


def _header_refuses(reader, budget: int) -> bool:
    """Whether the header alone refuses the file (the caller says why, reading it again)."""
    if hasattr(reader, "GetFileDimensionality") and reader.GetFileDimensionality() < 2:
        return True
    info = reader.GetOutputInformation(0)
    extent = info.Get(vtkStreamingDemandDrivenPipeline.WHOLE_EXTENT())
    if extent is None or budget < 0:
        return False
    points = 1
    for axis in range(3):
        points *= max(int(extent[2 * axis + 1]) - int(extent[2 * axis]) + 1, 0)
    scalars = vtkDataObject.GetActiveFieldInformation(
        info, vtkDataObject.FIELD_ASSOCIATION_POINTS, vtkDataSetAttributes.SCALARS)
    components, size = 1, 8
    if scalars is not None:
        components = max(int(scalars.Get(vtkDataObject.FIELD_NUMBER_OF_COMPONENTS())), 1)
        kind = vtkDataArray.CreateDataArray(int(scalars.Get(vtkDataObject.FIELD_ARRAY_TYPE())))
        size = kind.GetDataTypeSize() if kind is not None else 8
    return points * components * size > budget or points < 1


def main() -> None:
    path, limit, budget = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    _cap(limit)
    try:
        reader = pyvista.get_reader(path)   # its settings: what pyvista.read reads
    except ValueError:   # a format pyvista.read gives to meshio
        pyvista.read(path)
        print(json.dumps({"read": True}))
        return
    vtk_reader = reader.reader
    vtk_reader.UpdateInformation()
    if _header_refuses(vtk_reader, budget):
        print(json.dumps({"read": False}))
        return
    reader.read()
    print(json.dumps({"read": True}))


if __name__ == "__main__":
    main()
