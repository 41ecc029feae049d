"""Sphinx configuration of the impactid documentation.

Build (as CI does): ``python -m sphinx -W --keep-going -b html docs docs/_build/html``.

Choices:

* Markdown pages are read by myst-parser, which myst-nb activates (``myst_nb`` below) together with
  its notebook reader; numpydoc renders the docstrings; autodoc + autosummary build the API
  reference from module names only, so renames inside modules need no edit here.
* Theme: furo. The pages carry wide tables of measurements and a long API reference; furo's
  collapsible sidebar navigation, its search box on every page, its responsive layout and its light
  and dark modes make those readable, and it is one small pure-Python dependency. (alabaster, the
  default, has no navigation tree for a reference of this size.)
* Notebooks: the tutorials are the notebooks of ``notebooks/``, copied into ``docs/tutorials/`` at
  each build (``_copy_notebooks`` below, which adds a note on how to run each one; the copies are
  ignored by git). They are rendered with the outputs stored in them, without executing them
  (``nb_execution_mode = "off"``): ``tools/execute_notebooks.py`` executes them and stores their
  outputs and figures (and the gallery's thumbnails, ``docs/tutorials_thumbnails/``), and the test
  command executes every notebook (nbmake) without storing anything, so CI runs them once, not twice.
* Math: myst's ``dollarmath`` turns ``$...$`` and ``$$...$$`` in the pages and in the notebooks'
  Markdown cells (myst-nb reads them with the same settings) into math, which MathJax renders
  (``sphinx.ext.mathjax``, Sphinx's default for HTML). ``attrs_inline`` sizes the gallery's images.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))  # document this checkout's package, wherever sphinx is run from

import impactid  # noqa: E402

project = "impactid"
author = "the impactid developers"
copyright = "the impactid developers"  # noqa: A001
version = release = impactid.__version__

extensions = [
    "myst_nb",  # Markdown (myst-parser) and notebooks
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
]

exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "**.ipynb_checkpoints", "jupyter_execute",
                    "validation_valvetrain_*.md"]  # joined into validation_valvetrain.md
templates_path = ["_templates"]
html_static_path: list[str] = []

html_theme = "furo"
html_title = f"impactid {release}"

# ---- Markdown ----
myst_enable_extensions = ["attrs_inline", "colon_fence", "deflist", "dollarmath"]
myst_heading_anchors = 3

# ---- notebooks (myst-nb) ----
nb_execution_mode = "off"
nb_merge_streams = True


def _copy_notebooks() -> None:
    """Copy ``notebooks/*.ipynb`` into ``docs/tutorials/`` (only those that changed), each with a note
    after its title cell saying where its outputs come from and how to run it."""
    target = HERE / "tutorials"
    target.mkdir(exist_ok=True)
    wanted = set()
    for source in sorted((ROOT / "notebooks").glob("*.ipynb")):
        notebook = json.loads(source.read_text(encoding="utf-8"))
        note = NOTEBOOK_NOTE.format(name=source.name)
        notebook["cells"].insert(1, {"cell_type": "markdown", "id": "impactid-docs-note", "metadata": {},
                                     "source": note.splitlines(keepends=True)})
        text = json.dumps(notebook, indent=1, ensure_ascii=False) + "\n"
        copy = target / source.name
        wanted.add(copy.name)
        if not copy.exists() or copy.read_text(encoding="utf-8") != text:
            copy.write_text(text, encoding="utf-8")
    for stale in target.glob("*.ipynb"):
        if stale.name not in wanted:
            stale.unlink()


NOTEBOOK_NOTE = """```{{note}}
This page is the notebook `notebooks/{name}`, shown with the outputs stored in it (made by
`python tools/execute_notebooks.py`; the documentation build does not execute notebooks). Run it
yourself with `python -m pytest notebooks/{name}` (after `pip install ".[test]"`), or open it in
Jupyter (`pip install ".[notebooks]"`).
```
"""

_copy_notebooks()

# ---- API reference ----
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"show-inheritance": True}
autodoc_typehints = "none"  # numpydoc shows the documented types; annotations stay in the signatures' source
autodoc_member_order = "bysource"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()
