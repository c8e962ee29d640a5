"""The results pages of the documentation: led by figures that a shipped script makes.

Validation and Performance lead with a figure; every figure in ``docs/_static`` is
shown by a page, written by a script of ``docs/figures`` (which ships in the source
distribution), and its page names that script; the pages point at nothing that does
not ship (``benchmarks/``).
"""

import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"
RESULTS_PAGES = ("validation.md", "performance.md")
IMAGE = re.compile(r"```\{image\} (_static/[\w.-]+\.png)")


def _makers():
    """Figure file name -> the ``docs/figures`` script that writes it."""
    makers = {}
    for script in sorted((DOCS / "figures").glob("make_*.py")):
        for name in re.findall(r'output_path\("([\w.-]+\.png)"', script.read_text()):
            makers[name] = script
    return makers


@pytest.mark.parametrize("page", RESULTS_PAGES)
def test_results_page_leads_with_a_figure(page):
    text = (DOCS / page).read_text()
    first_image = IMAGE.search(text)
    assert first_image, f"{page} shows no figure"
    # before any table, and in the page's first section
    first_table = text.find("\n|")
    assert first_table == -1 or first_image.start() < first_table
    sections = [m.start() for m in re.finditer(r"\n## ", text)]
    assert len(sections) < 2 or first_image.start() < sections[1]


@pytest.mark.parametrize("page", RESULTS_PAGES)
def test_results_page_figures_come_from_shipped_scripts(page):
    text = (DOCS / page).read_text()
    makers = _makers()
    for path in IMAGE.findall(text):
        assert (DOCS / path).is_file(), path
        name = Path(path).name
        assert name in makers, f"{name}: no docs/figures/make_*.py writes it"
        assert f"docs/figures/{makers[name].name}" in text, (
            f"{page} does not say how {name} was made")
    assert "benchmarks/" not in text


def test_every_committed_figure_is_shown_and_made_by_a_script():
    makers = _makers()
    shown = {Path(p).name for page in DOCS.glob("*.md") for p in IMAGE.findall(
        page.read_text())}
    for png in (DOCS / "_static").glob("*.png"):
        assert png.name in makers, png.name
        assert png.name in shown, png.name
