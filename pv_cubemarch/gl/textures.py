"""Textures from numpy: uploaded lazily, inside a draw, when VTK has made the context current."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from vtkmodules.util.numpy_support import numpy_to_vtk
from vtkmodules.vtkRenderingOpenGL2 import vtkOpenGLVertexBufferObject, vtkTextureObject

from ..core import vtk_classes as vtk
from ..core.errors import GpuLimitError
from .sub_upload import (
    GL_OUT_OF_MEMORY,
    pending_gl_errors,
    sub_image_2d,
    sub_image_3d,
    sub_image_available,
    x_fastest,
)

_VTK_TYPES = {np.dtype(np.float32): vtk.VTK_FLOAT, np.dtype(np.uint8): vtk.VTK_UNSIGNED_CHAR,
              np.dtype(np.uint16): vtk.VTK_UNSIGNED_SHORT}


#: GL's error flags by code, for the messages.
_GL_ERRORS = {0x500: "GL_INVALID_ENUM", 0x501: "GL_INVALID_VALUE",
              0x502: "GL_INVALID_OPERATION", 0x505: "GL_OUT_OF_MEMORY",
              0x506: "GL_INVALID_FRAMEBUFFER_OPERATION"}


class Texture:
    """A numpy array that becomes a ``vtkTextureObject`` the first time it is drawn.

    Parameters
    ----------
    array : numpy.ndarray
        ``kind='2d'``: ``(height, width[, components])``; ``kind='3d'``: ``(nx, ny, nz[, c])``
        indexed x, y, z; ``kind='buffer'``: a flat float array read with ``texelFetch``.
        float32, uint8 and uint16 are uploaded as they are; other dtypes are converted to float32.
    kind : str
        ``'2d'``, ``'3d'`` or ``'buffer'``.
    interpolate : bool
        Linear filtering (``True``) or nearest (``False``); ignored for buffers.
    rebuild : callable, optional
        Makes ``array`` again. Given, the host copy is dropped after each upload and rebuilt
        only if the texture must be uploaded again (a new window): for data derived from
        other data the host keeps anyway (occupancy levels from labels).
    """

    def __init__(self, array: np.ndarray, kind: str = "2d", interpolate: bool = True,
                 rebuild: Callable[[], np.ndarray] | None = None):
        if kind not in ("2d", "3d", "buffer"):
            raise ValueError(f"kind must be '2d', '3d' or 'buffer', got {kind!r}.")
        self.kind = kind
        self.interpolate = interpolate
        self.gl_object: vtkTextureObject | None = None
        self._buffer: vtkOpenGLVertexBufferObject | None = None
        self._window = None
        self.upload_count = 0
        #: Bytes sent to the GPU so far (whole uploads and regions).
        self.uploaded_bytes = 0
        self._regions: list[tuple[tuple[int, ...], np.ndarray]] = []
        self._layout = None   # (dtype, components) of the texture object's last upload
        self.rebuild = rebuild
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
        self.array: np.ndarray | None = array
        self._shape, self._nbytes = array.shape, int(array.nbytes)
        self._dtype = array.dtype
        self._dirty = True
        self._regions = []

    def set_interpolation(self, linear: bool) -> None:
        """Read between texels linearly or take the nearest, from the next draw (no upload)."""
        self.interpolate = bool(linear)
        if self.gl_object is not None and self.kind != "buffer":
            self._set_filters(self.gl_object)   # sent when it is next bound

    def invalidate(self) -> None:
        """Upload the whole texture again at the next draw (remade first, if rebuildable).

        For data changed in place: an array the texture shares, or what ``rebuild`` reads.
        """
        if self.rebuild is not None:
            self.array = None
        self._dirty = True
        self._regions = []

    def update_region(self, origin, block: np.ndarray) -> None:
        """Replace the texels ``block`` from ``origin`` on.

        3D textures of one component: ``block`` ``(x, y, z)`` at ``origin`` ``(i, j, k)``;
        2D textures: ``block`` ``(rows, columns[, components])`` at ``origin`` ``(row,
        column)``, as the array indexes. Uploaded at the next draw as that region alone
        (``glTexSubImage2D/3D``), or the whole texture where partial uploads are not
        reachable. The host copy, if held, follows.
        """
        block = np.asarray(block)
        origin = tuple(int(v) for v in origin)
        spatial = {"2d": 2, "3d": 3}.get(self.kind)
        if spatial is None or len(origin) != spatial or block.shape[spatial:] != tuple(
                self._shape[spatial:]) or (self.kind == "3d" and len(self._shape) != 3):
            raise ValueError("update_region takes a 2D block of a 2D texture (its components) "
                             "or a 3D block of a one-component 3D texture.")
        if any(o < 0 or o + n > m
               for o, n, m in zip(origin, block.shape, self._shape, strict=False)):
            raise ValueError(f"A block of {block.shape} at {origin} leaves the texture "
                             f"{self._shape}.")
        region = tuple(slice(o, o + n) for o, n in zip(origin, block.shape, strict=False))
        if self.array is not None:
            self.array[region] = block
        if self.gl_object is None or self._dirty:
            return   # a whole upload is coming anyway
        if not sub_image_available():
            self._dirty = True
            return
        dtype = self.array.dtype if self.array is not None else np.dtype(self._dtype)
        self._regions.append((origin, block.astype(dtype, copy=True)))

    @property
    def components(self) -> int:
        """Components per texel."""
        spatial = {"2d": 2, "3d": 3, "buffer": 1}[self.kind]
        return 1 if len(self._shape) == spatial else int(self._shape[-1])

    @property
    def nbytes(self) -> int:
        """Bytes the texture occupies on the GPU (uncompressed)."""
        return self._nbytes

    @property
    def host_nbytes(self) -> int:
        """Bytes of the host copy held now (0 once a rebuildable texture is uploaded)."""
        return 0 if self.array is None else int(self.array.nbytes)

    def ensure(self, window) -> vtkTextureObject:
        """Create or refresh the GL texture for ``window``; needs the context current."""
        if self.gl_object is not None and self._window is window and not self._dirty:
            try:
                if self._regions:
                    # bound on a unit of its own: binding it on the active unit would take
                    # that unit from the texture activated there (seen: a transfer table
                    # read from a brick pool sub-uploaded after it, frames drawn dark)
                    self.gl_object.Activate()
                for origin, block in self._regions:
                    if self.kind == "3d":
                        sub_image_3d(origin, block)
                    else:   # GL's origin is (x, y): (column, row)
                        sub_image_2d((origin[1], origin[0]), block)
                    self.uploaded_bytes += int(block.nbytes)
                if self._regions:
                    self.gl_object.Deactivate()
                self._regions = []
                return self.gl_object
            except RuntimeError:   # no partial uploads with this context: upload it whole
                self.invalidate()
        if self.array is None:
            self.set_data(self.rebuild())   # dropped after the last upload
        layout = (self.array.dtype, self.components)
        if self.gl_object is not None and (self._window is not window
                                           or layout != self._layout):
            # Another window, or another texel format (e.g. labels widened to uint16): a
            # reused texture object keeps its old internal format (seen: uint16 labels read
            # as GL_R8), so a new one is made.
            self.release()
        self._layout = layout
        vtk_type = _VTK_TYPES[self.array.dtype]
        pending_gl_errors()   # older flags are not this upload's
        texture = self.gl_object or vtkTextureObject()
        texture.SetContext(window)
        shape, ncomp = self.array.shape, self.components
        if self.kind == "2d":
            data = np.ascontiguousarray(self.array)
            ok = texture.Create2DFromRaw(shape[1], shape[0], ncomp, vtk_type, data)
        elif self.kind == "3d":
            # VTK wants (z, y, x) C order, i.e. x fastest: Fortran order of (x, y, z).
            data = x_fastest(self.array)
            ok = texture.Create3DFromRaw(shape[0], shape[1], shape[2], ncomp, vtk_type, data)
        else:
            buffer = self._buffer or vtkOpenGLVertexBufferObject()
            buffer.SetDataType(vtk.VTK_FLOAT)
            self._vtk_array = numpy_to_vtk(np.ascontiguousarray(self.array), deep=True)
            buffer.UploadDataArray(self._vtk_array)
            self._buffer = buffer
            ok = texture.CreateTextureBuffer(self.array.size, 1, vtk.VTK_FLOAT, buffer)
        if not ok:
            raise RuntimeError(f"Uploading a {self.kind} texture of shape {shape} failed.")
        errors = pending_gl_errors()
        if errors and GL_OUT_OF_MEMORY not in errors:   # VTK said yes; GL said no
            texture.ReleaseGraphicsResources(window)
            names = ", ".join(_GL_ERRORS.get(code, hex(code)) for code in errors)
            raise GpuLimitError(f"GL refused a {self.kind} texture of shape {shape} ({names}): "
                               "it is past this GL's limits (GL_MAX_TEXTURE_SIZE, "
                               "GL_MAX_3D_TEXTURE_SIZE: pv-cubemarch info --gl); draw less "
                               "of it or a coarser copy.")
        if errors:   # VTK said yes; the driver has no room
            texture.ReleaseGraphicsResources(window)
            raise MemoryError(f"The GPU (or its driver) has no room for a {self.kind} texture "
                              f"of shape {shape} ({self.array.nbytes / 2**20:.0f} MiB): draw "
                              "it in smaller pieces (add_voxels(..., chunk_size=128)) or "
                              "downsample it.")
        if self.kind != "buffer":
            self._set_filters(texture)
            for setter in ("SetWrapS", "SetWrapT", "SetWrapR"):
                getattr(texture, setter)(vtkTextureObject.ClampToEdge)
        self.gl_object, self._window, self._dirty = texture, window, False
        self._regions = []
        self.upload_count += 1
        self.uploaded_bytes += int(self.array.nbytes)
        if self.rebuild is not None:
            self.array = None   # the GPU holds it; rebuilt if it must go up again
        return texture

    def _set_filters(self, texture) -> None:
        mode = vtkTextureObject.Linear if self.interpolate else vtkTextureObject.Nearest
        texture.SetMinificationFilter(mode)
        texture.SetMagnificationFilter(mode)

    def release(self) -> None:
        """Free the GL objects (safe to call twice, or with no context left)."""
        if self.gl_object is not None and self._window is not None:
            self.gl_object.ReleaseGraphicsResources(self._window)
            if self._buffer is not None:
                self._buffer.ReleaseGraphicsResources()
        self.gl_object, self._buffer, self._window = None, None, None
        self._dirty = True


