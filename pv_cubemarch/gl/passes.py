"""Render-to-texture passes: full-screen fragment passes into float targets, run inside a frame."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from vtkmodules.vtkRenderingOpenGL2 import (
    vtkOpenGLFramebufferObject,
    vtkOpenGLQuadHelper,
    vtkOpenGLRenderUtilities,
    vtkTextureObject,
)

from ..core import vtk_classes as vtk
from ..core.frame_errors import observe
from .bindings import TextureUnitLedger, UniformSource, set_uniform
from .shaders import ShaderRecipe, watch_shader_errors
from .textures import Texture

# Render-target formats: components, GL internal format, bytes per texel.
TARGET_FORMATS = {
    "rgba32f": (4, 0x8814, 16),
    "rgba16f": (4, 0x881A, 8),
    "r32f": (1, 0x822E, 4),
}

_SCISSOR_TEST = 0x0C11   # GL_SCISSOR_TEST


class RenderToTexturePass:
    """A full-screen fragment pass into float textures, run inside a frame before props draw.

    The pass runs from the renderer's ``StartEvent`` (context current, nothing drawn yet), so
    actors of the same frame can sample :attr:`outputs`. It runs when :meth:`invalidate` was
    called (or every frame with ``every_frame=True``): a pass runs only when something needs it.

    Parameters
    ----------
    renderer : vtkRenderer
        Renderer whose frames host the pass.
    recipe : ShaderRecipe or None
        Its standalone fragment snippet must write every render target; ``None`` until
        :meth:`set_recipe` gives it (e.g. once the bindings decided the feature switches).
    size : tuple of int
        ``(width, height)`` of every target.
    targets : int or sequence of str
        Number of RGBA float32 render targets, or the format of each, from
        :data:`TARGET_FORMATS` (e.g. ``("rgba16f", "r32f")``: half-float colour and one
        float32 channel of depth), so a target costs only the bytes its contents need.
    every_frame : bool
        Run at every frame (for results that follow the camera).
    run_when : callable, optional
        Asked at each frame; the pass runs when it returns ``True`` (e.g. a light moved).
    grow_only : bool
        Keep the largest targets made so far and draw into their lower-left ``size``
        (:attr:`allocated` is what the textures hold), so a size that goes back and forth
        reallocates nothing.
    on_demand : bool
        Run only when :meth:`run_now` is called (from inside a frame), never by itself.
    """

    def __init__(self, renderer, recipe: ShaderRecipe | None,
                 size: tuple[int, int] | Callable[[], tuple[int, int]],
                 targets: int | Sequence[str] = 1,
                 every_frame: bool = False, run_when: Callable[[], bool] | None = None,
                 grow_only: bool = False, on_demand: bool = False):
        self.renderer = renderer
        self.recipe = recipe
        self._size_source = size if callable(size) else None
        self.size = tuple(int(v) for v in (size() if callable(size) else size))
        self.grow_only = grow_only
        self.allocated = (0, 0) if grow_only else self.size
        self.allocations = 0
        self.formats = (("rgba32f",) * int(targets) if isinstance(targets, (int, np.integer))
                        else tuple(targets))
        unknown = [f for f in self.formats if f not in TARGET_FORMATS]
        if unknown or not self.formats:
            raise ValueError(f"Render target formats must be some of {list(TARGET_FORMATS)}, "
                             f"got {targets!r}.")
        self.n_targets = len(self.formats)
        self.every_frame = every_frame
        self.run_when = run_when
        self.textures: dict[str, Texture] = {}
        self.uniforms: dict[str, UniformSource] = {}
        #: ``(x, y, width, height)`` of the targets to draw, lower-left origin; None: all.
        #: The rest keeps what an earlier run drew.
        self.region: tuple[int, int, int, int] | None = None
        self.outputs: list[vtkTextureObject] = []
        self.runs = 0
        self._needed = True
        self._fbo = self._quad = None
        self._fragment = recipe.fragment_source() if recipe is not None else None
        self._vertex = vtkOpenGLRenderUtilities.GetFullScreenQuadVertexShader()
        self._tag = None if on_demand else observe(renderer, vtk.vtkCommand.StartEvent,
                                                   self._on_start)

    def run_now(self) -> bool:
        """Run at once (the context current: inside a frame); whether it drew."""
        self._needed = True
        runs = self.runs
        self._on_start()
        return self.runs > runs

    def invalidate(self) -> None:
        """Ask for the pass to run at the next frame."""
        self._needed = True

    def set_recipe(self, recipe: ShaderRecipe) -> None:
        """Use another fragment recipe (e.g. once its feature switches are known)."""
        self.recipe = recipe
        self._fragment = recipe.fragment_source()
        self._quad = None
        self._needed = True

    def add_texture(self, sampler: str, texture) -> None:
        """Bind ``texture`` to the sampler ``sampler`` whenever the pass runs.

        The pass does not own it: whoever made it frees it (a volume's data, a light map).
        """
        self.textures[sampler] = texture

    def set_uniform(self, name: str, value: UniformSource) -> None:
        """Give the uniform ``name`` this value (or callable) whenever the pass runs."""
        self.uniforms[name] = value

    @property
    def nbytes(self) -> int:
        """GPU bytes of the render targets."""
        return self.allocated[0] * self.allocated[1] * sum(self.target_nbytes(i)
                                                 for i in range(self.n_targets))

    def target_nbytes(self, target: int) -> int:
        """GPU bytes per texel of render target ``target``."""
        return TARGET_FORMATS[self.formats[target]][2]

    def _create(self, window) -> None:
        self.allocated = tuple(max(1, int(v)) for v in self.allocated)
        for name in self.formats:
            components, internal_format, _ = TARGET_FORMATS[name]
            target = vtkTextureObject()
            target.SetContext(window)
            target.SetInternalFormat(internal_format)
            target.Allocate2D(self.allocated[0], self.allocated[1], components, vtk.VTK_FLOAT)
            target.SetMinificationFilter(vtkTextureObject.Linear)
            target.SetMagnificationFilter(vtkTextureObject.Linear)
            self.outputs.append(target)
        self.allocations += 1
        self._fbo = vtkOpenGLFramebufferObject()
        self._fbo.SetContext(window)
        with watch_shader_errors(self.recipe.snippet_names):
            self._quad = vtkOpenGLQuadHelper(window, self._vertex, self._fragment, "")

    def _on_start(self, *_):
        asked = self.run_when() if self.run_when is not None else False
        if not (self._needed or self.every_frame or asked):
            return
        window = self.renderer.GetRenderWindow()
        TextureUnitLedger.release_window(window)  # between draws: the last one is over
        if self._size_source is not None:
            wanted = tuple(max(1, int(v)) for v in self._size_source())
            fits = all(w <= a for w, a in zip(wanted, self.allocated, strict=True))
            needed = tuple(max(w, a) for w, a in zip(wanted, self.allocated, strict=True)) \
                if self.grow_only else wanted
            if self._fbo is not None and (needed != self.allocated if not self.grow_only
                                          else not fits):
                self._release_targets(window)
            if self._fbo is None:
                self.allocated = needed
            self.size = wanted
        if self._fbo is None:
            self._create(window)
        elif self._quad is None:
            with watch_shader_errors(self.recipe.snippet_names):
                self._quad = vtkOpenGLQuadHelper(window, self._vertex, self._fragment, "")
        state = window.GetState()
        state.Push()  # viewport, scissor, blending: the renderer's draw continues after us
        state.PushFramebufferBindings()
        active = []
        try:
            self._fbo.Bind()
            for index, target in enumerate(self.outputs):
                self._fbo.AddColorAttachment(index, target)
            self._fbo.ActivateDrawBuffers(self.n_targets)
            # Start() wants the attachments' size (else VTK logs "FBO size does not match"
            # each run); a grow-only pass then draws into its lower-left ``size`` only
            self._fbo.Start(*self.allocated)
            if tuple(self.size) != tuple(self.allocated):
                state.vtkglViewport(0, 0, *self.size)
            if self.region is not None:
                state.vtkglEnable(_SCISSOR_TEST)
                state.vtkglScissor(*(int(v) for v in self.region))
            program = window.GetShaderCache().ReadyShaderProgram(self._vertex, self._fragment, "")
            if program is None:
                return
            for sampler, texture in self.textures.items():
                gl_object = texture.ensure(window)
                gl_object.Activate()
                active.append(gl_object)
                program.SetUniformi(sampler, gl_object.GetTextureUnit())
            for name, value in self.uniforms.items():
                set_uniform(program, name, value() if callable(value) else value)
            self._quad.Render()
        finally:
            for gl_object in active:
                gl_object.Deactivate()
            state.PopFramebufferBindings()
            state.Pop()
        self._needed = False
        self.runs += 1

    def output(self, target: int = 0) -> PassOutput:
        """Render target ``target`` as a texture that :class:`ShaderBindings` can bind."""
        if not 0 <= target < self.n_targets:
            raise IndexError(f"target must be in [0, {self.n_targets}), got {target}.")
        return PassOutput(self, target)

    def read(self, target: int = 0) -> np.ndarray:
        """Download target ``target`` as ``(height, width, components)`` float32.

        Its lower-left :attr:`size`, what the last run drew. The context must be live
        (e.g. in a render observer or after a frame).
        """
        width, height = self.allocated
        components = TARGET_FORMATS[self.formats[target]][0]
        out = np.zeros((height, width, components), dtype=np.float32)
        pixels = self.outputs[target].Download()
        if pixels is None or not pixels.Download2D(vtk.VTK_FLOAT, out, [width, height],
                                                   components, [0, 0]):
            raise RuntimeError("Reading the render target back failed.")
        return out[:self.size[1], :self.size[0]]

    def _release_targets(self, window) -> None:
        for target in self.outputs:
            target.ReleaseGraphicsResources(window)
        if self._fbo is not None:
            self._fbo.ReleaseGraphicsResources(window)
        self.outputs.clear()
        self._fbo = self._quad = None

    def release(self) -> None:
        """Free the targets and stop running."""
        self._release_targets(self.renderer.GetRenderWindow())
        if self._tag is not None:
            self.renderer.RemoveObserver(self._tag)
            self._tag = None


class PassOutput:
    """One render target of a :class:`RenderToTexturePass`, bindable like a :class:`Texture`.

    The pass owns the GL texture; binding it never uploads anything.
    """

    kind = "2d"

    def __init__(self, render_pass: RenderToTexturePass, target: int):
        self.render_pass = render_pass
        self.target = target

    @property
    def nbytes(self) -> int:
        """Counted once, by the pass."""
        return 0

    def ensure(self, window) -> vtkTextureObject:
        """The pass's target (created by the pass at the start of this frame)."""
        if not self.render_pass.outputs:
            self.render_pass._create(window)
        return self.render_pass.outputs[self.target]

    def release(self) -> None:
        """Nothing to free: the pass frees its targets."""

