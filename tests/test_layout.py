"""The test tree itself: pytest's default import mode needs unique module names."""

from collections import Counter
from pathlib import Path


def test_test_module_names_are_unique():
    names = Counter(p.name for p in Path(__file__).parent.rglob("test_*.py"))
    assert [n for n, c in names.items() if c > 1] == []


def test_private_scikit_learn_names_are_imported_in_one_module():
    """A scikit-learn release that moves a private name is a one-file fix."""
    import re

    package = Path(__file__).parents[1] / "tunnelsense"
    private = re.compile(r"from sklearn[\w.]*\._\w+ import|from sklearn[\w.]* import [^\n]*\b_\w+")
    offenders = [
        str(p.relative_to(package)) for p in package.rglob("*.py")
        if p.name != "_sklearn_compat.py" and private.search(p.read_text())
    ]
    assert offenders == []
