"""What every prim reader of one stage shares: the stage, the time, transforms, the report."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
from pxr import Usd, UsdGeom

from ...core.errors import SceneWarning
from ..model import Scene
from ..parts import SkippedPrim


class PrimError(ValueError):
    """A prim (or one of its parts) that cannot be drawn as authored; the message says why."""


@dataclass
class StageContext:
    """One stage being read at one time code, and the scene it fills."""

    stage: Usd.Stage
    scene: Scene
    time: Usd.TimeCode
    as_voxels: bool = False
    strict: bool = False
    xforms: UsdGeom.XformCache = field(init=False)
    #: Chunks of voxel worlds by world name, joined once the stage is read.
    world_chunks: dict = field(default_factory=dict)
    #: Materials read so far, by material path (``None``: not a UsdPreviewSurface).
    materials: dict = field(default_factory=dict)
    #: Things counted over the stage and reported once (say, subdivision meshes).
    counts: dict = field(default_factory=dict)
    #: The PointInstancers being read, outermost first (a prototype holding one of them
    #: is a cycle).
    instancing: list = field(default_factory=list)
    #: Prims below each prototype, nested instances expanded, by prototype path.
    prototype_prims: dict = field(default_factory=dict)

    def __post_init__(self):
        self.xforms = UsdGeom.XformCache(self.time)

    def world_matrix(self, prim) -> np.ndarray:
        """Column-vector 4x4 world matrix (USD stores row-vector matrices)."""
        return np.array(self.xforms.GetLocalToWorldTransform(prim), dtype=np.float64).T

    def get(self, prim, name: str, default=None):
        """Attribute ``name`` of ``prim`` at the stage time, or ``default`` when unauthored."""
        attribute = prim.GetAttribute(name)
        if not attribute or not attribute.HasAuthoredValue() and not attribute.HasFallbackValue():
            return default
        value = attribute.Get(self.time)
        return default if value is None else value

    def report(self, path: str, reason: str, warn: bool = True) -> None:
        """Record that ``path`` (or part of it) is left out or approximated; warn if ``warn``.

        Prims left out on purpose (invisible, inactive, guides) are recorded silently.
        """
        self.scene.skipped.append(SkippedPrim(str(path), reason, problem=warn))
        if warn:
            warnings.warn(f"{path}: {reason}", SceneWarning, stacklevel=3)
