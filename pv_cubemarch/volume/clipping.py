"""Volumetric clipping planes and crop box, read from the volume's mapper as VTK sets them.

``pl.add_volume_clip_plane(vol)`` and ``vol.mapper.AddClippingPlane(plane)`` put
``vtkPlane`` objects on the returned volume's mapper; a plane keeps the points ``x`` with
``normal . (x - origin) >= 0`` (VTK's side); ``mapper.SetCropping(True)`` with
``SetCroppingRegionPlanes`` keeps a box of the data's coordinates. Every frame the volume
reads them and its marchers cut each ray to the kept interval (``clip_planes.glsl``); the
shaders carry the planes only while there are some, and the light map is marched again
when they move.
"""

from __future__ import annotations

import numpy as np

from ..core import vtk_classes as vtk
from ..gl.bindings import FloatArray

#: VTK's limit: a mapper takes at most six clipping planes.
MAX_CLIP_PLANES = 6


def clip_plane_list(numbers) -> list:
    """``vtkPlane`` objects from six numbers each, checked.

    Each plane is a point, then the normal to the side kept; at most
    :data:`MAX_CLIP_PLANES`, finite, normals not zero.
    """
    if numbers is None:
        return []
    try:
        values = np.asarray(numbers, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise ValueError(f"clip_planes must be numbers, six a plane (a point, then the "
                         f"normal to the side kept), got {numbers!r}.") from None
    if values.size == 0 or values.size % 6 or values.size > 6 * MAX_CLIP_PLANES:
        raise ValueError(f"clip_planes takes six numbers a plane (a point, then the normal to "
                         f"the side kept), 1 to {MAX_CLIP_PLANES} planes; got "
                         f"{values.size} numbers.")
    planes = []
    for origin, normal in values.reshape(-1, 2, 3):
        if not (np.isfinite(origin).all() and np.isfinite(normal).all()
                and np.linalg.norm(normal) > 0):
            raise ValueError(f"clip_planes: the plane at {origin.tolist()} with normal "
                             f"{normal.tolist()} needs finite numbers and a normal that is "
                             "not zero.")
        plane = vtk.vtkPlane()
        plane.SetOrigin(*origin)
        plane.SetNormal(*normal)
        planes.append(plane)
    return planes


def plane_pairs(numbers) -> tuple:
    """``clip_planes=`` (six numbers a plane, or None) as world ``(origin, normal)`` pairs."""
    return tuple((tuple(p.GetOrigin()), tuple(p.GetNormal())) for p in clip_plane_list(numbers))


def plane_numbers(numbers) -> tuple[float, ...] | None:
    """``clip_planes=`` as a flat tuple of floats, checked as :func:`clip_plane_list` does."""
    if numbers is None:
        return None
    clip_plane_list(numbers)
    return tuple(float(v) for v in np.asarray(numbers, dtype=np.float64).ravel())


def set_crop_box(mapper, box) -> None:
    """Crop ``mapper``'s volume to ``box`` (six numbers, the data's coordinates), checked."""
    values = checked_crop_box(box)
    mapper.SetCropping(True)
    mapper.SetCroppingRegionPlanes(*values)
    mapper.SetCroppingRegionFlagsToSubVolume()


def checked_crop_box(box) -> np.ndarray:
    """``box`` as six finite floats, each min below its max (else a ValueError naming it)."""
    try:
        values = np.asarray(box, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        values = np.zeros(0)
    if values.size != 6 or not np.isfinite(values).all() or np.any(values[1::2] <= values[::2]):
        raise ValueError(f"crop_box takes six finite numbers, (xmin, xmax, ymin, ymax, zmin, "
                         f"zmax) in the data's coordinates, each min below its max; got "
                         f"{box!r}.")
    return values


def world_planes(mapper) -> tuple[tuple[tuple[float, ...], tuple[float, ...]], ...]:
    """The ``(origin, normal)`` of each clipping plane on ``mapper``, in world coordinates."""
    collection = mapper.GetClippingPlanes() if mapper is not None else None
    if collection is None:
        return ()
    planes = []
    for index in range(collection.GetNumberOfItems()):
        plane = collection.GetItem(index)
        planes.append((tuple(plane.GetOrigin()), tuple(plane.GetNormal())))
    if len(planes) > MAX_CLIP_PLANES:
        raise ValueError(f"The volume's mapper holds {len(planes)} clipping planes; VTK and "
                         f"pv_cubemarch take at most {MAX_CLIP_PLANES}. Remove some "
                         "(mapper.RemoveClippingPlane).")
    return tuple(planes)


def crop_planes(mapper, transform) -> tuple[tuple[tuple[float, ...], tuple[float, ...]], ...]:
    """The six world planes of the mapper's crop box (``SetCropping``), or none.

    VTK's cropping region planes are in the data's coordinates (before the volume's
    ``transform``), axis-aligned there (a grid's direction matrix does not turn them; VTK's
    own crop of such a grid matched neither reading); the default region flags keep the box
    between them, which is what is drawn. Other flags keep a non-convex union of the 27
    regions: refused.
    """
    if mapper is None or not mapper.GetCropping():
        return ()
    if mapper.GetCroppingRegionFlags() != vtk.VTK_CROP_SUBVOLUME:
        raise ValueError(
            f"The volume's mapper crops with region flags {mapper.GetCroppingRegionFlags():#x}"
            "; pv_cubemarch draws only the sub-volume between the cropping planes "
            "(mapper.SetCroppingRegionFlagsToSubVolume()), or use clipping planes.")
    return box_planes(mapper.GetCroppingRegionPlanes(), transform)


def data_transform(model):
    """Where ``model``'s data coordinates (a crop box's) lie in the world: its ``transform``.

    A group's (a channel volume's, volumes marched jointly) when its members share one;
    None (the world's) when they differ.
    """
    if hasattr(model, "shared_transform"):
        return model.shared_transform()
    return getattr(model, "transform", None)


def crop_keeps_nothing(box, model) -> bool:
    """Whether the crop ``box`` (the data's coordinates) misses ``model``'s box entirely."""
    bounds = np.asarray(model.world_bounds(), dtype=np.float64).reshape(3, 2)
    corners = np.array(np.meshgrid(*bounds, indexing="ij")).reshape(3, -1).T
    transform = data_transform(model)
    if transform is not None:   # the world box's corners in the data's coordinates
        inverse = np.linalg.inv(np.asarray(transform, dtype=np.float64))
        corners = corners @ inverse[:3, :3].T + inverse[:3, 3]
    low, high = corners.min(axis=0), corners.max(axis=0)
    box = np.asarray(box, dtype=np.float64).ravel()
    return bool(np.any(box[1::2] < low) or np.any(box[::2] > high))


def box_planes(box, transform) -> tuple[tuple[tuple[float, ...], tuple[float, ...]], ...]:
    """The six world ``(origin, normal)`` planes keeping ``box`` (xmin, xmax, ... zmax).

    ``box`` is in the data's coordinates, which ``transform`` places in the world.
    """
    bounds = np.asarray(box, dtype=np.float64).ravel()
    matrix = np.asarray(transform, dtype=np.float64)
    inverse_t = np.linalg.inv(matrix[:3, :3]).T
    planes = []
    for axis in range(3):
        for side, sign in ((0, 1.0), (1, -1.0)):
            origin = np.zeros(3)
            origin[axis] = bounds[2 * axis + side]
            normal = np.zeros(3)
            normal[axis] = sign
            world_normal = inverse_t @ normal
            planes.append((tuple(matrix[:3, :3] @ origin + matrix[:3, 3]),
                           tuple(world_normal / np.linalg.norm(world_normal))))
    return tuple(planes)


def texture_planes(planes, world_from_texture: np.ndarray) -> np.ndarray:
    """``(n, 4)`` planes of texture space: ``p`` is kept where ``plane . (p, 1) >= 0``.

    A world plane ``(normal, -normal . origin)`` pulled back through ``world_from_texture``
    (in double precision: far from the origin its terms cancel), scaled to unit length so
    the shader's single-precision sums stay in range.
    """
    rows = []
    for origin, normal in planes:
        normal = np.asarray(normal, dtype=np.float64)
        world = np.append(normal, -normal @ np.asarray(origin, dtype=np.float64))
        local = world @ np.asarray(world_from_texture, dtype=np.float64)
        scale = np.linalg.norm(local[:3])
        rows.append(local / scale if scale > 0 else local)
    return np.asarray(rows, dtype=np.float64).reshape(-1, 4)


class ClipState:
    """One volume's clipping planes as its marchers read them (shared by all its passes)."""

    def __init__(self):
        self.planes: tuple = ()

    def follow(self, mapper, transform=None) -> tuple[bool, bool]:
        """Read the planes (and crop box) of ``mapper``; return (count changed, any changed).

        ``transform``: the volume's placement of its data coordinates, where the crop box is.
        """
        planes = world_planes(mapper) + crop_planes(
            mapper, np.eye(4) if transform is None else transform)
        count_changed = len(planes) != len(self.planes)
        changed = planes != self.planes
        self.planes = planes
        return count_changed, changed

    def uniform(self, world_from_texture: np.ndarray) -> FloatArray:
        """The ``cm_clipPlanes`` floats (4 per plane)."""
        return FloatArray(texture_planes(self.planes, world_from_texture).ravel())

    @property
    def defines(self) -> dict:
        """The switch of the marchers: ``CM_CLIP_PLANES`` = the number of planes, or off."""
        return {"CM_CLIP_PLANES": len(self.planes) or None}
