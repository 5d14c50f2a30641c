"""Sphinx configuration: PyVista's theme, numpydoc, the API by autosummary, the gallery.

Build: ``bash tools/build_docs.sh`` (warnings fail the build). The gallery runs every
script in ``examples/`` offscreen and keeps each plotter's picture, as pyvista.org does;
``PV_CUBEMARCH_DOCS_GALLERY=quick`` runs only the quick ones (CI's fast subset).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pyvista

import pv_cubemarch

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_scripts"))

from gallery_scraper import OpenPlotterScraper  # noqa: E402
from generate_pages import generate_all  # noqa: E402

generate_all(HERE)

pyvista.OFF_SCREEN = True
pyvista.BUILDING_GALLERY = True
pyvista.set_plot_theme("document")

project = "pv_cubemarch"
author = "the pv_cubemarch developers"
copyright = "2026, the pv_cubemarch developers"  # noqa: A001
release = version = pv_cubemarch.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.intersphinx",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "sphinx_design",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "_generated/*.md.part", "auto_examples/*.ipynb",
                    "auto_examples/**/*.ipynb", "**/*.py.md5", "**/*.codeobj.json"]
templates_path = ["_templates"]
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3
suppress_warnings = ["myst.header"]

autosummary_generate = True
autodoc_default_options = {"members": True, "inherited-members": False}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_xref_param_type = False

intersphinx_mapping = {
    "python": ("https://docs.python.org/3", None),
    "numpy": ("https://numpy.org/doc/stable", None),
    "pyvista": ("https://docs.pyvista.org", None),
}
# The build must work offline (CI machines have no network): no inventories are fetched.
intersphinx_disabled_reftypes = ["*"]
intersphinx_timeout = 1
if os.environ.get("PV_CUBEMARCH_DOCS_ONLINE") != "1":
    intersphinx_mapping = {}

html_theme = "pydata_sphinx_theme"
html_title = "pv_cubemarch"
html_static_path = []
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc", "sourcelink"],
}

QUICK = os.environ.get("PV_CUBEMARCH_DOCS_GALLERY") == "quick"
sphinx_gallery_conf = {
    "examples_dirs": ["../examples"],
    "gallery_dirs": ["auto_examples"],
    # every script runs (not only plot_*); the quick subset is CI's fast build
    "filename_pattern": r"(quickstart|segmentation|material_grid)\.py$" if QUICK else r"\.py$",
    "image_scrapers": (OpenPlotterScraper(), "matplotlib"),
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    # by what users do, most common first
    "subsection_order": ["../examples/volumes", "../examples/labels", "../examples/surfaces",
                         "../examples/scenes", "../examples/live", "../examples/benchmarks"],
    "reset_modules": ("matplotlib",),
    "show_memory": False,
    "abort_on_example_error": True,
}
