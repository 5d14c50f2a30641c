"""The returned volume's property and mapper, as PyVista users set them after ``add_volume``.

They read what is drawn. At each frame a change the marchers follow is drawn (the
interpolation, unit distance, blend mode, shading and its terms, and the colours, as
PyVista's property follows its lookup table); any other is refused, naming the keyword
that draws it, and put back, so no frame shows a setting it ignores.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pyvista

from ..core import vtk_classes as vtk
from ..core.errors import RefusedChangeError, VolumeDataError
from ..core.user_warnings import warn_user
from ..models.group import VolumeGroup
from ..models.transfer import REFINED_ROWS, TransferFunction, transfer_for_lookup_table
from .gradient_shading import GradientShading, ShadeMaterial

#: VTK's blend mode of each ``blending=`` (what ``vol.mapper.GetBlendMode()`` reads).
VTK_BLEND_MODES = {"composite": vtk.vtkVolumeMapper.COMPOSITE_BLEND,
                   "maximum": vtk.vtkVolumeMapper.MAXIMUM_INTENSITY_BLEND,
                   "minimum": vtk.vtkVolumeMapper.MINIMUM_INTENSITY_BLEND,
                   "average": vtk.vtkVolumeMapper.AVERAGE_INTENSITY_BLEND,
                   "additive": vtk.vtkVolumeMapper.ADDITIVE_BLEND,
                   "isosurface": vtk.vtkVolumeMapper.ISOSURFACE_BLEND}
BLEND_NAMES = {mode: name for name, mode in VTK_BLEND_MODES.items()}
#: VTK's interpolation types, by PyVista's names (VTK's volume property takes no other).
INTERPOLATION_TYPES = {vtk.VTK_NEAREST_INTERPOLATION: "nearest",
                       vtk.VTK_LINEAR_INTERPOLATION: "linear"}
TERMS = ("ambient", "diffuse", "specular", "specular_power")
#: What each refused setting is given as instead.
INSTEAD = {
    "opacity_unit_distance": "add_volume(..., opacity_unit_distance=...)",
    "independent_components": "add_volume(..., independent_components=...) again: a "
                              "grid's array of 2 to 4 components is drawn as channels",
    "ambient": "add_volume(..., shade=True, ambient=...)",
    "diffuse": "add_volume(..., shade=True, diffuse=...)",
    "specular": "add_volume(..., shade=True, specular=...)",
    "specular_power": "add_volume(..., shade=True, specular_power=...)",
    "image_sample_distance": "technique='vtk', whose mapper draws at 1/d of the viewport, or "
                             "downsample= with technique='direct'",
    "lookup_table": "add_volume(..., cmap=...) again (an RGBA volume's colours are its "
                    "data; channels take one colormap each, cmap=[...]; volumes marched "
                    "jointly their members')",
    "colors": "vol.prop.apply_lookup_table(lut) or edits of vol.mapper.lookup_table (the "
              "property's transfer functions follow its lookup table, as PyVista's do)",
    "opacities": "vol.prop.apply_lookup_table(lut) or edits of vol.mapper.lookup_table "
                 "(lut.apply_opacity(...))",
    "scalar_bar": "vol.mapper.lookup_table, which the volume's own bar shows",
}


def _lookup_tables(volume) -> tuple:
    """The returned mapper's lookup table and the one its property last applied (or None)."""
    return (getattr(volume.GetMapper(), "lookup_table", None),
            getattr(volume.GetProperty(), "_lookup_table", None))   # PyVista's VolumeProperty


def _table_state(table) -> tuple:
    """A lookup table's identity and modified time (``()`` for none)."""
    return () if table is None else (id(table), int(table.GetMTime())
                                     if hasattr(table, "GetMTime") else 0)


def _content(table) -> tuple:
    """What of a lookup table PyVista's volume draws: colours, opacities, range, scale."""
    return (np.asarray(table.values).tobytes(), int(table.n_values),
            tuple(float(v) for v in table.scalar_range), bool(table.log_scale))


def apply_table(prop, table) -> None:
    """Give ``prop`` the transfer functions PyVista's ``apply_lookup_table`` gives it.

    Points at the table's ``n_values`` values over its range, coloured by its own mapping
    (log scale included), opacities capped at 0.998 (``to_opacity_tf``), built in one
    pass (``BuildFunctionFromTable``: PyVista adds them one by one, in time growing with
    the square of their number: seconds for 16384 colours).
    """
    n = int(table.n_values)
    lo, hi = (float(v) for v in table.scalar_range)
    points = np.linspace(lo, hi, n)
    rgb = np.array([table.map_value(float(p), opacity=False) for p in points], np.float64)
    alpha = np.minimum(np.asarray(table.values[:, 3], np.float64) / 255.0, 0.998)
    colour, opacity = vtk.vtkColorTransferFunction(), vtk.vtkPiecewiseFunction()
    if n > 1 and hi > lo:
        colour.BuildFunctionFromTable(lo, hi, n, np.ascontiguousarray(rgb.ravel()))
        opacity.BuildFunctionFromTable(lo, hi, n, np.ascontiguousarray(alpha), 1)
    else:
        colour.AddRGBPoint(lo, *rgb[0])
        opacity.AddPoint(lo, float(alpha[0]))
    prop.SetColor(colour)
    prop.SetScalarOpacity(opacity)


def _functions(prop) -> tuple:
    """The property's colour (RGB, or grey) and opacity functions of its first component."""
    colour = prop.GetGrayTransferFunction() if prop.GetColorChannels() == 1 else \
        prop.GetRGBTransferFunction()
    return colour, prop.GetScalarOpacity()


def _copied(function):
    """A deep copy of a VTK transfer function (the kept one is never handed out)."""
    copy = type(function)()
    copy.DeepCopy(function)
    return copy


def _sample_count(colour, opacity, lo: float, hi: float) -> int:
    """Points to sample two functions at over ``[lo, hi]``: every node on one, if they can.

    Nodes spread evenly (``m`` of them, as PyVista's ``to_color_tf`` lays them) fall on
    ``k (m - 1) + 1`` points; other nodes are sampled at :data:`REFINED_ROWS` points.
    """
    nodes = []
    for function, width in ((colour, 6 if isinstance(colour, vtk.vtkColorTransferFunction)
                             else 4), (opacity, 4)):
        node = [0.0] * width
        for index in range(function.GetSize()):
            function.GetNodeValue(index, node)
            nodes.append(node[0])
    nodes = np.unique(nodes)
    if 2 <= len(nodes) <= REFINED_ROWS and np.allclose(
            nodes, np.linspace(lo, hi, len(nodes)), rtol=0, atol=1e-9 * (hi - lo)):
        return max(1, (REFINED_ROWS - 1) // (len(nodes) - 1)) * (len(nodes) - 1) + 1
    return REFINED_ROWS


def functions_transfer(prop, current, value_offset):
    """The table of what VTK draws for ``prop``'s transfer functions as they are now.

    Both are sampled at :data:`REFINED_ROWS` points over the span of their nodes
    (exact at every node of functions whose nodes lie on those points, as PyVista's
    ``to_color_tf`` makes them), over ``current``'s opacity unit distance.
    """
    colour, opacity = _functions(prop)
    spans = [f.GetRange() for f in (colour, opacity) if f.GetSize() > 0]
    if spans and not np.isfinite(spans).all():
        raise ValueError(f"a transfer function has a node at a value that is not finite "
                         f"(range {spans})")
    lo, hi = (min(s[0] for s in spans), max(s[1] for s in spans)) if spans else (0.0, 1.0)
    count = _sample_count(colour, opacity, lo, hi) if hi > lo else 1
    alpha = np.zeros(count)
    opacity.GetTable(lo, hi, count, alpha)
    if isinstance(colour, vtk.vtkPiecewiseFunction):
        grey = np.zeros(count)
        colour.GetTable(lo, hi, count, grey)
        rgb = np.repeat(grey[:, None], 3, axis=1)
    else:
        rgb = np.zeros(3 * count)
        colour.GetTable(lo, hi, count, rgb)
    if not (np.isfinite(rgb).all() and np.isfinite(alpha).all()):
        raise ValueError("the property's transfer functions give values that are not "
                         "numbers (a node's colour or opacity is NaN)")
    spec = current.spec
    return TransferFunction.from_points(
        rgb.reshape(-1, 3), alpha, (lo, hi),
        spec.opacity_unit_distance if spec is not None else 1.0, value_offset)


def _read(volume, bar=None) -> dict:
    """What the returned volume's property and mapper (and ``bar``, its bar's) say now."""
    prop = volume.GetProperty()
    return {
        "table": tuple(_table_state(t) for t in _lookup_tables(volume)),
        "scalar_bar": () if bar is None else _table_state(bar.GetLookupTable()),
        "interpolation": INTERPOLATION_TYPES[prop.GetInterpolationType()],
        "opacity_unit_distance": float(prop.GetScalarOpacityUnitDistance()),
        "shade": bool(prop.GetShade()),
        "ambient": float(prop.GetAmbient()),
        "diffuse": float(prop.GetDiffuse()),
        "specular": float(prop.GetSpecular()),
        "specular_power": float(prop.GetSpecularPower()),
        "blending": int(volume.GetMapper().GetBlendMode()),
        "clim": tuple(getattr(volume.GetMapper(), "scalar_range", None) or ()),
        "independent_components": bool(prop.GetIndependentComponents()),
        "colors": (int(prop.GetColorChannels()), int(_functions(prop)[0].GetMTime())),
        "opacities": int(prop.GetScalarOpacity().GetMTime()),
        "image_sample_distance": float(volume.GetMapper().GetImageSampleDistance())
        if hasattr(volume.GetMapper(), "GetImageSampleDistance") else 1.0,
    }


def _write(volume, state: dict) -> None:
    prop = volume.GetProperty()
    prop.SetInterpolationType({v: k for k, v in INTERPOLATION_TYPES.items()}[
        state["interpolation"]])
    prop.SetScalarOpacityUnitDistance(state["opacity_unit_distance"])
    prop.SetShade(int(state["shade"]))
    prop.SetAmbient(state["ambient"])
    prop.SetDiffuse(state["diffuse"])
    prop.SetSpecular(state["specular"])
    prop.SetSpecularPower(state["specular_power"])
    prop.SetIndependentComponents(int(state["independent_components"]))
    volume.GetMapper().SetBlendMode(state["blending"])
    if state["clim"]:
        volume.GetMapper().scalar_range = state["clim"]
    if hasattr(volume.GetMapper(), "SetImageSampleDistance"):
        volume.GetMapper().SetImageSampleDistance(state["image_sample_distance"])


class ReturnedProperty:
    """Follows the returned volume's property and mapper for one volume binding."""

    def __init__(self, binding, volume, blending: str, shade, opacity_unit_distance: float,
                 interpolation: str):
        self.binding = binding
        self.volume = volume
        self.bar = None
        self._bar_said = False
        # VTK makes a default function when one is asked for (switching grey and RGB):
        # made now, as VTK's mapper will, so reading it later changes nothing
        volume.GetProperty().GetRGBTransferFunction()
        material = shade.material if shade is not None else None
        state = _read(volume)
        state.update(interpolation=interpolation, opacity_unit_distance=opacity_unit_distance,
                     shade=shade is not None, blending=VTK_BLEND_MODES[blending])
        if material is not None:
            state.update({term: float(getattr(material, term)) for term in TERMS})
        _write(volume, state)
        self.shade = shade
        #: The lookup table drawn (the returned mapper's, which its property applies and
        #: the volume's bar shows), and a copy of it as drawn (a refused edit is put back
        #: to the copy); None for a volume with no one colormap (RGBA, joint).
        self.lut = None
        table = getattr(volume.GetMapper(), "lookup_table", None)
        model = binding.model
        if isinstance(table, pyvista.LookupTable) and not isinstance(model, VolumeGroup) \
                and getattr(model, "colors", None) is None:
            self.lut = table
            apply_table(volume.GetProperty(), table)   # as PyVista's volume property
        self._keep_table()
        self.state = _read(volume)
        self._follow_edit_before_adding(binding.model.transfer)

    def _follow_edit_before_adding(self, transfer) -> None:
        """The user's table edited after a model was made from it: the first frame follows.

        (``TransferFunction.from_colormap(lut)`` keeps ``lut`` itself, as the returned
        mapper's; what is drawn is what it held then.)
        """
        spec = transfer.spec
        if self.lut is None or transfer.lookup_table is not self.lut or not isinstance(
                getattr(spec, "cmap", None), np.ndarray):
            return
        drawn = pyvista.LookupTable()
        drawn.values = np.round(np.column_stack([spec.cmap, spec.opacity]) * 255.0)
        drawn.scalar_range = spec.data_clim
        drawn.log_scale = spec.log_scale
        if _content(drawn) != _content(self.lut):
            self._kept_table = drawn
            self.state["table"] = ()

    @property
    def _prop_seen(self) -> tuple:
        """The property's own table (PyVista's link) as the last frame read it."""
        return self.state["table"][1] if self.state["table"] else ()

    def _keep_table(self, hand_edited: bool = False) -> None:
        """Copy the lookup table as drawn (for put backs), and the functions if edited by hand.

        Else the table's own functions are drawn, and put back from it.
        """
        self._kept_table = self._kept_functions = None
        if self.lut is not None:
            self._kept_table = pyvista.LookupTable()
            self._kept_table.DeepCopy(self.lut)
            if hand_edited:
                self._kept_functions = tuple(_copied(f) for f in _functions(
                    self.volume.GetProperty()))

    def watch_bar(self, mapper) -> None:
        """Follow the volume's scalar bar's mapper (``plotter.mapper``) too.

        It shares the volume's lookup table (``add_scalar_bar`` gives it the returned
        mapper's), so ``plotter.update_scalar_bar_range`` and PyVista's bar sharing
        recolour the volume as they recolour PyVista's own; a table put in its place is
        said once (:meth:`_say_bar_changed`).
        """
        self.bar = mapper
        # PyVista's bar sharing may have set the table's range as the bar was added (an
        # earlier prop under the same title): drawn now, as PyVista's volume draws it
        self.follow()

    def _say_bar_changed(self) -> None:
        """Once: the bar's lookup table was replaced; the volume keeps its own."""
        if self._bar_said:
            return
        self._bar_said = True
        warn_user(f"{self.binding.model.name!r}: its scalar bar's lookup table was replaced "
                  f"after add_volume; the volume keeps its own ({INSTEAD['scalar_bar']}).")

    def follow(self) -> None:
        """Draw what the user changed on the property, or refuse it (see the module)."""
        now = _read(self.volume, self.bar)
        if now == self.state:
            return
        if now["scalar_bar"] != self.state["scalar_bar"]:
            if self.bar is not None and self.bar.GetLookupTable() is not self.lut:
                self._say_bar_changed()
            self.state["scalar_bar"] = now["scalar_bar"]
        changed = [key for key in now if now[key] != self.state[key]]
        colours = {"table", "colors", "opacities", "clim"}
        followed = {"interpolation", "opacity_unit_distance", "blending", "shade"} | (
            set(TERMS) if self.shade is not None or now["shade"] else set()) | (
            {"image_sample_distance"} if getattr(self.binding, "technique", None) == "vtk"
            else set()) | (   # 'vtk''s drawing mapper takes it itself (vtk_mapper.py)
            colours if self.lut is not None else set())
        refused = [key for key in changed if key not in followed]
        if self.lut is not None and colours & set(changed):   # first: kept by a refusal
            self._follow_colours(now, changed)
        if refused:
            key = refused[0]
            if key in colours:
                key = "lookup_table"   # no one colormap to edit: add it again
            self._put_back(now)
            raise RefusedChangeError(
                f"The returned volume's {key} was changed after add_volume; pv_cubemarch "
                f"does not draw that change (it takes {INSTEAD[key]}). The property is set "
                "back to what is drawn.")
        if now["shade"] and now["blending"] not in (VTK_BLEND_MODES["composite"],
                                                    VTK_BLEND_MODES["isosurface"]):
            self._put_back(now)
            raise RefusedChangeError("The returned volume was set to shade with blend_mode="
                             f"{BLEND_NAMES[now['blending']]!r}; shade=True shades composite "
                             "blending (and levels) only. The property is set back to what "
                             "is drawn.")
        try:   # each change drawn joins the state, so a refusal puts back only the rest
            if "shade" in changed and not now["shade"]:   # off first: then any mode
                self.binding.set_shade(None)
                self.shade = None
                self.state["shade"] = False
            if "blending" in changed:
                self.binding.set_blending(BLEND_NAMES[now["blending"]])
                self.state["blending"] = now["blending"]
            if "shade" in changed and now["shade"]:
                shading = GradientShading(self.binding.main_renderer, self.binding.model,
                                          ShadeMaterial(**{t: now[t] for t in TERMS}))
                self.binding.set_shade(shading)
                self.shade = shading
                self.state.update(shade=True, **{t: now[t] for t in TERMS})
            if "interpolation" in changed:
                self.binding.set_interpolation(now["interpolation"])
                self.state["interpolation"] = now["interpolation"]
            if "opacity_unit_distance" in changed:
                self.binding.set_opacity_unit_distance(now["opacity_unit_distance"])
                self.state["opacity_unit_distance"] = now["opacity_unit_distance"]
        except ValueError as error:   # what this volume cannot draw (a streamed one ...)
            self._put_back(now)
            raise RefusedChangeError(f"{error} The property is set back to what is "
                                     "drawn.") from None
        if self.shade is not None and any(term in changed for term in TERMS):
            self.shade.material = replace(self.shade.material,
                                          **{term: now[term] for term in TERMS})
        self.state = _read(self.volume, self.bar)

    def _follow_colours(self, now: dict, changed: list) -> None:
        """Draw the colours meant now: a table changed or put in place, else the functions.

        Colours that cannot be drawn are refused and put back.
        """
        mapper_table, prop_table = _lookup_tables(self.volume)
        # the property's table (PyVista's apply_lookup_table link) only when it changed
        # since the last frame: a table applied once and replaced since stays replaced
        applied = prop_table is not None and prop_table is not self.lut and \
            _table_state(prop_table) != self._prop_seen
        table = mapper_table if mapper_table is not self.lut else \
            prop_table if applied else self.lut
        moved = table is not self.lut or _content(table) != _content(self._kept_table)
        if not moved and not {"colors", "opacities"} & set(changed):
            return   # modified, nothing drawn changed (an annotation, the same range)
        model = self.binding.model
        offset = getattr(model, "value_offset", 0)
        try:
            if not moved:
                transfer = functions_transfer(self.volume.GetProperty(), model.transfer,
                                              offset)
            elif not isinstance(table, pyvista.LookupTable):
                raise ValueError(f"it must be a pyvista.LookupTable, got {type(table).__name__}")
            else:
                same = np.array_equal(np.asarray(table.values),
                                      np.asarray(self._kept_table.values))
                transfer = transfer_for_lookup_table(table, model.transfer, offset, same)
            self.binding.set_transfer(transfer)
        except (VolumeDataError, ValueError) as error:
            self._put_back(now)
            raise RefusedChangeError(
                f"The returned volume's colours cannot be drawn as changed: {error} They "
                "are set back to what is drawn.") from None
        if moved:
            old, self.lut = self.lut, table
            mapper, prop = self.volume.GetMapper(), self.volume.GetProperty()
            mapper.lookup_table = table
            if prop_table is not table:
                apply_table(prop, table)
            mapper.scalar_range = tuple(table.scalar_range)   # reads the range drawn
            if table is not old:
                self._move_bar(old, table)
        self._keep_table(hand_edited=not moved)
        drawn = _read(self.volume, self.bar)
        self.state.update({key: drawn[key] for key in
                           ("table", "colors", "opacities", "clim", "scalar_bar")})

    def _move_bar(self, old, table) -> None:
        """The volume's bar (its mapper, and the bars drawn from its table) shows ``table``."""
        if self.bar is not None and self.bar.GetLookupTable() is old:
            self.bar.lookup_table = table
        renderer = getattr(self.binding, "main_renderer", None)
        props = renderer.GetViewProps() if renderer is not None else None
        for index in range(props.GetNumberOfItems() if props is not None else 0):
            actor = props.GetItemAsObject(index)
            if isinstance(actor, vtk.vtkScalarBarActor) and actor.GetLookupTable() is old:
                actor.SetLookupTable(table)

    def _put_back(self, now: dict) -> None:
        """Set the property and lookup table back to what is drawn.

        A transfer function of the property edited by hand stays as edited where no lookup
        table is drawn (an RGBA volume, volumes marched jointly).
        """
        if self.lut is not None:
            self.lut.DeepCopy(self._kept_table)
            self.volume.GetMapper().lookup_table = self.lut
            prop = self.volume.GetProperty()
            if self._kept_functions is None:
                apply_table(prop, self.lut)
            else:   # the functions drawn as edited by hand
                colour, opacity = (_copied(f) for f in self._kept_functions)
                prop.SetColor(colour)
                prop.SetScalarOpacity(opacity)
        _write(self.volume, self.state)
        self.state = _read(self.volume, self.bar)
