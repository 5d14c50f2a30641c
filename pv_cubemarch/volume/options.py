"""The user's options of each volume technique, validated in one place.

Each technique's options are a frozen dataclass whose fields are exactly the ``add_volume``
parameters that technique reads; :func:`pv_cubemarch.add_volume` builds the chosen one from
what the user gave, so an option the technique ignores is an error, not a silent no-op.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..core.options import positive_number, whole_number
from ..models.lights import DEFAULT_AMBIENT, DEFAULT_LIGHT_MAP_SIZE
from .march import BLEND_MODES, MAX_ISOSURFACES, MAX_STEPS, Blend, most_texels

#: Default finest face size ``S_0`` of the cube map (texels per face edge at MIP level 0).
DEFAULT_FACE_SIZE = 256
#: Default ``k_z`` of the bilateral depth filter (000 uses 0.5), per cube-map texel of depth.
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


@dataclass(frozen=True)
class Shading:
    """Options every volume technique reads: termination, skipping, lights."""

    stop_opacity: float = DEFAULT_STOP_OPACITY
    skip_empty: bool = True
    light_map_size: int = DEFAULT_LIGHT_MAP_SIZE
    ambient: float = DEFAULT_AMBIENT
    blending: str = "composite"
    isosurfaces: tuple[float, ...] = ()

    def check(self) -> None:
        """Raise a clear error for a bad option."""
        if self.blending not in BLEND_MODES:
            raise ValueError(f"blending must be one of {BLEND_MODES}, got {self.blending!r}.")
        if self.blending == "isosurface" and not self.isosurfaces:
            raise ValueError("blending='isosurface' draws the levels given as isosurfaces=; "
                             "pass one or more values, e.g. isosurfaces=[100, 300].")
        if self.isosurfaces and self.blending != "isosurface":
            raise ValueError("isosurfaces= are the levels blending='isosurface' draws; pass "
                             "that blending with them, or leave them out.")
        if len(self.isosurfaces) > MAX_ISOSURFACES:
            raise ValueError(f"isosurfaces: at most {MAX_ISOSURFACES} levels, got "
                             f"{len(self.isosurfaces)}.")
        positive_number("stop_opacity", self.stop_opacity, 0.0, 1.0)
        whole_number("light_map_size", self.light_map_size, 2, 128)
        positive_number("ambient", self.ambient, 0.0, 1.0, closed_low=True)

    @property
    def blend(self) -> Blend:
        """The blend mode and its levels, as the marcher binds them."""
        return Blend(self.blending, tuple(self.isosurfaces))


@dataclass(frozen=True)
class MarchOptions:
    """``technique='vtk'``: the step along the ray."""

    step_scale: float = 0.5

    def check(self) -> None:
        """Raise a clear error for a bad option."""
        positive_number("step_scale", self.step_scale, 0.0, 1e3)

    def check_model(self, model) -> None:
        """Refuse a step that would ask a ray through ``model`` for more steps than it takes.

        The marcher takes any number of steps up to ``MAX_STEPS`` per ray (per piece of a
        ray in a joint group); beyond that the ray would be cut short, silently too light.
        """
        texels = most_texels(model)
        refuse_more_steps(f"step_scale={self.step_scale:g}", texels / float(self.step_scale),
                          f"step_scale >= {texels / MAX_STEPS:.3g}")


@dataclass(frozen=True)
class DirectOptions(MarchOptions):
    """``technique='direct'``: the step, and the resolution the rays are marched at."""

    downsample: int = 1

    def check(self) -> None:
        """Raise a clear error for a bad option."""
        super().check()
        whole_number("downsample", self.downsample, 1, 64)


@dataclass(frozen=True)
class CubeMapOptions:
    """``technique='cubemap'``: the cube map's size, samples, LOD and depth filter."""

    face_size: int = DEFAULT_FACE_SIZE
    max_samples: int | None = None
    upscale: float = 1.0
    sample_factor: float = 1.0
    occlusion_sharpness: float = DEFAULT_OCCLUSION_SHARPNESS

    def check(self) -> None:
        """Raise a clear error for a bad option."""
        size = whole_number("face_size", self.face_size, 1, 4096)
        if size & (size - 1):
            raise ValueError(f"face_size must be a power of two from 1 to 4096, got {size}.")
        if self.max_samples is not None:
            whole_number("max_samples", self.max_samples, 1)
        positive_number("upscale", self.upscale)
        positive_number("sample_factor", self.sample_factor)
        positive_number("occlusion_sharpness", self.occlusion_sharpness, closed_low=True)

    def check_model(self, model) -> None:
        """Refuse ``max_samples`` that would ask a ray for more steps than it takes."""
        samples = int(self.max_samples or default_max_samples(model))
        # The cube map steps (longest axis of the volume's own grid) / samples texels.
        steps = samples * most_texels(model) / max(max(model.dimensions) - 1, 1)
        refuse_more_steps(f"max_samples={samples:,}", steps,
                          f"max_samples <= {int(samples * MAX_STEPS / steps):,}")


@dataclass(frozen=True)
class AutoOptions(CubeMapOptions):
    """``technique='auto'``: the cube map's options and the direct marcher's step."""

    step_scale: float = 0.5

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
