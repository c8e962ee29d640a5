"""The results pages of the documentation: led by figures that a shipped script makes.

Validation and Performance lead with a figure; every figure in ``docs/_static`` is
shown by a page, written by a script of ``docs/figures`` (which ships in the source
distribution), and its page names that script; the pages point at nothing that does
not ship (``benchmarks/``).  No page, nor the gallery's examples, reads as a lab record
or points outside the repository: no issue numbers, no "while developing".
"""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
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


#: What a user-facing page must not say: what it names -> the pattern.
NOT_FOR_USERS = {
    "a folder that ships in neither wheel nor sdist": re.compile(r"benchmarks/"),
    "an issue number": re.compile(r"\bissues?\s*(?:no\.?\s*)?#?\s*\d+|[(\[]#\d+\b|\bgh-\d+",
                                  re.IGNORECASE),
    "a development history": re.compile(
        r"(?:while|when|during) develop|never used (?:while|when|to)|used while"
        r"|development (?:tours?|seeds?|runs?)|\bwas tried\b|\bwe tried\b",
        re.IGNORECASE),
    # the seeds a default was chosen on ("seed 500", "seeds 2000-2002"); the small seeds
    # of a shown command ("--seed 0", "seed 1") are not a history
    "a seed history": re.compile(r"\bseeds? (?:of )?\d{3,}", re.IGNORECASE),
}


def _user_pages():
    """Every page of the documentation and every example of the gallery."""
    pages = [*DOCS.glob("*.md"), *DOCS.glob("*.rst"), *(ROOT / "examples").rglob("*.py")]
    return sorted(pages)


def _not_for_users(text):
    """``(what, matched text, line number)`` of every phrase not for users."""
    found = []
    for what, pattern in NOT_FOR_USERS.items():
        for m in pattern.finditer(text):
            found.append((what, m.group(0).strip(), text.count("\n", 0, m.start()) + 1))
    return found


@pytest.mark.parametrize("text", [
    "python benchmarks/bench_mst.py", "as issue 12 showed", "fixed in Issue #7",
    "see (#20)", "gh-31", "on the seeds never used while developing",
    "used while developing", "interpolation was tried and lost", "development tours",
    "on the tours of seed 500", "seeds 2000-2002, 3 x 4,000 scans",
])
def test_not_for_users_patterns_catch(text):
    assert _not_for_users(text), text


@pytest.mark.parametrize("text", [
    "tunnelsense detect tunnel --seed 0", "a colour #1f77b4", "then the smoother runs",
    "# Heading", "issues a warning", "docs/figures/make_speed.py",
    "wrote test-tour: 900 frames, scenario light, seed 1", "random_state=500",
    "an unencrypted PKCS #8 key",
])
def test_not_for_users_patterns_spare(text):
    assert not _not_for_users(text), text


def test_user_pages_read_as_documentation():
    pages = _user_pages()
    assert any(p.name == "street.md" for p in pages)
    bad = [f"{p.relative_to(ROOT)}:{line}: {what}: {match!r}" for p in pages
           for what, match, line in _not_for_users(p.read_text())]
    assert not bad, "\n".join(bad)
