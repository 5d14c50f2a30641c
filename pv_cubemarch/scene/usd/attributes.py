"""Reading authored attributes safely, and the ``cubemarch:*`` option tables of Volume prims."""

from __future__ import annotations

import re

from pxr import Usd

from ...core.declared import declared, usd_table
from ...core.errors import SceneLoadError
from ...surfaces import options as _surface_options  # noqa: F401  (declares its options)
from ...volume import options as _volume_options  # noqa: F401  (declares its options)
from ...voxels import options as _voxel_options  # noqa: F401  (declares its options)


def attr(prim, name: str, time=None):
    """The value of attribute ``name`` at ``time`` (default time), or ``None`` if not authored."""
    attribute = prim.GetAttribute(name)
    if not attribute or not attribute.HasValue():
        return None
    return attribute.Get(Usd.TimeCode.Default() if time is None else time)


#: ``cubemarch:*`` attributes of each kind of Volume prim and the options they set, from
#: the options' declarations (:func:`pv_cubemarch.core.declared.usd_table`).
VOLUME_OPTIONS = usd_table("volume")
VOXEL_OPTIONS = usd_table("voxels")
#: (with ``cubemarch:isovalue``, required)
SURFACE_OPTIONS = usd_table("surface")

#: The volume model's attributes (the transfer keywords, the interpolation), read where the
#: model is made: option name by attribute key, from the declarations.
MODEL_ATTRIBUTES = {o.usd_key: o for o in declared("volume") if o.model and o.usd_key}
#: Of those, what a voxels Volume prim reads too (the colormap of its palette).
SHARED_WITH_VOXELS = ("cmap",)
#: Volume attributes that a voxels Volume prim must not carry.
VOLUME_ONLY = tuple(key for key in (*MODEL_ATTRIBUTES, *(usd_key for usd_key, _, _ in
                                                          VOLUME_OPTIONS))
                    if key != "technique" and key not in SHARED_WITH_VOXELS
                    and key not in {k for k, _, _ in VOXEL_OPTIONS})


def options_error(name: str, authored_options: dict, kind: str,
                  error: ValueError) -> SceneLoadError:
    """A SceneLoadError naming the authored attributes the options' ``error`` is about."""
    named = [f"cubemarch:{key} = {value!r}" for key, (option, value) in authored_options.items()
             if re.search(rf"\b{option}\b", str(error))]
    return SceneLoadError(f"Volume {name}: {', '.join(named) or f'its {kind} options'}: "
                          f"{error}")


def authored(prim, name: str, table) -> dict:
    """The ``cubemarch:*`` options of ``table`` authored on ``prim``.

    ``{key: (option, value)}``, each converted to its kind (a SceneLoadError names a
    wrong one).
    """
    found = {}
    for key, option, kind in table:
        value = attr(prim, f"cubemarch:{key}")
        if value is not None:
            found[key] = (option, converted(name, key, value, kind))
    return found


def converted(name: str, key: str, value, kind):
    """An authored option value as ``kind``, or a SceneLoadError naming the attribute."""
    try:
        if kind is str:
            if not isinstance(value, str):
                raise TypeError
            return str(value)
        if kind is bool:
            if not isinstance(value, bool):
                raise TypeError
            return value
        if kind is int:
            if isinstance(value, (str, bool)) or float(value) != int(value):
                raise ValueError
            return int(value)
        if kind in (tuple, "color3f"):
            if isinstance(value, (str, bool)):
                raise TypeError
            numbers = tuple(float(v) for v in value)
            if kind == "color3f" and len(numbers) != 3:
                raise ValueError
            return numbers
        if isinstance(value, (str, bool)):
            raise TypeError
        return kind(value)
    except (TypeError, ValueError, OverflowError):
        expected = {str: "a string or token", int: "a whole number", float: "a number",
                    bool: "a bool", tuple: "an array of numbers (float[])",
                    "color3f": "a color3f"}[kind]
        raise SceneLoadError(f"Volume {name}: cubemarch:{key} must be {expected}, got "
                             f"{value!r}.") from None
