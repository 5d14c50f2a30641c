"""The error budget: the cheapest settings that meet a PSNR target against the CPU reference.

``quality=`` names a target (dB, or 'fast' / 'balanced' / 'best'); a technique's settings
are tried on the scene's own data and camera, cheapest first as its cost model orders
them, and the first whose error against the CPU reference meets the target is kept.
"""

from .calibration import QualityChoice, calibrate
from .ladders import Rung, volume_ladder, volume_tracks
from .targets import NAMED_TARGETS, QualityTarget, parse_quality

__all__ = ["NAMED_TARGETS", "QualityChoice", "QualityTarget", "Rung", "calibrate",
           "parse_quality", "volume_ladder", "volume_tracks"]
