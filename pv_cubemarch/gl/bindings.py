"""Per-draw binding: textures and uniforms given to a mapper's shader program at each draw.

A technique describes *what* to bind; this module is the only place that binds.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import vtk
from vtkmodules.util.misc import calldata_type
from vtkmodules.vtkRenderingOpenGL2 import vtkTextureObject

from .shaders import ShaderRecipe
from .textures import Texture

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


