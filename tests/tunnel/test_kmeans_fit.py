"""The BLAS thread limit of the verification: set when the work begins, lifted after."""

import numpy as np
import pytest

from tunnelsense.tunnel import _kmeans_fit as kf


class _Limiter:
    def __init__(self, log, limits):
        self.log = log
        log.append(("set", limits))

    def restore_original_limits(self):
        self.log.append(("lifted",))


class _Controller:
    """Stands in for threadpoolctl's controller: records what is set and lifted
    (the test depends on no BLAS build)."""

    def __init__(self):
        self.log = []

    def limit(self, *, limits, user_api):
        assert user_api == "blas"
        return _Limiter(self.log, limits)


@pytest.fixture
def controller(monkeypatch):
    fake = _Controller()
    monkeypatch.setattr(kf, "_controller", lambda: fake)
    return fake


def _verify(rows=5):
    H = np.full((rows, 3), 0.5)
    return kf.verify_histograms(H, np.ones((2, 3)), np.zeros((2, 3)), max_distance=1.0)


def test_a_short_run_sets_no_limit_a_long_one_sets_it_once_and_lifts_it(controller):
    with kf.blas_threads(1):
        for _ in range(kf.LIMIT_AFTER - 1):
            _verify()
    assert controller.log == []  # ten frames, or 29: the libraries are not looked for
    with kf.blas_threads(1):
        with kf.blas_threads(2):  # within the outer limit: counts toward it
            for _ in range(kf.LIMIT_AFTER):
                _verify()
        assert controller.log == [("set", 1)]
        for _ in range(3 * kf.LIMIT_AFTER):
            _verify()
        assert controller.log == [("set", 1)]
    assert controller.log == [("set", 1), ("lifted",)]
    assert kf._ACTING == [] and kf._IN_FORCE == [None]
    _verify()  # outside any context: nothing set
    assert len(controller.log) == 2


def test_large_work_sets_the_limit_at_once(controller):
    with kf.blas_threads(2):
        _verify(rows=kf._LARGE)
        assert controller.log == [("set", 2)]
    X = np.random.default_rng(0).uniform(0, 1, (40, 3))
    kf.fit_kmeans(X, 3, random_state=0)  # its own context (one thread), at once
    assert controller.log == [("set", 2), ("lifted",), ("set", 1), ("lifted",)]


def test_the_limit_is_lifted_when_the_context_fails(controller):
    with pytest.raises(RuntimeError), kf.blas_threads(1):
        _verify(rows=kf._LARGE)
        raise RuntimeError
    assert controller.log == [("set", 1), ("lifted",)]
    assert kf._ACTING == [] and kf._IN_FORCE == [None]


def test_the_verdicts_do_not_depend_on_the_limit(controller):
    rng = np.random.default_rng(1)
    H, P, N = rng.uniform(0, 1, (300, 8)), rng.uniform(0, 1, (5, 8)), rng.uniform(0, 1, (9, 8))
    free = kf.verify_histograms(H, P, N, max_distance=1.2, margin=0.1, quantum=2.0**-10)
    with kf.blas_threads(1):
        limited = [kf.verify_histograms(H, P, N, max_distance=1.2, margin=0.1,
                                        quantum=2.0**-10)
                   for _ in range(kf.LIMIT_AFTER + 1)]
    assert controller.log == [("set", 1), ("lifted",)]
    assert all(np.array_equal(free, v) for v in limited)
