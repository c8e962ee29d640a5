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
    "sphinxarg.ext",
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
    "tunnelsense.fleet": "Many tours at once",
}


#: Functions the ``tunnelsense`` command is built from (its reports, the demo, the
#: checks it runs before any work): public so that a script can do what a command
#: does, but listed apart from the estimators, on their own page.
CLI_HELPERS = {
    "tunnelsense.tunnel": ["format_detection", "format_tours", "format_training",
                           "run_demo"],
    "tunnelsense.street": ["format_object", "format_objects_written", "format_runs",
                           "format_training"],
    "tunnelsense.positioning": ["format_errors"],
    "tunnelsense.io": ["check_model_path", "format_description", "load_trusted_model",
                       "read_signing_key"],
    "tunnelsense.datasets": ["simulate_to_folder"],
}

#: Public estimator or pipeline -> (label of its user-guide section, the section's
#: title).  The API page of each links there; every public class with ``fit`` must
#: have an entry (checked when the reference is written).
USER_GUIDE = {
    "tunnelsense.tunnel.IntensityKeypointSampler": ("ug-keypoints", "3.1 keypoints"),
    "tunnelsense.tunnel.KMeansHistogramVerifier": ("ug-verifier", "3.2 verification"),
    "tunnelsense.tunnel.MSTClusterer": ("ug-clusters", "3.3 clusters"),
    "tunnelsense.tunnel.WeightedAdaBoost": ("ug-appearance", "3.4 appearance"),
    "tunnelsense.tunnel.TrajectoryLinker": ("ug-tracks", "3.5 trajectories"),
    "tunnelsense.tunnel.PCCVerifier": ("ug-motion", "3.6-3.7 motion check"),
    "tunnelsense.tunnel.make_indicator_pipeline": ("ug-indicator-detector",
                                                   "The FIR indicator detector"),
    "tunnelsense.street.ScanClusterer": ("ug-street-method",
                                         "Street-parked vehicles"),
    "tunnelsense.street.make_parking_pipeline": ("ug-street-api",
                                                 "Street-parked vehicles: API"),
    "tunnelsense.positioning.TunnelPositioner": ("ug-positioning",
                                                 "Positioning in a tunnel"),
}


def _write_api_pages(out_dir: Path) -> list[str]:
    import importlib
    import inspect

    out_dir.mkdir(parents=True, exist_ok=True)
    seen: dict[int, str] = {}
    pages = []

    def page(name, heading, intro, groups):
        lines = [heading, "=" * len(heading), ""] + intro
        for group, (module, attrs) in groups.items():
            if not attrs:
                continue
            lines += [group, "-" * len(group), "", f".. currentmodule:: {module}", "",
                      ".. autosummary::", "   :toctree: .", "   :nosignatures:", ""]
            lines += [f"   {a}" for a in sorted(attrs, key=str.lower)] + [""]
        path = out_dir / f"{name}.rst"
        text = "\n".join(lines)
        if not path.exists() or path.read_text() != text:
            path.write_text(text)
        pages.append(str(path.relative_to(HERE)))

    helpers: dict[str, tuple[str, list[str]]] = {}
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
                seen[id(obj)] = f"{name}.{attr}"
                if attr in CLI_HELPERS.get(name, ()):
                    helpers.setdefault(f"``{name}``", (name, []))[1].append(attr)
                    continue
                if (inspect.isclass(obj) and hasattr(obj, "fit")
                        and f"{name}.{attr}" not in USER_GUIDE):
                    raise RuntimeError(f"{name}.{attr}: no user-guide section in "
                                       "USER_GUIDE (docs/conf.py)")
                groups["Classes" if inspect.isclass(obj) else "Functions"].append(attr)
            else:
                groups["Constants"].append(attr)
        heading = f"``{name}``: {title}"
        intro = [f".. automodule:: {name}", "   :no-members:", ""]
        page(name, heading, intro, {g: (name, a) for g, a in groups.items()})
    missing = {f"{m}.{a}" for m, names in CLI_HELPERS.items() for a in names} - set(
        seen.values())
    if missing:
        raise RuntimeError(f"CLI_HELPERS lists names that are not public: {missing}")
    page("cli-helpers", "Command-line helpers",
         ["The functions the ``tunnelsense`` command is built from: its reports, the",
          "demo, and the checks it makes before any work.  Use them to do from a",
          "script what a command does; see :doc:`/cli` for the commands themselves.",
          ""], helpers)
    _alias_names(seen)
    return pages


def _alias_names(seen: dict[int, str]) -> None:
    """Every public path of each documented object, for its "Examples using" list
    (an example may import it from the top-level package or from its module)."""
    import importlib
    import inspect

    for name in API_MODULES:
        module = importlib.import_module(name)
        for attr in module.__all__:
            obj = getattr(module, attr)
            if (inspect.isclass(obj) or inspect.isfunction(obj)) and id(obj) in seen:
                ALIASES.setdefault(seen[id(obj)], set()).add(f"{name}.{attr}")
                ALIASES[seen[id(obj)]].add(f"{obj.__module__}.{obj.__qualname__}")


ALIASES: dict[str, set[str]] = {}
autosummary_generate = _write_api_pages(HERE / "generated" / "api")
autosummary_imported_members = True
autosummary_context = {
    "user_guide": USER_GUIDE,
    "aliases": {k: " ".join(sorted(v)) for k, v in ALIASES.items()},
}
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
    # "Examples using X" on each API page (the class and function templates)
    "doc_module": ("tunnelsense",),
    "backreferences_dir": "generated/backreferences",
    "reference_url": {"tunnelsense": None},
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


def _argparse_domain_any_xref():
    """MyST resolves a Markdown link to an anchor (``[text](#anchor)``) by asking every
    domain's ``resolve_any_xref``; sphinx-argparse's domain does not define it, which
    warns (an error under ``-W``).  It has no targets such a link could mean."""
    from sphinxarg.ext import ArgParseDomain

    if "resolve_any_xref" not in vars(ArgParseDomain):
        ArgParseDomain.resolve_any_xref = lambda self, *args, **kwargs: []


def setup(app):
    app.connect("source-read", _optional_pages)
    _argparse_domain_any_xref()
