"""pv_cubemarch: ray-marching techniques for PyVista/VTK through GLSL injection.

Importing the package selects an offscreen OpenGL window when there is no display
(OSMesa by default, EGL with ``PV_CUBEMARCH_GL=egl``) and, with the ``jupyter`` extra,
makes ``plotter.show()`` in a notebook show plotters holding our techniques by the
server-rendered view (:mod:`pv_cubemarch.views.notebook`).
"""

from __future__ import annotations

from .core.offscreen import configure_offscreen

configure_offscreen()

from . import plugin  # noqa: E402  (registers plotter.cubemarch for explicit imports too)
from .api import add_surface, add_volume, add_volumes, add_voxels  # noqa: E402
from .cluster import orbit, render_frames, render_sort_last, sweep_options  # noqa: E402
from .core.camera import Camera  # noqa: E402
from .core.errors import (  # noqa: E402
    CubemarchError,
    GpuLimitError,
    OffscreenUnavailableError,
    PlotterClosedError,
    RefusedChangeError,
    RefusedOptionsError,
    SceneChangedError,
    SceneLoadError,
    SceneWarning,
    ShaderCompileError,
    StoreReadError,
    VolumeDataError,
    VolumeDataWarning,
)
from .core.offscreen import gl_info  # noqa: E402
from .core.rendering import offscreen_plotter, render_frame, render_image  # noqa: E402
from .gl.bindings import ShaderBindings  # noqa: E402
from .gl.passes import RenderToTexturePass  # noqa: E402
from .gl.shaders import Replacement, ShaderRecipe  # noqa: E402
from .gl.textures import Texture  # noqa: E402
from .models.field_sources import make_field  # noqa: E402
from .models.group import VolumeGroup  # noqa: E402
from .models.label_colors import hashed_colors  # noqa: E402
from .models.label_ids import LabelIds  # noqa: E402
from .models.lights import VolumeLight  # noqa: E402
from .models.multiscale import MultiscaleSource, multiscale_source  # noqa: E402
from .models.pyramid import build_pyramid  # noqa: E402
from .models.surface import SplineField  # noqa: E402
from .models.transfer import TransferFunction  # noqa: E402
from .models.volume import VolumeModel, make_volume  # noqa: E402
from .models.voxels import Palette, VoxelModel, make_voxels  # noqa: E402
from .quality import QualityChoice  # noqa: E402
from .quality.interaction import FrameBudget  # noqa: E402
from .reference import ShadeSetup, render_blended, render_emission_absorption  # noqa: E402
from .reference.label_ids import trace_ids  # noqa: E402
from .scene.io import load_scene  # noqa: E402
from .scene.model import Scene, SceneLight, SceneMesh, SkippedPrim  # noqa: E402
from .scene.openvdb.image import read_vdb  # noqa: E402
from .views.live import LiveView, live_view  # noqa: E402
from .views.notebook import register_notebook_backends  # noqa: E402
from .voxels.technique import VoxelBinding, VoxelPick  # noqa: E402

__version__ = "0.1.0"

#: Another name for :func:`live_view` (a live view is the notebook widget).
widget = live_view

register_notebook_backends()

__all__ = [
    "Camera", "CubemarchError", "GpuLimitError", "OffscreenUnavailableError",
    "PlotterClosedError",
    "RefusedChangeError", "RefusedOptionsError", "RenderToTexturePass", "Replacement",
    "Scene", "SceneChangedError", "SceneLight",
    "SceneLoadError", "SceneMesh", "SceneWarning", "ShaderBindings",
    "ShaderCompileError", "ShaderRecipe", "SkippedPrim", "StoreReadError", "Texture",
    "TransferFunction",
    "VolumeDataError", "VolumeDataWarning", "VolumeGroup", "VolumeLight", "VolumeModel",
    "add_volume", "build_pyramid", "MultiscaleSource", "multiscale_source",
    "add_surface", "add_volumes", "add_voxels", "SplineField", "make_field",
    "configure_offscreen", "make_voxels", "Palette", "VoxelModel", "gl_info",
    "load_scene", "make_volume", "read_vdb", "offscreen_plotter", "plugin",
    "render_emission_absorption", "render_blended", "render_frame", "ShadeSetup",
    "render_image", "widget",
    "live_view", "LiveView", "LabelIds", "hashed_colors", "trace_ids", "VoxelBinding",
    "VoxelPick", "orbit", "render_frames", "render_sort_last", "sweep_options",
    "QualityChoice", "FrameBudget",
]
