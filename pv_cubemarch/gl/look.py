"""The returned box actor's property, as PyVista users set it after adding a surface or grid.

The terms our shaders read as uniforms (a surface's colour; the lit shading's ``ambient``
and ``diffuse``, and with a highlight ``specular`` and ``specular_power``) start on the
returned actor's property as drawn and are followed at each frame:
``actor.prop.ambient = 0.4`` is drawn. Any other change of the property (its opacity or
colour where a palette or a colormap colours, edges, lighting, the interpolation, a
representation) is not drawn and is said once; a representation other than a surface
would cut the box the marcher runs on into lines or points, so it is also set back.
"""

from __future__ import annotations

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy

from ..core.user_warnings import warn_user

#: Property term -> (its VTK setter, the uniform it feeds, the switch it needs).
FOLLOWED = {
    "color": ("SetColor", "cm_surfaceColor", None),   # one colour only
    "ambient": ("SetAmbient", "cm_ambient", None),
    "diffuse": ("SetDiffuse", "cm_diffuse", None),
    "specular": ("SetSpecular", "cm_specular", "CM_SPECULAR"),
    "specular_power": ("SetSpecularPower", "cm_specularPower", "CM_SPECULAR"),
}
#: Switches under which the colour comes from elsewhere: each level's own, a colormap.
COLOURED_BY = ("CM_LEVELS", "CM_COLOR_BY_CURVATURE", "CM_COLOR_VALUES")
#: Every term read, by its VTK getter: those not followed are said when set. The colour
#: is the diffuse one, as set (VTK's ``GetColor`` mixes in the ambient and specular terms).
SAID = {"opacity": "GetOpacity", "color": "GetDiffuseColor", "diffuse": "GetDiffuse",
        "ambient": "GetAmbient", "specular": "GetSpecular",
        "specular_power": "GetSpecularPower", "show_edges": "GetEdgeVisibility",
        "lighting": "GetLighting", "interpolation": "GetInterpolation",
        "line_width": "GetLineWidth", "edge_color": "GetEdgeColor",
        "point_size": "GetPointSize", "metallic": "GetMetallic", "roughness": "GetRoughness",
        "render_lines_as_tubes": "GetRenderLinesAsTubes"}   # (culling: placement's own)
#: Where a term not followed is set instead (else the binding's ``look_hint``).
INSTEAD = {"lighting": "the shading= keyword lights it or not ('unlit')",
           "scalar bar's colormap": "its colours are drawn as added: add it again with "
                                    "cmap= and clim= (labels: set_label_color)",
           "interpolation": "the shading= keyword ('flat' or 'blinn')",
           "ambient": "shading='flat' or 'blinn' reads it",
           "diffuse": "shading='flat' or 'blinn' reads it",
           "specular": "shading='blinn' reads it",
           "specular_power": "shading='blinn' reads it"}


def _value(prop, getter: str):
    value = getattr(prop, getter)()
    return tuple(float(v) for v in value) if isinstance(value, tuple) else float(value)


class ReturnedLook:
    """Follows the returned box actor's property for one binding (see the module)."""

    def __init__(self, binding):
        self.binding = binding
        self._tables: dict = {}   # table id: (modified time, content)
        bindings = binding.look_bindings()
        recipe = binding.recipe if binding.recipe is not None else (
            bindings[0].recipe if bindings else None)
        defines = recipe.defines if recipe is not None else {}
        uniforms = bindings[0].uniforms if bindings else {}
        #: The terms drawn from the property: their uniform is bound as a value (not read
        #: per draw from elsewhere) and the shader reads it.
        coloured = len(bindings) > 1 or any(defines.get(switch) for switch in COLOURED_BY)
        self.followed = {name: spec for name, spec in FOLLOWED.items()
                         if spec[1] in uniforms and not callable(uniforms[spec[1]])
                         and (spec[2] is None or defines.get(spec[2]))
                         and not (name == "color" and coloured)}
        binding.actor.GetMapper().GetLookupTable()   # VTK makes its default one now
        prop = binding.actor.GetProperty()
        for name, (setter, uniform, _) in self.followed.items():
            getattr(prop, setter)(*(uniforms[uniform] if name == "color"
                                    else (uniforms[uniform],)))
        if hasattr(type(prop), "color"):   # PyVista's: a colour set, so its style setter
            prop.color = prop.GetDiffuseColor()   # (wireframe) keeps it, as on a mesh
        shading = getattr(getattr(binding, "options", None), "shading", None)
        if isinstance(shading, str):   # reads lit as drawn, so turning it off is seen
            prop.SetLighting(shading not in ("unlit", "normals"))
        self.seen = self.read()
        self.count = len(bindings)
        self.said: set = set()

    def read(self) -> dict:
        """What the returned actor's property, mapper and bar say now."""
        prop = self.binding.actor.GetProperty()
        state = {name: _value(prop, getter) for name, getter in SAID.items()}
        state["representation"] = int(prop.GetRepresentation())
        mapper = self.binding.actor.GetMapper()   # a colormap's range and table: not ours
        table = mapper.GetLookupTable() if hasattr(mapper, "GetLookupTable") else None
        state["mapper lookup table"] = (tuple(mapper.GetScalarRange()),
                                        getattr(table, "__this__", None), self._content(table))
        bar = getattr(self.binding, "bar_mapper", None)   # update_scalar_bar_range's
        if bar is not None:
            state["scalar bar's colormap"] = (tuple(bar.GetScalarRange()),
                                              self._content(bar.GetLookupTable()))
        return state

    def _content(self, table) -> tuple:
        """A table's colours and range, read again only when it was modified.

        A bar's table is modified by every Build, its content not.
        """
        if table is None:
            return ()
        key, stamp = id(table), int(table.GetMTime())
        known = self._tables.get(key)
        if known is None or known[0] != stamp:
            values = np.asarray(vtk_to_numpy(table.GetTable()))
            known = (stamp, (values.tobytes(), tuple(table.GetTableRange())))
            self._tables[key] = known
        return known[1]

    def follow(self) -> None:
        """Draw the followed terms changed on the property; say the rest once."""
        now = self.read()
        for name in now.keys() - self.seen.keys():   # a bar made after the actor: as made
            self.seen[name] = now[name]
        targets = self.binding.look_bindings()
        if now == self.seen and len(targets) == self.count:
            return
        # bindings made since (a world's new chunks) take every followed term
        changed = [name for name in now if now[name] != self.seen[name]]
        for name in (self.followed if len(targets) != self.count else changed):
            if name in self.followed:
                uniform = self.followed[name][1]
                for bindings in targets:
                    if uniform in bindings.uniforms:
                        bindings.set_uniform(uniform, now[name])
        # the options say the terms drawn (a live view's re-add, a recalibration read them)
        self.binding.note_look({name: now[name] for name in changed if name in self.followed})
        self.count = len(targets)
        prop = self.binding.actor.GetProperty()
        if now["representation"] != self.seen["representation"]:
            prop.SetRepresentationToSurface()   # the box the marcher runs on, whole
            now["representation"] = int(prop.GetRepresentation())
        unfollowed = [name for name in changed
                      if name not in self.followed and name not in self.said]
        self.seen = now
        if unfollowed:   # once each
            self.said.update(unfollowed)
            drawn = ", ".join(sorted(self.followed)) or "none of its terms"
            where = "; ".join(sorted({INSTEAD.get(name, self.binding.look_hint)
                                      for name in unfollowed}))
            warn_user(f"{self.binding.model.name!r}: {', '.join(unfollowed)} set on the "
                      f"returned actor's property {'is' if len(unfollowed) == 1 else 'are'} "
                      f"not drawn (drawn from it: {drawn}); {where}.")
