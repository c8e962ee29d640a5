"""Locking on without a start: the hypotheses over the map (``LockOn``) directly."""

import numpy as np
import pytest

from tunnelsense.positioning._lock import LockOn, unseen_before


def test_lock_on_hypotheses_directly():
    """Exact passes on an irregular map lock at the third; a periodic map never."""
    irregular = np.cumsum([0.0, 180, 230, 160, 210, 240, 170, 200])
    kw = dict(scale=1.0, scale_sigma=0.05, fix_sigma=0.3, gate=4.0, miss_rate=0.05,
              false_pass_rate=5e-4, margin=9.0, min_passes=3)
    lock = LockOn(irregular, **kw)
    odo = (irregular[2:6] - irregular[2]) * 1.03  # 3 % long, from indicator 2
    got = [lock.add(d, 0.01, tag=k) for k, d in enumerate(odo)]
    assert got[0] is None and got[1] is None
    done = next(g for g in got if g is not None)
    assert done["indicator"] == 2 + got.index(done)
    assert [j for _, j in done["passes"]] == list(range(2, 2 + len(done["passes"])))
    assert done["state"][1] == pytest.approx(1 / 1.03, abs=1e-3)
    periodic = np.arange(0.0, 4000.0, 200.0)
    lock = LockOn(periodic, **kw)
    assert all(lock.add(d, 0.01) is None for d in np.arange(8) * 206.0)
    assert lock.n_explaining() > 5


def test_indicators_passed_unseen_before_the_first_pass():
    """At indicator j after 450 m of odometry, the record began 450 m before it:
    the indicators more than the clearance after that were in view."""
    chainage = np.array([0.0, 200.0, 400.0, 600.0])
    got = unseen_before(chainage, 450.0, 1.0, 0.0, 60.0)
    assert got.tolist() == [0, 1, 1, 1]
    # a short drive (within the clearance): nothing can have been missed
    assert unseen_before(chainage, 50.0, 1.0, 0.05, 60.0).tolist() == [0, 0, 0, 0]
    # with a scale sigma of 5 % the span counted is 10 % shorter: 270 m of odometry
    # count as 189 m past the clearance, not enough to reach the indicator before
    assert unseen_before(chainage, 270.0, 1.0, 0.0, 60.0).tolist() == [0, 1, 1, 1]
    assert unseen_before(chainage, 270.0, 1.0, 0.05, 60.0).tolist() == [0, 0, 0, 0]


def test_the_start_of_the_record_tells_repeated_spacings_apart():
    """Gaps 180, 230, 160 twice on the map; the record began 250 m before the first
    pass.  At the second copy the vehicle would have driven past two indicators
    unseen: with the start known the first copy wins, without it the two tie.
    (One indicator unseen would not do: a miss rate of 0.4 costs 0.92 each, within
    the margin of 1.5; two cost 1.83.)"""
    chainage = np.cumsum([0.0, 300, 180, 230, 160, 60, 60, 180, 230, 160])
    passes = 250.0 + np.array([0.0, 180.0, 410.0, 570.0])
    kw = dict(scale=1.0, scale_sigma=0.05, fix_sigma=0.3, gate=4.0, miss_rate=0.4,
              false_pass_rate=5e-5, margin=1.5, min_passes=3)
    tie = LockOn(chainage, **kw)
    assert all(tie.add(d, 0.01) is None for d in passes)
    assert tie.n_explaining() == 2
    known = LockOn(chainage, start=0.0, clearance=60.0, **kw)
    got = [known.add(d, 0.01) for d in passes]
    lock = next(g for g in got if g is not None)
    assert lock["indicator"] == 1 + got.index(lock)  # the first copy, from indicator 1
    # the same map with one indicator before the second copy: no lock (one miss is
    # within the margin)
    one = LockOn(np.cumsum([0.0, 300, 180, 230, 160, 120, 180, 230, 160]),
                 start=0.0, clearance=60.0, **kw)
    assert all(one.add(d, 0.01) is None for d in passes)


def test_silence_since_the_last_pass_tells_repeated_spacings_apart():
    """Gaps 180, 230, 160 twice on the map; after the first copy the next
    indicators are 40 and 120 m on, after the second 250 m.  The passes fit both
    copies; once the vehicle has driven 150 m past the last pass with no pass, the
    first copy would have had its next two indicators seen: the second wins, before
    the next pass.  After 100 m, one unseen indicator does not decide (a miss rate
    of 0.4 costs 0.92, within the margin of 1.5; two cost 1.83)."""
    chainage = np.cumsum([0.0, 300, 180, 230, 160, 40, 80, 180, 230, 160, 250, 200])
    passes = np.array([0.0, 180.0, 410.0, 570.0]) * 1.02  # odometry 2 % long
    kw = dict(scale=1.0, scale_sigma=0.05, fix_sigma=0.3, gate=4.0, miss_rate=0.4,
              false_pass_rate=5e-5, margin=1.5, min_passes=3)
    lock = LockOn(chainage, **kw)
    assert all(lock.add(d, 0.01) is None for d in passes)
    assert lock.n_explaining() == 2
    # 100 m on (102 m of odometry), the first copy's second indicator is still ahead
    assert lock.silence(passes[-1] + 102.0, 2.0) is None
    # the best hypothesis at each copy (the last indicator it accounts for)
    score, at = lock._h["score"], lock._last
    best = [int(np.flatnonzero(at == j)[np.argmax(score[at == j])]) for j in (4, 9)]
    assert lock.unseen_since(passes[-1] + 102.0, 2.0)[best].tolist() == [1, 0]
    assert lock.unseen_since(passes[-1] + 153.0, 2.0)[best].tolist() == [2, 0]
    got = lock.silence(passes[-1] + 153.0, 2.0)
    assert got is not None and got["indicator"] == 9
    assert [j for _, j in got["passes"]][-4:] == [6, 7, 8, 9]
    # the silence is not kept: a pass coming after all is scored as before
    assert lock.n_explaining() == 2


def test_lock_on_hypotheses_stay_bounded_on_an_evenly_spaced_map():
    """On a periodic map nothing locks; the branches "that pass was false" must not
    double the hypotheses at each pass: at most ``per_indicator`` per indicator."""
    chainage = np.arange(0.0, 20000.0, 200.0)
    lock = LockOn(chainage, scale=1.0, scale_sigma=0.05, fix_sigma=0.3, gate=4.0,
                  miss_rate=0.05, false_pass_rate=5e-5, margin=9.0, min_passes=3,
                  per_indicator=8)
    for k in range(40):  # (100 indicators: the map's end is not reached)
        assert lock.add(130.0 + 200.0 * 0.97 * k, 0.01) is None
        assert lock.n_hypotheses <= 8 * len(chainage)
    assert lock.n_explaining() > 1
