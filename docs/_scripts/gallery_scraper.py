"""The gallery's image scraper (a module of its own: Sphinx pickles its configuration)."""

from __future__ import annotations

import pyvista


class OpenPlotterScraper(pyvista.Scraper):
    """PyVista's scraper, leaving out plotters an example closed before showing them.

    With ``pyvista.BUILDING_GALLERY`` set, a closed plotter stays registered: one that was
    shown keeps its last image (the figure), one closed unshown has none, and PyVista's
    scraper would fail on it.
    """

    def __call__(self, block, block_vars, gallery_conf):
        """Drop closed plotters, then save the open ones' pictures as PyVista does."""
        plotters = pyvista.plotting.plotter._ALL_PLOTTERS
        for key, plotter in list(plotters.items()):
            closed = getattr(plotter, "render_window", None) is None
            if closed and getattr(plotter, "last_image", None) is None:
                del plotters[key]
        return super().__call__(block, block_vars, gallery_conf)
