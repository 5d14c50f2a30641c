"""The returned volume's property and mapper, as PyVista users set them after ``add_volume``.

The returned ``pyvista.Volume`` starts with what is drawn: ``vol.prop.interpolation_type``,
``opacity_unit_distance``, ``shade`` and its terms, ``vol.mapper.blend_mode``. At each frame
a change the marchers can follow is drawn (the interpolation, the opacity unit distance,
the blend mode, shading on or off, the shading terms; ``'vtk'``'s image sample distance);
any other, or a pair the marchers do
not draw together (shade with a projection), is refused with an error that says which
``add_volume`` keyword draws it, and the property is put back to what is drawn, so no
frame shows a setting it ignores.
"""

from __future__ import annotations

from dataclasses import replace

import vtk

from ..core.errors import RefusedChangeError
from ..core.user_warnings import warn_user
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
    "clim": "add_volume(..., clim=...)",
    "independent_components": "one scalar per point (several components are not drawn yet)",
    "colors": "add_volume(..., cmap=..., clim=...) (pv_cubemarch draws its own transfer table)",
    "opacities": "add_volume(..., opacity=...) (pv_cubemarch draws its own transfer table)",
    "ambient": "add_volume(..., shade=True, ambient=...)",
    "diffuse": "add_volume(..., shade=True, diffuse=...)",
    "specular": "add_volume(..., shade=True, specular=...)",
    "specular_power": "add_volume(..., shade=True, specular_power=...)",
    "image_sample_distance": "technique='vtk', whose mapper draws at 1/d of the viewport, or "
                             "downsample= with technique='direct'",
    "lookup_table": "add_volume(..., cmap=..., clim=...) (pv_cubemarch draws its own "
                    "transfer table)",
    "scalar_bar": "add the volume again with add_volume(..., cmap=..., clim=...) to draw "
                  "other colours",
}


def _table_state(mapper) -> tuple:
    """What a mapper's lookup table and range say now (their modified times, the range)."""
    if mapper is None:
        return ()
    table = mapper.GetLookupTable() if hasattr(mapper, "GetLookupTable") else None
    return (tuple(float(v) for v in mapper.GetScalarRange()),
            int(table.GetMTime()) if table is not None else 0)


def _read(volume, bar=None) -> dict:
    """What the returned volume's property and mapper (and ``bar``, its bar's) say now."""
    prop = volume.GetProperty()
    table = getattr(volume.GetMapper(), "lookup_table", None)
    return {
        "lookup_table": int(table.GetMTime()) if table is not None else 0,
        "scalar_bar": _table_state(bar),
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
        "colors": int(prop.GetRGBTransferFunction().GetMTime()),
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
        material = shade.material if shade is not None else None
        state = _read(volume)
        state.update(interpolation=interpolation, opacity_unit_distance=opacity_unit_distance,
                     shade=shade is not None, blending=VTK_BLEND_MODES[blending])
        if material is not None:
            state.update({term: float(getattr(material, term)) for term in TERMS})
        _write(volume, state)
        self.shade = shade
        #: The returned mapper's lookup table and its copy as drawn (a refused edit of it is
        #: put back to the copy); None where the mapper has none.
        self._table = getattr(volume.GetMapper(), "lookup_table", None)
        if self._table is not None:
            self._kept_table = vtk.vtkLookupTable()
            self._kept_table.DeepCopy(self._table)
        self.state = _read(volume)

    def watch_bar(self, mapper) -> None:
        """Follow the volume's scalar bar's mapper (``plotter.mapper``) too.

        ``plotter.update_scalar_bar_range`` and edits of its lookup table change the bar,
        not the volume: said once (:meth:`_say_bar_changed`).
        """
        self.bar = mapper
        self.state = _read(self.volume, self.bar)

    def _say_bar_changed(self) -> None:
        """Once: the bar's range or colours changed, the volume is drawn as added.

        ``plotter.update_scalar_bar_range``, an edit of ``plotter.mapper.lookup_table``, or
        PyVista's own bar sharing (a mesh added later with the same scalars' name sets
        the range of every mapper under that bar): not refused, as the bar may be
        another prop's too, but said, as the bar no longer tells the volume's colours.
        """
        if self._bar_said:
            return
        self._bar_said = True
        warn_user(f"{self.binding.model.name!r}: its scalar bar's range or colours changed "
                  f"after add_volume; the volume is drawn as added ({INSTEAD['scalar_bar']}).")

    def follow(self) -> None:
        """Draw what the user changed on the property, or refuse it (see the module)."""
        now = _read(self.volume, self.bar)
        if now == self.state:
            return
        if now["scalar_bar"] != self.state["scalar_bar"]:
            self._say_bar_changed()
            self.state["scalar_bar"] = now["scalar_bar"]
        changed = [key for key in now if now[key] != self.state[key]]
        followed = {"interpolation", "opacity_unit_distance", "blending", "shade"} | (
            set(TERMS) if self.shade is not None or now["shade"] else set()) | (
            {"image_sample_distance"} if getattr(self.binding, "technique", None) == "vtk"
            else set())   # 'vtk''s drawing mapper takes it itself (vtk_mapper.py)
        refused = [key for key in changed if key not in followed]
        if refused:
            key = refused[0]
            self._put_back(now)
            raise RefusedChangeError(
                f"The returned volume's {key} was changed after add_volume; pv_cubemarch "
                f"does not draw that change (it takes {INSTEAD[key]}): add the volume again "
                "with it. The property is set back to what is drawn.")
        if now["shade"] and now["blending"] != VTK_BLEND_MODES["composite"]:
            self._put_back(now)
            raise RefusedChangeError("The returned volume was set to shade with blend_mode="
                             f"{BLEND_NAMES[now['blending']]!r}; shade=True shades composite "
                             "blending only. The property is set back to what is drawn.")
        try:
            if "shade" in changed and not now["shade"]:   # off first: then any mode
                self.binding.set_shade(None)
                self.shade = None
            if "blending" in changed:
                self.binding.set_blending(BLEND_NAMES[now["blending"]])
            if "shade" in changed and now["shade"]:
                shading = GradientShading(self.binding.main_renderer, self.binding.model,
                                          ShadeMaterial(**{t: now[t] for t in TERMS}))
                self.binding.set_shade(shading)
                self.shade = shading
        except ValueError:
            self._put_back(now)
            raise
        if "interpolation" in changed:
            self.binding.set_interpolation(now["interpolation"])
        if "opacity_unit_distance" in changed:
            self.binding.set_opacity_unit_distance(now["opacity_unit_distance"])
        if self.shade is not None and any(term in changed for term in TERMS):
            self.shade.material = replace(self.shade.material,
                                          **{term: now[term] for term in TERMS})
        self.state = now

    def _put_back(self, now: dict) -> None:
        """Set the property back to what is drawn (a transfer function stays as edited)."""
        _write(self.volume, self.state)
        if now["lookup_table"] != self.state["lookup_table"]:   # the bar's is only said
            self._table.DeepCopy(self._kept_table)
        self.state = _read(self.volume, self.bar)
