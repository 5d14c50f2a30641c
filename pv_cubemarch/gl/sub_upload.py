"""GL calls VTK's Python wrapping lacks: partial 2D and 3D uploads, error flags, float readback.

The function is looked up by ``ctypes`` through the window system whose context is current
(OSMesa, EGL or GLX: the one VTK renders with) and called while VTK has the context current
and the texture bound. Where none gives it, callers upload the whole texture.
"""

from __future__ import annotations

import ctypes
import ctypes.util
from functools import cache

import numpy as np

from ..core.array_copy import copy_tiled

GL_TEXTURE_3D = 0x806F
GL_TEXTURE_2D = 0x0DE1
GL_RED = 0x1903
#: Pixel formats by components (red, red-green, RGB, RGBA).
GL_FORMATS = {1: GL_RED, 2: 0x8227, 3: 0x1907, 4: 0x1908}
GL_UNPACK_ALIGNMENT = 0x0CF5
#: Unpack state a tight block needs at 0 (VTK may leave row lengths set from its uploads).
GL_UNPACK_ZEROED = (0x0CF2, 0x0CF3, 0x0CF4, 0x806E, 0x806D)   # row length, skips, height
GL_TYPES = {np.dtype(np.uint8): 0x1401, np.dtype(np.uint16): 0x1403,
            np.dtype(np.float32): 0x1406}

_SUB_IMAGE = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                              ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                              ctypes.c_uint, ctypes.c_uint, ctypes.c_void_p)
_SUB_IMAGE_2D = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                                 ctypes.c_int, ctypes.c_int, ctypes.c_uint, ctypes.c_uint,
                                 ctypes.c_void_p)
_PIXEL_STORE = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_int)
_GET_ERROR = ctypes.CFUNCTYPE(ctypes.c_uint)
_GET_INTEGER = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.POINTER(ctypes.c_int))
_READ_PIXELS = ctypes.CFUNCTYPE(None, ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                                ctypes.c_uint, ctypes.c_uint, ctypes.c_void_p)
GL_FLOAT = 0x1406
GL_PACK_ALIGNMENT = 0x0D05
GL_PACK_ZEROED = (0x0D02, 0x0D03, 0x0D04)   # pack row length, skip rows, skip pixels
GL_OUT_OF_MEMORY = 0x0505


#: Window systems VTK may render with: library, its "current context" and lookup functions.
WINDOW_SYSTEMS = (("OSMesa", "OSMesaGetCurrentContext", "OSMesaGetProcAddress"),
                  ("EGL", "eglGetCurrentContext", "eglGetProcAddress"),
                  ("GL", "glXGetCurrentContext", "glXGetProcAddressARB"))


@cache
def _system(library: str, current: str, lookup: str):
    """``(has_current_context, (sub_image, pixel_store, get_error, read_pixels))``.

    Of one window system: its library's current-context test and GL functions.

    ``None`` where the library or a function is missing.
    """
    path = ctypes.util.find_library(library)
    if path is None:
        return None
    try:
        loaded = ctypes.CDLL(path)
        is_current, get = getattr(loaded, current), getattr(loaded, lookup)
    except (OSError, AttributeError):
        return None
    is_current.restype = ctypes.c_void_p
    get.restype = ctypes.c_void_p
    get.argtypes = [ctypes.c_char_p]
    sub, store, error = get(b"glTexSubImage3D"), get(b"glPixelStorei"), get(b"glGetError")
    read, sub_2d = get(b"glReadPixels"), get(b"glTexSubImage2D")
    integer = get(b"glGetIntegerv")
    if not (sub and store and error and read and sub_2d and integer):
        return None
    return is_current, (_SUB_IMAGE(sub), _PIXEL_STORE(store), _GET_ERROR(error),
                        _READ_PIXELS(read), _SUB_IMAGE_2D(sub_2d), _GET_INTEGER(integer))


def _unpack_alignment(functions) -> int:
    """The context's GL_UNPACK_ALIGNMENT now, restored after our uploads.

    VTK's whole uploads read rows with it (1: rows of any number of bytes).
    """
    value = ctypes.c_int(4)
    functions[5](GL_UNPACK_ALIGNMENT, ctypes.byref(value))
    return int(value.value)


def _gl_functions() -> tuple | None:
    """The GL functions of the window system whose context is current now, if any."""
    for system in WINDOW_SYSTEMS:
        found = _system(*system)
        if found is not None and found[0]():
            return found[1]
    return None


def sub_image_available() -> bool:
    """Whether partial 3D uploads can be made here: a window system that gives them."""
    return any(_system(*system) is not None for system in WINDOW_SYSTEMS)


def sub_image_3d(origin: tuple[int, int, int], block: np.ndarray) -> None:
    """Upload ``block`` ((x, y, z), one component) at ``origin`` of the bound 3D texture.

    The texture must be bound to ``GL_TEXTURE_3D`` with its context current.
    """
    functions = _gl_functions()
    if functions is None:
        raise RuntimeError("No current OpenGL context with glTexSubImage3D; upload the "
                           "whole texture.")
    sub, store = functions[:2]
    data = x_fastest(block)
    alignment = _unpack_alignment(functions)
    store(GL_UNPACK_ALIGNMENT, 1)
    for name in GL_UNPACK_ZEROED:
        store(name, 0)
    sub(GL_TEXTURE_3D, 0, int(origin[0]), int(origin[1]), int(origin[2]), block.shape[0],
        block.shape[1], block.shape[2], GL_RED, GL_TYPES[np.dtype(block.dtype)],
        data.ctypes.data)
    # as it was (seen: 4 restored where VTK had 1, and a uint8 texture uploaded whole
    # afterwards, rows of 6 bytes, read as rows of 8: garbled)
    store(GL_UNPACK_ALIGNMENT, alignment)


def sub_image_2d(origin: tuple[int, int], block: np.ndarray) -> None:
    """Upload ``block`` ``(rows, columns[, components])`` at ``origin`` ``(column, row)``.

    Into the texture bound to ``GL_TEXTURE_2D``, its context current.
    """
    functions = _gl_functions()
    if functions is None:
        raise RuntimeError("No current OpenGL context with glTexSubImage2D; upload the "
                           "whole texture.")
    store, sub = functions[1], functions[4]
    data = np.ascontiguousarray(block)
    components = 1 if data.ndim == 2 else int(data.shape[2])
    alignment = _unpack_alignment(functions)
    store(GL_UNPACK_ALIGNMENT, 1)
    for name in GL_UNPACK_ZEROED:
        store(name, 0)
    sub(GL_TEXTURE_2D, 0, int(origin[0]), int(origin[1]), data.shape[1], data.shape[0],
        GL_FORMATS[components], GL_TYPES[np.dtype(data.dtype)], data.ctypes.data)
    store(GL_UNPACK_ALIGNMENT, alignment)


def pending_gl_errors() -> list[int]:
    """The GL error flags set in the current context since they were last read (cleared).

    Empty where no window system gives ``glGetError``. VTK's uploads report success even when
    the driver refused the memory (``GL_OUT_OF_MEMORY``): the caller reads the flags around
    an upload to know.
    """
    functions = _gl_functions()
    if functions is None:
        return []
    errors = []
    for _ in range(16):   # one flag per error kind at most
        code = int(functions[2]())
        if code == 0:
            break
        errors.append(code)
    return errors


def read_red_floats(width: int, height: int) -> np.ndarray | None:
    """The red channel of the bound read framebuffer as float32 ``(height, width)``.

    Row 0 is the bottom row (GL's order). ``None`` where no window system gives the GL
    functions.
    """
    functions = _gl_functions()
    if functions is None:
        return None
    store, read = functions[1], functions[3]
    for name in GL_PACK_ZEROED:
        store(name, 0)
    store(GL_PACK_ALIGNMENT, 4)
    out = np.empty((int(height), int(width)), np.float32)
    read(0, 0, int(width), int(height), GL_RED, GL_FLOAT, out.ctypes.data)
    return out


def x_fastest(array: np.ndarray) -> np.ndarray:
    """A 3D ``(x, y, z, ...)`` array in VTK's upload order, x fastest (``(z, y, x)`` C order).

    No copy when it already is (Fortran-ordered grids, as PyVista's, and level atlases);
    otherwise copied by cubes (:func:`~pv_cubemarch.core.array_copy.copy_tiled`).
    """
    moved = np.moveaxis(array, (0, 1, 2), (2, 1, 0))
    if moved.flags.c_contiguous:
        return moved
    out = np.empty(moved.shape, moved.dtype)
    copy_tiled(out, moved)
    return out
