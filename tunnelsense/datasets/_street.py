"""Placeholder, being replaced by the street simulator (issue 3)."""

STREET_SCENARIOS = ()


def make_street_scans(*args, **kwargs):
    raise NotImplementedError("the street simulator is not written yet")
