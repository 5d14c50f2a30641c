"""The ``pyvista.Volume`` that ``add_volume`` returns when VTK's mapper does not draw it.

The direct marcher, the cube map and ``'auto'`` draw boxes and passes of their own; the
plotter knows the volume by this stand-in instead: a real ``pyvista.Volume`` spanning the
volume's world bounds, whose VTK mapper draws no fragment. PyVista's calls then work as on
its own volumes: ``pl.add_volume_clip_plane(vol)`` and ``vol.mapper.AddClippingPlane``
(the marchers read the planes), ``vol.bounds``, ``reset_camera``, ``remove_actor``,
visibility and picking.
"""

from __future__ import annotations

import numpy as np
import pyvista
import vtk

from ..gl.shaders import Replacement, ShaderRecipe

_DRAWS_NOTHING = ShaderRecipe([Replacement("//VTK::ComputeClipPos::Impl",
                                           "stand_in_clip_position", stage="vertex",
                                           keep_tag="before")])


def stand_in_volume(model) -> pyvista.Volume:
    """A volume spanning ``model``'s world bounds that draws nothing."""
    grid = vtk.vtkImageData()
    grid.SetDimensions(2, 2, 2)
    scalars = vtk.vtkFloatArray()
    scalars.SetName("stand-in")
    scalars.SetNumberOfTuples(8)
    scalars.Fill(0.0)
    grid.GetPointData().SetScalars(scalars)
    mapper = vtk.vtkOpenGLGPUVolumeRayCastMapper()
    mapper.SetInputData(grid)
    volume = pyvista.Volume()
    volume.SetMapper(mapper)
    volume.SetProperty(vtk.vtkVolumeProperty())
    _DRAWS_NOTHING.apply(volume.GetShaderProperty())
    place_stand_in(volume, model)
    return volume


def place_stand_in(volume, model) -> None:
    """Span ``model``'s world bounds (at creation and after the volume moved)."""
    bounds = np.asarray(model.world_bounds(), dtype=np.float64)
    lower, upper = bounds[0::2], bounds[1::2]
    extent = upper - lower
    # A flat grid keeps a sliver of thickness: VTK's mapper divides by the spacing.
    floor = max(float(extent.max()) * 1e-9, 1e-30)
    grid = volume.GetMapper().GetInput()
    grid.SetOrigin(*lower)
    grid.SetSpacing(*np.maximum(extent, floor))
    grid.Modified()
