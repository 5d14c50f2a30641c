"""Where a grid's rays start: at the brick shell, or where they enter the grid's box.

The brick shell (:func:`~pv_cubemarch.models.voxel_shell.choose_shell`) closes around every
filled voxel. At the start of a frame whose view changed a depth pass (:class:`FaceDepthPass`) draws
its front faces: per pixel, the view depth where the ray first meets it. The grid's box then
traverses each pixel's ray from there (every voxel before it is empty) and skips pixels that
meet no face. That holds only for rays that come from outside the filled voxels' box: on
frames where the near plane reaches it, no pass runs and the rays start at the box or the
near plane.
"""

from __future__ import annotations

import numpy as np
import pyvista

from ..core import vtk_classes as vtk
from ..gl.bindings import ShaderBindings
from ..gl.box import camera_matrices, near_plane_reaches, place_box, quads_polydata
from ..gl.face_depth import FaceDepthPass
from ..gl.shaders import Replacement, ShaderRecipe
from ..models.voxel_levels import filled_bounds
from ..models.voxel_shell import (
    PROXY_MARGIN,
    BrickShell,
    brick_bounds,
    brick_faces,
    choose_shell,
    occupied_bricks,
)
from ..models.voxels import VoxelModel

#: How far (voxels) from the filled voxels' box the near plane must stay for the shell:
#: beyond the shell's faces, which stand PROXY_MARGIN off the voxels.
NEAR_PLANE_PAD = 2.0 * PROXY_MARGIN

SHELL_RECIPE = ShaderRecipe(replacements=[
    Replacement("//VTK::Color::Dec", "voxel_shell_declarations", keep_tag="after"),
    Replacement("//VTK::Light::Impl", "voxel_shell_depth", keep_tag="before"),
    Replacement("//VTK::PositionVC::Dec", "voxel_proxy_declarations", stage="vertex",
                keep_tag="after"),
    Replacement("//VTK::PositionVC::Impl", "voxel_proxy_vertex", stage="vertex",
                keep_tag="before"),
])


def face_depth_actor(renderer) -> tuple[pyvista.Actor, ShaderBindings]:
    """An actor (not in the renderer) whose fragments write their view depth.

    For a :class:`FaceDepthPass`; its mesh is set with ``GetMapper().SetInputData``.
    """
    actor = pyvista.Actor()
    mapper = vtk.vtkOpenGLPolyDataMapper()
    actor.SetMapper(mapper)
    actor.GetProperty().LightingOff()
    bindings = ShaderBindings(mapper, renderer, SHELL_RECIPE)
    bindings.set_uniform("cm_projection", lambda: camera_matrices(renderer)[1])
    SHELL_RECIPE.apply(actor.GetShaderProperty())
    return actor, bindings


class ShellStart:
    """The brick shell of one grid, its depth pass, and whether it is used this frame."""

    def __init__(self, model: VoxelModel, renderer, shell: BrickShell,
                 depth: FaceDepthPass | None = None):
        self.model = model
        self.renderer = renderer
        self.actor, self.bindings = face_depth_actor(renderer)
        self.enabled = True      # False once edits leave no shell within the face budget
        #: Whether the grid is shown (set by its binding): a hidden grid runs no pass.
        self.shown = lambda: True
        self.on_shell = False
        #: The depth pass this shell draws in: its own, or one shared by a world's chunks
        #: (which draws every chunk's shell; the nearest face is a safe start for each).
        self.shared = depth is not None
        self.depth = depth if depth is not None else FaceDepthPass(renderer, self.actor,
                                                                   self.used)
        self._use(shell)
        self.place()

    @property
    def nbytes(self) -> int:
        """GPU bytes: the depth pass's targets and the shell's vertices and triangles."""
        mesh = self.actor.GetMapper().GetInput()
        return self.depth.nbytes + 12 * (mesh.GetNumberOfPoints() + mesh.GetNumberOfCells())

    @property
    def host_nbytes(self) -> int:
        """Host bytes of the shell's mesh."""
        return self.actor.GetMapper().GetInput().GetActualMemorySize() * 1024

    @property
    def start_at_shell(self) -> float:
        """The shader's ``cm_startAtProxy``: 1 on frames the depth pass drew."""
        return 1.0 if self.on_shell else 0.0

    def choose(self) -> bool:
        """Use the shell unless the near plane reaches the filled voxels' box; returns it."""
        self.on_shell = self.enabled and not near_plane_reaches(
            self.renderer, self.model.world_from_index(), *self.bounds, NEAR_PLANE_PAD)
        return self.on_shell

    @property
    def brick(self) -> int:
        """Edge of the shell's bricks, in voxels."""
        return 1 << self.level

    def _use(self, shell: BrickShell) -> None:
        """Draw ``shell``: its faces, its bricks' occupancy and box."""
        self.level = shell.level
        self.points, self.quads, self.appended = shell.points, shell.quads, 0
        self.occupied = shell.occupied.copy()
        self.bounds = brick_bounds(self.occupied, self.brick, self.model.dimensions)
        self.actor.GetMapper().SetInputData(quads_polydata(self.points, self.quads))
        self.depth.invalidate()

    def rebuild(self) -> None:
        """A new shell from all the labels (or none, when none fits the face budget)."""
        shell = choose_shell(self.model.labels)
        self.enabled = shell is not None
        if shell is not None:
            self._use(shell)
        else:
            self.bounds = filled_bounds(self.model.labels)

    def edit(self, box: tuple[slice, slice, slice]) -> None:
        """Follow labels changed in ``box``: faces for bricks that became filled.

        Bricks that emptied keep their faces (a ray may start earlier than it needs: never
        wrong); after many additions, or once disabled, the shell is rebuilt whole.
        """
        if not self.enabled:
            return   # no shell fitted the face budget: the next whole edit tries again
        brick, dims = self.brick, self.model.dimensions
        low = [s.start // brick for s in box]
        high = [-(-s.stop // brick) for s in box]
        region = tuple(slice(a * brick, min(b * brick, n))
                       for a, b, n in zip(low, high, dims, strict=True))
        cells = tuple(slice(a, b) for a, b in zip(low, high, strict=True))
        # `occupied` keeps every brick filled since the last rebuild: its faces stay.
        added = occupied_bricks(self.model.labels[region], brick) & ~self.occupied[cells]
        if not added.any():
            return
        self.occupied[cells] |= added
        points, quads = brick_faces(np.argwhere(added) + low, brick, dims)
        self.quads = np.concatenate([self.quads, quads + len(self.points)])
        self.points = np.concatenate([self.points, points])
        self.appended += len(quads)
        if self.appended > max(1024, len(self.quads) // 4):
            self.rebuild()
            return
        self.bounds = brick_bounds(self.occupied, brick, dims)
        self.actor.GetMapper().SetInputData(quads_polydata(self.points, self.quads))
        self.depth.invalidate()

    def used(self) -> bool:
        """Whether this frame's rays start at the shell: the grid shown, the near plane clear.

        The depth pass then draws, if the view changed.
        """
        return self.shown() and self.choose()

    def place(self) -> None:
        """Place the shell like the grid, drawing its front faces."""
        place_box(self.actor, self.model.world_from_index(), faces="front")
        self.depth.invalidate()

    def release(self) -> None:
        """Stop the pass and free its target and shader bindings."""
        self.enabled = False   # a shared pass asks no more of it
        if not self.shared:
            self.depth.release()
        self.bindings.release()
        self.actor.ReleaseGraphicsResources(self.renderer.GetRenderWindow())
