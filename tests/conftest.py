"""Shared fixtures: a global random seed, as in scikit-learn's test suite.

Set ``TUNNELSENSE_TESTS_GLOBAL_RANDOM_SEED`` to an integer (or ``"all"`` for 0-99) to
run the seeded tests under other seeds.

Hypothesis has two profiles: ``default`` (a few examples per property, for the fast
suite) and ``ci`` (many; ``pytest --hypothesis-profile=ci``, as ``.ci/run`` does).
Tests that take more than a few seconds are marked ``slow`` and left out of a plain
``pytest``; ``pytest -m slow`` runs them.
"""

import os

# scikit-learn's check_array_api_input (run by parametrize_with_checks) skips itself
# unless SciPy's array API support is on; with it on, the check verifies that
# enabling array API dispatch does not change results on NumPy inputs. It must be
# set before SciPy is imported.
os.environ.setdefault("SCIPY_ARRAY_API", "1")

import pytest  # noqa: E402
from hypothesis import HealthCheck, settings  # noqa: E402

_QUIET = [HealthCheck.function_scoped_fixture, HealthCheck.too_slow]
settings.register_profile("default", max_examples=15, deadline=None,
                          suppress_health_check=_QUIET)
settings.register_profile("ci", max_examples=150, deadline=None,
                          suppress_health_check=_QUIET)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))


def _seeds():
    value = os.environ.get("TUNNELSENSE_TESTS_GLOBAL_RANDOM_SEED", "42")
    if value == "all":
        return list(range(100))
    return [int(s) for s in value.replace(",", " ").split()]


@pytest.fixture(params=_seeds())
def global_random_seed(request):
    """An integer seed; tests using it must pass for any seed."""
    return request.param
