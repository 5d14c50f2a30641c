"""Options declared once: what each is, and every channel that sets it.

An :class:`Option` says an option's type, default, range or choices, one line of
documentation, which techniques read it, and how each channel spells it: the Python
keyword (its name), the ``pv-cubemarch render`` flag, the USD ``cubemarch:*`` attribute
and the live view's control. The options dataclasses take their fields' defaults and
checks from it; the CLI, the USD tables, the knobs and ``docs/options.md`` are generated
from it, and a test fails when an option lacks a channel without saying why.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from .options import positive_number, whole_number

#: The kinds of technique, as the registry names them.
KINDS = ("volume", "voxels", "surface")
#: The channels besides Python: each option has one or says why not (``without``).
CHANNELS = ("cli", "usd", "knob")
#: The choice of an optional option left unset (``None``): the technique picks its value.
AUTO = "auto"
#: A channel's name derived from the option's (camelCase attribute, kebab-case flag).
DERIVED = "derived"


@dataclass(frozen=True)
class Control:
    """How the live view tunes an option: a slider over a range, a select, a switch."""

    kind: str                       # 'slider', 'select' or 'switch'
    label: str = ""
    low: float = 0.0
    high: float = 1.0
    step: float = 0.1
    choices: tuple = ()             # a select's; the option's own choices when empty
    help: str = ""


def preset_or_number(word: str):
    """A flag's word that is a number or a preset's name (opacity, quality)."""
    try:
        return float(word)
    except ValueError:
        return word


@dataclass(frozen=True)
class Option:
    """One option of ``add_volume``, ``add_voxels`` or ``add_surface``, for every channel.

    ``type`` is ``float``, ``int``, ``bool``, ``str`` or ``tuple`` (of numbers);
    ``optional``: ``None`` is a value (the technique decides). ``low`` / ``high`` bound a
    number (``closed_low``: ``low`` itself allowed). ``usd`` / ``cli``: the attribute key
    (after ``cubemarch:``) and the flag, :data:`DERIVED` from the name by default, ``None``
    for none, with the reason in ``without``. ``model``: set on the data model where it is
    made (its USD attribute read there), not on the technique's options. ``usd_type``:
    how the attribute is read where it differs from ``type`` (``'color3f'``). ``parse``:
    how the flag's word becomes the value where ``type`` does not say (a preset or a
    number).
    """

    name: str
    kind: str
    type: type
    default: object
    doc: str
    techniques: tuple[str, ...] = ()
    choices: tuple = ()
    low: float | None = None
    high: float | None = None
    closed_low: bool = True
    optional: bool = False
    usd: str | None = DERIVED
    cli: str | None = DERIVED
    control: Control | None = None
    without: dict = field(default_factory=dict)
    model: bool = False
    usd_type: object = None
    parse: object = None

    @property
    def usd_key(self) -> str | None:
        """The ``cubemarch:<key>`` attribute, or ``None``."""
        if self.usd != DERIVED:
            return self.usd
        head, *rest = self.name.split("_")
        return head + "".join(part.title() for part in rest)

    @property
    def flag(self) -> str | None:
        """The ``pv-cubemarch render`` flag, or ``None``."""
        return "--" + self.name.replace("_", "-") if self.cli == DERIVED else self.cli

    @property
    def dest(self) -> str | None:
        """The attribute of the parsed arguments that holds the flag's value."""
        return None if self.flag is None else self.flag[2:].replace("-", "_")

    @property
    def attribute_type(self):
        """How the USD attribute is read: ``usd_type``, else ``type``."""
        return self.usd_type or self.type

    def reads(self, technique: str) -> bool:
        """Whether ``technique`` reads this option."""
        return not self.techniques or technique in self.techniques

    def field(self):
        """A dataclass field with this option's default (and the option as its metadata)."""
        return dataclasses.field(default=self.default, metadata={"option": self})

    def check(self, value) -> None:
        """Raise a ValueError naming the option when ``value`` is not one it takes."""
        if value is None and (self.optional or self.default is None):
            return
        if self.choices:
            if value not in self.choices:
                raise ValueError(f"{self.name} must be one of {self.choices}, got {value!r}.")
        elif self.type is bool:
            if not isinstance(value, (bool, np.bool_)):
                raise ValueError(f"{self.name} must be True or False, got {value!r}.")
        elif self.type is int:
            whole_number(self.name, value, int(self.low if self.low is not None else 0),
                         None if self.high is None else int(self.high))
        elif self.type is float:
            positive_number(self.name, value, -np.inf if self.low is None else self.low,
                            np.inf if self.high is None else self.high, self.closed_low)

    def describe_range(self) -> str:
        """The values it takes, for tables and ``--help``."""
        if self.choices:
            return " / ".join(str(c) for c in self.choices)
        if self.type in (int, float) and (self.low is not None or self.high is not None):
            low = "-inf" if self.low is None else f"{self.low:g}"
            high = "inf" if self.high is None else f"{self.high:g}"
            return f"{'[' if self.closed_low else '('}{low}, {high}]"
        return {bool: "True / False", tuple: "numbers"}.get(self.type, "")


def blinn_terms(kind: str) -> tuple[Option, Option, Option, Option]:
    """``ambient``, ``diffuse``, ``specular``, ``specular_power`` of a kind's shading.

    As VTK lights a mesh: colour * (ambient + diffuse * the lights' sum) + the highlight.
    """
    return (
        Option("ambient", kind, float, 0.2, "ambient term of the shading (added, as VTK's)",
               low=0.0, high=1.0, control=Control("slider", "ambient", 0.0, 1.0, 0.05)),
        Option("diffuse", kind, float, 0.8, "diffuse term: how much of the lights' colour a "
               "face facing them takes (PyVista's add_mesh: 1)", low=0.0, high=1.0,
               control=Control("slider", "diffuse", 0.0, 1.0, 0.05)),
        Option("specular", kind, float, 0.3, "highlight weight (blinn)", low=0.0, high=1.0,
               control=Control("slider", "specular", 0.0, 1.0, 0.05)),
        Option("specular_power", kind, float, 30.0, "highlight exponent (blinn)", low=0.0,
               high=1e4, closed_low=False,
               control=Control("slider", "specular power", 1.0, 200.0, 1.0)))


#: Why a scalar bar's keywords given as dicts have no flag, attribute or knob.
NO_DICT_CHANNEL = "a dict of keywords (PyVista's): give it in Python"


def scalar_bar_terms(kind: str) -> tuple[Option, Option, Option]:
    """``show_scalar_bar``, ``scalar_bar_args``, ``annotations``: a kind's scalar bar."""
    return (
        Option("show_scalar_bar", kind, bool, False, "add a scalar bar of what colours it "
               "(off by default, unlike PyVista)",
               control=Control("switch", "scalar bar",
                               help="the bar leaves with the item, as PyVista's does")),
        Option("scalar_bar_args", kind, dict, None, "keywords of plotter.add_scalar_bar",
               optional=True, usd=None, cli=None,
               without={"usd": NO_DICT_CHANNEL, "cli": NO_DICT_CHANNEL,
                        "knob": NO_DICT_CHANNEL}),
        Option("annotations", kind, dict, None, "value to label, shown on the scalar bar",
               optional=True, usd=None, cli=None,
               without={"usd": NO_DICT_CHANNEL, "cli": NO_DICT_CHANNEL,
                        "knob": NO_DICT_CHANNEL}))


_DECLARED: dict[tuple[str, str], Option] = {}


def declare(*options: Option) -> tuple[Option, ...]:
    """Register ``options`` (each kind's options module declares its own); returns them."""
    for option in options:
        if option.kind not in KINDS:
            raise ValueError(f"Option {option.name!r}: kind must be one of {KINDS}.")
        _DECLARED[(option.kind, option.name)] = option
    return options


def declared(kind: str | None = None) -> list[Option]:
    """The declared options of ``kind`` (every kind by default), in declaration order."""
    return [o for (k, _), o in _DECLARED.items() if kind is None or k == kind]


def option(kind: str, name: str) -> Option:
    """The declaration of option ``name`` of ``kind``."""
    return _DECLARED[(kind, name)]


def check_declared(options) -> None:
    """Check every field of an options dataclass against its declaration.

    A float option given a whole number (``step_scale=16``) is held as a float: GL takes
    a float uniform from a float only (set as an int it stays 0, and a ray stepping by 0
    never ends).
    """
    for item in dataclasses.fields(options):
        declaration = item.metadata.get("option")
        if declaration is not None:
            value = getattr(options, item.name)
            declaration.check(value)
            if declaration.type is float and not declaration.choices and isinstance(
                    value, (int, np.integer)) and not isinstance(value, (bool, np.bool_)):
                object.__setattr__(options, item.name, float(value))


def usd_table(kind: str) -> tuple[tuple[str, str, object], ...]:
    """``(attribute key, option, type)`` of the options of ``kind`` a prim sets as options.

    Options set on the data model (``model=True``) are read where the model is made.
    """
    return tuple((o.usd_key, o.name, o.attribute_type) for o in declared(kind)
                 if o.usd_key is not None and not o.model)


def options_markdown() -> str:
    """``docs/options.md``: a table per kind of every declared option and its channels."""
    titles = {"volume": "Volumes (`add_volume`)", "voxels": "Voxels (`add_voxels`)",
              "surface": "Surfaces (`add_surface`)"}
    lines = ["# Options", "",
             "Generated from the options' declarations (`pv_cubemarch.core.declared`) by",
             "`pv-cubemarch options > docs/options.md`; a test fails when it",
             "is out of date. Each option is a keyword of the Python function, a flag of",
             "`pv-cubemarch render`, a `cubemarch:*` attribute of a USD Volume prim and a",
             "control of the live view, or says why not.", ""]
    for kind in KINDS:
        lines += [f"## {titles[kind]}", "",
                  "| option | default | values | techniques | CLI flag | USD attribute | "
                  "live view | what |",
                  "|---|---|---|---|---|---|---|---|"]
        for item in declared(kind):
            usd = f"cubemarch:{item.usd_key}" if item.usd_key else None
            knob = item.control.kind if item.control else None
            shown = [f"`{value}`" if value else f"none: {item.without.get(name, '?')}"
                     for name, value in (("cli", item.flag), ("usd", usd), ("knob", knob))]
            lines.append(f"| `{item.name}` | `{item.default!r}` | {item.describe_range()} | "
                         f"{', '.join(item.techniques) or 'all'} | {' | '.join(shown)} | "
                         f"{item.doc} |")
        lines.append("")
    return "\n".join(lines)

