"""GL resources, written once: textures from numpy, per-draw binding, render-to-texture passes.

Everything here creates GL objects lazily, inside a draw, when VTK has made the context
current; a technique describes *what* to bind and never writes binding code itself.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import vtk
from vtkmodules.util.misc import calldata_type
from vtkmodules.vtkRenderingOpenGL2 import (
    vtkOpenGLFramebufferObject,
    vtkOpenGLQuadHelper,
    vtkOpenGLRenderUtilities,
    vtkOpenGLVertexBufferObject,
    vtkTextureObject,
)

from .shaders import ShaderRecipe, watch_shader_errors

_VTK_TYPES = {np.dtype(np.float32): vtk.VTK_FLOAT, np.dtype(np.uint8): vtk.VTK_UNSIGNED_CHAR}


class Texture:
    """A numpy array that becomes a ``vtkTextureObject`` the first time it is drawn.

    Parameters
    ----------
    array : numpy.ndarray
        ``kind='2d'``: ``(height, width[, components])``; ``kind='3d'``: ``(nx, ny, nz[, c])``
        indexed x, y, z; ``kind='buffer'``: a flat float array read with ``texelFetch``.
        float32 and uint8 are uploaded as they are; other dtypes are converted to float32.
    kind : str
        ``'2d'``, ``'3d'`` or ``'buffer'``.
    interpolate : bool
        Linear filtering (``True``) or nearest (``False``); ignored for buffers.
    """

    def __init__(self, array: np.ndarray, kind: str = "2d", interpolate: bool = True):
        if kind not in ("2d", "3d", "buffer"):
            raise ValueError(f"kind must be '2d', '3d' or 'buffer', got {kind!r}.")
        self.kind = kind
        self.interpolate = interpolate
        self.gl_object: vtkTextureObject | None = None
        self._buffer: vtkOpenGLVertexBufferObject | None = None
        self._window = None
        self.upload_count = 0
        self.set_data(array)

    def set_data(self, array: np.ndarray) -> None:
        """Replace the data; it is uploaded again at the next draw."""
        array = np.asarray(array)
        if array.dtype not in _VTK_TYPES or self.kind == "buffer":
            array = array.astype(np.float32)
        expected = {"2d": (2, 3), "3d": (3, 4), "buffer": (1,)}[self.kind]
        if array.ndim not in expected:
            raise ValueError(f"A {self.kind} texture needs an array with {expected} axes, "
                             f"got shape {array.shape}.")
        self.array = array
        self._dirty = True

    @property
    def components(self) -> int:
        """Components per texel."""
        spatial = {"2d": 2, "3d": 3, "buffer": 1}[self.kind]
        return 1 if self.array.ndim == spatial else int(self.array.shape[-1])

    @property
    def nbytes(self) -> int:
        """Bytes the texture occupies on the GPU (uncompressed)."""
        return int(self.array.nbytes)

    def ensure(self, window) -> vtkTextureObject:
        """Create or refresh the GL texture for ``window``; needs the context current."""
        if self.gl_object is not None and self._window is window and not self._dirty:
            return self.gl_object
        if self.gl_object is not None and self._window is not window:
            self.release()
        vtk_type = _VTK_TYPES[self.array.dtype]
        texture = self.gl_object or vtkTextureObject()
        texture.SetContext(window)
        shape, ncomp = self.array.shape, self.components
        if self.kind == "2d":
            data = np.ascontiguousarray(self.array)
            ok = texture.Create2DFromRaw(shape[1], shape[0], ncomp, vtk_type, data)
        elif self.kind == "3d":
            # VTK wants (z, y, x) C order, i.e. x fastest: Fortran order of (x, y, z).
            data = np.ascontiguousarray(np.moveaxis(self.array, (0, 1, 2), (2, 1, 0)))
            ok = texture.Create3DFromRaw(shape[0], shape[1], shape[2], ncomp, vtk_type, data)
        else:
            from vtkmodules.util.numpy_support import numpy_to_vtk

            buffer = self._buffer or vtkOpenGLVertexBufferObject()
            buffer.SetDataType(vtk.VTK_FLOAT)
            self._vtk_array = numpy_to_vtk(np.ascontiguousarray(self.array), deep=True)
            buffer.UploadDataArray(self._vtk_array)
            self._buffer = buffer
            ok = texture.CreateTextureBuffer(self.array.size, 1, vtk.VTK_FLOAT, buffer)
        if not ok:
            raise RuntimeError(f"Uploading a {self.kind} texture of shape {shape} failed.")
        if self.kind != "buffer":
            mode = vtkTextureObject.Linear if self.interpolate else vtkTextureObject.Nearest
            texture.SetMinificationFilter(mode)
            texture.SetMagnificationFilter(mode)
            for setter in ("SetWrapS", "SetWrapT", "SetWrapR"):
                getattr(texture, setter)(vtkTextureObject.ClampToEdge)
        self.gl_object, self._window, self._dirty = texture, window, False
        self.upload_count += 1
        return texture

    def release(self) -> None:
        """Free the GL objects (safe to call twice, or with no context left)."""
        if self.gl_object is not None and self._window is not None:
            self.gl_object.ReleaseGraphicsResources(self._window)
            if self._buffer is not None:
                self._buffer.ReleaseGraphicsResources()
        self.gl_object, self._buffer, self._window = None, None, None
        self._dirty = True


UniformValue = float | int | tuple | list | np.ndarray
UniformSource = UniformValue | Callable[[], UniformValue]


def set_uniform(program, name: str, value: Any) -> None:
    """Set a float/vec/mat4 (or int) uniform on a ``vtkShaderProgram`` by its value's shape."""
    if isinstance(value, (bool, int, np.integer)):
        program.SetUniformi(name, int(value))
        return
    array = np.asarray(value, dtype=np.float64)
    if array.shape == ():
        program.SetUniformf(name, float(array))
    elif array.shape in ((2,), (3,), (4,)):
        getattr(program, f"SetUniform{array.size}f")(name, [float(v) for v in array])
    elif array.shape in ((4, 4), (3, 3)):
        # vtkShaderProgram uploads a vtkMatrix row by row where GL expects columns, so the
        # transpose goes in and GLSL reads M * v with the usual column-vector meaning.
        matrix = vtk.vtkMatrix4x4() if array.shape == (4, 4) else vtk.vtkMatrix3x3()
        matrix.DeepCopy(array.T.ravel().tolist())
        program.SetUniformMatrix(name, matrix)
    else:
        raise ValueError(f"Uniform {name!r}: unsupported value shape {array.shape}.")


class ShaderBindings:
    """Textures and uniforms given to one mapper's shader program at every draw.

    Observes the mapper's ``UpdateShaderEvent`` (fired with the program bound) and the
    renderer's ``EndEvent`` (to free the texture units). Values may be callables,
    evaluated at draw time (e.g. a matrix that follows the camera).
    """

    def __init__(self, mapper, renderer, recipe: ShaderRecipe | None = None):
        self.mapper = mapper
        self.renderer = renderer
        self.recipe = recipe
        self.textures: dict[str, Texture] = {}
        self.uniforms: dict[str, UniformSource] = {}
        self.frames_started = 0
        self.frames_bound = 0
        self._bound_this_frame = False
        self._missed = False
        self._active: list[vtkTextureObject] = []
        on_update = calldata_type(vtk.VTK_OBJECT)(
            lambda caller, event, program: self._on_update(program))
        self._observers = [
            (mapper, mapper.AddObserver(vtk.vtkCommand.UpdateShaderEvent, on_update)),
            (renderer, renderer.AddObserver(vtk.vtkCommand.StartEvent, self._on_start)),
            (renderer, renderer.AddObserver(vtk.vtkCommand.EndEvent, self._on_end)),
            (mapper, mapper.AddObserver(vtk.vtkCommand.VolumeMapperRenderEndEvent,
                                        self._on_volume_drawn)),
        ]

    def add_texture(self, sampler: str, texture: Texture) -> Texture:
        """Bind ``texture`` to the GLSL sampler ``sampler`` at every draw."""
        self.textures[sampler] = texture
        return texture

    def set_uniform(self, name: str, value: UniformSource) -> None:
        """Give the GLSL uniform ``name`` this value (or callable) at every draw."""
        self.uniforms[name] = value

    @property
    def missed_last_frame(self) -> bool:
        """Whether the last frame drew the prop without our bindings.

        VTK's volume mapper skips ``UpdateShaderEvent`` on a frame where it rebuilds its
        shader; such a frame must be drawn again (see :func:`pv_cubemarch.render_frame`).
        """
        return self._missed

    def _on_volume_drawn(self, *_):
        if not self._bound_this_frame:
            self._missed = True

    @property
    def nbytes(self) -> int:
        """GPU bytes held by the textures."""
        return sum(t.nbytes for t in self.textures.values())

    def _on_start(self, *_):
        self.frames_started += 1
        self._bound_this_frame = False
        self._missed = False

    def _on_update(self, program):
        if program is None:
            return
        window = self.renderer.GetRenderWindow()
        for sampler, texture in self.textures.items():
            gl_object = texture.ensure(window)
            gl_object.Activate()
            self._active.append(gl_object)
            program.SetUniformi(sampler, gl_object.GetTextureUnit())
        for name, value in self.uniforms.items():
            set_uniform(program, name, value() if callable(value) else value)
        self._bound_this_frame = True
        self.frames_bound += 1

    def _on_end(self, *_):
        for gl_object in self._active:
            gl_object.Deactivate()
        self._active.clear()

    def release(self) -> None:
        """Free the textures and stop observing."""
        self._on_end()
        for texture in self.textures.values():
            texture.release()
        for subject, tag in self._observers:
            subject.RemoveObserver(tag)
        self._observers.clear()


# Render-target formats: components, GL internal format, bytes per texel.
TARGET_FORMATS = {
    "rgba32f": (4, 0x8814, 16),
    "rgba16f": (4, 0x881A, 8),
    "r32f": (1, 0x822E, 4),
}


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
    """

    def __init__(self, renderer, recipe: ShaderRecipe | None,
                 size: tuple[int, int] | Callable[[], tuple[int, int]],
                 targets: int | Sequence[str] = 1,
                 every_frame: bool = False, run_when: Callable[[], bool] | None = None):
        self.renderer = renderer
        self.recipe = recipe
        self._size_source = size if callable(size) else None
        self.size = tuple(int(v) for v in (size() if callable(size) else size))
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
        self.outputs: list[vtkTextureObject] = []
        self.runs = 0
        self._needed = True
        self._fbo = self._quad = None
        self._fragment = recipe.fragment_source() if recipe is not None else None
        self._vertex = vtkOpenGLRenderUtilities.GetFullScreenQuadVertexShader()
        self._tag = renderer.AddObserver(vtk.vtkCommand.StartEvent, self._on_start)

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
        """Bind ``texture`` to the sampler ``sampler`` whenever the pass runs."""
        self.textures[sampler] = texture

    def set_uniform(self, name: str, value: UniformSource) -> None:
        """Give the uniform ``name`` this value (or callable) whenever the pass runs."""
        self.uniforms[name] = value

    @property
    def nbytes(self) -> int:
        """GPU bytes of the render targets."""
        return self.size[0] * self.size[1] * sum(self.target_nbytes(i)
                                                 for i in range(self.n_targets))

    def target_nbytes(self, target: int) -> int:
        """GPU bytes per texel of render target ``target``."""
        return TARGET_FORMATS[self.formats[target]][2]

    def _create(self, window) -> None:
        for name in self.formats:
            components, internal_format, _ = TARGET_FORMATS[name]
            target = vtkTextureObject()
            target.SetContext(window)
            target.SetInternalFormat(internal_format)
            target.Allocate2D(self.size[0], self.size[1], components, vtk.VTK_FLOAT)
            target.SetMinificationFilter(vtkTextureObject.Linear)
            target.SetMagnificationFilter(vtkTextureObject.Linear)
            self.outputs.append(target)
        self._fbo = vtkOpenGLFramebufferObject()
        self._fbo.SetContext(window)
        with watch_shader_errors(self.recipe.snippet_names):
            self._quad = vtkOpenGLQuadHelper(window, self._vertex, self._fragment, "")

    def _on_start(self, *_):
        asked = self.run_when() if self.run_when is not None else False
        if not (self._needed or self.every_frame or asked):
            return
        window = self.renderer.GetRenderWindow()
        if self._size_source is not None:
            wanted = tuple(max(1, int(v)) for v in self._size_source())
            if wanted != self.size and self._fbo is not None:
                self._release_targets(window)
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
            self._fbo.Start(*self.size)
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

        The context must be live (e.g. in a render observer or after a frame).
        """
        width, height = self.size
        components = TARGET_FORMATS[self.formats[target]][0]
        out = np.zeros((height, width, components), dtype=np.float32)
        pixels = self.outputs[target].Download()
        if pixels is None or not pixels.Download2D(vtk.VTK_FLOAT, out, [width, height],
                                                   components, [0, 0]):
            raise RuntimeError("Reading the render target back failed.")
        return out

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
        for texture in self.textures.values():
            texture.release()
        self.renderer.RemoveObserver(self._tag)


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
