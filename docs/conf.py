"""Sphinx configuration of the tunnelsense documentation.

Build with ``sphinx-build -W -b html docs docs/_build/html`` after
``pip install ".[docs]"``.  The examples gallery runs every ``examples/*/plot_*.py``
script under matplotlib's Agg backend.
"""

from __future__ import annotations

import os
import sys
from datetime import date
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # document this checkout, not an installed copy

import tunnelsense  # noqa: E402

# -- Project -------------------------------------------------------------------------
project = "tunnelsense"
author = "the tunnelsense developers"
copyright = f"{date.today().year}, {author}"
version = release = tunnelsense.__version__

# -- General -------------------------------------------------------------------------
extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
templates_path = ["_templates"]
exclude_patterns = ["_build", "**/GALLERY_HEADER.rst", "sg_execution_times.rst"]
nitpicky = False
# Pages that may not exist in every checkout: listed in the index's "More topics"
# toctree only when present (see ``_optional_pages``), so the build passes either way.
OPTIONAL_PAGES = ("positioning", "tunnel-measurements")

# -- MyST (the Markdown pages) -------------------------------------------------------
myst_enable_extensions = ["colon_fence", "deflist", "dollarmath"]
myst_heading_anchors = 3

# -- API reference -------------------------------------------------------------------
# One page per public module, listing exactly the names of its ``__all__``: the
# reference follows the package when names are added, moved between private modules
# or removed.  Each object is documented once, under the first public module below
# that exports it (the stages under ``tunnelsense.tunnel`` / ``tunnelsense.street``,
# the records under ``tunnelsense``).
API_MODULES = {
    "tunnelsense.tunnel": "FIR indicator detector",
    "tunnelsense.street": "Laser parked-vehicle detector",
    "tunnelsense.positioning": "Positioning in a tunnel",
    "tunnelsense": "Records, tours and runs",
    "tunnelsense.exceptions": "Exceptions",
    "tunnelsense.io": "Reading and writing files",
    "tunnelsense.datasets": "Simulated data",
    "tunnelsense.metrics": "Scores",
    "tunnelsense.plotting": "Pictures",
    "tunnelsense.utils": "Checks for stage authors",
}


def _write_api_pages(out_dir: Path) -> list[str]:
    import importlib
    import inspect

    out_dir.mkdir(parents=True, exist_ok=True)
    seen: set[int] = set()
    pages = []
    for name, title in API_MODULES.items():
        module = importlib.import_module(name)
        groups: dict[str, list[str]] = {"Classes": [], "Functions": [], "Constants": []}
        for attr in module.__all__:
            if attr.startswith("__"):
                continue
            obj = getattr(module, attr)
            if inspect.isclass(obj) or inspect.isfunction(obj):
                if id(obj) in seen:
                    continue
                seen.add(id(obj))
                groups["Classes" if inspect.isclass(obj) else "Functions"].append(attr)
            else:
                groups["Constants"].append(attr)
        heading = f"``{name}``: {title}"
        lines = [heading, "=" * len(heading), "", f".. automodule:: {name}",
                 "   :no-members:", "", f".. currentmodule:: {name}", ""]
        for group, attrs in groups.items():
            if not attrs:
                continue
            lines += [group, "-" * len(group), "", ".. autosummary::",
                      "   :toctree: .", "   :nosignatures:", ""]
            lines += [f"   {a}" for a in sorted(attrs, key=str.lower)] + [""]
        path = out_dir / f"{name}.rst"
        text = "\n".join(lines)
        if not path.exists() or path.read_text() != text:
            path.write_text(text)
        pages.append(str(path.relative_to(HERE)))
    return pages


autosummary_generate = _write_api_pages(HERE / "generated" / "api")
autosummary_imported_members = True
autodoc_default_options = {"inherited-members": False}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()

# -- Examples gallery ----------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": [str(HERE.parent / "examples")],
    "gallery_dirs": ["auto_examples"],
    "filename_pattern": r"/plot_",
    "ignore_pattern": r"__init__\.py",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "capture_repr": (),
    "show_memory": False,
    "abort_on_example_error": True,
    "run_stale_examples": False,
}
# Examples save their pictures when run as plain scripts; under the gallery the
# scraper collects the figures instead, so no file is written into the docs tree.
os.environ.setdefault("TUNNELSENSE_EXAMPLES_NO_SAVE", "1")

# -- HTML ----------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"tunnelsense {release}"
html_theme_options = {
    "navigation_depth": 2,
    "show_toc_level": 2,
    "navbar_align": "left",
}
html_static_path: list[str] = []
html_show_sourcelink = False


def _optional_pages(app, docname, source):
    """Replace the index's ``%OPTIONAL_PAGES%`` marker by the pages that exist."""
    if docname != "index":
        return
    present = [p for p in OPTIONAL_PAGES if any((HERE / (p + ext)).exists() for ext in (".md", ".rst"))]
    source[0] = source[0].replace("%OPTIONAL_PAGES%", "\n   ".join(present))


def setup(app):
    app.connect("source-read", _optional_pages)
