"""Read a USD stage (.usd, .usda, .usdc, .usdz) into a :class:`~pv_cubemarch.scene.model.Scene`.

Modules: :mod:`.stage` walks the stage; :mod:`.meshes`, :mod:`.shapes` and
:mod:`.instancers` read geometry, :mod:`.preview_surface` materials, :mod:`.lights`
cameras and lights, :mod:`.volumes` Volume prims.


USD composes references, payloads and instancing for us; we walk the composed stage
(instance proxies included), load what is drawable and record what we skip and why.
Transfer functions are not part of USD: a ``Volume`` prim may carry ``cubemarch:cmap``,
``cubemarch:opacity``, ``cubemarch:clim`` and ``cubemarch:opacityUnitDistance``, and the
options of :func:`pv_cubemarch.add_volume` in camel case (:data:`VOLUME_OPTIONS`):
``cubemarch:technique``, ``stepScale``, ``stopOpacity``, ``skipEmpty``, ``downsample``,
``faceSize``, ``maxSamples``, ``upscale``, ``sampleFactor``, ``occlusionSharpness``,
``lights`` (``"scene"``: lit by the stage's lights, or ``"none"``), ``lightMapSize``,
``lightMapAmbient``, ``blending``, ``isosurfaces`` (every option: ``docs/options.md``). The
field
prim a ``field:*`` relationship targets has an asset ``filePath`` (.vti/.vtk/.npy/.npz)
and, for numpy files, optional ``cubemarch:origin`` and ``cubemarch:spacing``.

A ``Volume`` with ``cubemarch:technique = "voxels"`` (or every ``Volume`` with
``load_usd(..., as_voxels=True)``) is a material grid: its field (``field:labels``, else
``field:density``, else the first) holds integer labels, 0 = empty, drawn with
:func:`pv_cubemarch.add_voxels`. Its palette is ``cubemarch:palette`` (``color3f[]`` or
``color4f[]``, entry ``m`` for material ``m``, entry 0 unused) or ``cubemarch:cmap`` (a
colormap name), with optional ``cubemarch:paletteOpacity`` (``float[]``, one per palette
entry, 0 hides a material); its options are :data:`VOXEL_OPTIONS` (``traversal``,
``stepScale``, ``mipLevels``, ``distanceField``, ``mode``, ``shading``, ``ambient``,
``specular``, ``specularPower``, ``ambientOcclusion``, ``occlusionStrength``, ``proxy``,
``lod``, ``lodBias``), checked when the stage is loaded; ``cubemarch:chunkSize`` draws it in
chunks. A numpy label array fills voxels from ``cubemarch:origin`` (the grid box's corner),
as ``add_voxels`` places an array. Voxels Volumes with ``cubemarch:world`` and
``cubemarch:chunk`` are chunks of one world (:mod:`.voxel_worlds`).

A ``Volume`` with ``cubemarch:technique = "surface"`` is an implicit surface: the level
``cubemarch:isovalue`` of its field (``field:density``, else the first; one sample per point,
a cell centred on each), drawn with :func:`pv_cubemarch.add_surface`; its options are
:data:`SURFACE_OPTIONS` (``surfaceTechnique``: ``"active"`` or ``"full"``,
``surfaceTraversal``: ``"index"`` or ``"cell_boxes"``, ``steps``,
``refineSteps``, ``root``, ``activeTest``, ``activeSamples``, ``shading``, ``ambient``,
``specular``, ``specularPower``) and ``cubemarch:color``, checked when the stage is loaded.
"""

import importlib

#: The suffixes read as USD stages.
USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")

#: Names imported on first use, and their modules: USD's own modules take 0.16 s to import,
#: which ``import pv_cubemarch`` does not pay.
_LAZY = {"SURFACE_OPTIONS": "attributes", "VOLUME_OPTIONS": "attributes",
         "VOXEL_OPTIONS": "attributes", "load_usd": "stage"}


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["SURFACE_OPTIONS", "USD_SUFFIXES", "VOLUME_OPTIONS", "VOXEL_OPTIONS", "load_usd"]
