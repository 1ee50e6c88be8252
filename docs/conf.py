"""Sphinx configuration of the robolobes documentation.

Build (warnings are errors, the gallery is executed)::

    .venv/bin/pip install -e '.[docs]'
    .venv/bin/sphinx-build -W --keep-going -b html docs docs/_build/html
"""

import os
import re

os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("OMP_NUM_THREADS", "1")

project = "robolobes"
author = "robolobes developers"
copyright = "2026, robolobes developers"
try:
    from importlib.metadata import version as _version

    release = _version("robolobes")
except Exception:  # not installed: the build still documents the sources
    release = "0.1.0"
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build", "examples"]  # examples/ is the gallery's source; gallery/ is generated
root_doc = "index"

# MyST: markdown pages; headings get anchors so pages can link to sections.
myst_enable_extensions = ["colon_fence", "deflist", "dollarmath"]
myst_heading_anchors = 3

# API reference from the docstrings (numpy style).
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": False}
autodoc_member_order = "bysource"
autodoc_typehints = "none"
autosummary_generate = False
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False
napoleon_use_ivar = True  # "Attributes" as a field list: dataclass fields are not described twice

# The gallery: every example is executed during the build, so none can go stale.
sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "gallery",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "abort_on_example_error": True,
    "within_subsection_order": "FileNameSortKey",
    "show_memory": False,
    "plot_gallery": "True",
}

# Names re-exported by a package are documented under the package and under their module, so a
# short cross-reference in a docstring (``MillingCase``) can have two targets: that is not an error.
suppress_warnings = ["ref.python"]

_LITERAL = re.compile(r"(``.*?``|`[^`]*`)")


def _escape_bars(app, what, name, obj, options, lines):
    """Docstrings write absolute values as ``|x|``; outside literals, reST would read a substitution."""
    for i, line in enumerate(lines):
        row = line.strip()
        if "|" not in row or row.startswith(("+-", "+=")) or (row.startswith("|") and row.endswith("|")):
            continue  # a reST table
        parts = _LITERAL.split(line)
        lines[i] = "".join(p if k % 2 else p.replace("|", "\\|") for k, p in enumerate(parts))


def setup(app):
    app.connect("autodoc-process-docstring", _escape_bars, priority=400)


html_theme = "pydata_sphinx_theme"
html_title = f"robolobes {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
}
html_static_path: list[str] = []
