"""The ``pyvista.Volume`` that ``add_volume`` returns when VTK's mapper does not draw it.

The direct marcher, the cube map and ``'auto'`` draw boxes and passes of their own; the
plotter knows the volume by this stand-in instead: a real ``pyvista.Volume`` spanning the
volume's world bounds, whose VTK mapper draws no fragment. PyVista's calls then work as on
its own volumes: ``pl.add_volume_clip_plane(vol)`` and ``vol.mapper.AddClippingPlane``
(the marchers read the planes), ``vol.bounds``, ``reset_camera``, ``remove_actor`` and
visibility. Between frames its mapper holds the volume's values (:class:`PickerData`), so
that VTK's volume pickers cast through them as through PyVista's own volume.
"""

from __future__ import annotations

import numpy as np
import pyvista
from pyvista.plotting.mapper import GPUVolumeRayCastMapper
from pyvista.plotting.volume_property import VolumeProperty

from ..core import vtk_classes as vtk
from ..core.frame_errors import observe
from ..gl.box import place_by_user_matrix
from ..gl.shaders import Replacement, ShaderRecipe
from ..models.group import VolumeGroup
from .pyvista_keywords import scalar_bar_mapper

_DRAWS_NOTHING = ShaderRecipe([Replacement("//VTK::ComputeClipPos::Impl",
                                           "stand_in_clip_position", stage="vertex",
                                           keep_tag="before"),
                               # what PyVista's SSAO adds to a volume's shader reads it
                               Replacement("//VTK::Base::Dec", "ea_vtk_shading_gradient",
                                           keep_tag="after")])


def stand_in_volume(model) -> pyvista.Volume:
    """A volume spanning ``model``'s world bounds that draws nothing."""
    grid = vtk.vtkImageData()
    grid.SetDimensions(2, 2, 2)
    scalars = vtk.vtkFloatArray()
    scalars.SetName("stand-in")
    scalars.SetNumberOfTuples(8)
    scalars.Fill(0.0)
    grid.GetPointData().SetScalars(scalars)
    mapper = GPUVolumeRayCastMapper()   # PyVista's wrappers: vol.mapper.blend_mode ...
    mapper.SetInputData(grid)
    volume = pyvista.Volume()
    volume.SetMapper(mapper)
    prop = VolumeProperty()               # ... vol.prop.interpolation_type, as PyVista's
    volume.SetProperty(prop)
    if not isinstance(model, VolumeGroup):   # vol.mapper.scalar_range reads the clim
        mapper.lookup_table = scalar_bar_mapper(model).lookup_table
        mapper.scalar_range = tuple(float(v) for v in mapper.lookup_table.scalar_range)
    # Held from Python: PyVista's wrappers keep Python state (the mapper's lookup table and
    # range), lost with the wrapper if only VTK held the object.
    pyvista.set_new_attribute(volume, "_cubemarch_parts", (mapper, prop))
    pyvista.set_new_attribute(volume, "_cubemarch_drawn_grid", grid)
    _DRAWS_NOTHING.apply(volume.GetShaderProperty())
    place_stand_in(volume, model)
    return volume


def place_stand_in(volume, model) -> None:
    """Span ``model``'s box (at creation and after the volume moved).

    A volume's stand-in holds the grid's own box (origin, direction and extent) and, as its
    ``user_matrix``, the volume's ``transform``, as PyVista's volumes do: ``vol.user_matrix``
    reads what ``add_volume(user_matrix=...)`` was given. A group's spans its world box.
    """
    if isinstance(model, VolumeGroup):
        dataset_from_index, transform = model.world_from_index(), np.eye(4)
    else:
        dataset_from_index = model.dataset_from_index()
        transform = np.asarray(model.transform, dtype=np.float64)
    span = np.array(model.dimensions, dtype=np.float64) - 1.0
    axes = dataset_from_index[:3, :3]
    lengths = np.linalg.norm(axes, axis=0)
    direction = axes / np.where(lengths > 0, lengths, 1.0)
    extent = lengths * span
    # A flat grid keeps a sliver of thickness: VTK's mapper divides by the spacing.
    floor = max(float(extent.max()) * 1e-9, 1e-30)
    grid = getattr(volume, "_cubemarch_drawn_grid", None) or volume.GetMapper().GetInput()
    grid.SetOrigin(*dataset_from_index[:3, 3])
    grid.SetSpacing(*np.maximum(extent, floor))
    grid.SetDirectionMatrix(*direction.ravel())
    grid.Modified()
    place_by_user_matrix(volume, transform)


class PickerData:
    """The volume's values, held by the stand-in's mapper between frames for VTK's pickers.

    VTK's volume pickers (``vtkVolumePicker``, ``vtkCellPicker``: PyVista's
    ``picker='volume'`` and ``'cell'``) cast their ray through the mapper's input, through
    the property's opacity; the stand-in draws a grid of 2x2x2 points. Between frames its
    mapper holds an image of the values in the data's units (the dataset's own array,
    shared, not copied), and while the renderer draws, the drawn grid again. A volume
    whose values are not one array of its grid (RGBA, channels, offset integers) keeps
    none (``grid`` None).
    """

    def __init__(self, volume, model, renderer):
        self.mapper, self.renderer = volume.GetMapper(), renderer
        self.drawn = getattr(volume, "_cubemarch_drawn_grid", None)
        self.grid = _pickers_grid(model) if self.drawn is not None else None
        self._observers = []
        if self.grid is not None:
            self._observers = [observe(renderer, vtk.vtkCommand.StartEvent, self._drawing),
                               observe(renderer, vtk.vtkCommand.EndEvent, self._picking)]
            self._picking()

    def _drawing(self, *_) -> None:
        self.mapper.SetInputData(self.drawn)

    def _picking(self, *_) -> None:
        self.mapper.SetInputData(self.grid)

    def follow(self, model) -> None:
        """Hold ``model``'s values after ``set_values`` (a copy: the dataset's are old)."""
        if self.grid is None:
            return
        grid = pyvista.ImageData()
        grid.CopyStructure(self.grid)
        grid.point_data["values"] = (np.asarray(model.values, np.float64)
                                     + float(model.value_offset)).ravel(order="F")
        self.grid = grid
        self._picking()

    def release(self) -> None:
        """Stop following the renderer; the mapper holds the drawn grid again."""
        for tag in self._observers:
            self.renderer.RemoveObserver(tag)
        self._observers = []
        if self.drawn is not None:
            self._drawing()


def _pickers_grid(model):
    """An image of ``model``'s drawn array at its points, shared (None: none to share)."""
    if isinstance(model, VolumeGroup) or getattr(model, "colors", None) is not None or \
            getattr(model, "value_offset", 0) or getattr(model, "scalars", None) is None:
        return None
    array = model.grid.GetPointData().GetArray(model.scalars)
    if array is None or array.GetNumberOfComponents() != 1 or \
            array.GetNumberOfTuples() != model.grid.GetNumberOfPoints():
        return None
    grid = vtk.vtkImageData()
    grid.CopyStructure(model.grid)
    grid.GetPointData().SetScalars(array)
    return grid
