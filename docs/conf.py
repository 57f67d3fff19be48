"""Sphinx configuration of the cwlidar_sim documentation site.

Build (warnings are errors), from the repository root:

    python -m sphinx -n -W -b html docs docs/_build/html

The markdown notes in docs/*.md, the README's sections and CHANGELOG.md are the sources: the
site's pages include them (MyST), they are not copied.  The API reference is generated from the
subpackages' ``__all__`` (docs/_ext/apigen.py) into docs/api/ on every build, and the notebooks in
notebooks/ are executed in quick mode (CWLIDAR_SIM_QUICK=1, as tests/test_notebooks.py runs them).
A rebuild reads only what changed (an unchanged notebook is not run again); for a quick look at
the pages without running the notebooks at all, add ``-D nb_execution_mode=off`` (the notebook
pages then have no outputs, and .ci/check_site.py fails on them, as it should).
"""

from __future__ import annotations

import os
import re
import shutil
import sys
import tempfile
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))          # this checkout, ahead of any installed cwlidar_sim
sys.path.insert(0, str(DOCS / "_ext"))

import apigen  # noqa: E402
from sitetools import escape_bars, mark_headings  # noqa: E402

import cwlidar_sim  # noqa: E402

project = "cwlidar_sim"
author = "The cwlidar_sim developers"
copyright = "2026, The cwlidar_sim developers"
release = version = cwlidar_sim.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_nb",
    "xref",
]

# -- nitpicky: a dead cross-reference fails the build (with -W) ---------------------------------------
# References to a public object through any import path resolve to where the reference documents it
# (docs/_ext/xref.py). Objects of other projects cannot resolve: their inventories would have to be
# downloaded (intersphinx), and the build downloads nothing; they are ignored by module, so a dead
# reference inside cwlidar_sim still fails.
nitpicky = True
_EXTERNAL = r"(builtins|enum|typing|collections|dataclasses|os|pathlib|numpy|scipy|xarray|pandas|dask|distributed|h5netcdf|h5py|numba|matplotlib)"
nitpick_ignore_regex = [(r"py:.*", _EXTERNAL + r"(\..+)?"),
                        # a private base class named on a public class's "Bases:" line (autodoc writes it;
                        # private objects have no page by design)
                        (r"py:class", r"cwlidar_sim(\.\w+)*\._\w+(\.\w+)*")]

# -- the notes that stay where they are: docs/*.md are pages of their own --------------------------
# The notes that belong to the user guide; every other docs/*.md is a physics note, listed on
# physics/index automatically (so a new note needs no edit here, and none is left out of a toctree).
GUIDE_NOTES = ("speed_vs_accuracy", "convergence", "stability")
SITE_PAGES = ("index", "getting_started", "changelog")
PHYSICS_NOTES = sorted(p.stem for p in DOCS.glob("*.md") if p.stem not in GUIDE_NOTES + SITE_PAGES)

exclude_patterns = ["_build", "_templates", "_ext", "**.ipynb_checkpoints", "Thumbs.db", ".DS_Store"]
templates_path = ["_templates"]

# -- the notebooks: copies of notebooks/*.ipynb (mtime kept, so an unchanged notebook is not re-run)
NOTEBOOKS = DOCS / "notebooks"
NOTEBOOKS.mkdir(exist_ok=True)
for _stale in NOTEBOOKS.glob("*.ipynb"):
    if not (ROOT / "notebooks" / _stale.name).exists():
        _stale.unlink()
for _nb in sorted((ROOT / "notebooks").glob("*.ipynb")):
    _dst = NOTEBOOKS / _nb.name
    if not _dst.exists() or _dst.stat().st_mtime != _nb.stat().st_mtime or _dst.read_bytes() != _nb.read_bytes():
        shutil.copy2(_nb, _dst)

# quick mode, results into a scratch folder, the kernel imports this checkout
_NB_OUT = tempfile.mkdtemp(prefix="cwlidar_sim_docs_")
os.environ["CWLIDAR_SIM_QUICK"] = "1"
os.environ["CWLIDAR_SIM_OUT"] = _NB_OUT
os.environ["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + [p for p in [os.environ.get("PYTHONPATH")] if p])
# the kernel's figures must be images: an inherited non-interactive backend (MPLBACKEND=Agg) would
# leave "<Figure ...>" text instead; without the variable ipykernel uses its inline backend
os.environ.pop("MPLBACKEND", None)

nb_execution_mode = "force"        # every notebook that Sphinx reads is run; a failing cell fails the build
nb_execution_timeout = 900
nb_execution_raise_on_error = True
nb_execution_show_tb = True
nb_merge_streams = True

# -- MyST -------------------------------------------------------------------------------------------
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# -- API reference: generated from __all__ -----------------------------------------------------------
apigen.generate(str(DOCS / "api"))
autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "none"          # numpydoc's Parameters sections carry the types and units
autodoc_inherit_docstrings = False
numpydoc_show_class_members = False  # the class template lists members itself (no duplicate tables)
numpydoc_class_members_toctree = False
numpydoc_attributes_as_param_list = True

# -- HTML ---------------------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"cwlidar_sim {version}"
html_static_path: list[str] = []
html_theme_options = {
    "navbar_end": ["navbar-icon-links"],
    "navbar_persistent": ["search-field"],
    "show_toc_level": 2,
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_sidebars = {"index": []}
html_show_sourcelink = False


def _root_markdown(app, relative_path, parent_docname, content):
    """README.md and CHANGELOG.md, included from the repository root: their links into docs/ and
    notebooks/ point at the site's own pages and figures (a leading '/' is the source folder), and
    their headings are marked for section includes."""
    if Path(relative_path).parent == Path("..") and Path(relative_path).suffix == ".md":
        text = content[0]
        text = re.sub(r"\]\(docs/", "](/", text)
        text = re.sub(r"\]\(notebooks/", "](/notebooks/", text)
        content[0] = mark_headings(text)


def _physics_toctree(app, docname, source):
    """physics/index lists every physics note in docs/*.md (the marker line is replaced)."""
    if docname == "physics/index":
        source[0] = source[0].replace("<!-- physics-notes -->", "\n".join(f"../{n}" for n in PHYSICS_NOTES))


def _escape_docstring_bars(app, what, name, obj, options, lines):
    lines[:] = escape_bars(lines)


def _drop_object_base(app, name, obj, options, bases):
    """'Bases: object' says nothing; enums and exceptions keep theirs."""
    bases[:] = [b for b in bases if b is not object]


def _cleanup(app, exception):
    shutil.rmtree(_NB_OUT, ignore_errors=True)


def setup(app):
    app.connect("include-read", _root_markdown)
    app.connect("source-read", _physics_toctree)
    app.connect("build-finished", _cleanup)
    app.connect("autodoc-process-bases", _drop_object_base)
    app.connect("autodoc-process-docstring", _escape_docstring_bars, priority=400)  # before numpydoc
