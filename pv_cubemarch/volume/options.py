"""The user's options of each volume technique, validated in one place.

Each technique's options are a frozen dataclass whose fields are exactly the ``add_volume``
parameters that technique reads; :func:`pv_cubemarch.add_volume` builds the chosen one from
what the user gave, so an option the technique ignores is an error, not a silent no-op.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..core.declared import (
    AUTO,
    Control,
    Option,
    check_declared,
    declare,
    preset_or_number,
    scalar_bar_terms,
)
from ..models.channels import CHANNEL_MIXES
from ..models.lights import DEFAULT_AMBIENT, DEFAULT_LIGHT_MAP_SIZE
from ..models.volume import INTERPOLATIONS
from .binding import BLEND_MODES, MAX_ISOSURFACES, MAX_STEPS, Blend, most_texels

#: Largest default finest face ``S_0`` of the cube map (texels per face edge at MIP level
#: 0); a smaller grid gets :func:`fitting_face_size`.
DEFAULT_FACE_SIZE = 256
#: Default ``sample_factor`` (k_c): two samples per texel of the level of detail, on the
#: front where one is not (``bench dial``: 4.7-11 dB more for 20-30 % more time on the CT
#: phantom and the cells, within 0.6 dB on the smoke).
DEFAULT_SAMPLE_FACTOR = 2.0
#: Smallest default face (texels per edge).
SMALLEST_DEFAULT_FACE = 32


def fitting_face_size(dimensions) -> int:
    """The cube map's default face for a grid: twice its longest axis, to a power of two.

    From :data:`SMALLEST_DEFAULT_FACE` to :data:`DEFAULT_FACE_SIZE`. A finer face adds no
    detail of the data and costs its texels squared; a coarser one blurs the box's edges
    when a small grid fills the view (a 21-point grid at 100x80: 39.9 dB against
    PyVista at face 32, 46.2 at 64 and at 256). ``bench dial``, with the default two
    samples per texel: on a 64³ CT phantom face 128 gives 52.5 dB in 15 ms where 256 at
    one sample gave 40 dB in 14 ms; on a 72-point cell grid 48.9 dB in 18 ms against
    36.5 dB in 40 ms.
    """
    longest = max(int(n) for n in dimensions)
    fitted = 1 << max(0, math.ceil(math.log2(max(2 * longest, 1))))
    return int(min(DEFAULT_FACE_SIZE, max(SMALLEST_DEFAULT_FACE, fitted)))
#: Default ``k_z`` of the bilateral depth filter (the cube-map paper's), per cube-map texel of
#: depth.
DEFAULT_OCCLUSION_SHARPNESS = 0.5
#: ``step_scale`` values of the speed/accuracy sweeps of the marching techniques.
STEP_SCALES = (2.0, 1.0, 0.5, 0.25, 0.125)
#: Default early-termination opacity (VTK's own loop also stops above 1 - 1/255).
DEFAULT_STOP_OPACITY = 0.99


def refuse_more_steps(setting: str, steps: float, instead: str) -> None:
    """A ValueError when ``setting`` asks a ray for more steps than the marcher takes."""
    if steps > MAX_STEPS:
        raise ValueError(f"{setting} asks for up to {steps:,.0f} steps per ray, more than the "
                         f"{MAX_STEPS:,} steps a ray can take (it would be cut short); use "
                         f"{instead}.")


def default_max_samples(model) -> int:
    """Two samples per texel along the cube's diagonal (the direct marcher's default step)."""
    return max(1, 2 * (max(model.dimensions) - 1))


#: Colormaps and opacity presets the live view offers (any name works elsewhere).
KNOB_CMAPS = ("viridis", "magma", "inferno", "plasma", "cividis", "gray", "bone", "coolwarm",
              "jet", "tab20")
KNOB_OPACITIES = ("linear", "linear_r", "sigmoid", "sigmoid_r", "geom", "geom_r")
#: Why a range or a length has no live-view control.
NO_KNOB_UNITS = "a value in the data's own units: give it in Python, on the CLI or in USD"

#: Why the keywords of multiscale sources have no CLI flag, USD attribute or knob yet.
PAGED_ONLY = dict.fromkeys(
    ("usd", "knob"), "read only for a multiscale source (an OME-Zarr pyramid, a zarr or "
    "dask array) given to add_volume or to pv-cubemarch render; USD Volume prims and the "
    "live view's knobs read their grids whole")

#: Why the channel keywords have no CLI flag, USD attribute or knob yet.
COMPONENTS_WHEN_READ = ("decided when the data are read: a grid file's 2-4 components are "
                        "channels, 4 uint8 RGBA; set cubemarch:independentComponents in USD "
                        "or independent_components= in Python to choose")

MARCHERS = ("vtk", "direct", "auto")
CUBE_MAPS = ("cubemap", "auto")
#: Every option of the volume techniques, declared once (:mod:`pv_cubemarch.core.declared`).
TECHNIQUE, STEP_SCALE, STOP_OPACITY, SKIP_EMPTY, DOWNSAMPLE, FACE_SIZE, MAX_SAMPLES, UPSCALE, \
    SAMPLE_FACTOR, OCCLUSION_SHARPNESS, BLENDING, ISOSURFACES, INTERPOLATION, LIGHTS, \
    LIGHT_MAP_SIZE, LIGHT_MAP_AMBIENT, SHADE, AMBIENT, DIFFUSE, SPECULAR, SPECULAR_POWER, \
    CMAP, OPACITY, CLIM, OPACITY_UNIT_DISTANCE, N_COLORS, FLIP_SCALARS, LOG_SCALE, \
    CATEGORIES, LOD_BIAS, GPU_BYTES, HOST_BYTES, BRICK_SIZE, INDEPENDENT_COMPONENTS, \
    CHANNEL_BLENDING, CLIP_PLANES, CROP_BOX, AVERAGE_RANGE, QUALITY, FRAME_BUDGET_MS = declare(
        Option("technique", "volume", str, "vtk", "how the rays are set up and drawn",
               control=Control("select")),
        Option("step_scale", "volume", float, 0.5, "step along the ray, in texels of the "
               "ray's dominant axis", MARCHERS, low=0.0, high=1e3, closed_low=False,
               control=Control("slider", "step (texels)", 0.05, 2.0, 0.05,
                               help="smaller: finer, slower")),
        Option("stop_opacity", "volume", float, DEFAULT_STOP_OPACITY, "opacity at which a "
               "ray stops (early termination)", low=0.0, high=1.0, closed_low=False,
               control=Control("slider", "stop opacity", 0.5, 1.0, 0.01,
                               help="early ray termination")),
        Option("skip_empty", "volume", bool, True, "step over bricks whose data the "
               "transfer function makes transparent", control=Control("switch",
                                                                      "skip empty")),
        Option("downsample", "volume", int, 1, "march at 1/N of the viewport, then upsample",
               ("direct",), low=1, high=64,
               control=Control("select", choices=(1, 2, 4),
                               help="march at 1/N of the viewport")),
        Option("face_size", "volume", int, DEFAULT_FACE_SIZE, "texels per edge of the "
               "cube map's finest face (a power of two; by default twice the grid's longest "
               "axis, at most this)", CUBE_MAPS, low=1, high=4096,
               control=Control("select", "cube-map face", choices=(64, 128, 256, 512, 1024),
                               help="texels per face edge")),
        Option("max_samples", "volume", int, None, "most samples along the box diagonal "
               "(default two per texel)", CUBE_MAPS, low=1, optional=True,
               control=Control("select", choices=(AUTO, 64, 128, 256, 512, 1024, 2048),
                               help="samples along the box diagonal")),
        Option("upscale", "volume", float, 1.0, "screen pixels per cube-map texel", CUBE_MAPS,
               low=0.0, closed_low=False, control=Control("slider", "upscale", 0.5, 4.0,
                                                          0.25)),
        Option("sample_factor", "volume", float, DEFAULT_SAMPLE_FACTOR, "samples per texel "
               "of the cube map's level of detail", CUBE_MAPS, low=0.0, closed_low=False,
               control=Control("slider", "sample factor", 0.25, 4.0, 0.25)),
        Option("occlusion_sharpness", "volume", float, DEFAULT_OCCLUSION_SHARPNESS, "k_z of "
               "the cube map's bilateral depth filter, per texel of depth", CUBE_MAPS,
               low=0.0, control=Control("slider", "occlusion sharpness", 0.0, 4.0, 0.25)),
        Option("blending", "volume", str, "composite", "how the samples along a ray make "
               "its colour, as VTK's blend modes", choices=BLEND_MODES,
               control=Control("select", help="composite, projections, grey averages or "
                               "sums, isosurfaces")),
        Option("isosurfaces", "volume", tuple, None, "levels (data units), or their count "
               "over the data's range, that blending='isosurface' draws", optional=True,
               control=Control("select", "isosurfaces (count)", choices=(AUTO, 1, 2, 3, 5,
                                                                         8))),
        Option("interpolation", "volume", str, None, "how values are read between points "
               "(default: linear)", choices=INTERPOLATIONS, optional=True, model=True,
               control=Control("select", choices=(AUTO, *INTERPOLATIONS))),
        Option("lights", "volume", str, None, "light the medium by the scene's lights "
               "(its transmittance toward each; a file without lights: PyVista's three "
               "lights)", choices=("scene", "none"), optional=True,
               control=Control("select", choices=("none", "scene"))),
        Option("light_map_size", "volume", int, DEFAULT_LIGHT_MAP_SIZE, "light-map points "
               "per axis (with lights)", low=2, high=128,
               control=Control("select", "light map", choices=(8, 16, 32, 64))),
        Option("light_map_ambient", "volume", float, DEFAULT_AMBIENT, "share of the emission "
               "no light modulates (with lights; not VTK's shading ambient)", low=0.0,
               high=1.0, control=Control("slider", "light-map ambient", 0.0, 1.0, 0.05)),
        Option("shade", "volume", bool, False, "gradient shading by the renderer's lights, "
               "as VTK's volume mapper shades", control=Control("switch", "shade")),
        Option("ambient", "volume", float, 0.1, "ambient term of the gradient shading",
               low=0.0, high=1.0, control=Control("slider", "ambient", 0.0, 1.0, 0.05)),
        Option("diffuse", "volume", float, 0.7, "diffuse term of the gradient shading",
               low=0.0, high=1.0, control=Control("slider", "diffuse", 0.0, 1.0, 0.05)),
        Option("specular", "volume", float, 0.2, "specular term of the gradient shading",
               low=0.0, high=1.0, control=Control("slider", "specular", 0.0, 1.0, 0.05)),
        Option("specular_power", "volume", float, 10.0, "specular exponent of the gradient "
               "shading", low=0.0, high=128.0, closed_low=False,
               control=Control("slider", "specular power", 1.0, 128.0, 1.0)),
        # The transfer keywords: set on the volume's model where it is made (model=True).
        Option("cmap", "volume", str, None, "colormap of the emitted colour (PyVista's "
               "theme colormap by default)", optional=True, model=True,
               control=Control("select", "colormap", choices=(AUTO, *KNOB_CMAPS))),
        Option("opacity", "volume", str, "linear", "opacity preset, constant or curve over "
               "clim (per opacity_unit_distance)", model=True, parse=preset_or_number,
               control=Control("select", choices=KNOB_OPACITIES)),
        Option("clim", "volume", tuple, None, "scalar range of the colormap and opacity, in "
               "the data's units (the data range by default)", optional=True, model=True,
               without={"knob": NO_KNOB_UNITS}),
        Option("opacity_unit_distance", "volume", float, None, "world length the opacity "
               "refers to (PyVista's default: the diagonal over mean points less one)",
               low=0.0, closed_low=False, optional=True, model=True,
               without={"knob": NO_KNOB_UNITS}),
        Option("n_colors", "volume", int, 256, "colours of the colormap (rows of the "
               "transfer table)", low=1, high=16384, model=True,
               control=Control("select", "colours", choices=(2, 4, 8, 16, 64, 256, 1024))),
        Option("flip_scalars", "volume", bool, False, "reverse the colormap", model=True,
               control=Control("switch", "flip colormap")),
        Option("log_scale", "volume", bool, False, "map colours over clim logarithmically",
               model=True, control=Control("switch", "log scale")),
        Option("categories", "volume", bool, False, "as many colours as the data has "
               "distinct values (a number in Python: that many)", model=True,
               control=Control("switch", "categories")),
        # Multiscale sources streamed by bricks (volume/paged.py): set on the pager.
        Option("lod_bias", "volume", float, None, "levels added to the one whose points fit "
               "a pixel (multiscale sources; -30: the finest everywhere)", optional=True,
               model=True, usd=None, without=PAGED_ONLY),
        Option("gpu_bytes", "volume", int, None, "GPU budget in bytes of a multiscale source's "
               "brick pool (256 MiB by default)", low=1, optional=True, model=True, usd=None,
               without=PAGED_ONLY),
        Option("host_bytes", "volume", int, None, "host budget in bytes of a multiscale source's "
               "read bricks (2 GiB by default)", low=1, optional=True, model=True, usd=None,
               without=PAGED_ONLY),
        Option("brick_size", "volume", int, None, "points along a brick's edge (32 by "
               "default)", low=1, high=1024, optional=True, model=True, usd=None,
               without=PAGED_ONLY),
        # How a multi-component array is drawn: RGBA or channels (models/channels.py).
        Option("independent_components", "volume", bool, None, "2 to 4 components as "
               "channels, each its own transfer function (4 uint8: RGBA unless True)",
               optional=True, model=True, cli=None,
               without=dict(cli=COMPONENTS_WHEN_READ, knob=COMPONENTS_WHEN_READ)),
        Option("channel_blending", "volume", str, None, "how a channel volume's channels "
               "mix: one medium, or each alone with their light added", optional=True,
               choices=CHANNEL_MIXES, model=True,
               control=Control("select", "channels", choices=(AUTO, *CHANNEL_MIXES))),
        Option("clip_planes", "volume", tuple, None, "planes that cut the volume, six "
               "numbers each: a point, then the normal to the side kept", optional=True,
               without={"knob": "a plane is moved with PyVista's clip-plane widget "
                                "(plotter.add_volume_clip_plane) in Python"}),
        Option("crop_box", "volume", tuple, None, "the box kept, in the data's coordinates "
               "(xmin, xmax, ymin, ymax, zmin, zmax), as the mapper's cropping planes",
               optional=True,
               without={"knob": "six numbers in the data's units; set in Python, the CLI or "
                                "USD (mapper.SetCroppingRegionPlanes moves it)"}),
        Option("average_range", "volume", tuple, None, "the values (data units) that "
               "blending='average' averages, as VTK's AverageIPScalarRange", optional=True,
               without={"knob": NO_KNOB_UNITS}),
        Option("quality", "volume", str, None, "error budget: the cheapest step (or cube-map "
               "face) whose PSNR against the CPU reference meets this many dB, or fast / "
               "balanced / best (30 / 40 / 50)", ("vtk", "direct", "cubemap", "auto"),
               optional=True,
               parse=preset_or_number,
               control=Control("select", "quality", choices=(AUTO, "fast", "balanced", "best"),
                               help="calibrated against the CPU reference")),
        Option("frame_budget_ms", "volume", float, None, "while the view moves, the finest "
               "step (then fewer pixels: 'vtk', 'direct' with downsample; cube map: upscale) "
               "keeping frames within this many ms (the still one when it stops)",
               ("vtk", "direct", "cubemap", "auto"), low=0.0, closed_low=False,
               optional=True,
               control=Control("select", "frame budget (ms)", choices=(AUTO, 16, 33, 66, 100),
                               help="coarser while the view moves")),
    )
#: The scalar bar's keywords, as every kind declares them.
declare(*scalar_bar_terms("volume"))


@dataclass(frozen=True)
class CommonVolumeOptions:
    """Options every volume technique reads: termination, skipping, lights."""

    stop_opacity: float = STOP_OPACITY.field()
    skip_empty: bool = SKIP_EMPTY.field()
    light_map_size: int = LIGHT_MAP_SIZE.field()
    light_map_ambient: float = LIGHT_MAP_AMBIENT.field()
    blending: str = BLENDING.field()
    isosurfaces: tuple[float, ...] = ()   # in stored units (ISOSURFACES as add_volume reads)
    gradient: object = None               # GradientShading with shade=True

    def check(self) -> None:
        """Raise a clear error for a bad option."""
        check_declared(self)
        if self.blending == "isosurface" and not self.isosurfaces:
            raise ValueError("blending='isosurface' draws the levels given as isosurfaces=; "
                             "pass one or more values, e.g. isosurfaces=[100, 300] "
                             "(--isosurfaces 100 300 on the command line, "
                             "cubemarch:isosurfaces in USD).")
        if self.isosurfaces and self.blending != "isosurface":
            raise ValueError("isosurfaces= are the levels blending='isosurface' draws; pass "
                             "that blending with them, or leave them out.")
        if len(self.isosurfaces) > MAX_ISOSURFACES:
            raise ValueError(f"isosurfaces: at most {MAX_ISOSURFACES} levels, got "
                             f"{len(self.isosurfaces)}.")

    @property
    def blend(self) -> Blend:
        """The blend mode and its levels, as the marcher binds them."""
        return Blend(self.blending, tuple(self.isosurfaces), self.gradient)


@dataclass(frozen=True)
class MarchOptions:
    """``technique='vtk'``: the step along the ray."""

    step_scale: float = STEP_SCALE.field()

    def check(self) -> None:
        """Raise a clear error for a bad option."""
        check_declared(self)

    def check_model(self, model) -> None:
        """Refuse a step that would ask a ray through ``model`` for more steps than it takes.

        The marcher takes any number of steps up to ``MAX_STEPS`` per ray (per piece of a
        ray in a joint group); beyond that the ray would be cut short, silently too light.
        """
        texels = most_texels(model)
        given = " (the default)" if self.step_scale == STEP_SCALE.default else ""
        refuse_more_steps(f"step_scale={self.step_scale:g}{given}",
                          texels / float(self.step_scale),
                          f"step_scale >= {texels / MAX_STEPS:.3g}")


@dataclass(frozen=True)
class DirectOptions(MarchOptions):
    """``technique='direct'``: the step, and the resolution the rays are marched at."""

    downsample: int = DOWNSAMPLE.field()


@dataclass(frozen=True)
class CubeMapOptions:
    """``technique='cubemap'``: the cube map's size, samples, LOD and depth filter."""

    face_size: int = FACE_SIZE.field()
    max_samples: int | None = MAX_SAMPLES.field()
    upscale: float = UPSCALE.field()
    sample_factor: float = SAMPLE_FACTOR.field()
    occlusion_sharpness: float = OCCLUSION_SHARPNESS.field()

    def check(self) -> None:
        """Raise a clear error for a bad option."""
        check_declared(self)
        size = int(self.face_size)
        if size & (size - 1):
            raise ValueError(f"face_size must be a power of two from 1 to 4096, got {size}.")

    def check_model(self, model) -> None:
        """Refuse ``max_samples`` that would ask a ray for more steps than it takes."""
        samples = int(self.max_samples or default_max_samples(model))
        # The cube map steps (longest axis of the volume's own grid) / samples texels.
        steps = samples * most_texels(model) / max(max(model.dimensions) - 1, 1)
        given = "" if self.max_samples else " (the default: two per texel)"
        refuse_more_steps(f"max_samples={samples:,}{given}", steps,
                          f"max_samples <= {int(samples * MAX_STEPS / steps):,}")


@dataclass(frozen=True)
class AutoOptions(CubeMapOptions):
    """``technique='auto'``: the cube map's options and the direct marcher's step."""

    step_scale: float = STEP_SCALE.field()

    def check(self) -> None:
        """Raise a clear error for a bad option."""
        super().check()
        self.direct.check()

    def check_model(self, model) -> None:
        """Both paths' step limits."""
        self.cubemap.check_model(model)
        self.direct.check_model(model)

    @property
    def direct(self) -> DirectOptions:
        """The direct marcher's part."""
        return DirectOptions(step_scale=self.step_scale)

    @property
    def cubemap(self) -> CubeMapOptions:
        """The cube map's part."""
        return CubeMapOptions(self.face_size, self.max_samples, self.upscale,
                              self.sample_factor, self.occlusion_sharpness)
