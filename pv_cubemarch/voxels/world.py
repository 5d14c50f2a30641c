"""Voxel worlds on screen: a box actor per chunk that holds voxels, one shared depth pass.

Each chunk is drawn as a grid of its own (:func:`build_voxel_actor`), so frustum culling,
levels and editing work per chunk; a chunk of one label is a single stretched voxel, and
empty chunks draw nothing. The chunks' brick shells are drawn by one depth pass: the
nearest shell face over all chunks is a safe start for every chunk's rays (no chunk has a
filled voxel before it), so a chunk behind another starts at its own box and a chunk in
front of the nearest face ends at once. The world stands in the plotter as one invisible
bounds actor; the chunks' actors follow its visibility and leave with it.
"""

from __future__ import annotations

import pyvista
import vtk

from ..gl.face_depth import FaceDepthPass
from ..gl.overlay import bounds_proxy
from ..models.world import VoxelWorld
from .options import VoxelOptions
from .technique import VoxelBinding, build_voxel_actor


class WorldBinding:
    """What ``actor.cubemarch`` holds for a world: the world and its chunks' bindings."""

    technique = "voxels"

    def __init__(self, world: VoxelWorld, chunks: list[VoxelBinding],
                 depth: FaceDepthPass | None):
        self.model = world
        self.chunks = chunks
        self.depth = depth

    @property
    def nbytes(self) -> int:
        """GPU bytes of every chunk, the shared depth pass counted once."""
        total = sum(c.nbytes for c in self.chunks)
        shared = sum(1 for c in self.chunks if c.shell is not None)
        return total - max(shared - 1, 0) * (self.depth.nbytes if self.depth else 0)

    def release(self) -> None:
        """Free every chunk and the shared pass."""
        for chunk in self.chunks:
            chunk.release()
        if self.depth is not None:
            self.depth.release()


def build_world(plotter, world: VoxelWorld, options: VoxelOptions) -> pyvista.Actor:
    """Draw ``world``'s chunks in ``plotter``; returns the actor that stands for them.

    That actor is in the plotter (named after the world) before any chunk is tracked: a
    tracked chunk whose anchor is not in the renderer counts as removed.
    """
    renderer = plotter.renderer
    shells = []
    parts = vtk.vtkAssembly()

    def used() -> bool:   # each shell decides for its chunk; the pass draws if any uses it
        return any([shell.used() for shell in shells])

    depth = FaceDepthPass(renderer, parts, used) if options.proxy == "bricks" else None
    proxy = bounds_proxy(world)
    plotter.add_actor(proxy, name=world.name, reset_camera=False)
    chunks = []
    for key in sorted(set(world.stored) | set(world.uniform)):
        model = world.chunk_model(key)
        options.check_model(model)
        binding = build_voxel_actor(plotter, model, options, shared_depth=depth)
        renderer.AddActor(binding.drawn[0])
        binding.main_renderer = renderer
        binding.actor = proxy   # the anchor: the chunk follows its visibility, leaves with it
        if binding.shell is not None:
            parts.AddPart(binding.shell.actor)
            shells.append(binding.shell)
        plotter.cubemarch.track(binding)
        chunks.append(binding)
    if shells:
        shells[0].shared = False   # the first chunk's release frees the pass with the world
    pyvista.set_new_attribute(proxy, "cubemarch", WorldBinding(world, chunks, depth))
    return proxy
