"""A worker's part of a sort-last frame: its partition of a volume, marched as the whole.

The partition is drawn by the direct marcher's bindings in an offscreen plotter, but its box
draws nothing: a full-viewport float pass (``ea_partition_main.glsl``) marches the whole
volume's rays with the whole box's steps and blends only the samples lying in this
partition, into premultiplied RGBA and the blend mode's raw state, read back as float32.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..api import add_volume, add_voxels, voxel_options
from ..core.camera import Camera
from ..core.rendering import offscreen_plotter, read_depth, render_frame, render_image
from ..gl.box import bind_camera, camera_matrices, drawn_viewport
from ..gl.passes import RenderToTexturePass
from ..gl.shaders import ShaderRecipe
from ..gl.textures import Texture
from ..models.volume import make_volume
from ..models.voxels import make_voxels
from ..volume.binding import (
    DECLARATION_SNIPPETS,
    SCREEN_DECLARATIONS,
    Blend,
    bind_sampling,
    march_snippets,
    world_from_texture,
)
from ..volume.options import STOP_OPACITY

#: Blend modes a partitioned volume can be drawn with: the ones whose partial images combine
#: exactly (front-to-back "over"; the extreme of the extremes).
PARTITION_BLENDING = ("composite", "maximum", "minimum")
#: add_voxels keywords a split label grid is drawn with: the look, exact per voxel. The
#: others (ambient occlusion and edges, which read neighbours across the cut; approximate
#: traversals; translucency; clipping; colours by the rank of the ids a slab holds,
#: ``categories``) are refused.
LABEL_KEYWORDS = ("palette", "mode", "shading", "ambient", "diffuse", "specular", "specular_power",
                  "cmap", "clim", "n_colors", "flip_scalars", "background", "lighting",
                  "mip_levels")
#: add_volume keywords a partitioned volume is drawn with: the look and the marching. The
#: others (gradient shading and lights, whose samples read across the cut; clipping; other
#: techniques' settings) are refused rather than drawn unlike the whole volume.
PARTITION_KEYWORDS = ("cmap", "opacity", "clim", "opacity_unit_distance", "n_colors",
                      "flip_scalars", "log_scale", "categories", "blending", "step_scale",
                      "stop_opacity", "skip_empty", "interpolation", "nan_policy")


#: The look keywords make_volume / make_voxels check (the rest are the marcher's).
_VOLUME_LOOK = ("cmap", "opacity", "clim", "opacity_unit_distance", "n_colors",
                "flip_scalars", "log_scale", "categories", "interpolation", "nan_policy")
_LABEL_LOOK = ("palette", "cmap", "clim", "n_colors", "flip_scalars", "background")
_LABEL_OPTIONS = ("mode", "shading", "ambient", "diffuse", "specular", "specular_power",
                  "mip_levels")


def check_look(keywords: dict, labels: bool) -> None:
    """Raise here what a worker would refuse of ``keywords``, before any cluster starts.

    The look is built once on a tiny grid (no GL): a bad colormap, opacity, range, palette
    or option fails with the message add_volume / add_voxels gives.
    """
    if labels:
        voxel_options(**{k: keywords[k] for k in _LABEL_OPTIONS if k in keywords})
        empty = int(keywords.get("background", 0))
        tiny = np.full((2, 2, 2), empty, np.int64)
        tiny[0, 0, 0] = empty + 1
        make_voxels(tiny, **{k: keywords[k] for k in _LABEL_LOOK if k in keywords})
        return
    step = keywords.get("step_scale")
    if step is not None and not (isinstance(step, (int, float, np.number))
                                 and not isinstance(step, bool) and 0 < step < np.inf):
        raise ValueError(f"step_scale must be a positive number of texels, got {step!r}.")
    if "stop_opacity" in keywords:
        STOP_OPACITY.check(keywords["stop_opacity"])
    look = {k: keywords[k] for k in _VOLUME_LOOK if k in keywords}
    low, high = 1.0, 2.0   # positive: a log scale's range too
    if look.get("clim") is not None and np.size(look["clim"]) == 2 and look.get("log_scale"):
        low, high = sorted(float(v) for v in np.ravel(look["clim"]))
    make_volume(np.linspace(low, high, 8).reshape(2, 2, 2), **look)


@dataclass(frozen=True)
class Partition:
    """One brick of a grid: index planes ``lower`` to ``upper`` along each axis.

    A volume's brick holds points ``lower`` to ``upper``, both included: neighbours share
    their boundary points, so a sample between them is interpolated from the same points
    as in the whole grid. A label grid's (``cells``) holds voxels ``lower`` to
    ``upper - 1``. Slabs are bricks spanning the grid along two axes. ``values`` is the
    brick's array (x, y, z) or a lazy one (``.read()``) read on the worker.
    """

    index: int
    lower: tuple[int, int, int]
    upper: tuple[int, int, int]
    dimensions: tuple[int, int, int]
    spacing: tuple[float, float, float]
    origin: tuple[float, float, float]
    values: object
    cells: bool = False

    @property
    def bounds(self) -> tuple[float, ...]:
        """The whole grid's bounds ``(xmin, xmax, ymin, ymax, zmin, zmax)``."""
        hi = np.asarray(self.origin) + np.asarray(self.spacing) * (
            np.asarray(self.dimensions) - (0 if self.cells else 1))
        return tuple(float(v) for pair in zip(self.origin, hi, strict=True) for v in pair)

    def world_from_texture(self) -> np.ndarray:
        """4x4 from the whole grid's texture coordinates (texel centres on points) to world."""
        dims = np.asarray(self.dimensions, float)
        matrix = np.eye(4)
        matrix[:3, :3] = np.diag(np.asarray(self.spacing, float) * dims)
        matrix[:3, 3] = np.asarray(self.origin, float) - 0.5 * np.asarray(self.spacing, float)
        return matrix

    def grid_from_index(self) -> np.ndarray:
        """4x4 from the whole label grid's index space (voxel ``i`` spans ``[i, i+1]``).

        Made from the same numbers as a plotter drawing the whole grid makes it, so that
        a brick traverses its rays in the same frame, to the bit.
        """
        matrix = np.eye(4)
        matrix[:3, :3] = np.diag(np.asarray(self.spacing, float))
        matrix[:3, 3] = np.asarray(self.origin, float)
        return matrix

    def grid(self):
        """The slab as ``pyvista.ImageData`` in the whole grid's world coordinates."""
        import pyvista

        values = self.values.read() if hasattr(self.values, "read") else self.values
        values = np.asarray(values)
        expected = tuple(int(u - lo + (0 if self.cells else 1))
                         for lo, u in zip(self.lower, self.upper, strict=True))
        if values.shape != expected:
            raise ValueError(f"partition {self.index} read values of shape {values.shape}, "
                             f"expected {tuple(expected)}.")
        origin = [o + lo * d for o, lo, d in zip(self.origin, self.lower, self.spacing,
                                                 strict=True)]
        if self.cells:   # one voxel per cell
            grid = pyvista.ImageData(dimensions=np.asarray(values.shape) + 1,
                                     spacing=self.spacing, origin=origin)
            grid.cell_data["labels"] = values.ravel(order="F")
            return grid
        grid = pyvista.ImageData(dimensions=values.shape, spacing=self.spacing,
                                 origin=origin)
        grid.point_data["values"] = values.ravel(order="F")
        return grid


def _fit_camera(plotter, partition: Partition, camera: Camera) -> None:
    """The camera, its clipping range fitted to the whole grid (as one plotter fits it)."""
    camera.apply_to(plotter.camera)
    plotter.camera_set = True
    if camera.clipping_range is None:
        plotter.renderer.ResetCameraClippingRange(*partition.bounds)


class LabelView:
    """An offscreen plotter holding one slab of a label grid, drawn exactly as the whole.

    The voxel traversal is exact, so the slab's first hit at a pixel is the whole grid's
    whenever it is the nearest of the slabs'. Drawn without anti-aliasing (a silhouette
    pixel would mix in this plotter's background) and opaque (translucent labels would need
    every slab's layers, in depth order).
    """

    def __init__(self, partition: Partition, size: tuple[int, int], keywords: dict):
        self.partition = partition
        self.plotter = offscreen_plotter(size)
        try:
            self.plotter.disable_anti_aliasing()
            actor = add_voxels(self.plotter, partition.grid(), **keywords)
            actor.cubemarch.traverse_as_brick(partition.lower, partition.dimensions,
                                              partition.grid_from_index())
            opacity = actor.cubemarch.palette.rgba[1:, 3]
            if np.any((opacity > 0) & (opacity < 1)):
                raise ValueError("translucent labels cannot be split across partitions (the "
                                 "slabs are composited by depth); make them opaque or hide "
                                 "them.")
        except BaseException:
            self.plotter.close()
            raise

    def render(self, camera: Camera) -> tuple[np.ndarray, np.ndarray]:
        """The slab's RGB (uint8) and window depth (1: nothing), rows top to bottom."""
        _fit_camera(self.plotter, self.partition, camera)
        image = render_image(self.plotter)
        return image, read_depth(self.plotter).astype(np.float32)

    def close(self) -> None:
        self.plotter.close()


class PartitionView:
    """An offscreen plotter holding one partition, and the pass that marches it."""

    def __init__(self, partition: Partition, size: tuple[int, int], keywords: dict):
        blending = keywords.get("blending", "composite")
        if blending not in PARTITION_BLENDING:
            raise ValueError(f"blending={blending!r} cannot be split across partitions; "
                             f"use one of {PARTITION_BLENDING}.")
        self.partition = partition
        self.plotter = offscreen_plotter(size)
        # the pass draws into its own float targets: the window's multisampled buffers
        # would only be cleared and resolved every frame (14 ms a frame at 800x600)
        self.plotter.ren_win.SetMultiSamples(0)
        try:
            self._build(partition, keywords, blending)
        except BaseException:
            self.plotter.close()
            raise

    def _build(self, partition: Partition, keywords: dict, blending: str) -> None:
        plotter = self.plotter
        actor = add_volume(plotter, partition.grid(), technique="direct",
                           show_scalar_bar=False, **keywords)
        binding = actor.cubemarch
        actor.SetVisibility(False)   # the pass marches; the box draws nothing
        model, renderer = binding.model, plotter.renderer
        # the projections also keep the ray's raw state (the composite needs colour only)
        keeps_state = blending != "composite"
        march = RenderToTexturePass(renderer, None, size=lambda: drawn_viewport(renderer)[2:],
                                    targets=("rgba32f",) * (2 if keeps_state else 1),
                                    every_frame=True)
        sampling, defines = bind_sampling(march, binding.data, binding.step_scale,
                                          binding.stop_opacity, skip_empty=True,
                                          blend=Blend(blending))
        defines["CM_KEEP_STATE"] = keeps_state
        # composite: a second pass may draw chosen pixels again with their own stop opacity
        defines["CM_PIXEL_STOP"] = not keeps_state
        self._stops = Texture(np.full((1, 1), -1.0, np.float32), interpolate=False)
        self._redraw = False
        if not keeps_state:
            march.add_texture("cm_pixelStop", self._stops)
            march.set_uniform("cm_pixelStops", lambda: int(self._redraw))
            self._stops_origin = (0.0, 0.0)
            march.set_uniform("cm_pixelStopOrigin", lambda: self._stops_origin)
        bind_camera(march, renderer, lambda: world_from_texture(model))
        # The whole grid's frame, made alike in every partition from the same numbers (the
        # partitions' ownership of samples on a shared plane is decided in it).
        whole = np.asarray(partition.dimensions, float)
        whole_from_view = lambda: np.linalg.inv(  # noqa: E731
            camera_matrices(renderer)[0] @ partition.world_from_texture())
        march.set_uniform("cm_wholeTextureFromView", whole_from_view)
        march.set_uniform("cm_wholeDims", tuple(whole))
        lo = (np.asarray(partition.lower, float) + 0.5) / whole
        hi = (np.asarray(partition.upper, float) + 0.5) / whole
        march.set_uniform("cm_ownLo", tuple(lo))
        march.set_uniform("cm_ownHi", tuple(hi))
        march.set_recipe(ShaderRecipe(
            standalone=("pass_head", *DECLARATION_SNIPPETS, sampling, *SCREEN_DECLARATIONS,
                        *march_snippets(blending, defines), "pixel_ray", "screen_ray",
                        "ea_partition_main"),
            defines=defines))
        self.march, self.binding, self.blending = march, binding, blending

    def render(self, camera: Camera, stops: tuple | None = None
               ) -> tuple[np.ndarray, np.ndarray | None]:
        """The partition's float32 premultiplied RGBA for ``camera``, rows top to bottom.

        For the projections also the kept value and whether a sample was read. The
        clipping range is the camera's, or fitted to the whole grid's bounds (as one
        plotter holding the whole volume fits it), never to this partition's. ``stops``
        (composite only), ``(row0, col0, window)``: draw again only the window's pixels
        that hold a stop opacity (the rest negative), each ray stopping at its own; the
        other pixels are left transparent.
        """
        _fit_camera(self.plotter, self.partition, camera)
        region = None
        if stops is not None:
            if self.blending != "composite":
                raise ValueError("per-pixel stop opacities are for composite blending.")
            row, col, window = stops
            height = self.plotter.window_size[1]
            # the window's rows bottom to top, and where it lies in the targets
            region = (col, height - row - window.shape[0], window.shape[1], window.shape[0])
            self._stops.set_data(np.ascontiguousarray(window[::-1], np.float32))
            self._stops_origin = (float(region[0]), float(region[1]))
        self._redraw = stops is not None
        self.march.region = region
        try:
            render_frame(self.plotter)
        finally:
            self._redraw = False
            self.march.region = None
        if region is not None:   # the rest of the targets holds the first round's
            rgba = np.zeros((*self.march.size[::-1], 4), np.float32)
            row, col, window = stops
            rows, cols = slice(row, row + window.shape[0]), slice(col, col + window.shape[1])
            rgba[rows, cols] = self.march.read(0)[::-1][rows, cols]
            return rgba, None
        rgba = self.march.read(0)[::-1]
        if self.blending == "composite":
            return np.ascontiguousarray(rgba), None
        return np.ascontiguousarray(rgba), np.ascontiguousarray(self.march.read(1)[::-1, :, :2])

    def close(self) -> None:
        self._stops.release()
        self.plotter.close()
