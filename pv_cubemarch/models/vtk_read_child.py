"""Run as a script (not imported): read one file with a VTK reader under a memory limit.

``python -I vtk_read_child.py PATH READER LIMIT BUDGET``: imports only ``vtkmodules``,
caps the process's address space at what it has mapped plus ``LIMIT`` bytes, reads
``PATH`` with ``READER`` (a class of ``vtkIOLegacy`` or ``vtkIOImage``) and prints
``{"read": true}``; VTK logs its errors to stderr. It stops after the header pass, printing
``{"read": false}``, where the caller refuses the file from its header (an image whose
points' values exceed ``BUDGET`` bytes, -1 for none; a NRRD of fewer than two image axes,
which VTK crashes on). A crash or an allocation past the limit ends this process, not the
caller's (:mod:`.sandboxed_read`).
"""

import json
import resource
import sys

from vtkmodules import vtkIOImage, vtkIOLegacy
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
    path, reader_name, limit = sys.argv[1], sys.argv[2], int(sys.argv[3])
    budget = int(sys.argv[4])
    module = vtkIOLegacy if hasattr(vtkIOLegacy, reader_name) else vtkIOImage
    reader = getattr(module, reader_name)()
    cap = _mapped_bytes() + limit
    resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    reader.SetFileName(path)
    reader.UpdateInformation()
    if _header_refuses(reader, budget):
        print(json.dumps({"read": False}))
        return
    reader.Update()
    print(json.dumps({"read": True}))


if __name__ == "__main__":
    main()
