"""Per-draw binding: textures and uniforms given to a mapper's shader program at each draw.

A technique describes *what* to bind; this module is the only place that binds.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
from vtkmodules.vtkRenderingOpenGL2 import vtkTextureObject

from ..core import vtk_classes as vtk
from ..core.frame_errors import observe
from .box import render_pass_of
from .frame_inputs import frame_inputs
from .shaders import ShaderRecipe
from .textures import Texture

UniformValue = float | int | tuple | list | np.ndarray
UniformSource = UniformValue | Callable[[], UniformValue]


class FloatArray(tuple):
    """A uniform ``float name[N]`` (a plain tuple of 2-4 numbers is a vec2-vec4)."""


def set_uniform(program, name: str, value: Any) -> None:
    """Set a float/vec/mat4 (or int) uniform on a ``vtkShaderProgram`` by its value's shape."""
    if isinstance(value, FloatArray):
        if value:   # an empty array is a feature compiled out: nothing to set
            program.SetUniform1fv(name, len(value), [float(v) for v in value])
        return
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


def _same(held, value) -> bool:
    """Whether ``value`` is what ``held`` was set from: the same read-only array, or equal."""
    if held is value:
        return not isinstance(value, np.ndarray) or not value.flags.writeable
    if isinstance(value, np.ndarray) or isinstance(held, np.ndarray):
        return False
    return type(held) is type(value) and held == value


class ProgramUniforms:
    """What our bindings last set on each shader program in the current frame.

    The chunks of a world share one program (the same source): a value they all set
    alike (the projection, the lights, a constant) is set once a frame, not once a chunk.
    Keyed by program and renderer, valid within one frame of that renderer (a frame of
    another renderer, or the next, sets everything again): frames are told apart by
    their serial, never reused, as addresses of freed programs and renderers are.
    """

    _held: dict = {}

    @classmethod
    def of(cls, program, renderer, frame: int) -> dict:
        """The values set on ``program`` during ``frame`` (a serial) of ``renderer``."""
        key = (program.GetAddressAsString("vtkObject"),
               renderer.GetAddressAsString("vtkObject"))
        held = cls._held.get(key)
        if held is None or held[0] != frame:
            if len(cls._held) > 4096:   # programs and renderers long gone
                cls._held.clear()
            held = cls._held[key] = (frame, {})
        return held[1]


def under_ssao(renderer) -> bool:
    """Whether PyVista's SSAO pass draws ``renderer`` (asked once a frame)."""
    if renderer is None:
        return False
    return frame_inputs(renderer).per_frame(
        "ssao", lambda: render_pass_of(renderer, "vtkSSAOPass") is not None)


class TextureUnitLedger:
    """The texture units our bindings hold in one render window, released per draw.

    A binding activates its textures (each takes a texture unit) when its prop's shader is
    updated, just before the prop is drawn, and they must stay active through that draw.
    They are released as soon as the draw is over: at the volume mapper's
    ``VolumeMapperRenderEndEvent``, or, for polydata mappers (which fire no event after
    drawing), at the next of our bindings' or passes' activations in the same window,
    whichever comes first, and at the renderer's ``EndEvent`` at the latest. So one draw's
    textures are held at a time, whatever the number of props, and the window never runs
    out of units. One ledger per window, because units belong to the GL context.
    """

    _by_window: dict[str, TextureUnitLedger] = {}

    def __init__(self):
        self.held: list[vtkTextureObject] = []

    @classmethod
    def of(cls, window) -> TextureUnitLedger | None:
        """The ledger of ``window`` (``None`` without a window)."""
        if window is None:
            return None
        key = window.GetAddressAsString("vtkObject")
        ledger = cls._by_window.get(key)
        if ledger is None:
            ledger = cls._by_window[key] = cls()
        return ledger

    @classmethod
    def release_window(cls, window) -> None:
        """Free the units of ``window``'s last draw (the draw is over)."""
        if window is None:
            return
        ledger = cls._by_window.pop(window.GetAddressAsString("vtkObject"), None)
        if ledger is not None:
            ledger.release()

    def hold(self, texture: vtkTextureObject) -> None:
        """Activate ``texture`` for the draw about to happen (it takes a unit)."""
        texture.Activate()
        self.held.append(texture)

    def release(self) -> None:
        """Deactivate what the last draw held (its units go back to the window)."""
        for texture in self.held:
            texture.Deactivate()
        self.held.clear()


class ShaderBindings:
    """Textures and uniforms given to one mapper's shader program at every draw.

    Observes the mapper's ``UpdateShaderEvent`` (fired with the program bound, just before
    the draw); the texture units it takes are given back once that draw is over (see
    :class:`TextureUnitLedger`), so any number of props can be bound in one frame. Values
    may be callables, evaluated at draw time (e.g. a matrix that follows the camera).
    """

    def __init__(self, mapper, renderer, recipe: ShaderRecipe | None = None):
        self.mapper = mapper
        self.renderer = renderer
        self.recipe = recipe
        self.textures: dict[str, Texture] = {}
        self._owned: list = []
        self.uniforms: dict[str, UniformSource] = {}
        self.frames_started = 0
        self.frames_bound = 0
        self._bound_this_frame = False
        self._missed = False
        self._installed_on: tuple = ()   # the actors the recipe is installed on
        self._ssao = False               # whether it was installed with CM_SSAO
        self._observers = [
            (mapper, observe(mapper, vtk.vtkCommand.UpdateShaderEvent,
                             lambda caller, event, program: self._on_update(program),
                             calldata=vtk.VTK_OBJECT)),
            (renderer, observe(renderer, vtk.vtkCommand.StartEvent, self._on_start)),
            (renderer, observe(renderer, vtk.vtkCommand.EndEvent, self._on_end)),
            (mapper, observe(mapper, vtk.vtkCommand.VolumeMapperRenderEndEvent,
                             self._on_volume_drawn)),
        ]

    def install(self, recipe: ShaderRecipe, *actors) -> None:
        """Draw ``actors`` with ``recipe`` from the next frame (its shaders compile then).

        Under PyVista's SSAO (``enable_ssao()``) the recipe gains ``CM_SSAO``: a fragment
        then gives the pass its hit's position and normal (or, translucent, none of its
        own), not its box's face; the shaders are built again when SSAO comes or goes.
        """
        self.recipe = recipe
        self._installed_on = actors
        self._ssao = under_ssao(self.renderer)
        if self._ssao:
            recipe = replace(recipe, defines={**recipe.defines, "CM_SSAO": True})
        for actor in actors:
            recipe.apply(actor.GetShaderProperty())

    def add_texture(self, sampler: str, texture: Texture, owned: bool = False) -> Texture:
        """Bind ``texture`` to the GLSL sampler ``sampler`` at every draw.

        ``owned``: these bindings free it on :meth:`release`; a texture shared with other
        bindings (a volume's data, a pass's target, the frame's depth) is freed by its owner.
        """
        self.textures[sampler] = texture
        if owned:
            self._owned.append(texture)
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
        # The volume mapper has drawn: its textures' units are free again.
        TextureUnitLedger.release_window(self.renderer.GetRenderWindow())
        if not self._bound_this_frame:
            self._missed = True

    @property
    def nbytes(self) -> int:
        """GPU bytes held by the textures."""
        return sum(t.nbytes for t in self.textures.values())

    def _on_start(self, *_):
        if self.recipe is not None and self._installed_on \
                and under_ssao(self.renderer) != self._ssao:
            self.install(self.recipe, *self._installed_on)
        self.frames_started += 1
        self._bound_this_frame = False
        self._missed = False

    def _on_update(self, program):
        if program is None:
            return
        window = self.renderer.GetRenderWindow()
        ledger = TextureUnitLedger.of(window)
        ledger.release()  # the previous draw (ours or another binding's) is over
        for sampler, texture in self.textures.items():
            gl_object = texture.ensure(window)
            ledger.hold(gl_object)
            program.SetUniformi(sampler, gl_object.GetTextureUnit())
        held = ProgramUniforms.of(program, self.renderer, frame_inputs(self.renderer).serial)
        for name, value in self.uniforms.items():
            value = value() if callable(value) else value
            if name in held and _same(held[name], value):
                continue
            set_uniform(program, name, value)
            held[name] = value
        self._bound_this_frame = True
        self.frames_bound += 1

    def _on_end(self, *_):
        TextureUnitLedger.release_window(self.renderer.GetRenderWindow())

    def release(self) -> None:
        """Free the textures these bindings own and stop observing."""
        self._on_end()
        for texture in self._owned:
            texture.release()
        self._owned.clear()
        for subject, tag in self._observers:
            subject.RemoveObserver(tag)
        self._observers.clear()
