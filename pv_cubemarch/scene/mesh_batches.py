"""Many scene meshes as few actors: the opaque parts that would draw alike are merged first.

A stage of 20 000 prims would otherwise be 20 000 actors, each added under its name (and
PyVista looks every name up among all actors: quadratic time). Parts with the same
material, colour, shading and point/cell arrays draw the same merged or apart, so each such
group becomes one mesh (a cell array says which part each cell came from). Translucent
parts stay alone (their order of drawing matters), and so do parts whose material reads a
primvar other than the colour (drawn as its mean over each part). A merged group is one
actor: hiding or recolouring it acts on every part in it.
"""

from __future__ import annotations

from dataclasses import fields

import numpy as np
import pyvista

from ..core import vtk_classes as vtk
from .materials import PrimvarInput
from .parts import SceneMesh

#: Parts appended at a time (one vtkAppendPolyData of thousands of inputs is slower).
BATCH = 512
#: The cell array of a merged mesh giving, per cell, the index of the part it came from.
PART_INDEX = "cubemarch_part"


def draw_key(part: SceneMesh) -> str | None:
    """What makes two parts draw alike; None for a part drawn on its own (translucent)."""
    material = part.material
    opacity = getattr(material, "opacity", 1.0)
    if part.opacity < 1.0 or not isinstance(opacity, (int, float)) or opacity < 1.0:
        return None
    mesh = part.mesh
    if not isinstance(mesh, pyvista.PolyData) or mesh.GetFieldData().GetNumberOfArrays():
        return None   # constant primvars (field data) would keep the first part's alone
    if material is not None and any(isinstance(getattr(material, f.name), PrimvarInput)
                                    for f in fields(material) if f.name != "diffuse_color"):
        return None   # a primvar read as metallic, roughness...: drawn as its mean per part
    look = tuple((f.name, getattr(part, f.name)) for f in fields(part)
                 if f.name not in ("name", "mesh"))
    arrays = tuple(_arrays(data) for data in (mesh.GetPointData(), mesh.GetCellData(),
                                              mesh.GetFieldData()))
    normals = mesh.GetPointData().GetNormals()
    return repr((look, arrays, normals.GetName() if normals is not None else None))


def _arrays(data) -> tuple:
    """Name, type and components of each array of VTK attribute data.

    Read through VTK: PyVista's wrappers cost more than the rest of a 20 000-part scene.
    """
    out = []
    for k in range(data.GetNumberOfArrays()):
        array = data.GetAbstractArray(k)
        out.append((array.GetName(), array.GetDataType(), array.GetNumberOfComponents()))
    return tuple(sorted(out, key=repr))


def batched(parts: list[SceneMesh]) -> list[tuple[SceneMesh, list[str]]]:
    """The parts to add, each with the names of the parts it draws (in scene order)."""
    groups: dict = {}
    for n, part in enumerate(parts):
        key = draw_key(part)
        groups.setdefault(key if key is not None else n, []).append(part)
    out = []
    for members in groups.values():
        if len(members) == 1:
            out.append((members[0], [members[0].name]))
        else:
            out.append((_merged(members), [m.name for m in members]))
    return out


def _merged(parts: list[SceneMesh]) -> SceneMesh:
    """One part drawing all of ``parts`` (which draw alike), named after the first."""
    pieces = []
    for start in range(0, len(parts), BATCH):
        append = vtk.vtkAppendPolyData()
        for part in parts[start:start + BATCH]:
            append.AddInputData(part.mesh)
        append.Update()
        pieces.append(append.GetOutput())
    if len(pieces) > 1:
        append = vtk.vtkAppendPolyData()
        for piece in pieces:
            append.AddInputData(piece)
        append.Update()
        pieces = [append.GetOutput()]
    mesh = pyvista.wrap(pieces[0])
    index = np.repeat(np.arange(len(parts), dtype=np.int32),
                      [part.mesh.n_cells for part in parts])
    mesh.cell_data.set_array(index, PART_INDEX)    # not the active scalars
    first = parts[0]
    return SceneMesh(**{f.name: getattr(first, f.name) for f in fields(first)
                        if f.name != "mesh"}, mesh=mesh)
