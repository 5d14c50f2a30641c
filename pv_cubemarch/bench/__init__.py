"""The speed/accuracy instrument: frame time against error versus the CPU reference.

Rows measured side by side in one run (``harness``), and the cube map against viewport
resolution (``resolution``).
"""

from .harness import format_table, plot_pareto, run_tradeoff, sweeps, write_json
from .resolution import format_resolution_table, run_resolution

__all__ = ["format_resolution_table", "format_table", "plot_pareto", "run_resolution",
           "run_tradeoff", "sweeps", "write_json"]
