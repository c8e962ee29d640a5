"""Checks every record stage (frame or scan stage) must pass.

scikit-learn's common checks run nothing on an estimator that does not take 2-D arrays,
so tunnelsense checks its record stages itself: a stage maps a sequence of N records to
a sequence of N records with the same identities, accepts the plain lists that
cross-validation hands over, fits by returning itself, refuses to run unfitted, survives
``clone`` and ``pickle``, is deterministic under a fixed ``random_state``, and rejects
bad input with clear errors.

Use :func:`check_record_stage` to run them all, or :func:`record_stage_checks` to get
them one by one (for ``pytest.mark.parametrize``).  :func:`sklearn_api_checks` yields
the scikit-learn checks that make sense for an estimator without 2-D array input.
"""

from __future__ import annotations

import dataclasses
import pickle
from collections.abc import Mapping
from functools import partial

import numpy as np
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.utils import estimator_checks as sk_checks

from tunnelsense._records import (
    FrameRecord,
    FrameSequence,
    LaserGeometry,
    ScanRecord,
    ScanSequence,
)

__all__ = [
    "SKLEARN_RECORD_API_CHECKS",
    "assert_records_equal",
    "check_payload_contract",
    "check_record_stage",
    "record_stage_checks",
    "sklearn_api_checks",
]

#: scikit-learn API checks that need no 2-D array input, run one by one on record
#: stages (see :func:`sklearn_api_checks`).
SKLEARN_RECORD_API_CHECKS = (
    sk_checks.check_estimator_cloneable,
    sk_checks.check_estimator_tags_renamed,
    sk_checks.check_valid_tag_types,
    sk_checks.check_estimator_repr,
    sk_checks.check_no_attributes_set_in_init,
    sk_checks.check_parameters_default_constructible,
    sk_checks.check_get_params_invariance,
    sk_checks.check_set_params,
    sk_checks.check_do_not_raise_errors_in_init_or_set_params,
    sk_checks.check_mixin_order,
)


def sklearn_api_checks(estimator):
    """Yield ``(name, check)`` for the scikit-learn checks in SKLEARN_RECORD_API_CHECKS.

    Each ``check`` is a callable of no argument that runs the scikit-learn check on a
    clone of ``estimator``.

    Examples
    --------
    >>> from tunnelsense.tunnel import IntensityKeypointSampler
    >>> for name, check in sklearn_api_checks(IntensityKeypointSampler()):
    ...     check()
    """
    name = type(estimator).__name__
    for check in SKLEARN_RECORD_API_CHECKS:
        yield check.__name__, partial(check, name, clone(estimator))


# --------------------------------------------------------------------------------------
# Comparing records
# --------------------------------------------------------------------------------------
def _assert_value_equal(a, b, where):
    if isinstance(a, Mapping):
        assert isinstance(b, Mapping) and set(a) == set(b), (
            f"{where}: keys differ: {sorted(a)} != {sorted(b) if isinstance(b, Mapping) else b}"
        )
        for k in a:
            _assert_value_equal(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        assert a.shape == b.shape, f"{where}: shapes differ: {a.shape} != {b.shape}"
        assert a.dtype == b.dtype, f"{where}: dtypes differ: {a.dtype} != {b.dtype}"
        assert np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"), f"{where}: values differ"
    elif isinstance(a, list | tuple):
        assert isinstance(b, list | tuple) and len(a) == len(b), f"{where}: lengths differ"
        for i, (u, v) in enumerate(zip(a, b, strict=True)):
            _assert_value_equal(u, v, f"{where}[{i}]")
    else:
        assert a == b or (a != a and b != b), f"{where}: {a!r} != {b!r}"


def assert_records_equal(a, b):
    """Assert two sequences of records have equal identities and payloads."""
    a, b = list(a), list(b)
    assert len(a) == len(b), f"{len(a)} records != {len(b)} records"
    for i, (u, v) in enumerate(zip(a, b, strict=True)):
        assert type(u) is type(v), f"record {i}: {type(u).__name__} != {type(v).__name__}"
        assert u.key == v.key, f"record {i}: identity {u.key} != {v.key}"
        _assert_value_equal(u.payload, v.payload, f"record {i} {u.key} payload")


# --------------------------------------------------------------------------------------
# The checks
# --------------------------------------------------------------------------------------
def _kind(X):
    records = list(X)
    if not records:
        raise ValueError("the check suite needs at least one record in X")
    first = records[0]
    if isinstance(first, FrameRecord):
        return records, FrameSequence, ScanRecord
    if isinstance(first, ScanRecord):
        return records, ScanSequence, FrameRecord
    raise TypeError(f"X must hold FrameRecord or ScanRecord objects; got {type(first)}")


def _wrong_record(record_type):
    if record_type is ScanRecord:
        geometry = LaserGeometry(-0.5, 0.01, 0.1, 8.0, 1.0)
        return ScanRecord("wrong-kind", 0, np.ones(100), 0.0, geometry)
    return FrameRecord("wrong-kind", 1, np.zeros((48, 64), np.uint8))


def _seeded(estimator):
    """A clone with ``random_state=0`` when it has a ``random_state`` left at None."""
    est = clone(estimator)
    if est.get_params().get("random_state", 0) is None:
        est.set_params(random_state=0)
    return est


def _run(estimator, X, y, method):
    fitted = estimator.fit(X, y)
    return fitted, getattr(fitted, method)(X)


def check_fit_returns_self(estimator, X, y=None, method="transform"):
    """``fit`` returns the estimator itself."""
    est = clone(estimator)
    assert est.fit(X, y) is est, f"{type(est).__name__}.fit must return self"


def check_unfitted_raises(estimator, X, y=None, method="transform"):
    """``transform`` (or ``method``) before ``fit`` raises NotFittedError."""
    est = clone(estimator)
    try:
        getattr(est, method)(X)
    except NotFittedError:
        return
    raise AssertionError(f"{type(est).__name__}.{method} before fit must raise NotFittedError")


def check_samples_and_identities(estimator, X, y=None, method="transform"):
    """The output is a sequence of the same kind, same length, same identities."""
    records, seq_type, _ = _kind(X)
    _, out = _run(clone(estimator), X, y, method)
    assert isinstance(out, seq_type), (
        f"{type(estimator).__name__}.{method} must return a {seq_type.__name__}; "
        f"got {type(out).__name__}"
    )
    assert len(out) == len(records), f"{len(out)} records out for {len(records)} in"
    assert [r.key for r in out] == [r.key for r in records], "record identities changed"
    assert all(type(r) is type(s) for r, s in zip(out, records, strict=True))


def check_input_not_mutated(estimator, X, y=None, method="transform", *, snapshot=None):
    """Fitting and transforming leave the input records' payloads untouched.

    ``snapshot`` (pickled payloads taken before any check ran, as
    :func:`record_stage_checks` does) also catches a mutation made by another check.
    """
    records, _, _ = _kind(X)
    before = snapshot or [pickle.dumps(r.payload) for r in records]
    _run(clone(estimator), X, y, method)
    after = [pickle.dumps(r.payload) for r in records]
    assert before == after, "the stage changed the payload of its input records"


def check_accepts_plain_list(estimator, X, y=None, method="transform"):
    """A plain list of records (as CV folds give) gives the same output as the sequence."""
    records, seq_type, _ = _kind(X)
    est = _seeded(estimator)
    _, a = _run(clone(est), seq_type(records), y, method)
    _, b = _run(clone(est), list(records), None if y is None else list(y), method)
    assert_records_equal(a, b)


def check_clone_and_pickle(estimator, X, y=None, method="transform"):
    """A clone fitted alike, and a pickled fitted stage, give identical outputs.

    A ``random_state`` left at None is set to 0 first.
    """
    est = _seeded(estimator)
    fitted, a = _run(est, X, y, method)
    _, b = _run(clone(est), X, y, method)
    assert_records_equal(a, b)
    restored = pickle.loads(pickle.dumps(fitted))
    assert_records_equal(a, getattr(restored, method)(X))


def check_deterministic(estimator, X, y=None, method="transform"):
    """Two fits under the same fixed ``random_state`` give identical outputs."""
    est = clone(estimator)
    if "random_state" in est.get_params():
        est.set_params(random_state=0)
    _, a = _run(clone(est), X, y, method)
    _, b = _run(clone(est), X, y, method)
    assert_records_equal(a, b)


def _expect_error(func, types, must_mention, what):
    try:
        func()
    except types as exc:
        msg = str(exc)
        assert any(m in msg for m in must_mention), (
            f"{what}: the error message should mention one of {must_mention}; got {msg!r}"
        )
        return
    raise AssertionError(f"{what}: expected {' or '.join(t.__name__ for t in types)}")


def check_rejects_bad_input(estimator, X, y=None, method="transform"):
    """Arrays, wrong record types and mismatched ``y`` raise clear errors."""
    records, seq_type, wrong_type = _kind(X)
    name = type(estimator).__name__
    record_name = type(records[0]).__name__
    array = np.zeros((3, 8, 8))
    wrong = [_wrong_record(wrong_type)]
    _expect_error(
        lambda: clone(estimator).fit(array, y[:3] if y is not None else None),
        (TypeError, ValueError), ["X", record_name], f"{name}.fit on a 3-D array",
    )
    _expect_error(
        lambda: clone(estimator).fit(wrong, None if y is None else y[:1]),
        (TypeError, ValueError), [record_name], f"{name}.fit on a {wrong_type.__name__}",
    )
    fitted = clone(estimator).fit(X, y)
    _expect_error(
        lambda: getattr(fitted, method)(array), (TypeError, ValueError),
        ["X", record_name], f"{name}.{method} on a 3-D array",
    )
    _expect_error(
        lambda: getattr(fitted, method)(wrong), (TypeError, ValueError),
        [record_name], f"{name}.{method} on a {wrong_type.__name__}",
    )
    if y is not None and len(records) > 1:
        _expect_error(
            lambda: clone(estimator).fit(X, list(y)[:-1]), (ValueError,),
            ["y"], f"{name}.fit with y one entry short",
        )


def check_payload_contract(estimator, X, y=None, method="transform"):
    """The stage adds exactly the payload keys it declares and refuses a missing read.

    A stage declares ``_payload_adds`` (the keys it sets) and ``_payload_reads`` (the
    keys it needs; see :mod:`tunnelsense._payload`).  Every output record holds the
    input's keys plus the declared ones, the others unchanged (the same objects); a
    record lacking a key the stage reads is refused with a ValueError naming the key.
    A stage that declares nothing is not checked.
    """
    adds = getattr(estimator, "_payload_adds", None)
    if adds is None:
        return
    name = type(estimator).__name__
    records, _, _ = _kind(X)
    fitted, out = _run(clone(estimator), X, y, method)
    for r_in, r_out in zip(records, out, strict=True):
        got, expected = set(r_out.payload), set(r_in.payload) | set(adds)
        assert got == expected, (
            f"{name}.{method} on {r_in.key}: payload keys {sorted(got)}, expected the "
            f"input's plus the declared _payload_adds: {sorted(expected)}"
        )
        for key in set(r_in.payload) - set(adds):
            assert r_out.payload[key] is r_in.payload[key], (
                f"{name}.{method} on {r_in.key} changed payload[{key!r}], which it does "
                "not declare in _payload_adds"
            )
    for key in getattr(estimator, "_payload_reads", ()):
        stripped = [
            dataclasses.replace(r, payload={k: v for k, v in r.payload.items() if k != key})
            for r in records
        ]
        _expect_error(
            lambda stripped=stripped: getattr(fitted, method)(stripped), (ValueError,),
            [repr(key)], f"{name}.{method} on records without payload[{key!r}]",
        )


_CHECKS = (
    check_fit_returns_self,
    check_unfitted_raises,
    check_samples_and_identities,
    check_accepts_plain_list,
    check_clone_and_pickle,
    check_deterministic,
    check_rejects_bad_input,
    check_payload_contract,
    check_input_not_mutated,  # last: also catches mutations made during the others
)


def record_stage_checks(estimator, X, y=None, *, method="transform"):
    """Yield ``(name, check)`` pairs: the record-stage checks bound to their data.

    Parameters
    ----------
    estimator : estimator
        A frame stage or scan stage (unfitted).
    X : FrameSequence or ScanSequence
        A few records to fit and transform (a small simulated tour or run).
    y : list of ndarray or None, default=None
        Per-record targets (boxes per frame, targets per scan).
    method : str, default="transform"
        The method that maps records to records (``"transform"``, or ``"predict"``
        for a final stage).

    Yields
    ------
    name : str
    check : callable of no argument, raising AssertionError on failure

    Examples
    --------
    A pytest module would parametrize over them::

        @pytest.mark.parametrize("name, check", list(record_stage_checks(stage, X, y)))
        def test_stage(name, check):
            check()
    """
    snapshot = [pickle.dumps(r.payload) for r in X]
    for check in _CHECKS:
        if check is check_input_not_mutated:
            yield check.__name__, partial(check, estimator, X, y, method, snapshot=snapshot)
        else:
            yield check.__name__, partial(check, estimator, X, y, method)


def check_record_stage(estimator, X, y=None, *, method="transform"):
    """Run every record-stage check; raise AssertionError naming the first failure.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import FrameSequence
    >>> from tunnelsense.tunnel import IntensityKeypointSampler
    >>> X = FrameSequence.from_array(np.full((3, 40, 40), 170, np.uint8))
    >>> check_record_stage(IntensityKeypointSampler(), X, [np.empty((0, 4))] * 3)
    """
    for name, check in record_stage_checks(estimator, X, y, method=method):
        try:
            check()
        except AssertionError as exc:
            raise AssertionError(f"{type(estimator).__name__} fails {name}: {exc}") from exc
