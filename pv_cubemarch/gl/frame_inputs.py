"""What the frame drawn so far holds, as textures a shader can read, decided per frame.

* :class:`SceneDepth`: a renderer's opaque depth (or colour) copied into a texture at most
  once per frame, shared by every volume and pass that reads it;
* :class:`FramebufferDepth`: the depth attachment VTK draws into, read in place (it may be
  multisampled);
* :func:`frame_inputs`: one :class:`FrameInputs` per renderer: the shared copy and, once
  per frame, whether the renderer draws opaque props;
* :class:`MultisamplePolicy`: the window's multisampling, turned off only on frames that
  draw something needing a single-sampled framebuffer, and given back to the user's
  setting otherwise.
"""

from __future__ import annotations

import itertools

from vtkmodules.vtkRenderingOpenGL2 import vtkTextureObject

from ..core import vtk_classes as vtk
from ..core.frame_errors import observe
from .box import drawing_framebuffer, drawn_viewport, pass_viewport_now

_GL_READ_FRAMEBUFFER = 0x8CA8


#: ``GetObjectName()`` of props that only stand in for a volume's bounds (they draw nothing).
PROXY_NAME = "pv_cubemarch bounds proxy"


class SceneDepth:
    """A renderer's depth (or colour) of this frame, copied into a texture on first use.

    :meth:`mark_stale` (at each frame's start) asks for a new copy; every binding that
    reads it in the frame then shares one copy. With ``each_use=True`` every use copies
    again (the colour under a volume changes as the volumes before it draw). The copy needs
    a single-sampled framebuffer (a multisampled one gives zeros).
    """

    kind = "2d"
    nbytes = 0

    def __init__(self, renderer, color: bool = False, each_use: bool = False):
        self.renderer = renderer
        self.color = color
        self.each_use = each_use
        self.gl_object: vtkTextureObject | None = None
        self.copies = 0
        self._stale = True
        self._size = None
        self._window = None

    def mark_stale(self, *_) -> None:
        """The frame moved on: the next :meth:`ensure` copies again."""
        self._stale = True

    def ensure(self, window) -> vtkTextureObject:
        """The texture holding this frame's depth (or colour), copied if not yet."""
        in_pass = pass_viewport_now(self.renderer)   # a VTK pass's framebuffer is bound
        x0, y0, width, height = in_pass or drawn_viewport(self.renderer)
        if self.gl_object is None or self._size != (width, height) or self._window is not window:
            self.release()
            self.gl_object = vtkTextureObject()
            self.gl_object.SetContext(window)
            if self.color:
                self.gl_object.Allocate2D(width, height, 4, vtk.VTK_UNSIGNED_CHAR)
            else:
                self.gl_object.AllocateDepth(width, height, vtkTextureObject.Float32)
            self.gl_object.SetMinificationFilter(vtkTextureObject.Nearest)
            self.gl_object.SetMagnificationFilter(vtkTextureObject.Nearest)
            self._size, self._window = (width, height), window
            self._stale = True
        if not (self._stale or self.each_use):
            return self.gl_object
        # Read from the framebuffer VTK draws this frame into (another may be bound for
        # reading between renderers).
        state = window.GetState()
        drawing = drawing_framebuffer(window) if in_pass is not None else None
        state.PushReadFramebufferBinding()
        try:
            if drawing is None:
                window.GetRenderFramebuffer().Bind(_GL_READ_FRAMEBUFFER)
            else:   # the pass's framebuffer, which VTK does not hand out
                state.vtkglBindFramebuffer(_GL_READ_FRAMEBUFFER, drawing)
            self.gl_object.CopyFromFrameBuffer(x0, y0, 0, 0, width, height)
        finally:
            state.PopReadFramebufferBinding()
        self._stale = False
        self.copies += 1
        return self.gl_object

    def release(self) -> None:
        """Free the texture."""
        if self.gl_object is not None and self._window is not None:
            self.gl_object.ReleaseGraphicsResources(self._window)
        self.gl_object = self._window = None


class FramebufferDepth:
    """The depth attachment VTK draws into, bound as is (multisampled or not).

    Read with ``texelFetch`` while nothing writes depth (a translucent pass, or a pass
    between renderers), so no copy is made.
    """

    kind = "2d"
    nbytes = 0

    def ensure(self, window) -> vtkTextureObject:
        """The current render framebuffer's depth texture."""
        return window.GetRenderFramebuffer().GetDepthAttachmentAsTextureObject()

    def release(self) -> None:
        """Nothing: VTK owns it."""


_SERIALS = itertools.count(1)


class FrameInputs:
    """Per renderer and frame: the shared depth copy, whether opaque props are drawn.

    Also values every binding of the frame shares (:meth:`per_frame`).
    """

    def __init__(self, renderer):
        self.renderer = renderer
        self.depth = SceneDepth(renderer)
        self._opaque = None
        #: The renderer's frames started so far (a tile of a large image is one).
        self.frame = 0
        #: This frame's number among every renderer's frames: never the same twice, in
        #: any plotter (a new renderer, even at a freed one's address, counts on). Drawn
        #: at once: made during a draw, the frame under way has a number of its own too
        #: (0 for all such was shared, and a program and renderer at freed ones' addresses
        #: found the uniforms a freed program held as set: a texture view drew zeros).
        self.serial = next(_SERIALS)
        self._per_frame: dict = {}
        # First among the renderer's observers: later ones see this frame's state.
        self._tag = observe(renderer, vtk.vtkCommand.StartEvent, self._on_start, 10.0)

    def _on_start(self, *_):
        self.depth.mark_stale()
        self._opaque = None
        self.frame += 1
        self.serial = next(_SERIALS)

    def per_frame(self, key: str, compute):
        """``compute()``, once per frame for ``key``: shared by every binding that asks.

        A world of many chunks sets the same lights on each chunk's shader: placed once.
        """
        held = self._per_frame.get(key)
        if held is None or held[0] != self.frame:
            held = self._per_frame[key] = (self.frame, compute())
        return held[1]

    def has_opaque_props(self) -> bool:
        """Whether the renderer draws an opaque prop that could stop rays (once per frame)."""
        if self._opaque is None:
            self._opaque = any(
                actor.GetVisibility() and actor.GetObjectName() != PROXY_NAME
                and not actor.HasTranslucentPolygonalGeometry()
                for actor in self.renderer.GetActors())
        return self._opaque

    def release(self) -> None:
        """Free the copy and stop observing."""
        self.depth.release()
        self.renderer.RemoveObserver(self._tag)


def frame_inputs(renderer) -> FrameInputs:
    """The :class:`FrameInputs` of ``renderer`` (a pyvista renderer), made on first use."""
    inputs = renderer.__dict__.get("_cubemarch_frame_inputs")
    if inputs is None:
        inputs = FrameInputs(renderer)
        renderer.__dict__["_cubemarch_frame_inputs"] = inputs
    return inputs


def release_frame_inputs(renderer) -> None:
    """Free ``renderer``'s :class:`FrameInputs` (its last volume left), if it has one."""
    inputs = renderer.__dict__.pop("_cubemarch_frame_inputs", None)
    if inputs is not None:
        inputs.release()


class MultisamplePolicy:
    """The window's multisampling, decided at the start of every frame.

    :meth:`decide` turns it off for a frame that draws something reading the depth as a
    single-sampled texture, and otherwise gives back the user's own setting (which it
    follows if the user changes it between frames).
    """

    def __init__(self, window):
        self.window = window
        self.user_samples = int(window.GetMultiSamples())
        self._set = None   # what we last set, to tell the user's changes from ours

    def decide(self, single_sample: bool) -> None:
        """Set the window's samples for this frame."""
        current = int(self.window.GetMultiSamples())
        if self._set is None or current != self._set:
            self.user_samples = current   # the user set it (or we never did)
        wanted = 0 if single_sample else self.user_samples
        if current != wanted:
            self.window.SetMultiSamples(wanted)
        self._set = wanted

    def restore(self) -> None:
        """Give the user's setting back (the plotter closes)."""
        if self._set is not None and int(self.window.GetMultiSamples()) == self._set:
            self.window.SetMultiSamples(self.user_samples)
        self._set = None
