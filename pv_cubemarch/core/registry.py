"""The technique registry: the public functions and the bench dispatch through it.

Each technique registers its options, builder, CPU reference and benchmark sweep.

Adding a technique is one :func:`register_technique` call in its own module; nothing else
is wired by hand.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass


def describe_setting(setting: dict) -> str:
    """``key=value, ...`` of a bench setting (the default row label)."""
    return ", ".join(f"{k}={v}" for k, v in setting.items() if k != "technique")


@dataclass(frozen=True)
class Sweep:
    """Quality settings of a technique for the speed/accuracy bench, each a dict of options."""

    settings: list[dict]
    describe: Callable[[dict], str] = describe_setting


@dataclass(frozen=True)
class Technique:
    """A technique as the public API and the bench see it.

    Parameters
    ----------
    name : str
        What users pass as ``technique=``.
    kind : str
        What it draws (``'volume'``; voxels and surfaces next), so each public function
        dispatches among its own kind.
    options : type
        A frozen dataclass whose fields are the options the technique reads, with
        ``check()`` raising a clear error for a bad value and ``check_model(model)`` for
        a value the data cannot take (e.g. more steps than a ray can march).
    build : callable
        ``build(plotter, model, options)`` for every kind: makes the technique's actor(s)
        and returns its binding: ``drawn`` (the actors that draw it), ``renderer`` (where
        they draw), ``needs_single_sample``, ``blends_in_main_renderer``,
        ``follow_anchor()`` and ``release()`` (see :class:`pv_cubemarch.gl.handle.
        DrawnBinding`). A volume's ``model`` is its GPU data and ``options`` a
        :class:`~pv_cubemarch.volume.binding.VolumeSetup` (technique options, shading,
        light map); voxels and surfaces take their model and options dataclass.
    reference : callable
        The CPU reference that says what its right image is.
    sweep : Sweep, optional
        Its settings for ``pv-cubemarch bench tradeoff``.
    summary : str
        One line for error messages and ``--help``.
    groups : bool
        Whether it can march a group of overlapping volumes jointly.
    """

    name: str
    kind: str
    options: type
    build: Callable
    reference: Callable
    sweep: Sweep | None = None
    summary: str = ""
    groups: bool = True
    #: For a technique that picks one of others per frame (``'auto'``): those it picks
    #: among; it marches nothing of its own.
    chooses_among: tuple[str, ...] = ()

    @property
    def option_names(self) -> tuple[str, ...]:
        """The options this technique reads."""
        return tuple(f.name for f in dataclasses.fields(self.options))

    def make_options(self, given: dict):
        """The technique's options from those the user gave (the rest keep defaults).

        An option the technique does not read is an error that names the techniques that
        read it.
        """
        unused = [name for name in given if name not in self.option_names]
        if unused:
            name = unused[0]
            users = [t.name for t in techniques(self.kind) if name in t.option_names]
            raise ValueError(
                f"{name} is not an option of technique={self.name!r}"
                + (f"; it is used by technique={' or '.join(map(repr, users))}" if users
                   else "") + ". Leave it out, or choose a technique that uses it.")
        options = self.options(**given)
        options.check()
        return options


_REGISTRY: dict[tuple[str, str], Technique] = {}


def register_technique(technique: Technique) -> Technique:
    """Make ``technique`` available to the public functions and the bench."""
    _REGISTRY[(technique.kind, technique.name)] = technique
    return technique


def techniques(kind: str) -> list[Technique]:
    """The registered techniques of ``kind``, by name (an order that import order cannot change)."""
    return sorted((t for (k, _), t in _REGISTRY.items() if k == kind), key=lambda t: t.name)


def specific_option_names(kind: str) -> set[str]:
    """The options some technique of ``kind`` reads (each technique reads only its own)."""
    return {name for t in techniques(kind) for name in t.option_names}


def get_technique(kind: str, name) -> Technique:
    """The technique ``name`` of ``kind``, or a ValueError listing the choices."""
    found = _REGISTRY.get((kind, name)) if isinstance(name, str) else None
    if found is None:
        names = tuple(t.name for t in techniques(kind))
        raise ValueError(f"technique must be one of {names}, got {name!r}.")
    return found
