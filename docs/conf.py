"""Sphinx configuration of the netcosim documentation (``make docs``).

Offline by construction: the intersphinx inventories are files under ``docs/_inv/``
(taken from Debian's documentation packages, see ``docs/_inv/README.md``), the theme and
its assets come from the installed pydata-sphinx-theme, and every figure is produced by
code that runs during the build (the tutorial and the gallery, by sphinx-gallery).

``NETCOSIM_DOCS_GALLERY=full`` runs the gallery's experiments at full size; by default
(and in CI) each runs its ``--quick`` mode.  ``-D sphinx_gallery_conf.filename_pattern=x``
or ``NETCOSIM_DOCS_GALLERY=off`` skips running the examples altogether.
"""

from __future__ import annotations

import os
import sys
import types
from pathlib import Path

import netcosim

# autosummary's recursion imports every submodule: the command line's __main__ modules would
# parse sphinx-build's arguments on import.  They hold no API of their own.
for _name in ("netcosim.__main__", "netcosim.cli.__main__"):
    sys.modules.setdefault(_name, types.ModuleType(_name))

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(DOCS / "_ext"))
from netcosim_docs import PageScraper  # noqa: E402  (docs/_ext is on the path only from here)

project = "netcosim"
author = "the netcosim authors"
copyright = "the netcosim authors"
version = release = netcosim.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "sphinx.ext.intersphinx",
    "sphinx.ext.mathjax",
    "sphinx.ext.doctest",
    "sphinx_gallery.gen_gallery",
    "netcosim_docs",           # docs/_ext/netcosim_docs.py: re-exported names, the API landing table
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_inv", "_templates", "_ext", "**/README.md", "tutorial/*.py", "gallery_src/*.py",
                    "tutorial/GALLERY_HEADER.rst", "gallery_src/GALLERY_HEADER.rst"]
templates_path = ["_templates"]

# -- MyST: the existing docs/*.md pages ---------------------------------------------------
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# -- API reference: autosummary + autodoc + numpydoc ---------------------------------------
autosummary_generate = True
autosummary_imported_members = False
autosummary_ignore_module_all = True       # each object documented where it is defined
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_member_order = "bysource"
autodoc_typehints = "none"            # the signatures show the names; the prose says the units
autodoc_preserve_defaults = True
numpydoc_show_class_members = False   # the class template's autosummary lists members
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()

# -- intersphinx: offline inventories -----------------------------------------------------
# (URL the links point to, local inventory).  NumPy, python-control, CasADi, Matplotlib and Bokeh
# have no inventory reachable offline (no Debian documentation package ships one for the
# versions in use, and their wheels and sdists do not carry objects.inv): their names are
# written as plain literals in the docs, and nitpick_ignore below lists the few that
# autodoc produces from signatures.
_INV = DOCS / "_inv"
intersphinx_mapping = {
    "python": ("https://docs.python.org/3.11/", str(_INV / "python.inv")),
    "scipy": ("https://docs.scipy.org/doc/scipy-1.10.1/", str(_INV / "scipy.inv")),
    "pandas": ("https://pandas.pydata.org/pandas-docs/version/1.5.3/", str(_INV / "pandas.inv")),
    "simpy": ("https://simpy.readthedocs.io/en/3.0.11/", str(_INV / "simpy.inv")),
}
intersphinx_timeout = 1

# -- warnings as errors, nitpicky ---------------------------------------------------------
nitpicky = True
nitpick_ignore_regex = [
    # no offline inventory (see above): NumPy's, CasADi's and Matplotlib's types in signatures
    ("py:.*", r"(numpy|np)\..*"),
    ("py:.*", r"(casadi|ca)\..*"),
    ("py:.*", r"matplotlib\..*"),
    ("py:.*", r"control\..*"),
    ("py:.*", r"(zenoh|dask|distributed|pyarrow|filterpy)\..*"),
    # Bokeh (the viewer), pythonfmu and FMPy (the FMI coupling): no offline inventory either
    ("py:.*", r"(bokeh|pythonfmu|fmpy)\..*"),
    # numpydoc's type fields in the docstrings' Parameters sections are prose, not names
    ("py:class", r"(array_like|array-like|optional|callable|sequence|iterable|mapping|default.*|or|of)"),
]

# -- HTML: the PyData theme ---------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = "netcosim"
html_static_path: list[str] = []
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    # the API reference has ~800 pages: a sidebar listing them all on every page would make
    # the site ten times larger; the sidebar shows the current section's level only
    "collapse_navigation": True,
    "navigation_depth": 2,
    "show_nav_level": 1,
    "navbar_align": "left",
    "icon_links": [],
    "footer_start": ["copyright"],
    "footer_end": [],
}
html_show_sourcelink = False

# -- sphinx-gallery: the tutorial and the experiments -------------------------------------
_gallery_mode = os.environ.get("NETCOSIM_DOCS_GALLERY", "quick")
os.environ["NETCOSIM_DOCS_GALLERY"] = _gallery_mode       # the gallery scripts read it
os.environ.setdefault("MPLBACKEND", "Agg")
sphinx_gallery_conf = {
    "examples_dirs": ["tutorial", "gallery_src"],
    "gallery_dirs": ["tutorial_built", "gallery"],
    "filename_pattern": r"/(step|plot)_" if _gallery_mode != "off" else r"^$",
    "ignore_pattern": r"/_",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "abort_on_example_error": True,
    "only_warn_on_example_error": False,
    "plot_gallery": "True",
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib", PageScraper()),   # PageScraper: docs/_ext/netcosim_docs.py
    "reset_modules": ("matplotlib",),
    "show_memory": False,
    "show_signature": False,
    "capture_repr": (),
    "line_numbers": False,
    "min_reported_time": 1,
    "write_computation_times": False,
}
