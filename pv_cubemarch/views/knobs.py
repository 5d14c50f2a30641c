"""The speed/accuracy knobs of each kind of technique, as data a panel turns into controls.

A knob is an option of ``add_volume``/``add_voxels``/``add_surface`` with the range a user
tunes it over, made from the option's declaration (:mod:`pv_cubemarch.core.declared`), or
a surface's isovalue shift, or the voxel materials shown;
``techniques`` names the techniques that read it (empty: every technique of its kind). An
``optional`` knob may be left unset (its choice :data:`AUTO`): the technique decides.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..core.declared import AUTO, declared
from ..core.registry import techniques
from ..surfaces import options as _surface_options  # noqa: F401  (declares its options)
from ..volume import options as _volume_options  # noqa: F401  (declares its options)
from ..voxels import options as _voxel_options  # noqa: F401  (declares its options)

__all__ = ["AUTO", "Knob", "declared_knobs", "surface_knobs", "volume_knobs", "voxel_knobs"]


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


def declared_knobs(kind: str, **choices) -> list[Knob]:
    """A knob for every declared option of ``kind`` that has a control, in declared order.

    ``choices`` replaces the choices of the named knobs (the technique's, from the
    registry).
    """
    knobs = []
    for item in declared(kind):
        control = item.control
        if control is None:
            continue
        knobs.append(Knob(item.name, control.label or item.name.replace("_", " "),
                          control.kind, control.low, control.high, control.step,
                          tuple(choices.get(item.name, control.choices or item.choices)),
                          item.techniques, control.help,
                          optional=AUTO in (control.choices or ())))
    return knobs


def volume_knobs() -> tuple[Knob, ...]:
    """Emission/absorption: the technique and what trades its speed for accuracy."""
    return tuple(declared_knobs("volume", technique=[t.name for t in techniques("volume")]))


def voxel_knobs(materials: tuple[int, ...] = (), total: int | None = None
                ) -> tuple[Knob, ...]:
    """Voxel DDA blocks: their options, and the label ids shown.

    ``total``: how many ids the grids hold, said in the label when more than are listed.
    """
    listed = len(materials)
    label = "labels shown" if total is None or total <= listed else \
        f"labels shown ({total:,} ids; the first {listed} listed)"
    return (*declared_knobs("voxels"),
            Knob("materials", label, "multiselect", choices=tuple(materials),
                 help="label ids shown (the first 64 listed); a hidden label is traversed "
                      "as empty"))


def surface_knobs(isovalue_range: tuple[float, float] = (-1.0, 1.0)) -> tuple[Knob, ...]:
    """Active-cell surfaces: their options, and the level drawn.

    The level is a shift from the loaded isovalue (0: as loaded), applied to every surface.
    """
    low, high = isovalue_range
    return (*declared_knobs("surface", technique=[t.name for t in techniques("surface")]),
            Knob("isovalue", "isovalue shift", "slider", low, high, (high - low) / 100 or 0.01))
