"""Rendering on a Dask cluster: frame batches, sort-last frames of a split volume, sweeps.

Each worker keeps its scene (or its slabs of the volume) loaded between frames.
"""

from .frames import orbit, render_frames
from .sort_last import render_sort_last
from .sweep import sweep_options

__all__ = ["orbit", "render_frames", "render_sort_last", "sweep_options"]
