"""The VTK classes and constants the package uses, from the VTK modules that hold them.

``import vtk`` loads every VTK module (0.4 s of ``import pv_cubemarch``); modules here write
``from ..core import vtk_classes as vtk`` and read ``vtk.vtkActor`` as before. A name used
anywhere is added here (``tests/test_layout.py`` checks that none is missing).
"""

# The OpenGL2 modules also register the rendering and volume factories (as ``import vtk`` did).
from vtkmodules.vtkCommonCore import (
    VTK_FLOAT,
    VTK_LINEAR_INTERPOLATION,
    VTK_NEAREST_INTERPOLATION,
    VTK_OBJECT,
    VTK_STRING,
    VTK_UNSIGNED_CHAR,
    VTK_UNSIGNED_SHORT,
    vtkCommand,
    vtkDataArray,
    vtkDoubleArray,
    vtkFloatArray,
    vtkOutputWindow,
    vtkPoints,
    vtkTypeInt32Array,
    vtkUnsignedCharArray,
)
from vtkmodules.vtkCommonDataModel import (
    vtkCellArray,
    vtkDataObject,
    vtkDataSetAttributes,
    vtkImageData,
    vtkPiecewiseFunction,
    vtkPlane,
    vtkPolyData,
)
from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline
from vtkmodules.vtkCommonMath import vtkMatrix3x3, vtkMatrix4x4
from vtkmodules.vtkFiltersCore import (
    vtkAppendPolyData,
    vtkImplicitPolyDataDistance,
    vtkPolyDataTangents,
)
from vtkmodules.vtkFiltersGeometry import vtkDataSetSurfaceFilter
from vtkmodules.vtkIOImage import vtkHDRReader, vtkNrrdReader
from vtkmodules.vtkRenderingAnnotation import vtkScalarBarActor
from vtkmodules.vtkRenderingCore import (
    vtkActor,
    vtkAssembly,
    vtkColorTransferFunction,
    vtkPolyDataMapper,
    vtkSkybox,
    vtkTexture,
    vtkVolume,
    vtkVolumeProperty,
    vtkWindowToImageFilter,
)
from vtkmodules.vtkRenderingOpenGL2 import vtkOpenGLPolyDataMapper, vtkOpenGLRenderer
from vtkmodules.vtkRenderingVolume import VTK_CROP_SUBVOLUME, vtkVolumeMapper
from vtkmodules.vtkRenderingVolumeOpenGL2 import vtkOpenGLGPUVolumeRayCastMapper

__all__ = [
    "VTK_CROP_SUBVOLUME", "VTK_FLOAT", "VTK_LINEAR_INTERPOLATION", "VTK_NEAREST_INTERPOLATION",
    "VTK_OBJECT", "VTK_STRING", "VTK_UNSIGNED_CHAR", "VTK_UNSIGNED_SHORT", "vtkActor",
    "vtkAppendPolyData", "vtkAssembly", "vtkCellArray", "vtkColorTransferFunction",
    "vtkCommand", "vtkDataArray", "vtkDataObject", "vtkDataSetAttributes",
    "vtkDataSetSurfaceFilter", "vtkDoubleArray",
    "vtkFloatArray", "vtkHDRReader", "vtkImageData", "vtkImplicitPolyDataDistance",
    "vtkMatrix3x3", "vtkMatrix4x4", "vtkNrrdReader", "vtkOpenGLGPUVolumeRayCastMapper",
    "vtkOpenGLPolyDataMapper", "vtkOpenGLRenderer", "vtkOutputWindow", "vtkPiecewiseFunction",
    "vtkPlane", "vtkPoints", "vtkPolyData", "vtkPolyDataMapper", "vtkPolyDataTangents",
    "vtkScalarBarActor", "vtkSkybox", "vtkStreamingDemandDrivenPipeline", "vtkTexture",
    "vtkTypeInt32Array", "vtkUnsignedCharArray", "vtkVolume", "vtkVolumeMapper",
    "vtkVolumeProperty", "vtkWindowToImageFilter",
]
