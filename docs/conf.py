"""Sphinx configuration of geomech's documentation site (``make docs``).

The toolchain is Sphinx with numpydoc (every public name has a numpydoc docstring), sphinx-gallery (the scripts of
examples/ and docs/tutorials/ run during the build and appear with their figures and output) and the PyData theme
(the theme of numpy, scipy and xarray), with MyST for the Markdown guides. Nothing is fetched at build time or by the
pages: MathJax and plotly.js are served from the site itself, and there is no intersphinx.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

import plotly.offline

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE / "_ext"))
sys.path.insert(0, str(ROOT / "src"))

from gallery_plotly import plotly_scraper, reset_plotly  # noqa: E402

import geomech  # noqa: E402

project = "geomech"
author = "the geomech developers"
copyright = "the geomech developers"  # noqa: A001
release = geomech.__version__
version = ".".join(release.split(".")[:2])

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "geomech_docs",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "**/README.rst", "tutorials/*.py"]
templates_path = ["_templates"]
nitpicky = False

# The API reference: one page per public name, generated from each subpackage's __all__ (geomech_docs.py).
autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_typehints = "none"  # numpydoc's Parameters sections say the types
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()

# MyST: $...$ and $$...$$ in the Markdown guides, headings as link targets.
myst_enable_extensions = ["dollarmath", "amsmath"]
myst_heading_anchors = 3

# MathJax served from the site (the files of the sphinx-mathjax-offline package), never from a CDN.
_MATHJAX = Path(importlib.util.find_spec("sphinx-mathjax-offline").origin).parent / "static"
mathjax_path = "mathjax/tex-chtml.js"

# plotly.js once for the whole site, loaded by the pages that have an interactive figure (geomech_docs.py): the
# gallery's figures are embedded without their own copy.
_PLOTLY = HERE / "_build" / "plotly_static"
_PLOTLY.mkdir(parents=True, exist_ok=True)
(_PLOTLY / "plotly.min.js").write_text(plotly.offline.get_plotlyjs(), encoding="utf-8")
html_static_path = ["_static", str(_MATHJAX), str(_PLOTLY)]
html_css_files = ["geomech.css"]

html_theme = "pydata_sphinx_theme"
html_title = f"geomech {release}"
html_logo = None
html_favicon = "_static/favicon.svg"  # else the browser asks for /favicon.ico, which is not there
html_show_sourcelink = False
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "header_links_before_dropdown": 2,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_context = {"default_mode": "light"}

sphinx_gallery_conf = {
    "examples_dirs": [str(ROOT / "examples"), str(HERE / "tutorials")],
    "gallery_dirs": ["auto_examples", "auto_tutorials"],
    # every script runs during the build; GEOMECH_DOCS_PATTERN (a regular expression on the path) runs fewer while
    # one page is being written
    "filename_pattern": os.environ.get("GEOMECH_DOCS_PATTERN", r".*\.py$"),
    "ignore_pattern": r"__init__\.py",
    "abort_on_example_error": True,
    "only_warn_on_example_error": False,
    "download_all_examples": False,
    "remove_config_comments": True,
    "capture_repr": ("_repr_html_", "__repr__"),
    "image_scrapers": ("matplotlib", plotly_scraper),
    "reset_modules": ("matplotlib", "seaborn", reset_plotly),
    "matplotlib_animations": False,
    "within_subsection_order": "FileNameSortKey",
    "min_reported_time": 1,
    "show_memory": False,
    "write_computation_times": False,  # its pages load jQuery and DataTables from CDNs
    "parallel": True,  # as many example processes as sphinx-build's -j
    "plot_gallery": os.environ.get("GEOMECH_DOCS_GALLERY", "True"),
}

suppress_warnings = ["config.cache"]  # sphinx-gallery's configuration holds callables and paths
