"""Rendering on a Dask cluster: frame batches and sort-last frames of a split volume.

Each worker keeps its scene (or its slabs of the volume) loaded between frames.
"""

from .frames import orbit, render_frames
from .sort_last import render_sort_last

__all__ = ["orbit", "render_frames", "render_sort_last"]
