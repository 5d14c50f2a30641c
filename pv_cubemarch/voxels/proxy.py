"""Where a grid's rays start: at the brick shell, or where they enter the grid's box.

The brick shell (:func:`~pv_cubemarch.models.voxels.choose_shell`) closes around every
filled voxel. At the start of each frame a depth pass (:class:`FaceDepthPass`) draws its
front faces: per pixel, the view depth where the ray first meets it. The grid's box then
traverses each pixel's ray from there (every voxel before it is empty) and skips pixels that
meet no face. That holds only for rays that come from outside the filled voxels' box: on
frames where the near plane reaches it, no pass runs and the rays start at the box or the
near plane.
"""

from __future__ import annotations

import pyvista
import vtk

from ..gl.bindings import ShaderBindings
from ..gl.box import camera_matrices, near_plane_reaches, place_box, quads_polydata
from ..gl.face_depth import FaceDepthPass
from ..gl.shaders import Replacement, ShaderRecipe
from ..models.voxels import PROXY_MARGIN, BrickShell, VoxelModel, filled_bounds

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


class ShellStart:
    """The brick shell of one grid, its depth pass, and whether it is used this frame."""

    def __init__(self, model: VoxelModel, renderer, shell: BrickShell):
        self.model = model
        self.renderer = renderer
        self.level = shell.level
        self.bounds = filled_bounds(model.labels)
        self.actor = pyvista.Actor()
        mapper = vtk.vtkOpenGLPolyDataMapper()
        mapper.SetInputData(quads_polydata(shell.points, shell.quads))
        self.actor.SetMapper(mapper)
        self.actor.GetProperty().LightingOff()
        self.bindings = ShaderBindings(mapper, renderer, SHELL_RECIPE)
        self.bindings.set_uniform("cm_projection", lambda: camera_matrices(renderer)[1])
        SHELL_RECIPE.apply(self.actor.GetShaderProperty())
        self.enabled = True      # False once edits leave no shell within the face budget
        self.on_shell = False
        self._drawn_for = None   # the view the pass last drew for
        self.place()
        self.depth = FaceDepthPass(renderer, self.actor, self.pass_needed)

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

    def update(self, shell: BrickShell | None) -> None:
        """Follow changed labels: the new shell, the filled voxels' box, a new depth pass.

        ``shell``: ``None`` when none fits the face budget (the rays then start at the box).
        """
        self.bounds = filled_bounds(self.model.labels)
        self.enabled = shell is not None
        if shell is not None:
            self.actor.GetMapper().SetInputData(quads_polydata(shell.points, shell.quads))
        self._drawn_for = None

    def pass_needed(self) -> bool:
        """Whether the depth pass draws this frame: the shell is used, and the view changed.

        The camera, the viewport's size or the grid's placement: the target keeps the last
        drawing otherwise.
        """
        if not self.choose():
            return False
        camera = self.renderer.GetActiveCamera()
        view = (camera.GetMTime(), tuple(self.renderer.GetSize()),
                self.model.world_from_index().tobytes())
        if view == self._drawn_for and self.depth.runs:
            return False
        self._drawn_for = view
        return True

    def place(self) -> None:
        """Place the shell like the grid, drawing its front faces."""
        place_box(self.actor, self.model.world_from_index(), faces="front")

    def release(self) -> None:
        """Stop the pass and free its target and shader bindings."""
        self.depth.release()
        self.bindings.release()
