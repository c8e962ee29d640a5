"""The record-stage check suite passes good stages and catches broken ones."""

import numpy as np
import pytest
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from tunnelsense import (
    FrameSequence,
    LaserGeometry,
    ScanSequence,
    check_frames,
    check_scans,
)
from tunnelsense.utils import (
    SKLEARN_RECORD_API_CHECKS,
    assert_records_equal,
    check_record_stage,
    record_stage_checks,
    sklearn_api_checks,
)


class FrameMean(TransformerMixin, BaseEstimator):
    """A correct frame stage: the mean intensity of each frame, plus a learned offset."""

    def __init__(self, random_state=None):
        self.random_state = random_state

    def fit(self, X, y=None):
        records, _ = check_frames(X, y)
        self.offset_ = np.random.default_rng(self.random_state).random()
        return self

    def transform(self, X):
        check_is_fitted(self)
        records, _ = check_frames(X)
        return FrameSequence(r.evolve(mean=float(r.image.mean()) + self.offset_) for r in records)


class ScanCount(TransformerMixin, BaseEstimator):
    """A correct scan stage: the number of returns of each scan."""

    def fit(self, X, y=None):
        check_scans(X, y)
        self.fitted_ = True
        return self

    def transform(self, X):
        check_is_fitted(self)
        records, _ = check_scans(X)
        return ScanSequence(
            r.evolve(returns=int(np.isfinite(r.ranges).sum())) for r in records
        )


class DropsLast(FrameMean):
    def transform(self, X):
        return FrameSequence(list(super().transform(X))[:-1])


class ReturnsList(FrameMean):
    def transform(self, X):
        return list(super().transform(X))


class Mutates(FrameMean):
    def transform(self, X):
        records, _ = check_frames(X)
        for r in records:
            r.payload["touched"] = True
        return super().transform(X)


class Unseeded(FrameMean):
    def fit(self, X, y=None):
        super().fit(X, y)
        self.offset_ = np.random.default_rng().random()  # ignores random_state
        return self


class NoFittedCheck(FrameMean):
    def transform(self, X):
        records, _ = check_frames(X)
        return FrameSequence(r.evolve(mean=float(r.image.mean())) for r in records)


class AcceptsArrays(FrameMean):
    def fit(self, X, y=None):
        self.offset_ = 0.0
        return self


class FitReturnsNone(FrameMean):
    def fit(self, X, y=None):
        super().fit(X, y)


class IgnoresY(FrameMean):
    def fit(self, X, y=None):
        return super().fit(X)


class SortsFrames(FrameMean):
    def transform(self, X):
        out = super().transform(X)
        return FrameSequence(sorted(out, key=lambda r: -r.frame))


class Declared(FrameMean):
    """Declares what it adds and reads: the mean, from payload "offset"."""

    _payload_reads = ("offset",)
    _payload_adds = ("mean",)

    def transform(self, X):
        check_is_fitted(self)
        records, _ = check_frames(X)
        for i, r in enumerate(records):
            if "offset" not in r.payload:
                raise ValueError(f"X[{i}] has no payload['offset']")
        return FrameSequence(
            r.evolve(mean=float(r.image.mean()) + r.payload["offset"]) for r in records
        )


class AddsUndeclared(Declared):
    def transform(self, X):
        return FrameSequence(r.evolve(extra=1) for r in super().transform(X))


class ChangesUndeclared(Declared):
    def transform(self, X):
        return FrameSequence(r.evolve(offset=0.0) for r in super().transform(X))


class IgnoresMissingRead(Declared):
    def transform(self, X):
        records, _ = check_frames(X)
        return FrameSequence(
            r.evolve(mean=float(r.image.mean()) + r.payload.get("offset", 0.0))
            for r in records
        )


def frames(n=4):
    images = np.random.default_rng(0).integers(0, 256, (n, 12, 16)).astype(np.uint8)
    return FrameSequence.from_array(images, tour="t"), [np.empty((0, 4))] * n


def scans(n=4):
    geometry = LaserGeometry(-0.5, 0.01, 0.1, 8.0, 1.0)
    ranges = np.random.default_rng(0).uniform(0.5, 9, (n, 100))
    ranges[ranges > 8] = np.nan
    return ScanSequence.from_arrays(ranges, np.arange(n) * 0.1, geometry, run="r"), [
        np.empty((0, 2), np.int64)
    ] * n


def test_good_frame_stage_passes():
    X, y = frames()
    check_record_stage(FrameMean(), X, y)
    check_record_stage(FrameMean(random_state=3), X, None)


@pytest.mark.parametrize(
    "stage, ok",
    [(Declared(), True), (AddsUndeclared(), False), (ChangesUndeclared(), False),
     (IgnoresMissingRead(), False)],
)
def test_payload_contract_is_checked(stage, ok):
    X, y = frames()
    X = FrameSequence(r.evolve(offset=1.0) for r in X)
    check = dict(record_stage_checks(stage, X, y))["check_payload_contract"]
    if ok:
        check()
    else:
        with pytest.raises(AssertionError, match="payload"):
            check()


def test_good_scan_stage_passes():
    X, y = scans()
    check_record_stage(ScanCount(), X, y)


@pytest.mark.parametrize(
    "broken, failing_check",
    [
        (DropsLast(), "check_samples_and_identities"),
        (SortsFrames(), "check_samples_and_identities"),
        (ReturnsList(), "check_samples_and_identities"),
        (Mutates(), "check_input_not_mutated"),
        (Unseeded(), "check_deterministic"),
        (NoFittedCheck(), "check_unfitted_raises"),
        (AcceptsArrays(), "check_rejects_bad_input"),
        (FitReturnsNone(), "check_fit_returns_self"),
        (IgnoresY(), "check_rejects_bad_input"),
    ],
)
def test_broken_stages_fail_the_right_check(broken, failing_check):
    X, y = frames()
    checks = dict(record_stage_checks(broken, X, y))
    with pytest.raises(Exception):  # noqa: B017 -- any failure of that check
        checks[failing_check]()
    X, y = frames()  # fresh records: the broken stage may have changed the others
    with pytest.raises(AssertionError, match=type(broken).__name__):
        check_record_stage(broken, X, y)


def test_record_stage_checks_are_named_and_bound():
    X, y = frames()
    names = [name for name, _ in record_stage_checks(FrameMean(), X, y)]
    assert len(names) == len(set(names)) >= 8
    assert all(name.startswith("check_") for name in names)


def test_assert_records_equal_compares_payloads():
    X, _ = frames(2)
    a = [r.evolve(v=np.arange(3)) for r in X]
    assert_records_equal(a, [r.evolve(v=np.arange(3)) for r in X])
    with pytest.raises(AssertionError, match="values differ"):
        assert_records_equal(a, [r.evolve(v=np.arange(3) + 1) for r in X])
    with pytest.raises(AssertionError, match="dtypes differ"):
        assert_records_equal(a, [r.evolve(v=np.arange(3.0)) for r in X])
    with pytest.raises(AssertionError, match="keys differ"):
        assert_records_equal(a, list(X))


def test_suite_needs_records():
    with pytest.raises(ValueError, match="at least one record"):
        check_record_stage(FrameMean(), [], None)


@pytest.mark.parametrize("estimator", [FrameMean(), ScanCount()])
def test_sklearn_api_checks_run_on_record_stages(estimator):
    ran = [name for name, check in sklearn_api_checks(estimator) if check() is None]
    assert ran == [c.__name__ for c in SKLEARN_RECORD_API_CHECKS]
