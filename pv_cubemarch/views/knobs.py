"""The speed/accuracy knobs of each kind of technique, as data a panel turns into controls.

A knob is an option of ``add_volume``/``add_voxels``/``add_surface`` (or the technique, a
surface's isovalue, the voxel materials shown) with the range a user tunes it over;
``techniques`` names the techniques that read it (empty: every technique of its kind). An
``optional`` knob may be left unset (its choice :data:`AUTO`): the technique decides.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..core.registry import techniques
from ..volume.march import BLEND_MODES

#: The choice of an option left unset (``None``): the technique picks its value.
AUTO = "auto"


@dataclass(frozen=True)
class Knob:
    """One control: an option's name, how it is set, and over what."""

    name: str
    label: str
    control: str                  # 'slider', 'select', 'multiselect' or 'switch'
    low: float = 0.0
    high: float = 1.0
    step: float = 0.1
    choices: tuple = ()
    techniques: tuple[str, ...] = ()
    help: str = ""
    optional: bool = False        # AUTO (first choice) leaves the option unset

    def applies_to(self, technique: str) -> bool:
        """Whether ``technique`` reads this knob."""
        return not self.techniques or technique in self.techniques


def volume_knobs() -> tuple[Knob, ...]:
    """Emission/absorption: the technique and what trades its speed for accuracy."""
    return (
        Knob("technique", "technique", "select",
             choices=tuple(t.name for t in techniques("volume"))),
        Knob("step_scale", "step (texels)", "slider", 0.05, 2.0, 0.05,
             techniques=("vtk", "direct", "auto"), help="smaller: finer, slower"),
        Knob("stop_opacity", "stop opacity", "slider", 0.5, 1.0, 0.01,
             help="early ray termination"),
        Knob("downsample", "downsample", "select", choices=(1, 2, 4),
             techniques=("direct",), help="march at 1/N of the viewport"),
        Knob("face_size", "cube-map face", "select", choices=(64, 128, 256, 512, 1024),
             techniques=("cubemap", "auto"), help="texels per face edge"),
        Knob("max_samples", "max samples", "select", choices=(AUTO, 64, 128, 256, 512, 1024,
                                                              2048),
             techniques=("cubemap", "auto"), help="samples along the box diagonal",
             optional=True),
        Knob("blending", "blending", "select", choices=BLEND_MODES,
             help="composite, or the largest / smallest value along each ray"),
        Knob("lights", "lights", "select", choices=("none", "scene")),
        Knob("ambient", "ambient", "slider", 0.0, 1.0, 0.05),
    )


def voxel_knobs(materials: tuple[int, ...] = ()) -> tuple[Knob, ...]:
    """Voxel DDA blocks: traversal, occupancy levels, level of detail, materials shown."""
    return (
        Knob("traversal", "traversal", "select", choices=("dda", "fixed"),
             help="dda is exact; fixed steps may miss thin voxels"),
        Knob("mip_levels", "occupancy levels", "select", choices=(AUTO, *range(13)),
             optional=True),
        Knob("lod", "level of detail", "switch"),
        Knob("materials", "materials shown", "multiselect", choices=tuple(materials),
             help="a hidden material's voxels are traversed as empty"),
    )


def surface_knobs(isovalue_range: tuple[float, float] = (-1.0, 1.0)) -> tuple[Knob, ...]:
    """Active-cell surfaces: samples per diagonal, root finding, the level drawn.

    The level is a shift from the loaded isovalue (0: as loaded), applied to every surface.
    """
    low, high = isovalue_range
    return (
        Knob("steps", "steps (M)", "slider", 10, 5000, 10, help="samples along the diagonal"),
        Knob("root", "root", "select", choices=("march", "exact")),
        Knob("isovalue", "isovalue shift", "slider", low, high, (high - low) / 100 or 0.01),
    )
