"""Box actors that draw a technique's rays, and the camera uniforms of screen-space rays.

A box actor is a grid's bounding box placed in the world by a user matrix, drawing only
its back faces (interior faces, seen from inside or outside), in the translucent pass so
the frame's opaque depth is complete when it draws. A mirroring placement (negative
determinant) reverses the winding on screen, so the culled side follows the determinant.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from contextlib import contextmanager

import numpy as np
import pyvista

from ..core import vtk_classes as vtk

#: The point array of a box's corners' moves outward (see :func:`box_polydata`).
GROW = "cm_grow"
#: ``vtkOpenGLVertexBufferObject``'s shift-only method (its enum is not wrapped).
AUTO_SHIFT = 4


def numpy_matrix(matrix) -> np.ndarray:
    """A ``vtkMatrix4x4`` as a numpy array."""
    return np.array([[matrix.GetElement(i, j) for j in range(4)] for i in range(4)])


_GL_VIEWPORT = 0x0BA2
_GL_DRAW_FRAMEBUFFER_BINDING = 0x8CA6


def render_pass_of(renderer, class_name: str):
    """The pass of VTK class ``class_name`` drawing ``renderer``, or None.

    Followed through the passes' delegates (PyVista chains its passes so).
    """
    render_pass = renderer.GetPass()
    while render_pass is not None:
        if render_pass.IsA(class_name):
            return render_pass
        render_pass = render_pass.GetDelegatePass() \
            if hasattr(render_pass, "GetDelegatePass") else None
    return None


def supersampling_pass(renderer):
    """The ``vtkSSAAPass`` drawing ``renderer`` (PyVista's ``enable_anti_aliasing('ssaa')``)."""
    return render_pass_of(renderer, "vtkSSAAPass")


def supersampled_size(renderer) -> tuple[int, int] | None:
    """The size a ``vtkSSAAPass`` draws ``renderer``'s props at; None without one.

    It draws them into its own framebuffer, from the origin, sqrt(5) times the renderer's
    size (its tile's part in a tiled screenshot; truncated, as VTK computes it), then
    filters that down into the window.
    """
    if supersampling_pass(renderer) is None:
        return None
    width, height = drawn_viewport(renderer)[2:]   # a tile's part while VTK tiles
    return int(width * math.sqrt(5.0)), int(height * math.sqrt(5.0))


def props_size(renderer) -> tuple[int, int]:
    """The pixels ``renderer``'s props are drawn at: its size, or a supersampled one."""
    return supersampled_size(renderer) or tuple(drawn_viewport(renderer)[2:])


#: Viewports a draw of ours into its own target set for the fragments (the innermost last).
_drawing_at: list[tuple[int, int, int, int]] = []


@contextmanager
def drawing_at(viewport: tuple[int, int, int, int]):
    """Within: :func:`fragment_viewport` is ``viewport`` (a prop drawn into our target)."""
    _drawing_at.append(tuple(int(v) for v in viewport))
    try:
        yield
    finally:
        _drawing_at.pop()


def drawing_reduced() -> bool:
    """Whether a prop is being drawn into a target of ours (:func:`drawing_at`)."""
    return bool(_drawing_at)


def fragment_viewport(renderer) -> tuple[int, int, int, int]:
    """The viewport of ``gl_FragCoord`` while ``renderer``'s props draw.

    :func:`framebuffer_viewport`, except in a draw into a target of ours
    (:func:`drawing_at`).
    """
    if _drawing_at:
        return _drawing_at[-1]
    return peeling_viewport_now(renderer) or framebuffer_viewport(renderer)


def peeling_viewport_now(renderer) -> tuple[int, int, int, int] | None:
    """The viewport of VTK's depth peeling framebuffer, while it draws translucent props.

    With ``enable_depth_peeling()`` (and no pass of PyVista's) the renderer peels its
    translucent props in a framebuffer of its own, from its origin: a subplot's fragments
    lie there, not at its place in the window. (The scene's depth is still the window's:
    :func:`framebuffer_viewport`.) None otherwise.
    """
    if not renderer.GetUseDepthPeeling() or render_pass_of(renderer, "vtkRenderPass"):
        return None
    viewport = _viewport_off_window(renderer.GetRenderWindow())
    # VTK's peeling framebuffer holds the renderer's props from its origin, at its size;
    # another viewport is a framebuffer of ours (a cube map's atlas, drawn at the overlay's
    # start), in which the renderer's own viewport is meant
    size = tuple(drawn_viewport(renderer)[2:])
    return viewport if viewport == (0, 0, *size) else None


def _viewport_off_window(window) -> tuple[int, int, int, int] | None:
    """The viewport set now, while a framebuffer other than the window's is bound.

    That is a VTK pass's own, for drawing; None while the window's is bound.
    """
    framebuffer = window.GetRenderFramebuffer() if window is not None else None
    if framebuffer is None or drawing_framebuffer(window) == framebuffer.GetFBOIndex():
        return None
    viewport = [0, 0, 0, 0]
    window.GetState().vtkglGetIntegerv(_GL_VIEWPORT, viewport)
    return tuple(int(v) for v in viewport)


def framebuffer_viewport(renderer) -> tuple[int, int, int, int]:
    """The renderer's viewport in the framebuffer VTK draws it into (its depth's texels).

    :func:`drawn_viewport`, except inside a render pass of VTK's own framebuffer
    (:func:`pass_viewport_now`: supersampling, eye-dome lighting, SSAO).
    """
    return pass_viewport_now(renderer) or drawn_viewport(renderer)


def drawing_framebuffer(window) -> int:
    """The GL name of the framebuffer bound for drawing now."""
    name = [0]
    window.GetState().vtkglGetIntegerv(_GL_DRAW_FRAMEBUFFER_BINDING, name)
    return int(name[0])


def pass_viewport_now(renderer) -> tuple[int, int, int, int] | None:
    """The viewport set now in the framebuffer of a VTK pass drawing ``renderer``'s props.

    PyVista's supersampling (``vtkSSAAPass``), eye-dome lighting (``vtkEDLShading``) and
    SSAO (``vtkSSAOPass``) draw the props into a framebuffer of their own, from its
    origin, then composite it into the window's: the scene's depth is read from, and
    ``gl_FragCoord`` lies in, that framebuffer then. None while the window's framebuffer
    is bound for drawing, in a draw of ours (:func:`drawing_at`), or where the viewport
    set is not the pass's. Asked while the renderer draws (a shader's uniforms, a pass
    within the frame).
    """
    if _drawing_at or render_pass_of(renderer, "vtkRenderPass") is None:
        return None
    viewport = _viewport_off_window(renderer.GetRenderWindow())
    # the pass's framebuffer holds the renderer's props from its origin: its size that of
    # the renderer (the supersampled size under vtkSSAAPass); another viewport is a
    # framebuffer of ours (a cube map's atlas ...), in which the renderer's is meant
    size = supersampled_size(renderer) or tuple(drawn_viewport(renderer)[2:])
    return (0, 0, *size) if viewport == (0, 0, *size) else None


def drawn_viewport(renderer) -> tuple[int, int, int, int]:
    """``(x, y, width, height)`` in window pixels of what the renderer draws this pass.

    The renderer's own origin and size, except while VTK renders a large image in tiles
    (``screenshot(scale=N)``): then the renderer reports the whole image's size while each
    pass draws one tile of the window, with the camera's window centre moved to that tile.
    """
    window = renderer.GetRenderWindow()
    if window is None or tuple(window.GetTileScale()) == (1, 1):
        return (*(int(v) for v in renderer.GetOrigin()), *(int(v) for v in renderer.GetSize()))
    # the tile covers [t0, t2] x [t1, t3] of the whole image and fills the window
    t0, t1, t2, t3 = window.GetTileViewport()
    v0, v1, v2, v3 = renderer.GetViewport()
    width, height = window.GetActualSize()

    def pixel(value, low, high, size):
        return int(round((min(max(value, low), high) - low) / (high - low) * size))

    x, y = pixel(v0, t0, t2, width), pixel(v1, t1, t3, height)
    # a tile outside the renderer draws none of it: one pixel keeps matrices finite
    return (x, y, max(1, pixel(v2, t0, t2, width) - x), max(1, pixel(v3, t1, t3, height) - y))


def camera_matrices(renderer) -> tuple[np.ndarray, np.ndarray]:
    """The renderer's view and projection matrices (world to view, view to clip).

    Made once per camera state and viewport, however many volumes and passes ask.
    """
    camera = renderer.GetActiveCamera()
    width, height = drawn_viewport(renderer)[2:]
    key = (camera.GetAddressAsString("vtkObject"), camera.GetMTime(), width, height)
    cached = renderer.__dict__.get("_cubemarch_camera")
    if cached is not None and cached[0] == key:
        return cached[1]
    aspect = width / max(height, 1)
    view = numpy_matrix(camera.GetModelViewTransformMatrix())
    projection = numpy_matrix(camera.GetProjectionTransformMatrix(aspect, -1.0, 1.0))
    inverses = np.linalg.inv(np.stack([view, projection]))
    for matrix in (view, projection, inverses):
        matrix.flags.writeable = False
    renderer.__dict__["_cubemarch_camera"] = (key, (view, projection), inverses)
    return view, projection


def inverse_camera_matrices(renderer) -> np.ndarray:
    """``(2, 4, 4)``: the inverses of :func:`camera_matrices`, made with them, read-only."""
    camera_matrices(renderer)
    return renderer.__dict__["_cubemarch_camera"][2]


def box_actor(upper, world_from_index: np.ndarray, margin: float = 0.0,
              lower=(0.0, 0.0, 0.0)) -> pyvista.Actor:
    """The box ``[lower, upper]`` (index space) placed by ``world_from_index``, back faces.

    ``margin`` grows the drawn box on every side (index units): rasterisation covers a
    pixel whose centre is a hair inside the box's silhouette only when the edge is a
    sub-pixel step away, so a technique that clips its rays to the exact box in the shader
    draws a slightly larger box and loses no grazing pixel. The box's points stay exact
    (its bounds are the data's); the vertex shader grows it (``box_grow_vertex``).
    """
    mapper = vtk.vtkOpenGLPolyDataMapper()
    mapper.SetInputData(box_polydata(lower, upper, margin))
    mapper.MapDataArrayToVertexAttribute(GROW, GROW, vtk.vtkDataObject.FIELD_ASSOCIATION_POINTS,
                                         -1)
    # its points moved to the origin only (VTK's AUTO_SHIFT), never scaled: the corners'
    # moves are in the box's own units (a grid at 1e6 keeps its precision by the shift)
    mapper.SetVBOShiftScaleMethod(AUTO_SHIFT)
    actor = pyvista.Actor()
    actor.SetMapper(mapper)
    actor.ForceTranslucentOn()
    place_box(actor, world_from_index)
    return actor


def box_polydata(lower, upper, margin: float = 0.0) -> pyvista.PolyData:
    """The triangles of the box ``[lower, upper]``, to be drawn grown by ``margin``.

    Each corner's move outward is its point array ``cm_grow`` (index units, as the
    points), which the box actor's vertex shader adds: the points, and so the actor's
    bounds, stay the box's own.
    """
    lo, hi = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    box = pyvista.Box(bounds=(lo[0], hi[0], lo[1], hi[1], lo[2], hi[2])).triangulate()
    outward = np.where(np.asarray(box.points) > (lo + hi) / 2.0, 1.0, -1.0)
    box.point_data[GROW] = outward * float(margin)
    return box


def place_by_user_matrix(prop, matrix: np.ndarray) -> None:
    """Place ``prop`` by ``matrix`` alone: its ``user_matrix``, no position or turn.

    What PyVista's placement calls change afterwards is then read back from the prop.
    """
    prop.SetPosition(0.0, 0.0, 0.0)
    prop.SetOrientation(0.0, 0.0, 0.0)
    prop.SetScale(1.0, 1.0, 1.0)
    prop.SetOrigin(0.0, 0.0, 0.0)
    user = vtk.vtkMatrix4x4()
    user.DeepCopy(np.ascontiguousarray(matrix, dtype=np.float64).ravel().tolist())
    prop.SetUserMatrix(user)


def place_box(actor, world_from_index: np.ndarray, culling: bool = True,
              faces: str = "back") -> None:
    """Place an actor drawn in index space; the culled side follows the handedness.

    A placement with a negative determinant (negative spacing, a mirroring direction or
    transform) reverses the winding of every face on screen, so the faces GL sees as front
    faces are then the box's back faces. With ``culling``, only ``faces`` (``'back'``: the
    box actors; ``'front'``: a shell whose rays start where they meet it) are drawn. Called
    again when the placement changes.
    """
    matrix = vtk.vtkMatrix4x4()
    matrix.DeepCopy(np.ascontiguousarray(world_from_index, dtype=np.float64).ravel().tolist())
    actor.SetUserMatrix(matrix)
    if culling:
        cull(actor, world_from_index, faces)


def cull(actor, world_from_index: np.ndarray, faces: str) -> None:
    """Draw only the box's ``faces`` (``'back'`` or ``'front'``) under this placement."""
    mirrored = bool(np.linalg.det(np.asarray(world_from_index)[:3, :3]) < 0)
    cull_front = mirrored != (faces == "back")
    prop = actor.GetProperty()
    if (bool(prop.GetFrontfaceCulling()), bool(prop.GetBackfaceCulling())) != (
            cull_front, not cull_front):   # set only on a change (no new modified time)
        prop.SetFrontfaceCulling(cull_front)
        prop.SetBackfaceCulling(not cull_front)


def quads_polydata(points: np.ndarray, quads: np.ndarray) -> pyvista.PolyData:
    """Quads (``(n, 4)`` indices into ``points``) for a mapper, in few host bytes.

    float32 points and 32-bit connectivity: the mapper draws each quad as two triangles.
    """
    mesh = pyvista.PolyData()
    mesh.points = np.asarray(points, dtype=np.float32)
    cells = vtk.vtkCellArray()
    cells.Use32BitStorage()
    offsets = np.arange(0, 4 * len(quads) + 1, 4, dtype=np.int32)
    cells.SetData(_int32(offsets), _int32(np.asarray(quads, dtype=np.int32).ravel()))
    mesh.SetPolys(cells)
    return mesh


def _int32(values: np.ndarray):
    """A copy of int32 ``values`` in a vtkTypeInt32Array (what 32-bit cell arrays hold)."""
    array = vtk.vtkTypeInt32Array()
    array.SetNumberOfValues(len(values))
    if len(values):
        np.frombuffer(memoryview(array), dtype=np.int32)[:] = values
    return array


def near_plane_reaches(renderer, world_from_index: np.ndarray, lower, upper,
                       pad: float) -> bool:
    """Whether the near plane reaches the box ``[lower, upper]`` grown by ``pad``.

    Index space. False when every corner is deeper than the near plane: then every ray
    enters the box from outside and nothing of it is clipped by the near plane.
    """
    view = camera_matrices(renderer)[0]
    near = renderer.GetActiveCamera().GetClippingRange()[0]
    low = np.asarray(lower, dtype=np.float64) - pad
    high = np.asarray(upper, dtype=np.float64) + pad
    corners = np.array([[x, y, z, 1.0] for x in (low[0], high[0]) for y in (low[1], high[1])
                        for z in (low[2], high[2])]).T
    depths = -(view @ np.asarray(world_from_index, dtype=np.float64) @ corners)[2]
    return bool(depths.min() <= near)


def kept_inverse() -> Callable[[np.ndarray], np.ndarray]:
    """A function giving a matrix's inverse, kept while it is given the same matrix.

    A placement rarely changes, and is asked for at every draw.
    """
    held: list = [None, None]

    def inverse(matrix: np.ndarray) -> np.ndarray:
        if held[0] is None or not np.array_equal(held[0], matrix):
            held[:] = [np.array(matrix, dtype=np.float64), np.linalg.inv(matrix)]
        return held[1]

    return inverse


def bind_camera(target, renderer, world_from_texture: Callable[[], np.ndarray]) -> None:
    """Per-frame camera uniforms of the screen-ray code, for a binding or a pass.

    ``world_from_texture`` gives the technique's texture-to-world matrix at draw time.
    """
    placement_inverse = kept_inverse()
    target.set_uniform("cm_textureFromView", lambda: placement_inverse(world_from_texture())
                       @ inverse_camera_matrices(renderer)[0])
    target.set_uniform("cm_inverseProjection", lambda: inverse_camera_matrices(renderer)[1])
    target.set_uniform("cm_projection", lambda: camera_matrices(renderer)[1])
    target.set_uniform("cm_viewport", lambda: fragment_viewport(renderer))
