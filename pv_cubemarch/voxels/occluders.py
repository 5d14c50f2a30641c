"""Where a world's rays may stop: the faces of its solid bricks, drawn by a depth pass.

A brick whose voxels are all drawn stops every ray that reaches it, so per pixel the
nearest face of the solid bricks (standing a little inside them) is a depth past which no
chunk can show anything: each chunk's rays end there, and a chunk hidden behind nearer
terrain discards its pixels after one texture read instead of traversing. The faces are
those of the whole world's solid bricks merged into rectangles
(:func:`~pv_cubemarch.models.voxel_shell.shell_faces`), drawn only when the view changed.
"""

from __future__ import annotations

import numpy as np

from ..gl.box import place_box, quads_polydata
from ..gl.face_depth import FaceDepthPass
from ..models.voxel_shell import PROXY_MARGIN, shell_faces
from ..models.world import VoxelWorld
from .proxy import face_depth_actor

#: Edge (voxels) of the bricks whose solidity bounds the rays: coarse enough for few faces.
OCCLUDER_BRICK = 8
#: Most faces drawn: beyond, the pass would cost more than it saves (none is drawn).
OCCLUDER_FACE_BUDGET = 65536


class WorldOccluders:
    """The solid bricks' faces of ``world``, their depth pass, and whether it is used.

    ``opaque_only``: translucent labels are not solid (composited apart, behind which
    the opaque voxels must still be drawn).
    """

    def __init__(self, world: VoxelWorld, renderer, brick: int = OCCLUDER_BRICK,
                 opaque_only: bool = False):
        self.world = world
        self.renderer = renderer
        self.brick = brick
        self.actor, self.bindings = face_depth_actor(renderer)
        self.depth = FaceDepthPass(renderer, self.actor, self.used)
        #: Whether the world is shown (set by its binding): a hidden world runs no pass.
        self.shown = lambda: True
        #: Whether clip planes cut the world (set by its binding): its faces may be cut
        #: away, so rays do not end at them.
        self.clipped = lambda: False
        self.faces = 0
        self.active = False
        #: Whether translucent labels count as not solid (a world compositing them).
        self.opaque_only = opaque_only
        self.rebuild()

    def rebuild(self) -> None:
        """Faces from the world's labels and palette as they are now."""
        self.solid = self.world.solid_bricks(self.brick, self.opaque_only)
        self._draw_faces()

    def edit(self, box) -> None:
        """Follow labels changed in ``box`` (three slices of world voxels)."""
        if self.solid is None:
            return
        cells, solid = self.world.solid_bricks_in(self.brick, box, self.opaque_only)
        if not solid.size or np.array_equal(solid, self.solid[cells]):
            return
        self.solid[cells] = solid
        self._draw_faces()

    def _draw_faces(self) -> None:
        """Merge the solid bricks' outer faces and draw them from the next frame."""
        faces = None if self.solid is None else shell_faces(
            self.solid, self.brick, self.world.dimensions, -PROXY_MARGIN, OCCLUDER_FACE_BUDGET)
        self.faces = 0 if faces is None else len(faces[1])
        if self.faces:
            self.actor.GetMapper().SetInputData(quads_polydata(*faces))
        self.place()

    def place(self) -> None:
        """Place the faces like the world, drawing their front faces."""
        place_box(self.actor, self.world.world_from_index(), faces="front")
        self.depth.invalidate()

    @property
    def use(self) -> float:
        """The shader's ``cm_useOccluders``: 1 on frames the pass drew the faces."""
        return 1.0 if self.active else 0.0

    def used(self) -> bool:
        """Whether this frame's rays end at the faces (shown, not clipped, faces to draw)."""
        self.active = bool(self.shown() and self.faces and not self.clipped())
        return self.active

    @property
    def nbytes(self) -> int:
        """GPU bytes: the pass's targets and the faces' vertices and triangles."""
        return self.depth.nbytes + 12 * 4 * self.faces + 12 * 2 * self.faces

    def release(self) -> None:
        """Stop the pass and free its target and shader bindings."""
        self.faces = 0
        self.depth.release()
        self.bindings.release()
        self.actor.ReleaseGraphicsResources(self.renderer.GetRenderWindow())
