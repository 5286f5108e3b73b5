"""Sphinx configuration of the mlayer documentation.

Build (from the repository root, in the .venv that scripts/setup.sh makes):

    sphinx-build -W --keep-going -b html docs build-docs/html

The Python reference imports the installed ``mlayer`` package; the C reference is read from
include/mlayer/*.h by hawkmoth (libclang), through the adapter in docs/_ext/mlayer_cdoc.py.
"""
from __future__ import annotations

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(DOCS / "_ext"))

import mlayer  # noqa: E402  (the built package: autodoc documents what `import mlayer` gives)
import mlayer_cdoc  # noqa: E402
import mlayer_pydoc  # noqa: E402,F401  (registered below: docstrings from before the numpy style)

project = "mlayer"
author = "the mlayer authors"
copyright = "the mlayer authors, MIT licence"
release = mlayer_cdoc.project_version(ROOT / "meson.build")
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "myst_parser",
    "hawkmoth",
    "mlayer_cdoc",
    "mlayer_pydoc",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_ext", "Thumbs.db", ".DS_Store"]
templates_path: list[str] = []

highlight_language = "none"  # literal blocks of the headers and docstrings are text
html_theme = "furo"
html_title = f"mlayer {release}"
html_static_path: list[str] = []

# --- Python API (autodoc + napoleon, numpy style) ------------------------------------------
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_typehints_description_target = "documented_params"
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": False}
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False

if release != mlayer.__version__:
    raise RuntimeError(f"the installed mlayer is {mlayer.__version__}, this checkout {release}: "
                       "reinstall it (pip install --no-build-isolation .) before building the docs")

# --- C API (hawkmoth) ------------------------------------------------------------------------
_HEADERS = ROOT / "build-docs" / "c-headers"
C_HEADERS = mlayer_cdoc.prepare_headers(ROOT / "include" / "mlayer", _HEADERS / "mlayer", release)
hawkmoth_root = str(_HEADERS)
mlayer_include_dir = str(ROOT / "include" / "mlayer")
hawkmoth_clang = ["-I" + str(_HEADERS / "mlayer"), "-std=c11"]

# --- Markdown pages (docs/*.md) ---------------------------------------------------------------
myst_heading_anchors = 3
myst_enable_extensions = ["colon_fence"]
