"""The source distribution and the release metadata, checked from the source tree."""

import os
import re
import tarfile
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def sdist_names(tmp_path_factory):
    """The paths inside the sdist built from this tree (setuptools' own backend)."""
    from setuptools import build_meta

    out = tmp_path_factory.mktemp("sdist")
    cwd = Path.cwd()
    os.chdir(ROOT)  # the backend reads MANIFEST.in from the working directory
    try:
        name = build_meta.build_sdist(str(out))
    finally:
        os.chdir(cwd)
    with tarfile.open(out / name) as tar:
        return {n.split("/", 1)[1] for n in tar.getnames() if "/" in n}


def test_sdist_is_complete(sdist_names):
    expected = {"CHANGELOG.md", "README.md", "LICENSE", "pyproject.toml", "MANIFEST.in",
                "docs/conf.py", "docs/index.rst", "docs/figures/make_speed.py",
                "examples/GALLERY_HEADER.rst"}
    assert expected <= sdist_names
    # every test module ships with the data it reads
    tests = {p.relative_to(ROOT).as_posix() for p in (ROOT / "tests").rglob("*")
             if p.is_file() and "__pycache__" not in p.parts}
    assert tests and tests <= sdist_names
    # every example and every committed figure of the pages
    for folder in ("examples", "docs/_static"):
        files = {p.relative_to(ROOT).as_posix() for p in (ROOT / folder).rglob("*")
                 if p.is_file()}
        assert files <= sdist_names, folder


def test_sdist_holds_nothing_built(sdist_names):
    built = [n for n in sdist_names
             if n.startswith(("docs/_build", "docs/generated", "docs/auto_examples"))
             or "__pycache__" in n or n.endswith(".pyc")]
    assert built == []


def test_changelog_dates_the_version():
    from tunnelsense import __version__

    text = (ROOT / "CHANGELOG.md").read_text()
    heading = re.search(r"^## (\S+) \((\d{4}-\d{2}-\d{2})\)$", text, re.MULTILINE)
    assert heading, "no '## VERSION (YYYY-MM-DD)' heading in CHANGELOG.md"
    assert heading.group(1) == __version__


def test_classifiers_match_requires_python():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    floor = re.fullmatch(r">=3\.(\d+)", project["requires-python"]).group(1)
    versions = [int(c.rsplit(".", 1)[1]) for c in project["classifiers"]
                if re.fullmatch(r"Programming Language :: Python :: 3\.\d+", c)]
    assert versions and min(versions) == int(floor)
