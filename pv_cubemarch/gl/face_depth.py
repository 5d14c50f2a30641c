"""A geometry pass: per pixel, the view depth of the nearest face of an actor's mesh.

Drawn into a float target at the start of a frame (context current, nothing drawn yet),
with the depth test keeping the nearest face; a technique's actor reads it to start its
rays there. The mesh's many small faces cost little in this pass, whose shader only writes
a depth, while the ray marching runs once per pixel on the technique's own large faces (a
rasteriser that shades 4x4 blocks, as llvmpipe, runs a long shader once per block a face
touches, so small faces with a long shader waste most of it).
"""

from __future__ import annotations

from collections.abc import Callable

from vtkmodules.vtkRenderingOpenGL2 import vtkOpenGLFramebufferObject, vtkTextureObject

from ..core import vtk_classes as vtk
from ..core.frame_errors import observe
from .bindings import TextureUnitLedger
from .box import props_size
from .sub_upload import read_red_floats

#: What the target holds where no face is drawn (farther than any depth).
NO_FACE = 1e30
_R32F = 0x822E
_DEPTH_AND_COLOR = 0x00000100 | 0x00004000
_COLOR = 0x00004000
_DEPTH_TEST, _BLEND, _LESS = 0x0B71, 0x0BE2, 0x0201


def start_nearest_draw(state, fbo, color, depth, size, clear) -> None:
    """Bind ``fbo`` with ``color`` and ``depth`` at ``size``, cleared, for the nearest face.

    The colour is cleared to ``clear``; the depth test keeps the nearest fragment, with
    blending off. Without ``depth`` (None), every fragment is kept. The caller pushes and
    pops the window's state and framebuffer bindings.
    """
    fbo.Bind()
    fbo.AddColorAttachment(0, color)
    if depth is not None:
        fbo.AddDepthAttachment(depth)
    fbo.ActivateDrawBuffers(1)
    fbo.Start(*size)
    state.vtkglClearColor(*clear)
    state.vtkglDisable(_BLEND)
    if depth is None:
        state.vtkglDisable(_DEPTH_TEST)
        state.vtkglClear(_COLOR)
        return
    state.vtkglClearDepth(1.0)
    state.vtkglDepthMask(True)
    state.vtkglEnable(_DEPTH_TEST)
    state.vtkglDepthFunc(_LESS)
    state.vtkglClear(_DEPTH_AND_COLOR)


class FaceDepthPass:
    """Draw ``actor`` (not in the renderer) into a float target at a frame's start.

    The actor's shader must write its fragment's view depth as red (e.g.
    ``voxel_shell_depth.glsl``); the target holds :data:`NO_FACE` elsewhere. ``used`` is
    asked at each frame: the pass draws when it returns ``True`` and the camera or the
    viewport changed since it last drew, or :meth:`invalidate` was called (the mesh or its
    placement changed); otherwise the target keeps the last drawing.
    """

    kind = "2d"

    def __init__(self, renderer, actor, used: Callable[[], bool]):
        self.renderer = renderer
        self.actor = actor
        self.used = used
        self._drawn_for = None   # the view the target holds
        self.runs = 0
        #: Read the target back after each drawing (into :attr:`depths`).
        self.read_back = False
        #: The last drawing's depths, ``(height, width)`` from the bottom row, when read.
        self.depths = None
        #: Called after the pass at every frame that uses it (drawn or kept).
        self.on_frame: Callable[[], None] | None = None
        self._target = self._depth = self._fbo = None
        self._size = (0, 0)
        self._tag = observe(renderer, vtk.vtkCommand.StartEvent, self._on_start)

    @property
    def nbytes(self) -> int:
        """GPU bytes: the float target and its depth buffer."""
        return self._size[0] * self._size[1] * 8

    def ensure(self, window) -> vtkTextureObject:
        """The target, as :class:`~pv_cubemarch.gl.bindings.ShaderBindings` binds textures."""
        if self._target is None:
            self._create(window, tuple(max(1, v) for v in props_size(self.renderer)))
        return self._target

    def _create(self, window, size: tuple[int, int]) -> None:
        self._release_targets(window)
        self._target = vtkTextureObject()
        self._target.SetContext(window)
        self._target.SetInternalFormat(_R32F)
        self._target.Allocate2D(size[0], size[1], 1, vtk.VTK_FLOAT)
        self._target.SetMinificationFilter(vtkTextureObject.Nearest)
        self._target.SetMagnificationFilter(vtkTextureObject.Nearest)
        self._depth = vtkTextureObject()
        self._depth.SetContext(window)
        self._depth.AllocateDepth(size[0], size[1], vtkTextureObject.Float32)
        self._fbo = vtkOpenGLFramebufferObject()
        self._fbo.SetContext(window)
        self._size = size

    def invalidate(self) -> None:
        """Draw again at the next frame that uses the pass."""
        self._drawn_for = None

    def _on_start(self, *_) -> None:
        if not self.used():
            return
        view = (self.renderer.GetActiveCamera().GetMTime(), props_size(self.renderer))
        if view != self._drawn_for:
            self._draw(view)
        if self.on_frame is not None:
            self.on_frame()

    def _draw(self, view) -> None:
        """Draw the actor's faces into the target (and read it back when asked)."""
        window = self.renderer.GetRenderWindow()
        TextureUnitLedger.release_window(window)
        size = tuple(max(1, v) for v in props_size(self.renderer))
        if self._fbo is None or size != self._size:
            self._create(window, size)
        self._drawn_for = view
        state = window.GetState()
        state.Push()
        state.PushFramebufferBindings()
        try:
            start_nearest_draw(state, self._fbo, self._target, self._depth, size,
                               (NO_FACE, 0.0, 0.0, 0.0))
            self.actor.RenderOpaqueGeometry(self.renderer)
            if self.read_back:
                self.depths = read_red_floats(*size)
        finally:
            state.PopFramebufferBindings()
            state.Pop()
        self.runs += 1

    def _release_targets(self, window) -> None:
        self._drawn_for = None   # a new target holds nothing yet
        self.depths = None
        for gl_object in (self._target, self._depth, self._fbo):
            if gl_object is not None:
                gl_object.ReleaseGraphicsResources(window)
        self._target = self._depth = self._fbo = None

    def release(self) -> None:
        """Free the target and stop running (safe to call twice)."""
        if self._tag is not None:
            self.renderer.RemoveObserver(self._tag)
            self._tag = None
        self._release_targets(self.renderer.GetRenderWindow())
