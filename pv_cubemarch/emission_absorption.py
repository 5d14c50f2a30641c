"""Emission/absorption ray casting (004) injected into VTK's GPU volume mapper.

VTK's ``vtkOpenGLGPUVolumeRayCastMapper`` sets up the ray (entry at the box or the near
plane, exit at the box or the opaque depth) and steps it; we replace its per-sample work
with front-to-back emission/absorption compositing from our own transfer table, with the
exponential opacity correction for the real segment length and early ray termination.
"""

from __future__ import annotations

import numpy as np
import pyvista
import vtk

from .gl_resources import ShaderBindings, Texture
from .shaders import Replacement, ShaderRecipe
from .volume import VolumeModel, make_volume

#: Default early-termination opacity (VTK's own loop also stops above 1 - 1/255).
DEFAULT_STOP_OPACITY = 0.99


def vtk_mapper_recipe(table_size: int) -> ShaderRecipe:
    """The shader replacements of the VTK-mapper path."""
    return ShaderRecipe(
        replacements=[
            Replacement("//VTK::Base::Dec", "ea_declarations", keep_tag="after"),
            Replacement("//VTK::ComputeColor::Dec", "ea_vtk_declarations", keep_tag="after"),
            Replacement("//VTK::Shading::Init", "ea_vtk_ray_init"),
            Replacement("//VTK::Shading::Impl", "ea_vtk_shading"),
        ],
        defines={"CM_TABLE_SIZE": int(table_size)},
    )


def world_voxel_size(volume: VolumeModel) -> float:
    """The smallest edge of a voxel in world units."""
    lengths = np.linalg.norm(volume.world_from_index()[:3, :3], axis=0)
    return float(lengths.min())


def add_volume(
    plotter: pyvista.Plotter,
    volume,
    scalars: str | None = None,
    *,
    cmap="magma",
    opacity="linear",
    clim=None,
    opacity_unit_distance: float | None = None,
    step_scale: float = 0.5,
    stop_opacity: float = DEFAULT_STOP_OPACITY,
    transform=None,
    nan_policy: str = "raise",
    name: str | None = None,
) -> pyvista.Volume:
    """Add a volume rendered with emission/absorption compositing; return its actor.

    Parameters
    ----------
    plotter : pyvista.Plotter
        The plotter to draw in.
    volume : pyvista.ImageData, numpy.ndarray or VolumeModel
        Scalars on a uniform grid (a numpy array is indexed x, y, z with unit spacing), or a
        :class:`VolumeModel` that already carries its transfer function and placement.
    scalars : str, optional
        Name of the point (or cell) array to draw; the active scalars by default.
    cmap : str or sequence
        Matplotlib colormap for the emitted colour.
    opacity : str, float or sequence of float
        PyVista opacity preset or values over ``clim``: the fraction absorbed over
        ``opacity_unit_distance``.
    clim : sequence of float, optional
        Scalar range of the transfer function; the data range by default.
    opacity_unit_distance : float, optional
        World length that ``opacity`` refers to; the mean grid spacing by default.
    step_scale : float
        Ray step as a fraction of the smallest voxel edge. Smaller is more accurate and
        slower (cost grows as ``1 / step_scale``).
    stop_opacity : float
        Early ray termination: stop once the accumulated opacity exceeds this (in (0, 1]).
    transform : array_like, optional
        4x4 matrix placing the grid in the world.
    nan_policy : str
        ``'raise'`` (default) for NaN/Inf in the data, or ``'zero'`` to draw them as 0.
    name : str, optional
        Actor name in the plotter (replaces an actor of the same name).

    Returns
    -------
    pyvista.Volume
        The volume actor; ``actor.cubemarch`` holds the bindings and the model.

    Examples
    --------
    >>> import numpy as np, pyvista as pv, pv_cubemarch
    >>> x, y, z = np.mgrid[-1:1:32j, -1:1:32j, -1:1:32j]
    >>> density = np.exp(-4 * (x**2 + y**2 + z**2))
    >>> pl = pv.Plotter(off_screen=True)
    >>> actor = pv_cubemarch.add_volume(pl, density, cmap="inferno", step_scale=0.5)
    >>> image = pv_cubemarch.render_image(pl)  # doctest: +SKIP
    """
    if not 0 < float(step_scale) <= 1e3 or not np.isfinite(step_scale):
        raise ValueError(f"step_scale must be a positive number, got {step_scale}.")
    if not 0 < float(stop_opacity) <= 1:
        raise ValueError(f"stop_opacity must be in (0, 1], got {stop_opacity}.")
    if isinstance(volume, VolumeModel):
        model = volume
    else:
        model = make_volume(volume, scalars, cmap=cmap, opacity=opacity, clim=clim,
                            opacity_unit_distance=opacity_unit_distance, transform=transform,
                            nan_policy=nan_policy, name=name or "volume")
    component = plotter.cubemarch  # created now so its close hook frees our GPU resources
    actor = _build_actor(plotter, model, float(step_scale), float(stop_opacity))
    plotter.add_actor(actor, name=name or model.name, reset_camera=False)
    actor.cubemarch.actor = actor
    component.track(actor.cubemarch)
    if not plotter.camera_set:
        plotter.reset_camera()
    return actor


class VolumeBinding:
    """What we keep per volume actor: the model, the shader bindings, the settings."""

    def __init__(self, model: VolumeModel, bindings: ShaderBindings, recipe: ShaderRecipe,
                 step_scale: float, stop_opacity: float):
        self.model = model
        self.bindings = bindings
        self.recipe = recipe
        self.step_scale = step_scale
        self.stop_opacity = stop_opacity
        self.actor = None

    @property
    def name(self) -> str:
        """The volume's name."""
        return self.model.name

    @property
    def nbytes(self) -> int:
        """GPU bytes we added (the transfer table; VTK owns the volume texture)."""
        return self.bindings.nbytes

    def release(self) -> None:
        """Free our GPU resources and observers."""
        self.bindings.release()


def _build_actor(plotter, model: VolumeModel, step_scale: float, stop_opacity: float):
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
    recipe = vtk_mapper_recipe(model.transfer.n_colors)
    recipe.apply(actor.GetShaderProperty())
    bindings = ShaderBindings(mapper, plotter.renderer, recipe)
    table = model.transfer.table.reshape(1, -1, 4)
    bindings.add_texture("cm_transferTable", Texture(table, kind="2d", interpolate=True))
    bindings.set_uniform("cm_clim", model.transfer.clim)
    bindings.set_uniform("cm_stopOpacity", stop_opacity)
    pyvista.set_new_attribute(
        actor, "cubemarch", VolumeBinding(model, bindings, recipe, step_scale, stop_opacity))
    return actor
