"""The public functions that add what pv_cubemarch draws to a plotter.

Each dispatches through the technique registry (:mod:`pv_cubemarch.core.registry`): the
chosen technique's options are validated, its builder makes the actor(s), and the result
is placed in the plotter the same way for every technique.
"""

from __future__ import annotations

import copy
import dataclasses
import importlib.util
import inspect
import warnings
from pathlib import Path

import numpy as np
import pyvista

from .core import vtk_classes as vtk
from .core.errors import RefusedOptionsError, VolumeDataError
from .core.frame_errors import observe
from .core.mesh_keywords import SURFACE as SURFACE_REFUSED
from .core.mesh_keywords import VOXELS as VOXEL_REFUSED
from .core.mesh_keywords import refuse_mesh_keywords, shading_for_lighting
from .core.registry import get_technique
from .core.rendering import open_window
from .core.user_warnings import warn_user
from .gl.look import ReturnedLook
from .gl.overlay import bounds_proxy
from .models.array_files import ARRAY_SUFFIXES, read_array_file
from .models.array_sources import is_array_source, world_from_array
from .models.channels import (
    is_channels,
    make_data_model,
    with_channel_mix,
    with_channel_transfer,
)
from .models.field_sources import color_values, make_field, with_scalars_array
from .models.group import MAX_GROUP_MEMBERS, VolumeGroup, overlap_groups
from .models.image_files import read_data_file
from .models.label_ids import check_background_id
from .models.lights import DEFAULT_AMBIENT, DEFAULT_LIGHT_MAP_SIZE, light_source
from .models.multiscale import MultiscaleSource, is_zarr_group, multiscale_source
from .models.transfer import table_range
from .models.volume import (
    NAN_POLICIES,
    VolumeModel,
    checked_transform,
    uniform_grid,
    with_transfer,
)
from .models.voxels import (
    VoxelModel,
    fits_one_texture,
    image_array_name,
    listed_rows,
    make_voxels,
)
from .models.world import DEFAULT_CHUNK_SIZE, VoxelWorld
from .quality.interaction import attach_frame_budget, check_frame_budget
from .quality.surfaces import SurfaceCalibration, check_surface_quality
from .quality.targets import parse_quality
from .quality.volumes import check_quality_request, volume_calibration
from .quality.voxels import (
    VoxelCalibration,
    check_translucent,
    check_voxel_quality,
    check_world_reference,
)
from .surfaces import technique as _surfaces  # noqa: F401  (registers 'active', 'full')
from .surfaces.levels import (
    SurfaceLevels,
    add_surface_scalar_bar,
    level_lookup_table,
    surface_levels,
)
from .surfaces.options import ROOT as SURFACE_ROOT
from .surfaces.options import STEPS as SURFACE_STEPS
from .surfaces.technique import build_translucent_levels
from .volume import auto, direct, vtk_mapper  # noqa: F401  (each registers its technique)
from .volume.binding import VolumeBinding, VolumeData, VolumeSetup
from .volume.brick_pager import BRICK_POINTS, GPU_BYTES, BrickPager, coarsest_fits
from .volume.clipping import (
    checked_crop_box,
    clip_plane_list,
    crop_keeps_nothing,
    plane_numbers,
    set_crop_box,
)
from .volume.cubemap import technique as _cubemap  # noqa: F401  (registers 'cubemap')
from .volume.gradient_shading import gradient_shading
from .volume.light_map import LightMap
from .volume.options import (
    CUBE_MAPS,
    DEFAULT_STOP_OPACITY,
    INTERPOLATION,
    CommonVolumeOptions,
    CubeMapOptions,
    DirectOptions,
    fitting_face_size,
)
from .volume.paged import (
    PagedData,
    PagedVolume,
    build_paged_actor,
    check_paging,
    paged_transfer,
)
from .volume.pyvista_keywords import (
    add_scalar_bar,
    check_channels,
    check_direct_color,
    isosurface_levels,
    resolve_aliases,
    set_average_range,
    volume_input,
)
from .volume.returned_property import ReturnedProperty
from .volume.stand_in import PickerData, stand_in_volume
from .voxels import technique as _voxels  # noqa: F401  (registers 'voxels')
from .voxels.indexed_world import build_indexed_world, why_not_indexed
from .voxels.options import VoxelOptions
from .voxels.paged_labels import LabelPager, PagedLabels, build_paged_labels
from .voxels.per_chunk_world import build_world
from .voxels.scalar_bar import add_voxel_scalar_bar


def add_volume(
    plotter: pyvista.Plotter,
    volume,
    scalars=None,
    *,
    cmap=None,
    opacity=None,
    clim=None,
    opacity_unit_distance: float | None = None,
    n_colors: int | None = None,
    flip_scalars: bool | None = None,
    log_scale: bool | None = None,
    categories: bool | int | None = None,
    resolution=None,
    preference: str = "point",
    show_scalar_bar: bool = False,
    scalar_bar_args: dict | None = None,
    annotations: dict | None = None,
    technique: str = "vtk",
    quality=None,
    frame_budget_ms: float | None = None,
    step_scale: float | None = None,
    stop_opacity: float = DEFAULT_STOP_OPACITY,
    skip_empty: bool = True,
    downsample: int | None = None,
    face_size: int | None = None,
    max_samples: int | None = None,
    upscale: float | None = None,
    sample_factor: float | None = None,
    occlusion_sharpness: float | None = None,
    lights=None,
    light_map_size: int = DEFAULT_LIGHT_MAP_SIZE,
    light_map_ambient: float = DEFAULT_AMBIENT,
    transform=None,
    user_matrix=None,
    nan_policy: str = "raise",
    name: str | None = None,
    reset_camera: bool | None = None,
    pickable: bool = True,
    render: bool = True,
    blending: str = "composite",
    isosurfaces=None,
    interpolation: str | None = None,
    shade: bool = False,
    ambient: float | None = None,
    diffuse: float | None = None,
    specular: float | None = None,
    specular_power: float | None = None,
    independent_components: bool | None = None,
    channel_blending: str | None = None,
    clip_planes=None,
    crop_box=None,
    average_range=None,
    multi_colors: bool = False,
    lod_bias: float | None = None,
    gpu_bytes: int | None = None,
    host_bytes: int | None = None,
    brick_size: int | None = None,
    **kwargs,
) -> pyvista.Volume:
    """Add a volume rendered with emission/absorption compositing; return its actor.

    Parameters
    ----------
    plotter : pyvista.Plotter
        The plotter to draw in.
    volume : pyvista.ImageData, MultiBlock, numpy.ndarray, VolumeModel, VolumeGroup, or zarr
        Scalars on a uniform grid (a numpy array is indexed x, y, z with unit spacing), a
        :class:`VolumeModel` that already carries its transfer function and placement, or a
        :class:`VolumeGroup` of overlapping volumes marched jointly (see :func:`add_volumes`;
        ``technique='vtk'`` cannot march one, so a group is drawn by ``'direct'`` then).
        A multiscale source (an OME-Zarr image group or its path, a zarr or dask array, a
        list of arrays finest first, a :class:`MultiscaleSource`) is never read whole: its
        bricks stream into a GPU pool as the view needs them (``lod_bias``, ``gpu_bytes``,
        ``host_bytes``, ``brick_size``), drawn by the direct marcher with the transfer
        keywords, ``step_scale``, ``stop_opacity``, ``interpolation`` and a placement;
        ``clim`` defaults to its coarsest level's range.
        A path is read by ``pyvista.read`` (its header checked first), a ``.npy``/``.npz``
        as its array, a ``.zarr`` store streamed.
        A MultiBlock adds each block as its own volume (named ``name-index``) and returns
        the list of their actors, as PyVista does.
    scalars : str or numpy.ndarray, optional
        Name of the point (or cell) array to draw, or the values themselves (one per point
        or per cell); the active scalars by default. An array of 4 uint8 components (a
        numpy volume ``(x, y, z, 4)``) is an RGBA volume, as in PyVista: its first three
        components are the colour, the fourth goes through ``opacity`` over ``clim`` (the
        range of all four by default) per ``opacity_unit_distance`` (1 by default, what
        VTK draws PyVista's RGBA volumes with); blending 'composite', or 'maximum' /
        'minimum' (the sample of extreme alpha, with its colour, as VTK); no ``shade``.
    cmap : str, sequence, matplotlib colormap or pyvista.LookupTable, optional
        Colormap of the emitted colour (PyVista's theme colormap by default); a lookup
        table brings its own colours and opacities. ``colormap=`` is an alias.
    opacity : str, float or sequence of float, optional
        PyVista opacity preset (``'linear'``, the default, ``'sigmoid'``, ``'geom'`` ...), a
        constant, or values in [0, 1] over ``clim``: the fraction absorbed over
        ``opacity_unit_distance`` (capped at 0.998, as PyVista caps it).
    clim : float or sequence of float, optional
        Scalar range of the colormap and opacity, in the data's units (the data range by
        default; one number ``c`` means ``(-c, c)``). ``rng=`` is an alias.
    opacity_unit_distance : float, optional
        World length that ``opacity`` refers to; as in PyVista, the grid's diagonal over
        its mean number of points less one by default.
    n_colors : int, optional
        Colours of the colormap (rows of the transfer table, 1 to 16384; 256 by default).
    flip_scalars : bool, optional
        Reverse the colormap (off by default).
    log_scale : bool, optional
        Map colours over ``clim`` logarithmically (a lower bound at or below 0 becomes the
        smallest positive float, as in PyVista; off by default).
    categories : bool or int, optional
        ``True``: as many colours as the data has distinct values; a number: that many.

    Given with a :class:`VolumeModel`, the transfer keywords change its transfer function
    (the others stay as it was made with); a keyword left out (``None``) keeps it.
    resolution : sequence of float, optional
        A numpy volume's spacing (unit spacing by default).
    preference : str
        ``'point'`` or ``'cell'``: where a ``scalars`` array that fits both goes.
    show_scalar_bar : bool
        Add a scalar bar of the volume's colours (off by default, unlike PyVista, so that
        images compare with the CPU reference); ``plotter.add_scalar_bar()`` adds one
        afterwards either way.
    scalar_bar_args : dict, optional
        Keywords of ``plotter.add_scalar_bar`` (title, position, ...).
    annotations : dict, optional
        Scalar value to label, shown on the scalar bar.
    technique : str
        ``'vtk'``: marched inside VTK's GPU volume mapper (it sets up the ray). ``'direct'``:
        the direct screen-space marcher on a box actor, one ray per pixel. ``'cubemap'``:
        one ray per texel of a cube map on the box's interior faces, resampled on screen,
        so the cost stops growing with the viewport's resolution. ``'auto'``: each
        frame, the cube map when its visible texels are fewer than the volume's projected
        pixels, else the direct marcher (``actor.cubemarch.force`` pins one,
        ``actor.cubemarch.choice`` tells which was drawn). All run the same marching GLSL.
    quality : float or str, optional
        An error budget instead of settings: a PSNR in dB (up to 60) against the
        technique's CPU reference, or ``'fast'`` (30), ``'balanced'`` (40), ``'best'``
        (50). The cheapest ``step_scale`` (``'vtk'``, ``'direct'``) or ``face_size`` and
        ``sample_factor`` (``'cubemap'``) that meets it is chosen by drawing a few of them
        from the camera the view will have, at the window's size, and comparing pixels
        with the reference; ``actor.cubemarch.quality`` says what was chosen, its
        estimated error and what was tried. Choices are kept per data, camera, window
        size, background, clip planes and GL renderer (in ``~/.cache/pv_cubemarch``, or
        ``PV_CUBEMARCH_CACHE_DIR``). A still frame drawn from another view than the one
        calibrated warns once; ``actor.cubemarch.recalibrate()`` chooses for the view
        then (set the camera before adding to avoid it). ``'auto'``: both of its paths
        are calibrated apart (the step and the face), so either meets the target. A
        volume composited (an RGBA one, channels and volumes marched jointly too) or as
        isosurfaces (``shade=True`` too: lit by one headlight on the probe and in the
        reference, with its material) or projected (``'maximum'``, ``'minimum'``,
        ``'average'`` with its ``average_range``, ``'additive'``), cut by its clip
        planes and crop box; not with the settings it chooses. With ``lights=`` the
        reference lights its samples through the volume as the light map does; the light
        map's own error (38.5 dB at 64 points a side on a CT phantom) bounds what a
        target can reach. Not for a multiscale source (the reference traces the whole
        volume, which streaming avoids).
    frame_budget_ms : float, optional
        ``'vtk'``, ``'direct'``, ``'cubemap'`` and ``'auto'``: while the view moves (VTK's
        interactors, the live view's mouse), each frame takes the finest step (the cube
        map: ``upscale``) predicted to stay within this many milliseconds from the
        costliest of the last three frames (time grows as ``1 / step_scale``, or
        ``1 / upscale**2``; past step 16, ``'vtk'`` draws at 1/2-1/4 the size, VTK's
        ``ImageSampleDistance``, ``'direct'`` at 1/2-1/4 the size too, or with
        ``downsample`` above 1 at 2-4 times its downsample); the first frame after the
        view stops draws the still setting
        again (given, or what ``quality`` chose). ``'auto'``: each path its own knob,
        predicted from the frames that path drew. A multiscale source takes it too (no
        brick is read for it). Nothing is rebuilt. ``actor.cubemarch.frame_budget`` keeps
        the frames' values and times.
    step_scale : float, optional
        ``'vtk'``, ``'direct'`` and ``'auto'``: step length in texels along the ray's
        dominant texture axis (texel-spaced sampling, 0.5 by default). Smaller is more
        accurate and slower (cost grows as ``1 / step_scale``); up to 2^24 steps per ray
        are marched, and a value that would need more is refused. ``'cubemap'`` sets its
        step from ``max_samples`` instead (passing ``step_scale`` with it is an error).
    stop_opacity : float
        Early ray termination: stop once the accumulated opacity exceeds this (in (0, 1]).
    skip_empty : bool
        Step over 8^3 bricks whose values map to zero extinction. Exact (it skips only what
        adds nothing); costs one small texture, and is left out when no brick is empty.
    downsample : int, optional
        ``technique='direct'`` only (1 by default): march at 1/downsample of the viewport
        resolution in each direction (1, 2, 4 ...) and upsample with a depth-aware filter,
        so edges against meshes stay sharp. Cost falls about as ``1 / downsample**2``.
    face_size : int, optional
        ``'cubemap'`` and ``'auto'``: the largest cube-map face, in texels per edge (a
        power of two, the size at MIP level 0). By default twice the grid's longest axis
        rounded up to a power of two, from 32 to 256: a finer face adds no detail of the
        data, a coarser one blurs a small grid filling the view (``bench dial``). Caps
        the marching cost at ``6 * face_size**2`` rays; a volume far away uses a smaller
        level. Larger is sharper when the volume fills a big viewport.
    max_samples : int, optional
        ``'cubemap'`` and ``'auto'``: most samples along a ray crossing the whole box
        diagonally; shorter rays take proportionally fewer. Cost grows linearly with it. By
        default two per texel of the grid's longest axis (the ``step_scale=0.5`` of the
        other techniques).
    upscale : float, optional
        ``'cubemap'`` and ``'auto'`` (1 by default): screen pixels per cube-map texel the
        LOD aims at (``k_u``): 2 marches a quarter of the texels for a softer image.
    sample_factor : float, optional
        ``'cubemap'`` and ``'auto'`` (2 by default): samples per cube-map texel along the
        box diagonal (``k_c``). The LOD asks for ``k_c`` times the face's texels, capped by
        ``max_samples``, then sizes the face from the samples it got (``S = sqrt(3) N /
        k_c``): above 1, fewer texels and finer steps; below 1, more texels and coarser
        steps.
    occlusion_sharpness : float, optional
        ``'cubemap'`` and ``'auto'`` (0.5 by default): ``k_z`` of the bilateral depth filter
        against opaque meshes: a cube texel stops counting for a pixel once their ray ends
        differ by ``1/k_z`` cube-map texels. 0 is plain bilinear filtering (halos at mesh
        edges).
    lights : None, 'scene', pyvista.Light or list of them
        Light the medium: each sample's colour is scaled by ``light_map_ambient +
        (1 - light_map_ambient) * sum(colour * intensity * transmittance toward the
        light)``, the transmittances kept
        in a light map recomputed only when a light, the placement or the data change.
        ``'scene'`` takes the plotter's switched-on lights; at most 4. ``None``: unlit
        (the light-map pass does not exist).
    light_map_size : int
        Light-map points per axis (2 to 128): finer shadows for ``light_map_size**3 * 16``
        bytes and a longer light pass.
    light_map_ambient : float
        Share of the emission no light modulates, in [0, 1] (with ``lights``). Not VTK's
        ``ambient`` of gradient shading, which PyVista's ``ambient=`` means.
    transform, user_matrix : array_like, optional
        4x4 matrix placing the grid in the world (``user_matrix`` is PyVista's name; give
        one of the two).
    nan_policy : str
        ``'raise'`` (default) for NaN/Inf in the data, or ``'zero'`` to draw them as 0.
    name : str, optional
        Actor name in the plotter (replaces an actor of the same name).
    reset_camera : bool, optional
        Reset the camera to the scene after adding (by default only while the user has
        set no camera, as PyVista does).
    pickable : bool
        Whether the actor is pickable.
    render : bool
        Render once the volume is added, if the plotter is already shown.
    blending : str
        How the samples along a ray make its colour, as VTK draws each mode, in every
        technique: ``'composite'`` (emission/absorption, default); ``'maximum'`` /
        ``'minimum'`` (the largest / smallest value along the ray, drawn with its colour
        and its opacity); ``'average'`` (the mean of the samples' values, each normalised
        over the data's range and weighted by its opacity, as an opaque grey level);
        ``'additive'`` (their sum along the ray per ``opacity_unit_distance``, grey,
        clamped to white); ``'isosurface'`` (the levels of ``isosurfaces`` as surfaces with
        their colour and opacity). The modes other than composite take no lights and no
        joint groups, and read every sample (no empty-space skipping).
    isosurfaces : sequence of float or int, optional
        The levels ``blending='isosurface'`` draws, in data units; an int ``n`` takes ``n``
        levels spread over the data's range, as :meth:`pyvista.DataSetFilters.contour`
        does.
    interpolation : str, optional
        How values are read between grid points: ``'linear'`` (trilinear; the default for
        raw data, a VolumeModel keeps its own) or ``'nearest'`` (the nearest point:
        PyVista's default, its ``actor.prop.interpolation_type``), in every technique and
        the CPU reference.
    shade : bool
        Gradient shading, as VTK's volume mapper shades (``pl.add_volume(shade=True)``):
        each sample lit by the renderer's switched-on lights on the data's gradient, with
        ``ambient``, ``diffuse``, ``specular`` and ``specular_power``; composite blending,
        one volume, no ``lights=`` (the light map's shadows are another lighting). With
        ``blending='isosurface'`` each level is shaded by the gradient at the sample that
        crossed it, as VTK shades its isosurface mode.
    ambient, diffuse, specular, specular_power : float, optional
        VTK's volume property terms with ``shade=True`` (defaults 0.1, 0.7, 0.2, 10, as
        PyVista leaves them).
    independent_components : bool, optional
        How a multi-component array is drawn, as VTK's volume property names it: 2 to 4
        components are independent channels (microscopy), each with its own ``cmap``,
        ``opacity``, ``clim``, ``opacity_unit_distance``, ``flip_scalars`` and
        ``log_scale`` (a list with one per channel, or one value for all; one ``n_colors``
        for every channel and no ``categories``, as the channels share one table size; a colour
        name as a channel's ``cmap`` ramps from black to it; each channel's own range is
        its default ``clim``; without ``cmap`` the channels ramp from black to green,
        magenta, cyan and yellow). 4 uint8 components are RGBA unless this is ``True``.
        Channels are marched as joint members (``technique='vtk'`` draws them with the
        direct marcher, the same GLSL).
    channel_blending : str, optional
        How the channels mix: ``'composite'`` (default: one medium, their extinctions add,
        the colour is their extinction-weighted mean, the continuous form of VTK's
        independent components) or ``'additive'`` (each channel drawn as if alone, their
        light added, as napari adds channels; no ``lights`` or ``shade``).
    clip_planes : sequence of float, optional
        Planes that cut the volume, six numbers each: a point on the plane, then its
        normal, which points to the side kept (VTK's); put on the returned volume's mapper,
        as ``vol.mapper.AddClippingPlane`` and ``plotter.add_volume_clip_plane`` put them
        (at most 6). For scenes: ``--clip-planes`` and ``cubemarch:clipPlanes``.
    crop_box : sequence of float, optional
        ``(xmin, xmax, ymin, ymax, zmin, zmax)`` kept, in the data's coordinates (before
        ``transform``; volumes marched jointly with different placements: the world's):
        the mapper's cropping planes, as ``vol.mapper.SetCropping(True)``
        and ``SetCroppingRegionPlanes`` set them. For scenes: ``--crop-box`` and
        ``cubemarch:cropBox``.
    average_range : sequence of float, optional
        ``(low, high)`` in the data's units: ``blending='average'`` averages only the
        samples in it (air left out of a CT's mean), as VTK's
        ``vol.mapper.SetAverageIPScalarRange`` (which it sets, and which is followed at
        each frame). For scenes: ``--average-range`` and ``cubemarch:averageRange``.
    multi_colors : bool
        With a MultiBlock: each block takes the next of PyVista's colormaps ('Reds',
        'Greens', 'Blues', 'Greys', 'Oranges', 'Purples') instead of ``cmap``.
    lod_bias : float, optional
        Multiscale sources (0 by default): each sample reads the coarsest level whose point
        spacing fits one pixel times ``2**lod_bias`` (``-30``: the finest everywhere, what
        the in-memory render draws; ``1``: twice coarser, fewer bytes read).
    gpu_bytes : int, optional
        Multiscale sources: the brick pool's GPU budget (256 MiB by default; no more than
        every brick of every level).
    host_bytes : int, optional
        Multiscale sources: the host cache of read bricks (2 GiB by default), least
        recently used bricks forgotten first.
    brick_size : int, optional
        Multiscale sources: points along a brick's edge (32 by default).
    **kwargs
        PyVista's aliases ``rng`` (``clim``) and ``colormap`` (``cmap``). Any other
        keyword raises a ``TypeError`` that says what to use instead.

    Options of another technique than the chosen one raise a ``ValueError`` that names
    the techniques using them.

    Returns
    -------
    pyvista.Volume
        The volume the plotter knows (by ``name``), in every technique a stand-in whose
        VTK mapper draws nothing (the technique's own props draw), with PyVista's mapper
        and property: ``pl.add_volume_clip_plane(actor)``, ``actor.mapper.AddClippingPlane``
        and a crop box cut the volume; ``actor.prop.interpolation_type``, the shading
        terms and ``actor.user_matrix`` / ``position`` set later are drawn; other changes
        are refused at the next frame, by name. ``actor.cubemarch`` holds the model, the
        bindings and ``set_values`` / ``set_transform``; ``plotter.remove_actor(actor)`` (or
        adding another actor under the same name) removes the volume and frees it; hiding
        the actor hides it.

    Examples
    --------
    >>> import numpy as np, pyvista as pv, pv_cubemarch
    >>> x, y, z = np.mgrid[-1:1:32j, -1:1:32j, -1:1:32j]
    >>> density = np.exp(-4 * (x**2 + y**2 + z**2))
    >>> pl = pv.Plotter(off_screen=True)
    >>> actor = pv_cubemarch.add_volume(pl, density, cmap="inferno", step_scale=0.5)
    >>> image = pv_cubemarch.render_image(pl)  # doctest: +SKIP
    """
    open_window(plotter)   # a closed plotter: PlotterClosedError, not a half-added actor
    _checked_name(name)
    if not isinstance(shade, (bool, np.bool_)) and shade not in (0, 1):
        raise TypeError(f"shade must be True or False, got {shade!r}.")
    paging = dict(lod_bias=lod_bias, gpu_bytes=gpu_bytes, host_bytes=host_bytes,
                  brick_size=brick_size)
    if is_multiscale_input(volume):
        given = {key: value for key, value in locals().items()
                 if key not in ("plotter", "volume", "kwargs", "paging")}
        return _add_paged(plotter, volume, given, kwargs)
    dataset = _read_path(volume, "add_volume")   # the dataset whose edits are said
    volume = _regular_grid(dataset, "add_volume")
    unused = [key for key, value in paging.items() if value is not None]
    if unused:
        raise ValueError(f"{', '.join(unused)}: for multiscale sources (an OME-Zarr group, a "
                         "zarr or dask array, a list of levels), which are streamed by bricks; "
                         f"this volume ({type(volume).__name__}) is drawn whole.")
    if isinstance(volume, pyvista.MultiBlock):
        given = {key: value for key, value in locals().items()
                 if key not in ("plotter", "volume", "kwargs", "multi_colors", "paging",
                                "unused", "dataset", *paging)}
        return _add_blocks(plotter, volume, multi_colors, {**given, **kwargs})
    if multi_colors:
        raise ValueError("multi_colors colours the blocks of a MultiBlock; this volume is "
                         "one grid: give cmap= instead.")
    bar_title = None
    named = resolve_aliases(kwargs, {"clim": clim, "cmap": cmap})
    clim, cmap = named["clim"], named["cmap"]
    if isinstance(blending, str):
        blending = blending.lower()   # PyVista takes 'MAXIMUM' too
    transform = _one_transform(transform, user_matrix)
    chosen = get_technique("volume", technique)
    given = {key: value for key, value in dict(
        step_scale=step_scale, downsample=downsample, face_size=face_size,
        max_samples=max_samples, upscale=upscale, sample_factor=sample_factor,
        occlusion_sharpness=occlusion_sharpness).items() if value is not None}
    options = chosen.make_options(given)
    CommonVolumeOptions(stop_opacity, bool(skip_empty), light_map_size, light_map_ambient,
                        blending, (0.0,) if blending == "isosurface" and isosurfaces is not None
                        else ()).check()
    if blending != "composite" and (isinstance(volume, VolumeGroup) or lights is not None):
        raise ValueError(f"blending={blending!r} reads the samples along a ray without "
                         "attenuating them; it takes no lights and no jointly marched "
                         "volumes. Use blending='composite' for those.")
    transfer = {key: value for key, value in dict(
        cmap=cmap, opacity=opacity, clim=clim, opacity_unit_distance=opacity_unit_distance,
        n_colors=n_colors, flip_scalars=flip_scalars, log_scale=log_scale,
        categories=categories).items() if value is not None}
    if isinstance(volume, (VolumeModel, VolumeGroup)):
        # a volume's own copy (its arrays shared): what is set on the returned volume
        # (colours, values, interpolation) leaves the user's model, and its other volumes,
        # as they were; a group's members too
        model = own_copy(volume)
        if transfer and isinstance(model, VolumeGroup) and not is_channels(model):
            raise ValueError(f"{', '.join(transfer)}: volumes marched jointly keep each "
                             "member's transfer function; give it to make_volume per member.")
        if transfer:
            model = (with_channel_transfer(model, **transfer) if is_channels(model)
                     else with_transfer(model, **transfer))
        if channel_blending is not None:
            model = with_channel_mix(model, channel_blending)
        if interpolation is not None and interpolation != getattr(model, "interpolation",
                                                                   interpolation):
            INTERPOLATION.check(interpolation)
            model = dataclasses.replace(model, interpolation=interpolation)
    else:
        volume, scalars = volume_input(volume, scalars, resolution, preference)
        if scalars is None and isinstance(volume, pyvista.DataSet):
            bar_title = volume.active_scalars_name   # as PyVista titles its bar
        model = make_data_model(volume, scalars, independent_components, channel_blending,
                            dict(cmap=cmap, opacity=opacity, clim=clim,
                                 opacity_unit_distance=opacity_unit_distance,
                                 n_colors=n_colors, flip_scalars=flip_scalars,
                                 log_scale=log_scale, categories=categories),
                            transform=transform, nan_policy=nan_policy,
                            name=name or "volume", interpolation=interpolation or "linear")
    if quality is None and "face_size" not in given and chosen.name in CUBE_MAPS \
            and hasattr(model, "dimensions"):
        given["face_size"] = fitting_face_size(model.dimensions)   # no finer than the data
        options = chosen.make_options(given)
    if (is_channels(model) or isinstance(model, VolumeGroup)) and not chosen.groups:
        # VTK's mapper marches one texture: channels and groups are drawn by 'direct', as
        # the returned actor's technique says
        chosen = get_technique("volume", "direct")
        options = chosen.make_options({k: v for k, v in given.items() if k != "face_size"})
    if frame_budget_ms is not None:   # refused before anything is drawn or calibrated
        check_frame_budget(frame_budget_ms, chosen.name)
    check_channels(model, blending, shade, lights)   # before a calibration draws them
    choice = calibration = None
    if quality is not None:
        target = check_quality_request(
            quality, given, blending, rgba=getattr(model, "colors", None) is not None)
        calibration = volume_calibration(
            model, chosen.name, target,
            {"stop_opacity": stop_opacity, "skip_empty": skip_empty,
             "clip_planes": clip_planes, "blending": blending,
             **({"crop_box": crop_box} if crop_box is not None else {}),
             **({"average_range": average_range} if average_range is not None else {}),
             **({"isosurfaces": isosurfaces} if blending == "isosurface" else {}),
             **({"lights": _lights_now(plotter, lights), "light_map_size": light_map_size,
                 "light_map_ambient": light_map_ambient} if lights is not None else {}),
             **({"shade": True, "ambient": ambient, "diffuse": diffuse, "specular": specular,
                 "specular_power": specular_power} if shade else {}),
             **{k: given[k] for k in ("downsample", "upscale", "occlusion_sharpness")
                if k in given}}, add_volume)
        choice = calibration.run(plotter, reset_camera)
        given = {**given, **choice.setting}
        options = chosen.make_options(given)
    options.check_model(model)
    check_direct_color(model, blending, shade, cmap)
    gradient = gradient_shading(plotter, model, shade, lights, blending,
                                dict(ambient=ambient, diffuse=diffuse, specular=specular,
                                     specular_power=specular_power))
    shading = CommonVolumeOptions(stop_opacity, bool(skip_empty), light_map_size,
                                  light_map_ambient, blending,
                                  isosurface_levels(isosurfaces, model), gradient)
    shading.check()
    component = plotter.cubemarch  # created now: it follows frames and frees on close
    source = light_source(lights, plotter.renderer)
    data = VolumeData(model)
    light_map = None if source is None else LightMap(
        plotter.renderer, data, source, int(light_map_size), float(light_map_ambient))
    binding = chosen.build(plotter, data, VolumeSetup(options, shading, light_map))
    binding.light_map = light_map
    binding.quality = choice
    if calibration is not None:
        calibration.follow(binding, plotter)
    if frame_budget_ms is not None:
        steps = {} if choice is None else {m["setting"]["step_scale"]: m["psnr"]
                                           for m in choice.measured
                                           if "step_scale" in m["setting"]}
        attach_frame_budget(binding, chosen.name, plotter.ren_win, frame_budget_ms,
                            {"direct": steps} if chosen.name == "auto" else steps)
    binding.blending = blending
    binding.isosurfaces = isosurfaces   # as given (data units, or a count)
    actor = _place(plotter, binding, name or _unused_name(plotter, model.name))
    _say_edits_of(binding, dataset)
    if gradient is None:   # terms given unshaded: the property holds them, as PyVista's
        for term, value in dict(ambient=ambient, diffuse=diffuse, specular=specular,
                                specular_power=specular_power).items():
            if value is not None:
                setattr(actor.prop, term, float(value))
    spec = getattr(model.transfer, "spec", None)
    binding.returned_property = ReturnedProperty(
        binding, actor, blending, gradient,
        1.0 if spec is None else float(spec.opacity_unit_distance),
        getattr(model, "interpolation", "linear"))
    binding.picker_data = PickerData(actor, binding.model, plotter.renderer)   # VTK's pickers
    binding.extra_release.append(binding.picker_data.release)
    component.track(binding)
    if show_scalar_bar and (isinstance(model, VolumeGroup) or model.colors is not None):
        warnings.warn("show_scalar_bar: an RGBA volume, a channel volume or volumes marched "
                      "jointly have no one colormap to show; no bar is added (add one per "
                      "channel with plotter.add_scalar_bar(mapper=...) if needed).",
                      stacklevel=2)
    elif not isinstance(model, VolumeGroup) and model.colors is None:
        binding.returned_property.watch_bar(add_scalar_bar(
            plotter, actor, model, scalars if isinstance(scalars, str) else bar_title
            or model.name, show_scalar_bar, scalar_bar_args, annotations))
    _cut(actor, model, clip_plane_list(clip_planes), crop_box)
    if average_range is not None:
        set_average_range(actor.mapper, average_range, blending)
    _shown(plotter, actor, reset_camera, pickable, render)
    return actor


def _cut(actor, model, planes: list, crop_box) -> None:
    """The returned volume's mapper given ``add_volume``'s clipping planes and crop box."""
    for plane in planes:
        actor.mapper.AddClippingPlane(plane)
    if crop_box is not None:
        set_crop_box(actor.mapper, crop_box)
        if crop_keeps_nothing(crop_box, model):
            warn_user(f"crop_box={tuple(crop_box)!r} keeps none of {model.name!r} (its box "
                      "lies outside the data, in the data's coordinates, before transform): "
                      "nothing of it is drawn.")


#: add_volume's keywords a multiscale source takes, and their defaults when left out.
PAGED_KEYWORDS = ("cmap", "opacity", "clim", "opacity_unit_distance", "n_colors",
                  "flip_scalars", "log_scale", "technique", "step_scale", "stop_opacity",
                  "transform", "user_matrix", "name", "reset_camera", "pickable", "render",
                  "interpolation", "lod_bias", "gpu_bytes", "host_bytes", "brick_size",
                  "blending", "skip_empty", "show_scalar_bar", "scalar_bar_args",
                  "annotations", "preference", "light_map_size", "light_map_ambient",
                  "nan_policy", "multi_colors", "face_size", "max_samples", "upscale",
                  "sample_factor", "occlusion_sharpness", "frame_budget_ms", "clip_planes",
                  "crop_box")


def own_copy(volume):
    """A volume's own copy of ``volume`` (arrays shared); a group's with its members'."""
    made = copy.copy(volume)
    if isinstance(volume, VolumeGroup):
        made.members = [copy.copy(member) for member in volume.members]
    return made


def _bar_title(grid, scalars, default: str) -> str:
    """A label grid's scalar bar title, as PyVista titles a mesh's: the array's name."""
    if isinstance(scalars, str):
        return scalars
    if isinstance(grid, pyvista.ImageData) and grid.array_names:
        return image_array_name(grid, None)
    return default


def _read_path(data, what: str):
    """``data``, or the dataset ``pyvista.read`` reads from it where it is a file path.

    As ``add_surface`` reads a mesh file; a ``.zarr`` path is streamed before this.
    """
    if not (isinstance(data, str) or hasattr(data, "__fspath__")):
        return data
    path = Path(data).expanduser()
    if not path.exists():   # a folder may be a DICOM series, which pyvista.read reads
        raise FileNotFoundError(f"{what}: {str(path)!r} does not exist (a path is read with "
                                "pyvista.read; a .zarr store is streamed).")
    if path.suffix.lower() in ARRAY_SUFFIXES:   # numpy's: the array, indexed x, y, z
        return read_array_file(path, path.suffix.lower(), None, what, str(path),
                               error=VolumeDataError)
    if path.suffix.lower() == ".zip":   # nothing reads it (meshio neither): said
        raise VolumeDataError(f"{what}: {str(path)!r}: a .zip is read by no reader here (a "
                              "zipped zarr store: unzip it to a .zarr folder, which is "
                              "streamed).")
    if path.is_file():   # said by name, not as VTK's empty complaint
        try:
            pyvista.get_reader(str(path))
        except ValueError as error:
            if "custom reader" in str(error) or importlib.util.find_spec("meshio"):
                return _read_data(path, what)   # a plugin's (.vdb, .usda) or meshio's
            raise VolumeDataError(f"{what}: {str(path)!r}: pyvista.read has no reader for "
                                  f"{path.suffix or 'files without a suffix'!r}; "
                                  "give a file it reads (.vti, .vtk, .nrrd, .nii, .tif ...), "
                                  "a .npy/.npz array or a .zarr store.") from None
    return _read_data(path, what)


def _read_data(path: Path, what: str):
    """``pyvista.read`` of ``path``, checked first (:func:`read_data_file`)."""
    try:   # an image's header checked, or the file read first in a capped child
        return read_data_file(path, what, error=VolumeDataError)
    except VolumeDataError:
        raise
    except Exception as error:
        raise VolumeDataError(f"{what}: {str(path)!r} could not be read by pyvista.read "
                              f"({error}); give a pyvista dataset or a numpy array, or load "
                              "a scene file with pv_cubemarch.load_scene.") from error


def _table_colours(cmap, clim) -> tuple:
    """``(cmap, clim)``, a ``pyvista.LookupTable`` made its colours and range.

    As ``add_mesh`` takes one: over its own range whatever ``clim`` says (said).
    """
    if not isinstance(cmap, pyvista.LookupTable):
        return cmap, clim
    from matplotlib.colors import ListedColormap

    low, high = table_range(cmap, clim, "add_mesh")
    # its colours at 256 values across its range, through its own mapping (a log scale)
    mapped = [cmap.map_value(float(v), opacity=False) for v in np.linspace(low, high, 256)]
    return ListedColormap(np.asarray(mapped, dtype=np.float64)[:, :3]), (low, high)


def _regular_grid(data, what: str):
    """``data`` as a grid of samples: a VTK image wrapped, a RectilinearGrid an ImageData.

    Another PyVista dataset (a mesh, a table) is refused by name: it holds no such grid.
    """
    if isinstance(data, vtk.vtkDataObject) and not isinstance(data, pyvista.DataObject):
        data = pyvista.wrap(data)
    if isinstance(data, pyvista.RectilinearGrid):
        return uniform_grid(data)
    if isinstance(data, pyvista.DataObject) and not isinstance(
            data, (pyvista.ImageData, pyvista.MultiBlock)):
        raise VolumeDataError(
            f"{what}: {type(data).__name__} is not a regular grid of samples (an "
            "ImageData, a uniform RectilinearGrid or a 3D array). Resample it onto an "
            "ImageData first (pyvista.ImageData(...).sample(data)), or, for a closed mesh, "
            "voxelize it (pyvista.voxelize) or draw it with add_surface.")
    return data


def is_multiscale_input(volume) -> bool:
    """Whether ``add_volume`` streams ``volume`` by bricks (a source beyond memory)."""
    if isinstance(volume, (MultiscaleSource, PagedVolume)) or is_zarr_group(volume):
        return True
    if isinstance(volume, str) or hasattr(volume, "__fspath__"):
        return str(volume).rstrip("/").lower().endswith(".zarr")
    if isinstance(volume, (list, tuple)):
        return bool(volume) and all(is_array_source(v) or isinstance(v, np.ndarray)
                                    for v in volume)
    return is_array_source(volume)


def _add_paged(plotter: pyvista.Plotter, source, given: dict, extra: dict):
    """``add_volume`` for a multiscale source: the direct marcher reading a brick pool."""
    named = resolve_aliases(dict(extra), {"clim": given["clim"], "cmap": given["cmap"]})
    given = {**given, **named}   # PyVista's rng= and colormap=
    defaults = {key: value.default for key, value in inspect.signature(
        add_volume).parameters.items()}

    def left_out(key, value) -> bool:   # not given, or given as the default
        if value is None or (key == "downsample" and _same(value, 1)):   # full resolution only
            return True
        default = defaults.get(key)
        return default is not None and _same(value, default)

    refused = sorted(key for key, value in given.items()
                     if key not in PAGED_KEYWORDS and not left_out(key, value))
    _one_transform(given["transform"], given["user_matrix"])   # refused before any read
    check_paging(given)
    if given["technique"] not in ("vtk", "direct", "auto", "cubemap"):
        refused.insert(0, f"technique={given['technique']!r}")
    cube = given["technique"] == "cubemap"
    drawn_by = "cubemap" if cube else "direct"   # 'vtk' and 'auto' march the pool directly
    marcher = {key: given[key] for key in ("face_size", "max_samples", "upscale",
                                            "sample_factor", "occlusion_sharpness")
               if not left_out(key, given[key])}
    if marcher and not cube:
        refused += sorted(marcher)
    if given["blending"] != "composite":
        refused.append(f"blending={given['blending']!r}")
    if given["quality"] is not None:
        raise ValueError("quality= calibrates against a CPU reference that traces the whole "
                         "volume, which a multiscale source is streamed to avoid: give "
                         "step_scale= (or the cube map's face_size=) and lod_bias= instead, "
                         "or add a level that fits in memory to calibrate on it.")
    if given["frame_budget_ms"] is not None:   # refused before the source is opened
        check_frame_budget(given["frame_budget_ms"], drawn_by)
    planes = clip_plane_list(given["clip_planes"])   # checked before the source is opened
    if given["crop_box"] is not None:
        checked_crop_box(given["crop_box"])
    if refused:
        raise RefusedOptionsError(
            f"A multiscale source is drawn by the direct marcher or the cube map "
            f"(technique='cubemap') reading a brick pool (blending='composite'); "
            f"{', '.join(refused)} cannot be used with it.", refused,
            "it is drawn by the direct marcher or the cube map reading a brick pool, "
            "composite blending only")
    transform = _one_transform(given["transform"], given["user_matrix"])
    if isinstance(source, PagedVolume):   # added again (the live view): as it was, but what
        made = source                     # this call changes
        source = made.source
        transform = made.transform if transform is None else transform
        paging = {k: given[k] if given[k] is not None else made.paging.get(k)
                  for k in made.paging}
        given = {**given, "interpolation": given["interpolation"] or made.interpolation}
    else:
        made, paging = None, {k: given[k] for k in ("lod_bias", "gpu_bytes", "host_bytes",
                                                     "brick_size")}
    interpolation = given["interpolation"] or "linear"
    INTERPOLATION.check(interpolation)
    if given["nan_policy"] not in NAN_POLICIES:
        raise VolumeDataError(f"nan_policy must be one of {NAN_POLICIES}, got "
                              f"{given['nan_policy']!r}.")
    source = multiscale_source(source, name=given["name"])
    coarsest_fits(source, paging.get("brick_size") or BRICK_POINTS,   # before any read
                  paging.get("gpu_bytes") or GPU_BYTES)
    keywords = [given[k] for k in ("cmap", "opacity", "clim", "opacity_unit_distance",
                                   "n_colors", "flip_scalars", "log_scale")]
    transfer = made.transfer if made is not None and all(k is None for k in keywords) \
        else paged_transfer(source, *keywords, nan_policy=given["nan_policy"])
    model = PagedVolume(source, transfer, np.eye(4) if transform is None
                        else checked_transform(transform), given["name"] or source.name,
                        interpolation, paging, given["nan_policy"])
    if cube:
        if given["step_scale"] is not None:
            raise ValueError("step_scale is the direct marcher's; the cube map steps "
                             "max_samples along the volume's diagonal.")
        options = CubeMapOptions(**marcher)
    else:
        options = DirectOptions(**({} if given["step_scale"] is None
                                   else {"step_scale": given["step_scale"]}))
    options.check_model(model)
    shading = CommonVolumeOptions(given["stop_opacity"], False)
    shading.check()
    component = plotter.cubemarch
    pager = BrickPager.from_paging(model, plotter.renderer,
                                   skip_empty=bool(given["skip_empty"]))
    build = get_technique("volume", "cubemap").build if cube else build_paged_actor
    binding = build(plotter, PagedData(model, pager), VolumeSetup(options, shading, None))
    binding.light_map = None
    if given["frame_budget_ms"] is not None:   # the step (cube map: upscale) while moving
        attach_frame_budget(binding, drawn_by, plotter.ren_win, given["frame_budget_ms"])
    actor = _place(plotter, binding, given["name"] or _unused_name(plotter, model.name))
    _cut(actor, model, planes, given["crop_box"])
    # what is set on the returned volume is drawn or refused, never ignored
    binding.returned_property = ReturnedProperty(
        binding, actor, "composite", None, float(transfer.spec.opacity_unit_distance)
        if transfer.spec is not None else 1.0, interpolation)
    component.track(binding)
    if given["show_scalar_bar"]:
        binding.returned_property.watch_bar(add_scalar_bar(
            plotter, actor, model, model.name, True, given["scalar_bar_args"],
            given["annotations"]))
    _shown(plotter, actor, given["reset_camera"], given["pickable"], given["render"])
    return actor


def is_multiscale_labels(grid) -> bool:
    """Whether ``add_voxels`` streams ``grid`` by bricks: a pyramid, not one array."""
    if isinstance(grid, (MultiscaleSource, PagedLabels)) or is_zarr_group(grid):
        return True
    if isinstance(grid, str) or hasattr(grid, "__fspath__"):
        return str(grid).rstrip("/").endswith(".zarr")
    # levels of 3 axes each (a list of 2D slices is one grid, stacked)
    return isinstance(grid, (list, tuple)) and bool(grid) and all(
        (is_array_source(v) or isinstance(v, np.ndarray)) and len(np.shape(v)) == 3
        for v in grid)


def _same(value, default) -> bool:
    """Whether a keyword was left at its default (arrays compared as values, no error)."""
    if value is default:
        return True
    if isinstance(value, np.ndarray) or isinstance(default, np.ndarray):
        return False
    try:
        return bool(type(value) is type(default) and value == default)
    except (TypeError, ValueError):
        return False


#: What ``add_voxels`` reads for a multiscale label source (the rest is refused by name).
PAGED_LABEL_KEYWORDS = ("palette", "mode", "shading", "ambient", "diffuse", "specular",
                        "specular_power", "lod_bias", "transform", "name", "background",
                        "gpu_bytes", "host_bytes", "brick_size", "frame_budget_ms",
                        "clip_planes", "reset_camera", "pickable", "render")


def _add_paged_labels(plotter: pyvista.Plotter, source, given: dict):
    """``add_voxels`` for a multiscale source: the traversal reading a brick pool."""
    defaults = {key: value.default for key, value in inspect.signature(
        add_voxels).parameters.items()}
    refused = sorted(key for key, value in given.items() if key not in PAGED_LABEL_KEYWORDS
                     and value is not None and not _same(value, defaults.get(key)))
    if refused:
        raise RefusedOptionsError(
            f"A multiscale label source is streamed by bricks and drawn opaque by the exact "
            f"traversal; {', '.join(refused)} cannot be used with it (add the finest level "
            "alone to use them).", refused,
            "its bricks are drawn opaque by the exact traversal")
    palette = given["palette"]
    if not (palette is None or isinstance(palette, dict) or
            (callable(palette) and not isinstance(palette, str))):
        raise ValueError(f"palette={palette!r}: a multiscale label source's ids are met as "
                         "its bricks are read, so its palette is None (colours hashed from "
                         "each id), a {id: colour} dict or a function of the id.")
    check_paging(given)
    check_background_id(given["background"])
    if given["frame_budget_ms"] is not None:   # refused before anything is read
        check_frame_budget(given["frame_budget_ms"], "voxels")
    options = voxel_options(mode=given["mode"], shading=given["shading"],
                            ambient=given["ambient"], diffuse=given["diffuse"],
                            specular=given["specular"],
                            specular_power=given["specular_power"],
                            clip_planes=given["clip_planes"])
    transform = given["transform"]
    if isinstance(source, PagedLabels):   # added again: as it was, but what this call changes
        model = dataclasses.replace(
            source, palette=source.palette if palette is None else palette,
            background=source.background if given["background"] == 0 else given["background"],
            transform=source.transform if transform is None else checked_transform(transform),
            paging={k: given[k] if given[k] is not None else source.paging.get(k)
                    for k in source.paging})
    else:
        model = PagedLabels(multiscale_source(source, name=given["name"]), palette,
                            np.eye(4) if transform is None else checked_transform(transform),
                            given["name"] or "voxels", int(given["background"]),
                            {k: given[k] for k in ("lod_bias", "gpu_bytes", "host_bytes",
                                                   "brick_size")})
    pager = LabelPager.from_paging(model, plotter.renderer)
    binding = build_paged_labels(plotter, model, options, pager)
    if given["frame_budget_ms"] is not None:   # fewer pixels while the view moves
        attach_frame_budget(binding, "voxels", plotter.ren_win, given["frame_budget_ms"])
    actor = _place(plotter, binding, given["name"] or _unused_name(plotter, model.name))
    plotter.cubemarch.track(binding)
    _shown(plotter, actor, given["reset_camera"], given["pickable"], given["render"])
    return actor


def _shown(plotter: pyvista.Plotter, actor, reset_camera: bool | None, pickable: bool,
           render: bool) -> None:
    """PyVista's last steps of an ``add_*``: pickable, the camera framed, a render if shown."""
    actor.SetPickable(bool(pickable))
    _frame(plotter, reset_camera)
    if render and plotter.ren_win is not None and getattr(plotter, "_rendered", False):
        plotter.render()


def _one_transform(transform, user_matrix):
    """The placement given as ``transform=`` or as PyVista's ``user_matrix=``, not both."""
    if user_matrix is None:
        return transform
    if transform is not None:
        raise ValueError("give transform= or user_matrix= (PyVista's name), not both.")
    return checked_transform(user_matrix, "user_matrix")   # (a vtkMatrix4x4 too)


def _frame(plotter: pyvista.Plotter, reset_camera: bool | None = None) -> None:
    """Frame a new prop: the camera if asked or the user set none, else the clipping range."""
    if reset_camera or (reset_camera is None and not plotter.camera_set):
        plotter.renderer.reset_camera(render=False)   # (the plotter's own renders)
    else:
        plotter.renderer.ResetCameraClippingRange()


def _unused_name(plotter: pyvista.Plotter, base: str) -> str:
    """``base``, or ``base-2``, ``base-3``... the first no actor of the plotter has.

    A name the user gives replaces the actor of that name, as in PyVista; a default name
    must not (PyVista's own defaults are unique): two surfaces added without names both
    stay.
    """
    taken = set(plotter.actors)
    if base not in taken:
        return base
    number = 2
    while f"{base}-{number}" in taken:
        number += 1
    return f"{base}-{number}"


def _checked_name(name):
    """``name`` (an actor's name in the plotter) as given, or a clear error."""
    if name is not None and not isinstance(name, str):
        raise TypeError(f"name must be a string (the actor's name in the plotter), got "
                        f"{name!r}.")
    return name


def _place(plotter: pyvista.Plotter, binding, name: str):
    """Give the plotter the actor that stands for the volume, under ``name``.

    A technique that draws one actor in the plotter's renderer returns that actor; one that
    draws elsewhere (the overlay renderer) or draws several returns a bounds proxy, which
    keeps ``reset_camera`` and the clipping range aware of the volume.
    """
    try:
        binding.check_reach()
    except ValueError:
        binding.release()   # nothing of it is kept
        raise
    main = plotter.renderer
    binding.main_renderer = main
    drawn = binding.drawn
    volume = isinstance(binding, VolumeBinding)
    if len(drawn) == 1 and binding.renderer is main and not volume:
        actor = drawn[0]
        binding.use_frame_box()   # placed as a mesh of the data: PyVista's calls act alike
    else:
        for item in drawn:
            if not item.GetNumberOfConsumers():   # in no renderer yet
                binding.renderer.AddActor(item)
                if binding.renderer is main:   # not named: the stand-in's removal frees it
                    binding.extra_release.append(lambda item=item: main.RemoveActor(item))
            if main.HasViewProp(item):   # the returned prop's bounds frame it: PyVista's
                item.UseBoundsOff()      # set_scale scales this one too before any frame
                                         # undoes it (keep_placed_by_matrix)
        actor = stand_in_volume(binding.model) if volume else bounds_proxy(
            binding.model, binding.drawn_frame_bounds())
        binding.bounds_proxy = actor
    if volume:
        binding.clip_source = actor.GetMapper()
        binding.data.range_source = actor.GetMapper()
        for item in drawn:   # a picker returns the volume the plotter knows, not its parts
            item.PickableOff()
    plotter.add_actor(actor, name=name, reset_camera=False, render=False)
    binding.actor = actor
    if not volume:   # its property reads what is drawn; edits of it drawn or said
        binding.look = ReturnedLook(binding)
    if getattr(actor, "cubemarch", None) is not binding:
        pyvista.set_new_attribute(actor, "cubemarch", binding)
    return actor


def _say_edits_of(binding, source) -> None:
    """Warn, once, if the dataset added is modified afterwards: what is drawn is a copy.

    PyVista's mappers draw a dataset as it is at each frame; ours uploaded it once.
    """
    if not isinstance(source, vtk.vtkDataObject):
        return
    said = []

    def modified(*_):
        if not said:
            said.append(True)
            setter = "set_values" if getattr(binding, "technique", "") != "surfaces" else None
            how = (f"actor.cubemarch.{setter}(...) draws new values"
                   if setter and hasattr(binding, setter) else "add it again")
            warn_user(f"{binding.name!r}: the dataset was modified after it was added, and "
                      f"what is drawn is a copy of it as it was; {how}.")

    tag = observe(source, vtk.vtkCommand.ModifiedEvent, modified)
    binding.extra_release.append(lambda: source.RemoveObserver(tag))


def _measure_voxels(plotter: pyvista.Plotter, actor, target, keep: dict, options) -> None:
    """``quality=`` of a grid or world just added: its frame measured and reported.

    Nothing is chosen (the exact traversal is drawn), so it is measured after the build,
    from the camera the plotter will frame the actor's own bounds with; a world's labels
    are read again at each calibration (edits included).
    """
    binding = actor.cubemarch
    calibration = VoxelCalibration(binding.model, "voxels", target, keep,
                                   _probe_adder(add_voxels, False),
                                   get_technique("voxels", "voxels").reference,
                                   look=_voxel_reference_look(options),
                                   bounds_of=actor.GetBounds)
    binding.quality = calibration.run(plotter, None)
    calibration.follow(binding, plotter)


def _say_levels_without_zero(model, levels) -> None:
    """Warn of the levels the field never reaches (each draws nothing), all or some.

    The field is a convex combination of its coefficients: a level outside their range
    (``model`` is the field less the first level) has no zero.
    """
    low, high = float(model.coefficients.min()), float(model.coefficients.max())
    offsets = [0.0] if levels is None else [float(v) - float(levels[0]) for v in levels]
    missing = [i for i, offset in enumerate(offsets) if not low <= offset <= high]
    if not missing:
        return
    if levels is None:
        warnings.warn(f"The field has no zero (its coefficients lie in [{low:g}, {high:g}]): "
                      "nothing is drawn. Check the isovalue or the field's sign.", stacklevel=3)
        return
    base = float(levels[0])
    named = ", ".join(f"{levels[i]:g}" for i in missing)
    what = "nothing is drawn" if len(missing) == len(levels) else "those draw nothing"
    warnings.warn(f"The field never reaches the isosurfaces {named} (its values lie in "
                  f"[{low + base:g}, {high + base:g}]): {what}. Check the levels.",
                  stacklevel=3)


def _lights_now(plotter: pyvista.Plotter, lights):
    """``lights=`` as a calibration's probe takes it: ``'scene'``, this plotter's lights on now.

    The probe has lights of its own; a volume lit by the scene is lit by the user's.
    """
    if isinstance(lights, str) and lights == "scene":
        return [light for light in plotter.renderer.GetLights() if light.GetSwitch()]
    return lights


def _check_voxel_quality(model, options) -> None:
    """Refuse ``quality=`` for a grid or world the voxel reference cannot draw as drawn."""
    check_translucent(model, _voxel_reference_look(options))
    if options.mode != "color":
        raise ValueError(f"quality= measures the colours a grid is drawn in; mode="
                         f"{options.mode!r} draws none: leave one of them out.")


def _why_per_chunk(world: VoxelWorld, options) -> str | None:
    """Why ``world`` would be drawn by a box per chunk with ``options`` (None: it would not)."""
    if options.world_traversal == "per_chunk":
        return "world_traversal='per_chunk'"
    return None if options.world_traversal == "index" else why_not_indexed(world, options)


def _add_world(plotter: pyvista.Plotter, world: VoxelWorld, options, name: str | None,
               reset_camera: bool | None = None):
    """Draw a chunked world by one traversal or a box per chunk; returns its actor."""
    options.check_ids(world.dimensions)
    if _why_per_chunk(world, options) is None:   # 'index' asked for and refused raises
        binding = build_indexed_world(plotter, world, options)
        if not binding.composites:
            binding.opaque_because = _opaque_because(options)
            binding.say_drawn_opaque()
        actor = _place(plotter, binding, name or _unused_name(plotter, world.name))
        plotter.cubemarch.track(binding)
    else:
        if options.mode == "id":
            reason = why_not_indexed(world, options)
            raise ValueError("mode='id' writes a voxel's index within its grid; a world "
                             "drawn per chunk has one index space per chunk: " + (
                                 f"one traversal cannot draw this one ({reason}). Use "
                                 "mode='face' or 'color', or pick()." if reason else
                                 "use world_traversal='index'."))
        if options.ambient_occlusion:   # seen: 101 of 3072 pixels lighter at chunk borders
            raise ValueError("ambient_occlusion reads the voxels around each hit, across "
                             "chunk borders, which a world drawn per chunk cannot: use "
                             "world_traversal='index' (a power-of-two chunk_size, no "
                             "distance_field, proxy='box').")
        actor = build_world(plotter, world, options, name or _unused_name(plotter, world.name))
        if not actor.cubemarch.composites:
            actor.cubemarch.opaque_because = _opaque_because(options)
            actor.cubemarch.say_drawn_opaque()
    _frame(plotter, reset_camera)
    return actor


#: The colormaps PyVista gives a MultiBlock's blocks in turn with ``multi_colors=True``.
MULTI_COLORS = ("Reds", "Greens", "Blues", "Greys", "Oranges", "Purples")


def _add_blocks(plotter: pyvista.Plotter, blocks, multi_colors: bool, keywords: dict) -> list:
    """Each block of a MultiBlock added as its own volume, as PyVista's add_volume does."""
    actors = []
    base = keywords.pop("name", None)
    for index, block in enumerate(blocks):
        if block is None:
            continue
        # PyVista's names: name-index, or (no name) ones no other actor holds
        own = dict(keywords, name=f"{base}-{index}" if base is not None else _unused_name(
            plotter, f"volume-{index}"))
        if multi_colors:
            own["cmap"] = MULTI_COLORS[len(actors) % len(MULTI_COLORS)]
        actors.append(add_volume(plotter, block, **own))
    if not actors:
        raise VolumeDataError("The MultiBlock holds no block to draw.")
    return actors


def add_volumes(plotter: pyvista.Plotter, volumes, **options) -> list:
    """Add several volumes; those whose boxes overlap are marched jointly as one medium.

    Parameters
    ----------
    plotter : pyvista.Plotter
        The plotter to draw in.
    volumes : sequence of VolumeModel
        Volumes with their transfer functions and placements (see
        :func:`pv_cubemarch.make_volume`).
    **options
        Options of :func:`pv_cubemarch.add_volume` for every volume (or group).
        ``technique='vtk'`` cannot march a group; groups take ``'direct'`` then.

    Returns
    -------
    list
        One actor per group, in the order of the groups' first volumes.

    Examples
    --------
    >>> import numpy as np, pyvista as pv, pv_cubemarch as cm
    >>> shift = np.eye(4)
    >>> shift[0, 3] = 8.0  # half a box along x: the two boxes overlap
    >>> a = cm.make_volume(np.random.rand(16, 16, 16), name="a")
    >>> b = cm.make_volume(np.random.rand(16, 16, 16), name="b", transform=shift)
    >>> pl = pv.Plotter(off_screen=True)
    >>> actors = cm.add_volumes(pl, [a, b], technique="cubemap")  # doctest: +SKIP
    """
    open_window(plotter)   # a closed plotter: PlotterClosedError, not a half-added actor
    actors = []
    for group in overlap_groups(list(volumes)):
        if len(group) == 1:
            actors.append(add_volume(plotter, group[0], **options))
            continue
        joint = dict(options)
        if joint.get("technique", "vtk") == "vtk":
            joint["technique"] = "direct"
        if len(group) > MAX_GROUP_MEMBERS:
            parts = -(-len(group) // MAX_GROUP_MEMBERS)
            warn_user(f"{len(group)} volumes overlap ({', '.join(v.name for v in group)}); "
                      f"one joint group marches at most {MAX_GROUP_MEMBERS}, so they are "
                      f"drawn as {parts} groups in their order, each composited whole over "
                      "the others: wrong where volumes of different groups overlap. Merge "
                      "some onto one grid (resample) to march them jointly.")
        for start in range(0, len(group), MAX_GROUP_MEMBERS):
            chunk = group[start:start + MAX_GROUP_MEMBERS]
            item = VolumeGroup(chunk) if len(chunk) > 1 else chunk[0]
            actors.append(add_volume(plotter, item, **joint))   # its own copies (own_copy)
    return actors




def voxel_options(**given) -> VoxelOptions:
    """The checked options of :func:`add_voxels` from its keyword arguments.

    Parameters
    ----------
    **given
        Any of ``add_voxels``'s options (``traversal``, ``step_scale``, ``mip_levels``,
        ``distance_field``, ``mode``, ``shading``, ``ambient``, ``specular``,
        ``specular_power``, ``ambient_occlusion``, ``occlusion_strength``, ``proxy``);
        ``None`` or left out takes the default (``mip_levels``: the levels that pay off
        with the DDA, none with the fixed step).

    Returns
    -------
    VoxelOptions
        The validated options.

    Raises
    ------
    ValueError
        For a bad value, or a name that is not an option of the voxel technique; the
        message names the option.
    """
    chosen = {key: value for key, value in given.items() if value is not None}
    return get_technique("voxels", "voxels").make_options(chosen)


def _opaque_because(options) -> str:
    """Why a grid (or a world) with ``options`` draws translucent labels opaque."""
    return f"mode={options.mode!r}" if options.mode != "color" else "level of detail (lod)"


def _numpy_by_chunks(grid, chunk_size, colouring: dict) -> bool:
    """Whether a numpy array of labels is read into a world chunk by chunk.

    So when it exceeds one texture even at a byte a voxel, no colouring keyword asks for
    the whole grid's values (which :func:`make_voxels` reads), and no chunk size is given.
    """
    return (isinstance(grid, np.ndarray) and grid.ndim == 3 and grid.dtype.kind in "iu"
            and chunk_size is None and not fits_one_texture(grid.shape, np.uint8)
            and all(value is None for value in colouring.values()))


def _array_grid(source, chunk_size, background, palette, transform, name, colouring):
    """A chunked array source as a numpy array (it fits one texture) or a world by chunks."""
    shape = tuple(int(n) for n in source.shape)
    whole = chunk_size is None and fits_one_texture(shape, np.uint16)
    if whole:
        return np.asarray(source[:, :, :])
    given = [key for key, value in colouring.items() if value is not None]
    if given:
        raise ValueError(f"{', '.join(given)}: a chunked array drawn by chunks (too large "
                         "for one texture, or chunk_size= given) is read a chunk at a time, "
                         "never whole, so its ids are coloured by palette= (a dict or "
                         "function of the id, or a colormap name over the ids), not by "
                         "their values' range.")
    placement = {} if transform is None else {"transform": checked_transform(transform)}
    # (a world's transform places its index space, as make_voxels places a numpy array)
    return world_from_array(source, chunk_size or DEFAULT_CHUNK_SIZE, background, palette,
                            name=name or "voxels", **placement)


def add_voxels(
    plotter: pyvista.Plotter,
    grid,
    scalars: str | np.ndarray | None = None,
    *,
    palette=None,
    traversal: str = "dda",
    step_scale: float | None = None,
    mip_levels: int | None = None,
    distance_field: int = 0,
    mode: str = "color",
    shading: str = "blinn",
    ambient: float = 0.2,
    diffuse: float = 0.8,
    specular: float = 0.3,
    specular_power: float = 30.0,
    ambient_occlusion: bool = False,
    occlusion_strength: float = 0.5,
    proxy: str | None = None,
    lod: bool = False,
    lod_bias: float = 0.0,
    world_traversal: str | None = None,
    chunk_size: int | None = None,
    transform=None,
    name: str | None = None,
    show_scalar_bar: bool = False,
    scalar_bar_args: dict | None = None,
    annotations: dict | None = None,
    cmap=None,
    categories: bool = False,
    show_edges: bool = False,
    edge_color=None,
    line_width: float | None = None,
    edge_opacity: float | None = None,
    edge_mode: str = "voxels",
    clim=None,
    n_colors: int | None = None,
    flip_scalars: bool = False,
    opacity: float | None = None,
    lighting: bool | None = None,
    background: int = 0,
    clip_planes=None,
    gpu_bytes: int | None = None,
    host_bytes: int | None = None,
    brick_size: int | None = None,
    quality=None,
    frame_budget_ms: float | None = None,
    user_matrix=None,
    reset_camera: bool | None = None,
    pickable: bool = True,
    render: bool = True,
    **kwargs,
) -> pyvista.Actor:
    """Add a material grid drawn exactly, voxel by voxel (Amanatides & Woo traversal).

    Every pixel shows the first drawn voxel its ray meets, opaque, at its real depth (meshes
    and volumes occlude it and are occluded by it exactly), from one byte per voxel (two
    above 255 label ids, four above 65535, whatever the ids' own type).

    Parameters
    ----------
    plotter : pyvista.Plotter
        The plotter to draw in.
    grid : numpy.ndarray, pyvista.ImageData, array-like, VoxelModel or VoxelWorld
        Integer labels, 0 (or ``background``) = empty: a 3D array indexed x, y, z (unit
        voxels from the origin), or an ImageData whose cell data (one voxel per cell) or
        point data (one voxel centred on each point) holds them; a chunked array (zarr,
        dask, h5py, ``numpy.memmap``: anything with ``shape``, ``dtype`` and slicing), read
        whole when it fits one texture, else drawn in chunks read one at a time; or a
        world of chunks. Any
        integer type and any ids (a segmentation's uint32 or uint64 cell ids, negative
        ids): ids beyond 0..65535 are compacted to dense rows on upload (1, 2 or 4 bytes a
        voxel: up to 255, 65535, 16.7 million distinct ids), and every per-label
        property is one entry of a table by id (``actor.cubemarch.set_label_color``,
        ``hide_labels``, ``show_selected_labels``, ``highlight_labels``). A multiscale
        source (an OME-Zarr pyramid as a path or zarr group, a list of arrays finest
        first, :func:`~pv_cubemarch.multiscale_source`) is streamed by bricks, never read
        whole: see ``gpu_bytes``.
    scalars : str or numpy.ndarray, optional
        The ImageData array of labels, by name or as values (one per point or per cell, as
        ``add_mesh(scalars=)`` takes them); by default its active scalars, else the first
        cell (then point) array.
    palette : str, list, dict, callable, array or Palette, optional
        Colour (and opacity) per label id: by default tab10/tab20 where the largest id is
        at most 20, else a colour hashed from each id (the same in every run, chunk and grid;
        neighbouring ids differ); a matplotlib colormap name (its colours in the order of
        the ids), ``{id: colour}`` or ``{id: (colour, opacity)}`` (ids left out are
        hidden), a function of the id returning either; a list of colours (entry ``m`` for
        label ``m``) or an ``(n, 3|4)`` array for labels 0..65535. Opacity 0 hides a label;
        ``actor.cubemarch.set_label_color(ids, color=..., opacity=...)`` changes any later
        without uploading the labels again.
    traversal : str
        ``'dda'`` (default): exact, every voxel a ray crosses is visited. ``'fixed'``: a
        fixed step (``step_scale`` voxels along the dominant axis, 0.1 by default), kept as
        the baseline: it steps over thin voxels and corners.
    step_scale : float, optional
        ``traversal='fixed'`` only: the step in voxels. Cost grows as ``1 / step_scale``.
    mip_levels : int, optional
        ``traversal='dda'``: occupancy mipmap levels (0-12; level ``L``'s cells are
        ``2^L`` voxels wide) used to leave empty space in one step; by default the levels
        that pay off on the labels (every level leaving at least 30 % of its cells empty,
        none below three: 7 on a sparse 256³ grid, 0 on a 1 % random fill). The ray
        descends a level on an occupied cell and climbs back when it leaves it. Exact
        whatever the number, for at most 1/7 more bytes.
    distance_field : int
        ``traversal='dda'``: the neighbour distance field, 0 (off, default) or its
        largest radius 1-3: one more byte per voxel telling how large an empty cube
        surrounds it, which the ray leaves in one step. Exact whatever the radius.
    mode : str
        ``'color'``: the palette colour, shaded. ``'id'``: the voxel's linear index + 1
        (``i + nx * (j + ny * k) + 1``) as 24-bit RGB, for exact tests. ``'face'``: the
        face each ray entered its voxel through, as red ``32 * (face + 2)`` (face
        ``2 * axis + 1`` entered moving +axis, ``2 * axis`` moving -axis, -1 from inside).
    shading : str
        ``'blinn'`` (default): the scene's switched-on lights (up to 8; headlights follow
        the camera) on the face each ray entered, Lambert plus a Blinn-Phong highlight;
        ``'flat'``: Lambert only; ``'unlit'``: the palette colour as is.
    ambient, diffuse, specular, specular_power : float
        As VTK lights a mesh (PyVista's ``add_mesh`` keywords): the colour times
        ``ambient + diffuse * sum(light * max(n.l, 0))`` (each 0-1; PyVista's mesh takes 0
        and 1), plus the highlight's weight (0-1) times its exponent's power.
    ambient_occlusion : bool
        Darken each face near the drawn voxels around it (per-vertex voxel ambient
        occlusion, interpolated over the face; ``mode='color'``, ``traversal='dda'``, any
        shading): a factor from 1 down to ``1 - occlusion_strength`` scales the unlit
        colour, or the ambient + diffuse term (not the highlight). Hidden materials cast
        none; outside the grid is empty.
    occlusion_strength : float
        How dark a fully occluded corner gets (0-1, 0.5 by default).
    proxy : str
        What starts the rays: ``'bricks'`` (default), the outer faces of the filled 2³
        bricks (4³ or 8³ for scattered content), so pixels that see none run nothing and
        rays start next to the voxels (the box instead on frames where the near plane
        reaches them, and with ``lod``, whose coarse cells reach past the bricks);
        ``'box'``, the grid's bounding box (every ray from the box). Exact
        either way; only the speed differs. By default ``'bricks'``, and ``'box'`` for a grid
        drawn in chunks (a hundred chunks' shells cost more than they save: ``bench voxel-world``).
    lod : bool
        Level of detail (off by default, as it is not exact): where a voxel is smaller than
        a pixel, rays stop at the coarsest occupancy level whose cells are no wider than a
        pixel and draw the most frequent label under the cell. Chosen per pixel from where
        its ray starts, so distant chunks and the far side of a grid go coarse first.
        ``pv-cubemarch bench voxel-world`` reports its error and speed-up.
    lod_bias : float
        With ``lod``: levels added to the chosen one (``1``: cells up to two pixels wide,
        faster and coarser; ``-1``: finer).
    world_traversal : str, optional
        How a grid drawn in chunks is traversed. ``'index'``: one box and one traversal
        over the whole world through a small chunk index (an empty chunk is one step,
        stored chunks are read from one pool texture; a ray stops at its first hit in any
        chunk, so chunks behind the camera or behind nearer ground cost nothing).
        ``'per_chunk'``: a box per chunk, culled against the view and the world's solid
        faces, drawn far to near. ``None`` (default): ``'index'`` where its pool fits one
        texture and the options allow it (a power-of-two ``chunk_size``, at most 2048
        chunks a side, ``mip_levels`` at most ``log2(chunk_size)``, no
        ``distance_field``, ``proxy`` not ``'bricks'``), else ``'per_chunk'``. With
        ``'index'``, ``lod`` cells reach at most half a chunk. Either way, change colours
        with ``actor.cubemarch.set_material`` (a palette changed on the model directly is
        drawn only after the next edit).
    chunk_size : int, optional
        Draw the grid in chunks of this edge (empty chunks cost nothing, a chunk of one
        label one byte); grids over 2048 voxels on a side (the largest 3D texture here) or
        over 512 MiB of labels are chunked by 128 without asking. A chunked grid's
        ``actor.cubemarch`` is an
        :class:`~pv_cubemarch.voxels.indexed_world.IndexedWorldBinding` (the world's box) or,
        per chunk, a :class:`~pv_cubemarch.voxels.per_chunk_world.WorldBinding` (an invisible
        actor standing for all chunks); both take edits, ``pick`` and ``set_material`` in
        world voxel indices (``mode='id'`` only with ``'index'``). A
        :class:`~pv_cubemarch.models.world.VoxelWorld` (e.g. chunks placed by hand with
        ``VoxelWorld.from_chunks``) is drawn in its own chunks.
    transform, user_matrix : array_like, optional
        4x4 affine placement of the grid in the world (``user_matrix`` is PyVista's name;
        give one of the two).
    name : str, optional
        The actor's name in the plotter.
    reset_camera : bool, optional
        Reset the camera to the scene after adding (by default only while the user has
        set no camera, as PyVista does).
    pickable : bool
        Whether the actor is pickable (VTK's pickers and ``plotter.enable_*_picking``).
    render : bool
        Render once it is added, if the plotter is already shown.
    show_scalar_bar : bool
        Add a scalar bar of the materials' colours, one block per material as PyVista's
        ``categories=True`` shows (off by default); ``plotter.add_scalar_bar()`` adds one
        afterwards either way.
    scalar_bar_args : dict, optional
        Keywords of ``plotter.add_scalar_bar`` (title, position, ...).
    annotations : dict, optional
        Material to name (``{1: "bone", 2: "liver"}``), shown on the scalar bar.
    cmap : str, list or pyvista.LookupTable, optional
        A colormap over the drawn labels' range, as ``threshold`` + ``add_mesh(cmap=...)``
        colours the cells (``palette=`` instead gives one colour per material number; give
        one of the two); a lookup table colours over its own range, whatever ``clim``
        says, as ``add_mesh`` draws one.
    categories : bool
        Colour the labels as PyVista's ``threshold`` + ``add_mesh(categories=True,
        cmap=...)`` does: as many colours as distinct labels above 0, over their range
        (labels with gaps get the colours PyVista gives them, not one per label number).
    clim : sequence of float, optional
        With ``cmap``: the label values at the colormap's ends (the drawn labels' range by
        default), as ``add_mesh(clim=)``.
    n_colors : int, optional
        With ``cmap``: how many colours the colormap is cut into (256), as ``add_mesh``.
    flip_scalars : bool
        With ``cmap``: the colormap reversed, as ``add_mesh(flip_scalars=True)``.
    opacity : float, optional
        Every material's opacity (0-1), as ``add_mesh(opacity=)``: translucent materials
        are composited front to back (per material: ``palette={label: (colour, opacity)}``
        or ``actor.cubemarch.set_material``).
    lighting : bool, optional
        PyVista's name: ``False`` draws the voxels unlit (``shading='unlit'``).
    background : int
        The label id drawn as empty (0).
    clip_planes : sequence of float, optional
        Planes that cut the grid, six numbers each: a point, then the normal to the side
        kept (1 to 6 planes, as ``add_volume(clip_planes=)``). Each ray is cut to the kept
        part: a voxel the cut crosses is drawn on the plane (its label's colour there, as a
        clipped solid shows its inside). ``actor.cubemarch.set_clip_planes`` moves them.
        Grids drawn whole and worlds drawn in chunks alike.
    quality : float or str, optional
        An error budget: ``'exact'``, a PSNR in dB, or ``'fast'`` / ``'balanced'`` /
        ``'best'``. Every target is met by the exact traversal (``traversal='dda'``, no
        ``lod``): it visits every voxel a ray crosses, and no cheaper approximate setting
        was measured (``bench voxels``). Its error against the CPU reference is measured
        over a frame of the window's size from the camera the view will have, and
        reported in ``actor.cubemarch.quality`` (``'exact'`` is met only when the
        measurement shows the reference drawn: 45 dB or more). ``mode='color'``; not
        with ``traversal``, ``step_scale`` or ``lod``. Translucent labels are measured
        against the layered reference (their faces composited in depth order), without
        ``show_edges`` or ``ambient_occlusion``, which it does not draw. A world (in
        chunks) is measured as drawn, against its filled voxels read whole (up to 2**27
        of them).
    frame_budget_ms : float, optional
        While the view moves, each frame draws the grid at the most pixels (1/2, 1/3 or 1/4
        of the viewport across, shown at full size with their depth) predicted to stay
        within this many milliseconds from the costliest of the last three frames (time
        grows with the pixels): no traversal was measured cheaper than the exact one
        (``bench voxels``), so the pixels are what a moving view coarsens. The first frame
        after the view stops is drawn at full size. A world drawn per chunk has its chunks
        drawn into one reduced frame (their rays start at their boxes, not ended at the
        solid faces, both drawn at the full viewport); translucent labels are drawn at the
        same reduction (after the scene's other translucent props while the view moves).
        ``actor.cubemarch.frame_budget`` keeps the frames' values and times.
    **kwargs
        Other ``add_mesh`` keywords are refused by name, with what to use instead.
    show_edges : bool
        Outline every drawn face of every voxel, as ``threshold`` + ``add_mesh(...,
        show_edges=True)`` draws the cells' edges (``traversal='dda'``, ``mode='color'``,
        without ``lod``).
    edge_color : ColorLike, optional
        The edges' colour (the theme's ``edge_color`` by default).
    line_width : float, optional
        The edges' width in pixels (the theme's ``line_width``; as VTK, at least 1.1).
    edge_opacity : float, optional
        How much of the edge colour covers the face, 0-1 (the theme's ``edge_opacity``).
    edge_mode : str
        With ``show_edges``: ``'voxels'`` (default), every drawn face's outline;
        ``'labels'``, only the boundaries between different labels: a face's edge where the
        surface across it shows another label (or none), and where a clip plane cuts the
        grid, the lines where the cut crosses from one label to another.
    gpu_bytes, host_bytes, brick_size : int, optional
        A multiscale source only: the GPU budget of its brick pool (256 MiB), the host
        budget of its read bricks (2 GiB) and the voxels along a brick's edge (32). Each
        voxel is drawn from the coarsest level whose voxels fit a pixel there (``lod_bias``
        levels coarser, or finer when negative: ``-64`` draws the finest everywhere),
        from the next coarser level while its brick is read; coarse levels should keep the
        most frequent non-empty id of each block (``build_pyramid(..., method='mode')``),
        so a coarse hit is a real label. ``render_image(plotter, converge=True)`` waits
        until every brick the view wants is drawn; ``actor.cubemarch.stats()`` says what
        is resident and read. Labels are drawn opaque; ``palette`` is ``None``, a dict or
        a function of the id.

    A material with an opacity between 0 and 1 is composited front to back, as PyVista
    draws ``threshold`` + ``add_mesh(opacity=...)`` per label under depth peeling (chunked
    worlds too, by either ``world_traversal``); ``lod`` and ``mode='id'``/``'face'`` draw
    it opaque, with a warning.

    Returns
    -------
    pyvista.Actor
        The grid's box actor; ``actor.cubemarch`` (a
        :class:`~pv_cubemarch.voxels.technique.VoxelBinding`) holds the model and its
        palette, the per-label methods by id (``set_label_color``, ``hide_labels``,
        ``show_labels``, ``show_selected_labels``, ``highlight_labels``,
        ``clear_highlight``), ``pick``, ``set_clip_planes``, edits and ``set_transform``.
        ``mode='id'`` images match :func:`~pv_cubemarch.reference.voxels.id_colors` on a
        black background without anti-aliasing or multisampling.

    Examples
    --------
    >>> import numpy as np, pyvista as pv, pv_cubemarch as cm
    >>> x, y, z = np.mgrid[-1:1:32j, -1:1:32j, -1:1:32j]
    >>> labels = (x**2 + y**2 + z**2 < 0.8).astype(np.uint8) + (z > 0.5)
    >>> pl = pv.Plotter(off_screen=True)
    >>> actor = cm.add_voxels(pl, labels, palette=["black", "tan", "steelblue"])
    """
    open_window(plotter)   # a closed plotter: PlotterClosedError, not a half-added actor
    refuse_mesh_keywords("add_voxels", kwargs, VOXEL_REFUSED)
    _checked_name(name)
    transform = _one_transform(transform, user_matrix)
    shading = shading_for_lighting(lighting, shading)
    if is_multiscale_labels(grid):
        given = {key: value for key, value in locals().items()
                 if key not in ("plotter", "grid", "kwargs", "lighting", "user_matrix")}
        return _add_paged_labels(plotter, grid, given)
    source = _read_path(grid, "add_voxels")   # the dataset whose edits are said
    grid = _regular_grid(source, "add_voxels")
    if isinstance(grid, pyvista.MultiBlock):
        raise VolumeDataError("add_voxels draws one grid of labels; a MultiBlock holds "
                              f"{grid.n_blocks}: add each block on its own "
                              "([add_voxels(plotter, block) for block in blocks]).")
    grid, scalars = with_scalars_array(grid, scalars)   # an array: as add_mesh takes it
    streaming = [key for key, value in (("gpu_bytes", gpu_bytes), ("host_bytes", host_bytes),
                                        ("brick_size", brick_size)) if value is not None]
    if streaming:
        raise ValueError(f"{', '.join(streaming)}: for multiscale label sources (an OME-Zarr "
                         "pyramid, a list of levels) streamed by bricks; this grid is read "
                         "whole (or by chunks: chunk_size=).")
    chosen = get_technique("voxels", "voxels")
    target = None if quality is None else check_voxel_quality(
        quality, traversal, step_scale, lod)
    if frame_budget_ms is not None:   # the number, before anything is built
        check_frame_budget(frame_budget_ms, "voxels")
    options = voxel_options(traversal=traversal, step_scale=step_scale, mip_levels=mip_levels,
                            distance_field=distance_field, mode=mode, shading=shading,
                            ambient=ambient, diffuse=diffuse, specular=specular,
                            specular_power=specular_power, ambient_occlusion=ambient_occlusion,
                            occlusion_strength=occlusion_strength, proxy=proxy, lod=lod,
                            lod_bias=lod_bias, world_traversal=world_traversal,
                            show_edges=show_edges, edge_color=edge_color,
                            line_width=line_width, edge_opacity=edge_opacity,
                            edge_mode=edge_mode, clip_planes=clip_planes)
    colouring = dict(cmap=cmap, categories=categories or None, clim=clim, n_colors=n_colors,
                     flip_scalars=flip_scalars or None, opacity=opacity)
    if is_array_source(grid) or _numpy_by_chunks(grid, chunk_size, colouring):
        # zarr, dask, h5py, memmap: whole if it fits, else by chunks (numpy arrays too
        # large for one texture too: no compacted copy of the whole grid)
        grid = _array_grid(grid, chunk_size, background, palette, transform, name, colouring)
        if isinstance(grid, VoxelWorld):   # its ids, palette and placement are in it now
            background, transform = 0, None
    if isinstance(grid, (VoxelModel, VoxelWorld)):
        model = grid
        if transform is not None:
            raise ValueError("transform goes with raw data; a VoxelModel or VoxelWorld carries "
                             "its own (set model.transform, or actor.cubemarch.set_transform).")
        colouring = [key for key, value in dict(
            colouring, background=None if background == 0 else background).items()
            if value is not None]
        if colouring:
            raise ValueError(f"{', '.join(colouring)}: these colour raw labels; a VoxelModel "
                             "or VoxelWorld carries its palette (make_voxels(..., palette=..., "
                             "categories=True), or actor.cubemarch.set_material).")
    else:
        model = make_voxels(grid, scalars, palette=palette, transform=transform,
                            name=name or "voxels", categories=bool(categories), cmap=cmap,
                            clim=clim, n_colors=n_colors, flip_scalars=flip_scalars,
                            opacity=opacity, background=background)
    if isinstance(model, VoxelWorld) and chunk_size not in (None, model.chunk_size):
        raise ValueError(f"chunk_size={chunk_size} differs from the world's own "
                         f"{model.chunk_size}; leave it out for a VoxelWorld.")
    if isinstance(model, VoxelWorld) or chunk_size is not None or not fits_one_texture(
            model.dimensions, model.labels.dtype):
        if proxy is None:   # chunks: no brick shells by default (bench voxel-world)
            options = dataclasses.replace(options, proxy="box")
        if not isinstance(model, VoxelWorld):
            model = VoxelWorld.from_model(
                model, DEFAULT_CHUNK_SIZE if chunk_size is None else chunk_size)
        per_chunk = _why_per_chunk(model, options)
        if target is not None:   # refused before anything is drawn
            _check_voxel_quality(model, options)
            check_world_reference(model)
        actor = _add_world(plotter, model, options, name, reset_camera)
        if target is not None:   # measured with the world drawn as the user's will be
            _measure_voxels(plotter, actor, target, dict(
                _voxel_look(options),
                world_traversal="index" if per_chunk is None else "per_chunk"), options)
        if frame_budget_ms is not None:
            attach_frame_budget(actor.cubemarch, "voxels", plotter.ren_win, frame_budget_ms)
    else:
        options.check_model(model)
        if world_traversal is not None:   # said, not ignored in silence
            warnings.warn(f"world_traversal={world_traversal!r} is for grids drawn in chunks; "
                          f"this grid of {tuple(model.dimensions)} voxels is drawn whole (give "
                          "chunk_size= to draw it in chunks).", stacklevel=2)
        if target is not None:
            _check_voxel_quality(model, options)
        component = plotter.cubemarch
        binding = chosen.build(plotter, model, options)
        if frame_budget_ms is not None:
            attach_frame_budget(binding, "voxels", plotter.ren_win, frame_budget_ms)
        if not binding.composites:
            binding.opaque_because = _opaque_because(options)
            binding.say_drawn_opaque()
        actor = _place(plotter, binding, name or _unused_name(plotter, model.name))
        _say_edits_of(binding, source)
        component.track(binding)
        _frame(plotter, reset_camera)
        if target is not None:   # measured with the grid drawn, framed as its actor is
            _measure_voxels(plotter, actor, target, _voxel_look(options), options)
    add_voxel_scalar_bar(plotter, actor, model.palette, _bar_title(grid, scalars, model.name),
                         show_scalar_bar, scalar_bar_args, annotations, model.ids,
                         listed_rows(model) if model.ids.identity else None)
    _shown(plotter, actor, reset_camera, pickable, render)
    return actor


def add_surface(
    plotter: pyvista.Plotter,
    field,
    isovalue: float | None = None,
    scalars: str | None = None,
    *,
    technique: str = "active",
    steps: int | None = None,
    refine_steps: int = 10,
    root: str | None = None,
    traversal: str = "index",
    active_test: str = "bernstein",
    active_samples: int = 4,
    color=None,
    shading: str = "blinn",
    ambient: float = 0.2,
    diffuse: float = 0.8,
    specular: float = 0.3,
    specular_power: float = 30.0,
    color_by=None,
    cmap: str = "viridis",
    clim=None,
    cells=64,
    spline: str = "interpolating",
    transform=None,
    name: str | None = None,
    isosurfaces=None,
    opacity: float = 1.0,
    smooth_shading: bool | None = None,
    show_scalar_bar: bool = False,
    scalar_bar_args: dict | None = None,
    annotations: dict | None = None,
    lighting: bool | None = None,
    quality=None,
    frame_budget_ms: float | None = None,
    clip_planes=None,
    user_matrix=None,
    reset_camera: bool | None = None,
    pickable: bool = True,
    render: bool = True,
    **kwargs,
) -> pyvista.Actor:
    """Draw the implicit surface f = 0 of a field, per pixel, from its cells' polynomials.

    The field is a uniform quadratic B-spline: each cell's 27 coefficients make a
    polynomial evaluated in the cell's own coordinates; with the default
    ``technique='active'`` only the cells the surface can cross are stored and drawn, and
    each pixel's ray is marched only inside them. The hit's real depth is written, so
    meshes and other techniques occlude the surface and are occluded by it.

    Parameters
    ----------
    plotter : pyvista.Plotter
        The plotter to draw in.
    field : SplineField, numpy.ndarray, pyvista.ImageData, pyvista.PolyData or path
        A :class:`~pv_cubemarch.models.surface.SplineField` (e.g. from raw coefficients:
        ``SplineField(coefficients)`` with ``(nx + 2, ny + 2, nz + 2)`` of them); samples
        (one per cell: a 3D array indexed x, y, z, or an ImageData's cell or point data)
        whose ``isovalue`` surface is drawn, the inside where they exceed it; a closed
        surface mesh (or a mesh file), drawn from its signed distance sampled at the
        centres of ``cells`` cells along its longest side; or a point cloud with outward
        normals (a PolyData without faces with ``point_data['Normals']``, or a
        ``(points, normals)`` pair), fitted by sparse least squares on ``cells`` cells
        (32³ in seconds, with a progress bar).
    isovalue : float, optional
        The level of sampled data to draw (required for samples).
    scalars : str or numpy.ndarray, optional
        The ImageData array, by name or as values (one per point or per cell, as
        ``contour(scalars=)`` takes them); the first cell (then point) array by default.
    technique : str
        ``'active'`` (default): only the active cells (the cells the surface can cross).
        ``'full'``: the baseline, every ray marched through the whole domain with every
        cell's coefficients.
    steps : int
        Samples along the domain's diagonal (in cells); each cell crossed is sampled every
        ``diagonal / steps`` from where the ray enters it and at its exit. More steps miss
        fewer thin features and grazing hits, at a cost (500 by default).
    refine_steps : int
        Bisections of the first sign change (10 by default): the depth error halves with
        each.
    root : str
        ``'march'`` (default: samples every ``diagonal / steps``, so two roots closer than a
        step, a thin feature or a grazing ray, can be missed) or ``'exact'`` (the first root
        of each cell's degree-6 polynomial along the ray by Bernstein subdivision, whatever
        ``steps``; ``technique='active'``).
    traversal : str
        How ``technique='active'`` reaches its cells. ``'index'`` (default): one ray per
        pixel steps through bricks of 4³ cells, skipping those without active cells, and
        marches the active cells it meets in order, stopping at the first root; the
        bricks share their cells' coefficients (about 9 floats per active cell).
        ``'cell_boxes'``: every active cell's box is drawn and each of its fragments marches
        that cell alone, the depth test keeping the nearest hit (27 floats and 12 triangles
        per active cell; every active cell on a ray is marched).
    active_test : str
        ``'bernstein'`` (default, exact: a cell is kept when its Bernstein coefficients
        change sign, so no crossed cell is ever left out) or ``'sample'`` (the field at
        ``active_samples ** 3`` points per cell changes sign; misses thin features).
    active_samples : int
        Points per axis per cell of ``active_test='sample'``.
    color : ColorLike, optional
        The surface's colour (white by default; with several ``isosurfaces``, each level's
        colour through ``cmap`` by default, as PyVista colours a contour by its values).
    shading : str
        ``'blinn'`` (default), ``'flat'`` or ``'unlit'``: the scene's lights (up to 8) on the
        analytic normal, both sides lit; ``ambient``, ``diffuse``, ``specular``,
        ``specular_power`` as for voxels. ``'normals'``: the view-space normal facing the
        eye as the colour ``0.5 + 0.5 n`` (to check normals).
    ambient, diffuse, specular, specular_power : float
        As VTK lights a mesh (PyVista's ``add_mesh`` keywords): the colour times
        ``ambient + diffuse * sum(light * max(n.l, 0))`` (each 0-1; PyVista's mesh takes 0
        and 1), plus the highlight's weight (0-1) times its exponent's power.
    color_by : str or array_like, optional
        ``'curvature'``: the mean curvature per world unit (positive where the surface
        bends like a ball), computed from the cell polynomial's gradient and Hessian;
        or a second field's samples (an array or ImageData on the same cells as the
        surface's samples, or the name of an array of the grid given), interpolated as the
        field is and read at the hit. An array is ``(nx, ny, nz)`` indexed ``[i, j, k]``,
        or flat in VTK's point order (x fastest), as ``grid.point_data`` holds it.
    cmap : str, matplotlib colormap or pyvista.LookupTable
        The colormap of ``color_by`` (256 entries); a lookup table's colours over its own
        range, whatever ``clim`` says, as ``add_mesh`` draws one.
    clim : sequence of float, optional
        The values at the colormap's ends: of ``color_by`` (by default the second field's
        range, or plus and minus 4 / the domain's shortest edge for curvature), or of the
        ``isosurfaces`` coloured by value (by default their range, as PyVista's contour).
    cells : int or sequence of int
        A mesh's or point cloud's resolution: cells along its longest side (64), or (a
        mesh) three counts; two more on every side keep the surface inside the domain.
    spline : str, default: 'interpolating'
        How samples (or a mesh's distances) become the spline: ``'interpolating'`` passes
        through every sample; between samples that step sharply (CT air next to tissue) it
        overshoots them, and near a plateau close to the level crosses it where no sample
        does (said with a warning). ``'approximating'`` takes the samples as its
        coefficients: it never crosses a level where no neighbouring sample does, and is
        smoother, but does not pass through the samples (a ridge one sample wide is drawn
        lower: the samples are blurred by ``(1, 6, 1) / 8`` along each axis).
    transform, user_matrix : array_like, optional
        4x4 placement of the field in the world (``user_matrix`` is PyVista's name; give
        one of the two).
    name : str, optional
        The actor's name in the plotter.
    reset_camera : bool, optional
        Reset the camera to the scene after adding (by default only while the user has
        set no camera, as PyVista does).
    pickable : bool
        Whether the actor is pickable (VTK's pickers and ``plotter.enable_*_picking``).
    render : bool
        Render once it is added, if the plotter is already shown.
    isosurfaces : int or sequence of float, optional
        Several levels of sampled data (or of any field: offsets of its zero set), as
        ``contour(isosurfaces=...)`` takes them: the values, or a count spread from the
        samples' smallest to largest value. Each level is drawn opaque at its real depth,
        so nested levels hide each other as PyVista's opaque contour does (give
        ``isovalue`` or ``isosurfaces``, not both).
    opacity : float
        1 (default) is opaque. Below 1, every crossing of the surface along a pixel's ray,
        up to the opaque scene behind, is composited front to back, each lit and covering
        ``opacity`` of what lies behind: what PyVista draws for ``contour`` +
        ``add_mesh(opacity=...)`` under depth peeling with enough peels, in one pass
        (``technique='active'``, ``traversal='index'``). With several ``isosurfaces``
        (up to 8, ``root='march'``) every crossing of every level is composited in depth
        order. Other translucent props (meshes, volumes, other translucent surfaces) are
        blended whole before or after it, in the order they draw, as VTK blends
        translucent props without depth peeling.
    smooth_shading : bool, optional
        ``True`` (or left out): the surface is lit with its exact normal, which is what
        smooth shading approximates; ``False`` is refused (the surface has no facets).
    show_scalar_bar : bool
        Add a scalar bar of ``cmap`` over what colours the surface (``color_by``'s range,
        or the levels'); ``plotter.add_scalar_bar()`` afterwards shows it either way.
    scalar_bar_args : dict, optional
        Keywords of ``plotter.add_scalar_bar`` (title, position, ...).
    annotations : dict, optional
        Value to label, shown on the scalar bar (as ``add_mesh(annotations=)``).
    lighting : bool, optional
        PyVista's name: ``False`` draws the surface unlit (``shading='unlit'``).
    quality : float or str, optional
        An error budget instead of ``steps``: a PSNR in dB (up to 60) against the CPU
        reference, ``'fast'`` (30), ``'balanced'`` (40), ``'best'`` (50), or ``'exact'``
        (``root='exact'``: no root missed at any step). The fewest ``steps`` that meet it
        are chosen by drawing a few from the camera the view will have, at the window's
        size, in the surface's colour and shading lit by a headlight, and comparing
        pixels with the reference; ``actor.cubemarch.quality`` says what was chosen and
        what was tried. Kept per field, look, camera, window size, background and GL
        renderer; ``actor.cubemarch.recalibrate()`` chooses again for the view then.
        Several isosurfaces, translucency and ``color_by`` are drawn in the probe and
        traced by the reference as drawn (translucent ones take a PSNR, not ``'exact'``);
        not with ``steps``, ``root`` or ``shading='normals'``.
    frame_budget_ms : float, optional
        While the view moves, each frame marches the most ``steps`` predicted to stay within
        this many milliseconds from the costliest of the last three frames (time grows with
        the steps); below 100 steps it draws fewer pixels instead, at 1/2, 1/3 or 1/4 of the
        viewport across, shown at full size with their depth (the walk through the cells
        costs what the steps do not). The first frame after the view stops draws the still
        ``steps`` again, at full size. Nothing is rebuilt. Several isosurfaces move
        together; a translucent surface is drawn reduced after the scene's opaque props
        and composited over the frame (after its other translucent props, while the view
        moves). Not with ``root='exact'``.
    clip_planes : sequence of float, optional
        Planes that cut the surface, six numbers each: a point, then the normal to the
        side kept (1 to 6 planes, as ``add_volume(clip_planes=)``). Each ray finds its
        first root where every plane keeps it; the cut is left open, as
        ``mesh.clip(...)`` leaves a contour. ``actor.cubemarch.set_clip_planes`` moves
        them, and planes put on the returned actor's mapper (a plane widget's) cut too.
    **kwargs
        Other ``add_mesh`` keywords are refused by name, with what to use instead.

    Returns
    -------
    pyvista.Actor
        The surface's actor; ``actor.cubemarch`` holds the field (``model``), the active
        cells (``cells``) and the GPU bytes (``nbytes``, against ``dense_bytes``). With
        several ``isosurfaces``, an invisible actor standing for every level
        (``actor.cubemarch.levels``, each level's binding, and ``values``).

    Examples
    --------
    >>> import numpy as np, pyvista as pv, pv_cubemarch as cm
    >>> x, y, z = np.mgrid[-1:1:32j, -1:1:32j, -1:1:32j]
    >>> pl = pv.Plotter(off_screen=True)
    >>> actor = cm.add_surface(pl, 0.8 - (x**2 + y**2 + z**2), isovalue=0.0)
    """
    open_window(plotter)   # a closed plotter: PlotterClosedError, not a half-added actor
    refuse_mesh_keywords("add_surface", kwargs, SURFACE_REFUSED)
    _checked_name(name)
    transform = _one_transform(transform, user_matrix)
    shading = shading_for_lighting(lighting, shading)
    try:
        if opacity is None or isinstance(opacity, (bool, str)):
            raise TypeError
        opacity = float(opacity)
    except (TypeError, ValueError):
        raise ValueError(f"opacity={opacity!r}: give a number in [0, 1] (1, the default, is "
                         "opaque).") from None
    if smooth_shading is not None and not smooth_shading:
        raise ValueError("smooth_shading=False shades a mesh's facets flat; this surface is "
                         "drawn from its polynomial with its exact normal and has no facets. "
                         "Leave smooth_shading out (shading='flat' drops the highlight).")
    if isosurfaces is not None and isovalue is not None:
        raise ValueError("give isovalue= (one level) or isosurfaces= (several), not both.")
    field, scalars = with_scalars_array(field, scalars)   # an array: as contour takes it
    cmap, clim = _table_colours(cmap, clim)
    levels = None if isosurfaces is None else surface_levels(
        isosurfaces, _samples_of(field, scalars))
    chosen = get_technique("surface", technique)
    if isinstance(color_by, str) and color_by not in ("curvature", "field") and isinstance(
            field, pyvista.DataSet) and color_by in field.array_names:
        color_by = field[color_by]   # an array of the grid, by name (as scalars= takes it)
    colouring = color_by if color_by is None or isinstance(color_by, str) else "field"
    if levels is not None and len(levels) > 1 and colouring is not None:
        raise ValueError("color_by colours one surface; several isosurfaces are coloured "
                         "by their levels through cmap (or all by color=).")
    by_level = levels is not None and len(levels) > 1 and color is None
    if show_scalar_bar and colouring is None and not by_level:
        raise ValueError("show_scalar_bar shows what colours the surface through cmap; this "
                         "one has one colour: pass color_by=, or several isosurfaces "
                         "without color=.")
    color = "white" if color is None else color
    given = {k: v for k, v in (("steps", steps), ("root", root)) if v is not None}
    steps = SURFACE_STEPS.default if steps is None else steps
    root = SURFACE_ROOT.default if root is None else root
    options = chosen.make_options(dict(
        steps=steps, refine_steps=refine_steps, root=root, traversal=traversal,
        active_test=active_test,
        active_samples=active_samples, color=color, shading=shading, ambient=ambient,
        diffuse=diffuse,
        specular=specular, specular_power=specular_power, color_by=colouring, cmap=cmap,
        clim=None if clim is None else tuple(clim), opacity=opacity,
        clip_planes=plane_numbers(clip_planes)))
    with warnings.catch_warnings():   # several levels: each out of range is named below
        if levels is not None and len(levels) > 1:
            warnings.filterwarnings("ignore", message="isovalue=.* outside the data range")
        model = make_field(field, isovalue if levels is None else levels[0], scalars,
                           cells=cells, transform=transform, spline=spline,
                           name=name or getattr(field, "name", "surface"))
    if colouring == "field" and not isinstance(color_by, str):   # values, not a name
        model = dataclasses.replace(model, color_values=color_values(color_by, model, spline))
    options.check_model(model)
    if frame_budget_ms is not None:   # refused before anything is drawn or calibrated
        check_frame_budget(frame_budget_ms, chosen.name)
        if root == "exact" or (quality is not None and parse_quality(quality,
                                                                     exact=True).exact):
            raise ValueError("frame_budget_ms moves a marched surface's steps; root='exact' "
                             "(or quality='exact') has none: leave one of them out.")
    table = None
    if levels is not None and len(levels) > 1:
        table = level_lookup_table(cmap, levels, options.clim)
        colours = [tuple(float(v) for v in table.map_value(level, opacity=False))
                   if by_level else options.rgb for level in levels]
    calibration = choice = None
    if quality is not None:
        target = check_surface_quality(quality, given, options, chosen.name)
        look, offsets = _surface_look(options), None
        if table is not None:   # the levels from the model's zero, coloured as here
            offsets = tuple(v - levels[0] for v in levels)
            look.update(isosurfaces=list(offsets), color=None if by_level else options.color,
                        clim=None if options.clim is None else tuple(
                            float(c) - levels[0] for c in options.clim))
        calibration = SurfaceCalibration(
            model, chosen.name, target, look, _probe_adder(add_surface), chosen.reference,
            options=options, exact_rung=frame_budget_ms is None, levels=offsets,
            level_colors=None if table is None else tuple(colours))
        choice = calibration.run(plotter, None)
        options = dataclasses.replace(options, **choice.setting)
    _say_levels_without_zero(model, levels)
    if table is not None and options.translucent:   # every level in one pass
        if technique != "active":
            raise ValueError(f"opacity={opacity:g} with {len(levels)} isosurfaces: they are "
                             "composited along one ray per pixel by technique='active'; "
                             f"technique={technique!r} keeps only the nearest hit.")
        binding = build_translucent_levels(plotter, model, options,
                                           [v - levels[0] for v in levels], colours)
        binding.values = tuple(float(v) for v in levels)
    elif table is not None:
        drawn = []
        for level, colour in zip(levels, colours, strict=True):   # B-splines keep constants
            shifted = dataclasses.replace(model, coefficients=model.coefficients
                                          - (level - levels[0]))
            drawn.append(chosen.build(plotter, shifted,
                                      dataclasses.replace(options, color=colour)))
        binding = SurfaceLevels(drawn, levels)
    else:
        binding = chosen.build(plotter, model, options)
        if options.color_by:
            table = pyvista.LookupTable(cmap)
            table.scalar_range = options.color_range(model)
    binding.quality = choice
    if calibration is not None:
        calibration.follow(binding, plotter)
    if frame_budget_ms is not None:
        attach_frame_budget(binding, chosen.name, plotter.ren_win, frame_budget_ms, {
            m["setting"]["steps"]: m["psnr"] for m in (choice.measured if choice else [])
            if "steps" in m["setting"]})
    actor = _place(plotter, binding, name or _unused_name(plotter, model.name))
    _say_edits_of(binding, field)
    plotter.cubemarch.track(binding)
    if table is not None:
        if annotations:
            table.annotations = {float(k): str(v) for k, v in annotations.items()}
        add_surface_scalar_bar(plotter, actor, table, scalars or (color_by if isinstance(
            color_by, str) else model.name), show_scalar_bar, scalar_bar_args)
    elif annotations:
        raise ValueError("annotations label the scalar bar of what colours the surface "
                         "through cmap; this one has one colour: pass color_by=, or "
                         "several isosurfaces without color=.")
    _shown(plotter, actor, reset_camera, pickable, render)
    return actor


def _surface_look(options) -> dict:
    """What a surface's calibration candidates are drawn with besides the rung."""
    return {name: getattr(options, name) for name in (
        "refine_steps", "traversal", "active_test", "active_samples", "color", "shading",
        "ambient", "diffuse", "specular", "specular_power", "color_by", "cmap", "clim",
        "opacity", "clip_planes")}


def _probe_adder(add, technique: bool = True):
    """``add`` as calibration draws a candidate (the probe's camera is set after).

    ``technique``: whether ``add`` takes one (``add_voxels`` has one only).
    """
    def draw(plotter, model, reset_camera=None, render=None, **keywords):
        if not technique:
            keywords.pop("technique", None)
        return add(plotter, model, **keywords)
    return draw


def _voxel_look(options) -> dict:
    """What a voxel grid's probe is drawn with: its options but the traversal's."""
    return {f.name: getattr(options, f.name) for f in dataclasses.fields(options)
            if f.name not in ("traversal", "step_scale", "lod", "lod_bias",
                              "world_traversal")}


def _voxel_reference_look(options) -> dict:
    """The voxel reference's keywords for the grid's look."""
    look = {name: getattr(options, name) for name in (
        "shading", "ambient", "diffuse", "specular", "specular_power", "ambient_occlusion",
        "occlusion_strength", "show_edges", "edge_mode")}
    look["clip_planes"] = options.world_planes or None
    if options.show_edges:
        color, half_width, opacity = options.edge_style
        look.update(edge_color=color, line_width=2.0 * half_width, edge_opacity=opacity)
    return look


def _samples_of(field, scalars):
    """The samples of an array or ImageData (for a count of isosurfaces), else None."""
    if isinstance(field, np.ndarray):
        return field
    if isinstance(field, pyvista.ImageData):
        names = list(field.cell_data.keys()) + list(field.point_data.keys())
        if scalars is not None or names:
            return np.asarray(field[scalars or names[0]])
    return None
