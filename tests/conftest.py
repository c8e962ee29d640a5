"""Shared fixtures: a global random seed, as in scikit-learn's test suite.

Set ``TUNNELSENSE_TESTS_GLOBAL_RANDOM_SEED`` to an integer (or ``"all"`` for 0-99) to
run the seeded tests under other seeds.
"""

import os

import pytest


def _seeds():
    value = os.environ.get("TUNNELSENSE_TESTS_GLOBAL_RANDOM_SEED", "42")
    if value == "all":
        return list(range(100))
    return [int(s) for s in value.replace(",", " ").split()]


@pytest.fixture(params=_seeds())
def global_random_seed(request):
    """An integer seed; tests using it must pass for any seed."""
    return request.param
