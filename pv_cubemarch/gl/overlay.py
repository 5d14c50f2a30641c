"""The scene overlay: a renderer drawn after the plotter's, over its colour and depth.

Passes that need the frame's finished opaque depth (the reduced-resolution pass, the cube
ray-marching pass) run at the overlay's start, after every opaque prop of the scene was
drawn; the volumes that composite their result over the scene are drawn by the overlay,
farthest first. One overlay serves every such volume of a plotter; the opaque depth is
the main renderer's shared copy (:func:`~pv_cubemarch.gl.frame_inputs.frame_inputs`), made
at most once per frame for every user.
"""

from __future__ import annotations

import numpy as np
import pyvista
from vtkmodules.vtkRenderingOpenGL2 import vtkOpenGLGL2PSHelper

from ..core import vtk_classes as vtk
from ..core.frame_errors import observe
from ..core.user_warnings import warn_user
from .box import place_by_user_matrix
from .draw_order import sort_far_to_near
from .frame_inputs import PROXY_NAME, frame_inputs
from .shaders import Replacement, ShaderRecipe

#: OpenGL's blend factors (GL_ONE, GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA).
ONE, SRC_ALPHA, ONE_MINUS_SRC_ALPHA = 1, 0x0302, 0x0303


class SceneOverlay:
    """The overlay renderer of one plotter and the opaque depth copied at its start."""

    def __init__(self, main):
        self.main = main
        self.window = main.GetRenderWindow()
        renderer = vtk.vtkOpenGLRenderer()
        self.window.SetNumberOfLayers(max(self.window.GetNumberOfLayers(),
                                          self.main.GetLayer() + 2))
        renderer.SetLayer(self.main.GetLayer() + 1)
        renderer.SetViewport(self.main.GetViewport())
        renderer.SetActiveCamera(self.main.GetActiveCamera())
        renderer.SetPreserveColorBuffer(True)
        renderer.SetPreserveDepthBuffer(True)
        renderer.InteractiveOff()
        renderer.SetUseOIT(False)
        self.window.AddRenderer(renderer)
        self.renderer = renderer
        self.depth = frame_inputs(self.main).depth
        self.users: dict = {}  # user -> whether it reads the depth copy
        # Priority above the passes' observers: the depth is copied before any pass reads it.
        self._tag = observe(renderer, vtk.vtkCommand.StartEvent, self._on_start, 1.0)
        self._window_tag = observe(self.window, vtk.vtkCommand.StartEvent, self._follow_layer)

    def _follow_layer(self, *_) -> None:
        """Stay the layer above the main renderer's, which may move; none in a GL2PS export.

        PyVista's ``add_background_image`` puts it on layer 2: the overlay drew under it.
        ``save_graphic`` (VTK's GL2PS exporter) crashed in the overlay's draw: the overlay
        is left out of the file, and that is said.
        """
        exporting = vtkOpenGLGL2PSHelper.GetInstance() is not None
        if self.renderer is not None:
            self.renderer.SetDraw(not exporting)
            if exporting and self.renderer.GetActors().GetNumberOfItems():
                warn_user("save_graphic (VTK's GL2PS export) cannot draw the volumes "
                          "pv_cubemarch composites over the scene (technique='cubemap', "
                          "'direct' with downsample > 1, frames under a frame budget): "
                          "they are left out of the file; plotter.screenshot() keeps them.")
        layer = self.main.GetLayer() + 1
        if self.renderer is not None and self.renderer.GetLayer() != layer:
            self.window.SetNumberOfLayers(max(self.window.GetNumberOfLayers(), layer + 1))
            self.renderer.SetLayer(layer)

    def _on_start(self, *_):
        # The main renderer's camera may have been replaced (link_views, a camera shared
        # between subplots): the overlay draws with the one the passes read. (A tiled
        # screenshot swaps in cameras of its own and puts them back: left to it.)
        camera = self.main.GetActiveCamera()
        if self.renderer.GetActiveCamera() is not camera and \
                tuple(self.window.GetTileScale()) == (1, 1):
            self.renderer.SetActiveCamera(camera)
        if any(self.users.values()):
            self.depth.ensure(self.window)
        self._sort_far_to_near()
        # The overlay's volumes blend straight alpha over the frame: colour by alpha, and
        # the frame's alpha as "over" (a + (1 - a) dst), as VTK's own translucent pass does,
        # whatever blending the main renderer's passes left (a transparent background's
        # alpha was squared).
        self.window.GetState().vtkglBlendFuncSeparate(SRC_ALPHA, ONE_MINUS_SRC_ALPHA, ONE,
                                                      ONE_MINUS_SRC_ALPHA)

    def _sort_far_to_near(self) -> None:
        """Draw the overlay's volumes farthest first, so nearer ones composite over them.

        Seen from the main renderer's camera; reordered in place (none leaves the overlay,
        so none releases its graphics resources).
        """
        sort_far_to_near(self.renderer, list(self.renderer.GetActors()),
                         self.main.GetActiveCamera().GetPosition())

    def remove_actor(self, actor) -> None:
        """Stop drawing ``actor`` (if the overlay still exists)."""
        if self.renderer is not None:
            self.renderer.RemoveActor(actor)

    def add_user(self, user, reads_depth: bool = False) -> None:
        """Keep the overlay while ``user`` needs it (and copy the depth if it reads it)."""
        self.users[user] = reads_depth

    def release_user(self, user) -> None:
        """``user`` is done; the overlay leaves the window with its last user."""
        self.users.pop(user, None)
        if not self.users and self.renderer is not None:
            self.renderer.RemoveObserver(self._tag)
            self.window.RemoveObserver(self._window_tag)
            self.window.RemoveRenderer(self.renderer)
            self.renderer = None


def scene_overlay(plotter) -> SceneOverlay:
    """The overlay of the plotter's renderer, made on first use (again after its last user left)."""
    return renderer_overlay(plotter.renderer)


def renderer_overlay(main) -> SceneOverlay:
    """The overlay of ``main`` (a PyVista renderer in its window), as :func:`scene_overlay`."""
    overlay = main.__dict__.get("_cubemarch_overlay")
    if overlay is None or overlay.renderer is None:
        overlay = SceneOverlay(main)
        main.__dict__["_cubemarch_overlay"] = overlay
    return overlay


def bounds_proxy(model, bounds=None) -> pyvista.Actor:
    """An invisible prop spanning ``model``'s world box, for the plotter's own renderer.

    A volume drawn by the overlay is not among the plotter renderer's props, which
    ``reset_camera`` and the automatic clipping range look at; this prop stands in for it:
    the two corners of the box's world bounds as points whose fragments are discarded (an
    opaque prop, so it starts no translucency pass). A volume drawn by the overlay returns
    its proxy from ``add_volume``: the plotter knows it by name, and removing it removes
    the volume. ``bounds``: the part of the data's own frame it spans (by default all).
    """
    points = vtk.vtkPoints()
    points.SetDataTypeToDouble()   # corners far from the origin (1e6) kept to the digit
    points.SetNumberOfPoints(2)
    cells = vtk.vtkCellArray()
    for index in range(2):
        cells.InsertNextCell(1)
        cells.InsertCellPoint(index)
    corners = vtk.vtkPolyData()
    corners.SetPoints(points)
    corners.SetVerts(cells)
    mapper = vtk.vtkOpenGLPolyDataMapper()
    mapper.SetInputData(corners)
    proxy = pyvista.Actor()
    proxy.SetMapper(mapper)
    proxy.PickableOff()
    proxy.SetObjectName(PROXY_NAME)
    ShaderRecipe([Replacement("//VTK::Light::Impl", "discard_fragment", keep_tag="before")]
                 ).apply(proxy.GetShaderProperty())
    place_bounds_proxy(proxy, model, bounds)
    return proxy


def place_bounds_proxy(proxy, model, bounds=None) -> None:
    """Span ``model``'s box, as a mesh of its data placed by its ``transform`` would.

    The proxy's two points are the corners of the data's own bounds (before the
    ``transform``), and its ``user_matrix`` is the ``transform`` (position, orientation and
    scale none): PyVista's placement calls on it then move it as they move a mesh, and
    :meth:`~pv_cubemarch.gl.handle.Placement.follow_proxy_placement` moves the data along.
    A model with no ``transform`` spans its world bounds; ``bounds`` in its frame, if
    given, replace its own (what is drawn of it, where that is less than the whole grid).
    """
    if hasattr(model, "frame_bounds"):
        transform = np.asarray(model.transform, np.float64)
        bounds = model.frame_bounds() if bounds is None else bounds
    else:
        bounds, transform = model.world_bounds(), np.eye(4)
    corners = proxy.GetMapper().GetInput()
    corners.GetPoints().SetPoint(0, bounds[0], bounds[2], bounds[4])
    corners.GetPoints().SetPoint(1, bounds[1], bounds[3], bounds[5])
    corners.GetPoints().Modified()
    corners.Modified()
    place_by_user_matrix(proxy, transform)


def is_bounds_proxy(actor) -> bool:
    """Whether ``actor`` is a :func:`bounds_proxy`."""
    return actor is not None and actor.GetObjectName() == PROXY_NAME
