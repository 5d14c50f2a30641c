"""Surface materials as a scene file describes them (UsdPreviewSurface's inputs), to be drawn.

An input is a constant, a texture lookup (:class:`TextureInput`) or a primvar of the mesh
(:class:`PrimvarInput`). Colours are linear; a texture says which colour space its file
is in.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class TextureInput:
    """One ``UsdUVTexture`` read: the file, the channels used and how they are mapped."""

    file: str
    channels: str = "rgb"                 # 'rgb', 'r', 'g', 'b' or 'a'
    st: str = "st"                        # primvar of the texture coordinates
    wrap: tuple[str, str] = ("repeat", "repeat")   # 'repeat', 'clamp', 'mirror', 'black'
    scale: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0)
    bias: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    color_space: str = "auto"             # 'sRGB', 'raw' or 'auto' (sRGB for 8-bit colour)
    #: 3x3 matrix applied to (s, t, 1) before the lookup (``UsdTransform2d``), or ``None``.
    st_transform: np.ndarray | None = None
    fallback: tuple[float, ...] | None = None
    #: The file's bytes when it is inside a package (``.usdz``) rather than on disk.
    data: bytes | None = None


@dataclass
class PrimvarInput:
    """A value read from the mesh's primvar ``name`` (``UsdPrimvarReader_*``)."""

    name: str
    fallback: tuple[float, ...] | float | None = None


@dataclass
class SurfaceMaterial:
    """A ``UsdPreviewSurface``: each input a constant, a texture or a primvar."""

    name: str
    diffuse_color: tuple | TextureInput | PrimvarInput = (0.18, 0.18, 0.18)
    emissive_color: tuple | TextureInput | PrimvarInput = (0.0, 0.0, 0.0)
    opacity: float | TextureInput | PrimvarInput = 1.0
    opacity_threshold: float = 0.0
    metallic: float | TextureInput | PrimvarInput = 0.0
    roughness: float | TextureInput | PrimvarInput = 0.5
    occlusion: float | TextureInput | PrimvarInput = 1.0
    normal: TextureInput | None = None
    #: Inputs read but not drawn (say, ``clearcoat``, ``displacement``), for the report.
    ignored: list[str] = field(default_factory=list)

    def inputs(self) -> dict:
        """Every drawn input by its USD name."""
        return {"diffuseColor": self.diffuse_color, "emissiveColor": self.emissive_color,
                "opacity": self.opacity, "metallic": self.metallic,
                "roughness": self.roughness, "occlusion": self.occlusion,
                "normal": self.normal}

    def textures(self) -> list[TextureInput]:
        """The texture inputs."""
        return [v for v in self.inputs().values() if isinstance(v, TextureInput)]

    def primvars(self) -> set[str]:
        """Names of the mesh primvars the material reads (texture coordinates included)."""
        names = {t.st for t in self.textures()}
        names |= {v.name for v in self.inputs().values() if isinstance(v, PrimvarInput)}
        return names
