"""PyVista's ``add_mesh`` keywords as ``add_voxels`` and ``add_surface`` answer them.

``lighting=`` is taken (``False`` is ``shading='unlit'``); the others a PyVista user may
pass are refused by name with what to use instead, never a bare ``TypeError``.
"""

from __future__ import annotations

#: add_mesh keywords neither kind draws, and what to use instead.
COMMON = {
    "style": "the voxels and the surface are drawn as surfaces only",
    "render_points_as_spheres": "there are no points to draw",
    "point_size": "there are no points to draw",
    "texture": "the colours come from the palette or the colormap",
    "rgb": "the colours come from the palette or the colormap",
    "pbr": "shading= picks the lighting ('unlit', 'flat', 'blinn')",
    "metallic": "shading= picks the lighting ('unlit', 'flat', 'blinn')",
    "roughness": "shading= picks the lighting ('unlit', 'flat', 'blinn')",
    "nan_color": "empty voxels (0) and the field's outside are not drawn",
    "below_color": "a voxel takes its material's colour",
    "above_color": "a voxel takes its material's colour",
    "culling": "the box draws the faces its rays need",
}
VOXELS = {
    **COMMON,
    "color": "give palette= a colour per material ({label: colour}), or cmap=",
    "smooth_shading": "a voxel's faces are flat; shading= picks the lighting",
    "split_sharp_edges": "a voxel's faces are flat; shading= picks the lighting",
    "interpolate_before_map": "a voxel takes one colour: its material's",
    "log_scale": "labels are categories: give palette= a colour per material",
}
SURFACE = {
    **COMMON,
    "show_edges": "an implicit surface has no mesh edges; draw pl.add_mesh(grid.contour("
                  "...), show_edges=True) for them",
    "n_colors": "cmap= colours color_by or the levels through 256 colours",
    "flip_scalars": "reverse the colormap by name (cmap='viridis_r')",
}


def shading_for_lighting(lighting, shading: str, default: str = "blinn") -> str:
    """``shading`` with PyVista's ``lighting=`` applied (``False``: unlit)."""
    if lighting is None or bool(lighting):
        return shading
    if shading not in ("unlit", default):
        raise ValueError(f"lighting=False draws unlit, and shading={shading!r} asks for "
                         "light: pass one of the two.")
    return "unlit"


def refuse_mesh_keywords(function: str, kwargs: dict, refused: dict) -> None:
    """Raise for the keywords left in ``kwargs``: by name where PyVista has them."""
    for key in kwargs:
        if key in refused:
            raise TypeError(f"{function} does not take {key}= (PyVista's add_mesh "
                            f"keyword): {refused[key]}.")
    if kwargs:
        raise TypeError(f"{function} got unexpected keyword argument(s) {sorted(kwargs)}; "
                        f"see help(pv_cubemarch.{function}) for the keywords it takes.")
