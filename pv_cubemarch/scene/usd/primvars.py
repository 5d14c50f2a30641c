"""A mesh's polygons and its primvars of every interpolation, as PyVista data.

USD gives values per mesh (``constant``), per face (``uniform``), per point (``vertex``,
``varying``) or per face corner (``faceVarying``). VTK interpolates point data only, so a
mesh with any per-corner value we use is drawn *unwelded*: one point per face corner, every
value expanded to corners. Faces with fewer than three corners are dropped (and reported);
a left-handed mesh or a mirroring transform has its corners reversed, values with them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyvista
from pxr import UsdGeom

from .context import PrimError

CONSTANT, UNIFORM, VARYING, VERTEX, FACE_VARYING = (
    str(UsdGeom.Tokens.constant), str(UsdGeom.Tokens.uniform), str(UsdGeom.Tokens.varying),
    str(UsdGeom.Tokens.vertex), str(UsdGeom.Tokens.faceVarying))


@dataclass
class Polygons:
    """The faces we draw and where each face and corner came from in the authored arrays."""

    points: np.ndarray          # (n, 3) authored points
    counts: np.ndarray          # corners of each drawn face
    indices: np.ndarray         # point of each drawn corner
    face_source: np.ndarray     # authored face of each drawn face
    corner_source: np.ndarray   # authored corner of each drawn corner
    authored_faces: int
    authored_corners: int
    dropped: int = 0            # faces of fewer than 3 corners left out

    @property
    def face_of_corner(self) -> np.ndarray:
        """Drawn face of each drawn corner."""
        return np.repeat(np.arange(len(self.counts)), self.counts)


def read_polygons(points, counts, indices, reverse: bool, holes=()) -> Polygons:
    """Check the topology arrays and keep faces of three corners or more.

    ``reverse`` flips every face's corner order (left-handed meshes, mirroring transforms);
    the faces in ``holes`` (``holeIndices``) are left out.
    """
    points = vectors(points, "points")
    counts = np.asarray(counts, dtype=np.int64).ravel()
    indices = np.asarray(indices, dtype=np.int64).ravel()
    if counts.size and counts.min() < 0:
        raise PrimError("faceVertexCounts has negative counts")
    if counts.sum() != indices.size:
        raise PrimError(f"faceVertexCounts sum to {int(counts.sum())} corners but "
                        f"faceVertexIndices has {indices.size}")
    if indices.size and (indices.min() < 0 or indices.max() >= len(points)):
        raise PrimError(f"faceVertexIndices go from {int(indices.min())} to "
                        f"{int(indices.max())} but there are {len(points)} points")
    starts = np.cumsum(counts) - counts
    keep = counts >= 3
    holes = np.asarray(holes if holes is not None else [], dtype=np.int64).ravel()
    holes = holes[(holes >= 0) & (holes < len(counts))]
    dropped = int((~keep).sum())
    keep[holes] = False
    face_source = np.nonzero(keep)[0]
    kept_counts = counts[keep]
    corner_face = np.repeat(np.arange(len(kept_counts)), kept_counts)
    position = np.arange(kept_counts.sum()) - np.repeat(np.cumsum(kept_counts) - kept_counts,
                                                         kept_counts)
    if reverse:
        position = kept_counts[corner_face] - 1 - position
    corner_source = starts[face_source][corner_face] + position
    return Polygons(points, kept_counts, indices[corner_source], face_source, corner_source,
                    len(counts), int(indices.size), dropped)


def vectors(values, name: str) -> np.ndarray:
    """``values`` as an (n, 3) float array, or a PrimError saying what they are instead."""
    try:
        array = np.asarray(values if values is not None else [], dtype=np.float64)
    except (TypeError, ValueError):
        raise PrimError(f"{name} must be an array of 3-vectors, got {values!r:.60}") from None
    if array.size == 0:
        return array.reshape(0, 3)
    if array.ndim != 2 or array.shape[1] != 3:
        raise PrimError(f"{name} must be an array of 3-vectors, got {type(values).__name__} "
                        f"of shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise PrimError(f"{name} has NaN or infinite values")
    return array


def expected_length(interpolation: str, polygons: Polygons) -> int | None:
    """How many values a primvar of ``interpolation`` has on this mesh (``None``: any >= 1)."""
    return {CONSTANT: None, UNIFORM: polygons.authored_faces,
            VERTEX: len(polygons.points), VARYING: len(polygons.points),
            FACE_VARYING: polygons.authored_corners}.get(interpolation, -1)


def check_length(name: str, values: np.ndarray, interpolation: str,
                 polygons: Polygons) -> None:
    """Raise a PrimError when ``values`` do not fit the mesh for their interpolation."""
    expected = expected_length(interpolation, polygons)
    if expected == -1:
        raise PrimError(f"{name} has unknown interpolation {interpolation!r}")
    if expected is None and len(values) < 1 or expected is not None and len(values) != expected:
        raise PrimError(f"{name} is {interpolation} with {len(values)} values; the mesh needs "
                        f"{expected if expected is not None else 'at least 1'}")


def per_corner(values: np.ndarray, interpolation: str, polygons: Polygons) -> np.ndarray:
    """Values of every drawn corner (the point data of the unwelded mesh)."""
    if interpolation == CONSTANT:
        return np.repeat(values[:1], polygons.corner_source.size, axis=0)
    if interpolation == UNIFORM:
        return values[polygons.face_source][polygons.face_of_corner]
    if interpolation in (VERTEX, VARYING):
        return values[polygons.indices]
    return values[polygons.corner_source]


def polydata(polygons: Polygons, welded: bool, faces: np.ndarray | None = None
             ) -> tuple[pyvista.PolyData, np.ndarray]:
    """The drawn faces (all, or the drawn-face ids ``faces``) as PolyData.

    Returns the mesh and, for each of its points, the authored point (welded) or the
    drawn corner (unwelded) it is; points no face uses are left out.
    """
    counts = polygons.counts
    faces = np.arange(len(counts)) if faces is None else np.unique(faces)
    corners = np.arange(counts.sum()) if len(faces) == len(counts) else \
        np.nonzero(np.isin(polygons.face_of_corner, faces))[0]
    if welded:
        used, local = np.unique(polygons.indices[corners], return_inverse=True)
        points = polygons.points[used]
        source = used
    else:
        local = np.arange(corners.size)
        points = polygons.points[polygons.indices[corners]]
        source = corners
    chosen = counts[faces]
    cells = np.insert(local, np.cumsum(chosen) - chosen, chosen) if chosen.size else None
    return pyvista.PolyData(points, faces=cells), source


def reversed_connectivity(offsets: np.ndarray, connectivity: np.ndarray) -> np.ndarray:
    """Each cell's point ids in reverse order (cells given as VTK offsets and connectivity)."""
    counts = np.diff(offsets)
    cell = np.repeat(np.arange(len(counts)), counts)
    position = np.arange(len(connectivity)) - offsets[:-1][cell]
    return connectivity[offsets[:-1][cell] + counts[cell] - 1 - position]


def cell_arrays(mesh: pyvista.PolyData) -> tuple[np.ndarray, np.ndarray]:
    """The offsets and connectivity of a mesh's polygons."""
    polys = mesh.GetPolys()
    return (pyvista.convert_array(polys.GetOffsetsArray()).astype(np.int64),
            pyvista.convert_array(polys.GetConnectivityArray()).astype(np.int64))


def with_winding_reversed(mesh: pyvista.PolyData) -> pyvista.PolyData:
    """A copy of ``mesh`` whose polygons wind the other way (points and data unchanged)."""
    offsets, connectivity = cell_arrays(mesh)
    out = mesh.copy()
    out.SetPolys(pyvista.CellArray.from_arrays(offsets, reversed_connectivity(
        offsets, connectivity), deep=True))
    return out


def cofactor(matrix: np.ndarray) -> np.ndarray:
    """The cofactor matrices (det · inverse transpose) of ``(..., 3, 3)`` matrices.

    They turn normals as the inverse transpose does, and stay defined for singular
    (zero-scale) matrices.
    """
    a, b, c = (matrix[..., :, k] for k in range(3))
    return np.stack([np.cross(b, c), np.cross(c, a), np.cross(a, b)], axis=-1)
