"""Emission/absorption ray casting (004) inside VTK's GPU volume mapper (``technique='vtk'``).

VTK's ``vtkOpenGLGPUVolumeRayCastMapper`` sets up the ray (entry at the box or the near
plane, exit at the box or the opaque depth); we replace its per-sample work with the shared
marcher: front-to-back emission/absorption from our own transfer table, the exponential
opacity correction for the real segment length and early ray termination.
"""

from __future__ import annotations

import numpy as np
import pyvista
import vtk

from ..core.registry import Sweep, Technique, register_technique
from ..gl.bindings import ShaderBindings
from ..gl.shaders import Replacement, ShaderRecipe
from ..models.volume import VolumeModel
from ..reference.emission_absorption import render_emission_absorption
from .march import MARCH_SNIPPETS, VolumeBinding, VolumeData, bind_sampling
from .options import STEP_SCALES, MarchOptions


def vtk_mapper_recipe(defines: dict, lit: bool) -> ShaderRecipe:
    """The shader replacements of the VTK-mapper path."""
    return ShaderRecipe(
        replacements=[
            Replacement("//VTK::Base::Dec", "ea_declarations", keep_tag="after"),
            Replacement("//VTK::ComputeColor::Dec",
                        ("ea_vtk_declarations", *MARCH_SNIPPETS,
                         *(("light_sample",) if lit else ())), keep_tag="after"),
            Replacement("//VTK::Shading::Init", "ea_vtk_ray_init"),
        ],
        defines=defines,
    )


def build_vtk_actor(plotter, data: VolumeData, options, shading, light_map=None):
    """A ``pyvista.Volume`` drawn by VTK's GPU mapper with our marcher; returns the actor."""
    model: VolumeModel = data.model
    step_scale = options.step_scale
    grid = pyvista.ImageData(dimensions=model.dimensions, spacing=model.grid.spacing,
                             origin=model.grid.origin)
    grid.direction_matrix = model.grid.direction_matrix
    grid.point_data["scalars"] = model.values.ravel(order="F")
    mapper = vtk.vtkOpenGLGPUVolumeRayCastMapper()
    mapper.SetInputData(grid)
    mapper.SetBlendModeToComposite()
    mapper.SetAutoAdjustSampleDistances(False)
    mapper.SetLockSampleDistanceToInputSpacing(False)
    mapper.SetUseJittering(False)
    mapper.SetSampleDistance(step_scale * float(np.min(model.grid.spacing)))
    prop = vtk.vtkVolumeProperty()
    prop.SetInterpolationTypeToLinear()
    prop.ShadeOff()
    actor = pyvista.Volume()
    actor.SetMapper(mapper)
    actor.SetProperty(prop)
    matrix = vtk.vtkMatrix4x4()
    matrix.DeepCopy(np.asarray(model.transform, dtype=np.float64).ravel().tolist())
    actor.SetUserMatrix(matrix)
    bindings = ShaderBindings(mapper, plotter.renderer)
    _, defines = bind_sampling(bindings, data, step_scale, shading.stop_opacity,
                               shading.skip_empty, sample_data=False)
    if light_map is not None:
        light_map.bind(bindings)
        defines.update(light_map.defines)
    recipe = vtk_mapper_recipe(defines, lit=light_map is not None)
    bindings.recipe = recipe
    recipe.apply(actor.GetShaderProperty())
    binding = VolumeBinding(model, data, bindings, recipe, step_scale, shading.stop_opacity)
    binding.technique = "vtk"
    binding.vtk_input = grid
    binding.drawn = [actor]
    binding.renderer = plotter.renderer
    pyvista.set_new_attribute(actor, "cubemarch", binding)
    return binding


register_technique(Technique(
    name="vtk", kind="volume", options=MarchOptions, build=build_vtk_actor,
    reference=render_emission_absorption,
    sweep=Sweep([{"step_scale": s} for s in STEP_SCALES]),
    summary="marched inside VTK's GPU volume mapper, which sets up each ray", groups=False))
