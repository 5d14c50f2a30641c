"""Rendering on a Dask cluster: batches of frames, each worker keeping its scene loaded."""

from .frames import orbit, render_frames

__all__ = ["orbit", "render_frames"]
