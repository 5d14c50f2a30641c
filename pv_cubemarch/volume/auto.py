"""``technique='auto'``: per volume and frame, the cube map or direct marching.

:func:`classify` makes the cube-map paper's choice: the cube map when its visible texels are fewer
than the pixels the volume covers, else every pixel marched directly. Both paths are built
once and share the volume's data; the one not chosen is hidden for the frame.
"""

from __future__ import annotations

import numpy as np

from ..core import vtk_classes as vtk
from ..core.frame_errors import observe
from ..core.registry import Technique, register_technique
from ..gl.box import camera_matrices, drawn_viewport
from ..gl.handle import keep_placed_by_matrix
from ..reference.emission_absorption import render_emission_absorption
from .binding import VolumeBinding, VolumeData, VolumeSetup, follow_placement
from .cubemap.lod import cube_corners
from .cubemap.technique import build_cubemap_actor
from .direct import build_direct_actor
from .options import AutoOptions


def projected_pixels(clip_from_local: np.ndarray, size) -> float:
    """Pixels the box covers on screen (its projected hull clipped to the viewport)."""
    width, height = size
    clip = np.column_stack([cube_corners(), np.ones(8)]) @ clip_from_local.T
    if (clip[:, 3] <= 0).any():
        return float(width * height)  # the eye is close or inside: the box fills the view
    points = (clip[:, :2] / clip[:, 3:4] + 1.0) * 0.5 * np.array([width, height])
    hull = _clip_polygon(_convex_hull(points), width, height)
    if len(hull) < 3:
        return 0.0
    x, y = hull[:, 0], hull[:, 1]
    return float(0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _convex_hull(points: np.ndarray) -> np.ndarray:
    pts = sorted(map(tuple, points))

    def turn(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    def half(seq):
        chain = []
        for p in seq:
            while len(chain) >= 2 and turn(chain[-2], chain[-1], p) <= 0:
                chain.pop()
            chain.append(p)
        return chain

    lower, upper = half(pts), half(reversed(pts))
    return np.array(lower[:-1] + upper[:-1])


def _clip_polygon(polygon: np.ndarray, width: float, height: float) -> np.ndarray:
    """Sutherland-Hodgman clipping of a convex polygon to [0, width] x [0, height]."""
    for axis, bound, keep_below in ((0, 0.0, False), (0, width, True), (1, 0.0, False),
                                    (1, height, True)):
        if len(polygon) == 0:
            break
        out = []
        for a, b in zip(polygon, np.roll(polygon, -1, axis=0), strict=True):
            a_in = a[axis] <= bound if keep_below else a[axis] >= bound
            b_in = b[axis] <= bound if keep_below else b[axis] >= bound
            if a_in:
                out.append(a)
            if a_in != b_in:
                t = (bound - a[axis]) / (b[axis] - a[axis])
                out.append(a + t * (b - a))
        polygon = np.array(out)
    return polygon


def classify(visible_faces: int, face_size: int, pixels: float) -> str:
    """The paper's choice of technique for one volume in one frame.

    March the cube map when its visible texels are fewer than the pixels the volume covers,
    else march every pixel directly.
    """
    texels = visible_faces * face_size * face_size
    return "cubemap" if texels < pixels else "direct"


class AutoBinding(VolumeBinding):
    """A volume drawn by the cube map or directly, chosen per frame (``technique='auto'``).

    ``force`` (``None``, ``'cubemap'`` or ``'direct'``) overrides the choice; ``choice``
    and ``choices`` (a count per technique) say what was drawn. ``direct`` and ``cubemap``
    are the two paths' own bindings; both read the same data.
    """

    technique = "auto"
    needs_single_sample = True   # its cube map reads the depth single-sampled
    blends_in_main_renderer = True   # its direct box draws in the translucent pass

    def __init__(self, plotter, data: VolumeData, direct, cube):
        super().__init__(direct.model, data, direct.bindings, direct.recipe, direct.step_scale,
                         direct.stop_opacity)
        self.renderer = self.main_renderer = plotter.renderer
        self.direct = direct
        self.cubemap = cube
        self.direct_actor, self.cube_actor = direct.drawn[0], cube.drawn[0]
        self.drawn = [self.direct_actor, self.cube_actor]
        self.targets = direct.targets + cube.targets
        self.force: str | None = None
        self.choice = "direct"
        self.choices = {"cubemap": 0, "direct": 0}
        self._visible = False
        # The cube pass uses this frame's choice and culling, decided once in _choose, and
        # runs only while the volume is shown.
        self.cubemap.cube_pass.run_when = lambda: (self.shown and self.choice == "cubemap"
                                                   and self._visible)
        self.extra_release = [lambda: self.renderer.RemoveObserver(self._tag),
                              lambda: self.renderer.RemoveActor(self.direct_actor),
                              direct.release, cube.release]
        # Before anything draws: the direct box is drawn by this renderer's translucent pass.
        self._tag = observe(self.renderer, vtk.vtkCommand.StartEvent, self._choose, 2.0)

    def _choose(self, *_):
        frame = self.cubemap.frame
        self._visible = frame.update()
        if self.force in ("cubemap", "direct"):
            choice = self.force
        else:
            view, projection = camera_matrices(self.renderer)
            pixels = projected_pixels(projection @ view @ frame.world_from_local,
                                      drawn_viewport(self.renderer)[2:])
            choice = classify(bin(frame.face_mask).count("1"), frame.lod.level_size, pixels)
        self.choice = choice
        self.choices[choice] += 1
        self.direct_actor.SetVisibility(self.shown and choice == "direct")
        self.cube_actor.SetVisibility(self.shown and choice == "cubemap")

    def follow_anchor(self) -> None:
        """At each frame: what was set on the returned volume (visibility: :meth:`_choose`)."""
        for actor in self.drawn:
            if actor is not self.actor:
                keep_placed_by_matrix(actor)
        self.follow_returned_volume()

    def set_march_defines(self, changes: dict) -> None:
        """Both paths' marchers (and the light map they share) take the switches."""
        self.direct.set_march_defines(changes)
        self.cubemap.set_march_defines(changes)

    def set_blending(self, blending: str) -> None:
        """Both paths composite by another blend mode (see ``VolumeBinding.set_blending``)."""
        self.direct.set_blending(blending)
        self.cubemap.set_blending(blending)
        self.blending = blending

    def set_shade(self, shading) -> None:
        """Both paths shade, or not (see ``VolumeBinding.set_shade``)."""
        for path in (self.direct, self.cubemap):
            path.blending = self.blending
            path.set_shade(shading)

    @property
    def lod(self):
        """The cube map's last LOD choice."""
        return self.cubemap.lod

    @property
    def memory(self) -> dict[str, int]:
        """GPU bytes of both paths (the cube map's targets exist once it was chosen)."""
        memory = dict(self.cubemap.memory)
        memory["direct"] = 0   # the direct path shares the data counted by the cube map
        if self.light_map is not None:
            memory["light_map"] = self.light_map.nbytes
        return memory

    @property
    def nbytes(self) -> int:
        """All GPU bytes of the volume."""
        return sum(self.memory.values())

    def place(self, transform) -> None:
        """Both paths follow: the direct box, the cube box (culling too) and its frame."""
        self.direct.set_transform(transform)
        self.cubemap.set_transform(transform)
        follow_placement(self)


def build_auto_actor(plotter, data: VolumeData, setup: VolumeSetup):
    """Both paths of a ``technique='auto'`` volume, sharing its data; returns the binding."""
    cube = build_cubemap_actor(plotter, data, setup.with_options(setup.options.cubemap))
    direct = build_direct_actor(plotter, data, setup.with_options(setup.options.direct))
    cube.renderer.AddActor(cube.drawn[0])
    plotter.renderer.AddActor(direct.drawn[0])
    return AutoBinding(plotter, data, direct, cube)


register_technique(Technique(
    name="auto", kind="volume", options=AutoOptions, build=build_auto_actor,
    reference=render_emission_absorption, chooses_among=("cubemap", "direct"),
    summary="per frame, the cube map or the direct marcher, whichever marches fewer rays"))
