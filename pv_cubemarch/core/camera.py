"""A plain camera description shared by scenes, the GPU path and the CPU reference."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Camera:
    """A pinhole (or parallel) camera in world coordinates, as VTK defines one.

    ``view_angle`` is the vertical field of view in degrees; ``clipping_range`` is
    ``(near, far)`` along the view direction, or ``None`` to let the renderer fit it.
    """

    position: tuple[float, float, float]
    focal_point: tuple[float, float, float]
    view_up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    view_angle: float = 30.0
    clipping_range: tuple[float, float] | None = None
    parallel_projection: bool = False
    parallel_scale: float = 1.0

    @classmethod
    def from_pyvista(cls, camera) -> Camera:
        """Copy a ``pyvista.Camera`` (or ``vtkCamera``)."""
        return cls(
            position=tuple(camera.GetPosition()),
            focal_point=tuple(camera.GetFocalPoint()),
            view_up=tuple(camera.GetViewUp()),
            view_angle=float(camera.GetViewAngle()),
            clipping_range=tuple(camera.GetClippingRange()),
            parallel_projection=bool(camera.GetParallelProjection()),
            parallel_scale=float(camera.GetParallelScale()),
        )

    def apply_to(self, camera) -> None:
        """Set a ``pyvista.Camera`` / ``vtkCamera`` to this camera."""
        camera.SetPosition(*self.position)
        camera.SetFocalPoint(*self.focal_point)
        camera.SetViewUp(*self.view_up)
        camera.SetViewAngle(self.view_angle)
        camera.SetParallelProjection(self.parallel_projection)
        camera.SetParallelScale(self.parallel_scale)
        if self.clipping_range is not None:
            camera.SetClippingRange(*self.clipping_range)

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Orthonormal ``(right, up, forward)`` vectors of the view."""
        forward = np.subtract(self.focal_point, self.position).astype(np.float64)
        length = np.linalg.norm(forward)
        if length == 0:
            raise ValueError("Camera position and focal_point coincide; move one of them.")
        forward /= length
        right = np.cross(forward, self.view_up)
        if np.linalg.norm(right) < 1e-12:
            raise ValueError("Camera view_up is parallel to the view direction; choose another.")
        right /= np.linalg.norm(right)
        return right, np.cross(right, forward), forward

    def rays(self, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """World ray origins and unit directions through pixel centres, rows top to bottom.

        Returns arrays of shape ``(height, width, 3)``. Perspective rays start at the eye;
        parallel rays start on the plane through the eye.
        """
        width, height = size
        right, up, forward = self.basis()
        xs = (np.arange(width) + 0.5) / width * 2.0 - 1.0
        ys = 1.0 - (np.arange(height) + 0.5) / height * 2.0
        ndc_x, ndc_y = np.meshgrid(xs, ys)
        aspect = width / height
        eye = np.asarray(self.position, dtype=np.float64)
        if self.parallel_projection:
            half_h = self.parallel_scale
            origins = (eye + ndc_x[..., None] * half_h * aspect * right
                       + ndc_y[..., None] * half_h * up)
            directions = np.broadcast_to(forward, origins.shape).copy()
            return origins, directions
        half_h = np.tan(np.radians(self.view_angle) / 2.0)
        directions = (forward + ndc_x[..., None] * half_h * aspect * right
                      + ndc_y[..., None] * half_h * up)
        directions /= np.linalg.norm(directions, axis=-1, keepdims=True)
        origins = np.broadcast_to(eye, directions.shape).copy()
        return origins, directions
