"""A run's clock at its start and mid-run: the right length, or a clear error.

A stale first stamp (a driver's buffered scan), stamps that repeat before the clock
advances, a clock that resets, stamps that never advance: each gives the lengths of
exact stamps (within a scan) or a ``ValueError`` naming the run, in the detector and
in the census alike, batch and streaming.
"""

import dataclasses
import functools

import numpy as np
import pytest
from _street_scenes import make_run, sedan

from tunnelsense.street import ScanClusterer, parked_extents, scan_distances
from tunnelsense.street._clock import (
    START_DIFFERENCES,
    period_and_gap,
    run_start,
    stamp_spans,
)
from tunnelsense.street._history import History

SPEED = 11.0  # m/s; 75 scans/s: 0.147 m a scan
PERIOD = 1 / 75
ONE_SCAN = SPEED * PERIOD


def car(s0):
    return dict(s0=s0, s1=s0 + 4.4, depth=5.0, width=1.8, top=sedan)


@functools.lru_cache(maxsize=1)
def fitted():
    fit = make_run([car(4.0)], ["parked"], n_scans=80, speed=SPEED)
    return ScanClusterer(speed=SPEED).fit(fit.scans)


@functools.lru_cache(maxsize=4)
def run_from(s0, n_scans=70):
    return list(make_run([car(s0)], ["parked"], n_scans=n_scans, speed=SPEED).scans)


def restamped(scans, stamps):
    return [dataclasses.replace(r, stamp=float(t)) for r, t in zip(scans, stamps,
                                                                   strict=True)]


def stale_first(scans, early):
    """The first scan stamped ``early`` seconds before its time."""
    return restamped(scans, [scans[0].stamp - early] + [r.stamp for r in scans[1:]])


def equal_first(scans, n):
    """The first ``n`` scans stamped with the first one's stamp (a clock that did
    not advance), the clock right from then on."""
    return restamped(scans, [scans[0].stamp] * n + [r.stamp for r in scans[n:]])


def parked_lengths(scans):
    """The parked length of the detector and of the census."""
    det = fitted().detect(scans)
    parked = det[det["label"] == "parked"]
    census = parked_extents(det, scan_distances([r.stamp for r in scans], SPEED))
    return parked["length"].tolist(), census["length_m"].tolist()


# -- the period and the lost scans read from the stamps ----------------------------

def test_a_stale_first_stamp_is_not_the_period():
    # it read 1.0 s, then 0.51 s: the second scan's step was 11 m
    values = np.r_[np.nan, 1.0, np.full(40, PERIOD)]
    period, gap, _ = period_and_gap(np.empty(0), values)
    np.testing.assert_allclose(period, PERIOD)
    assert gap[1] < 1.0  # the jump is a jump
    h = History()
    h.begin(values)
    np.testing.assert_allclose(h.steps(values, SPEED), ONE_SCAN)


@pytest.mark.parametrize("catch_up", [True, False])
def test_stamps_that_repeat_at_the_start_are_not_the_period(catch_up):
    # four scans stamped alike, then the clock catches up (or only runs on): the
    # period is the clock's from the first scan (it read 0.0033-0.0089 s)
    first = [0.0, 0.0, 0.0, 4 * PERIOD if catch_up else PERIOD]
    values = np.r_[np.nan, first, np.full(200, PERIOD)]
    period, gap, spans = period_and_gap(np.empty(0), values)
    np.testing.assert_allclose(period, PERIOD, rtol=1e-9)
    assert spans[4] == 4
    assert values[4] < gap[4]  # the step that catches up loses no scan


def test_a_clock_coarser_than_the_period_is_read_over_whole_steps():
    # 40 ms stamps at 75 scans/s: the first period is read between steps of the
    # clock (a window ending between two steps read 0.0125 s)
    values = np.r_[np.nan, np.tile([0.0, 0.0, 0.04], 20)]
    period, gap, _ = period_and_gap(np.empty(0), values)
    np.testing.assert_allclose(period[:START_DIFFERENCES], PERIOD, rtol=1e-9)
    assert (gap >= 0.1 - 1e-12).all()


def test_no_lost_scan_is_read_from_fewer_than_three_steps():
    _, _, _, ready, trusted, _ = run_start(np.r_[np.nan, 0.01, 0.03, 0.01])
    assert not ready and not trusted
    _, gap, _ = period_and_gap(np.empty(0), np.r_[np.nan, 0.01, 0.03])
    assert np.isinf(gap).all()


def test_stamp_spans_count_the_scans_a_stamp_stood_for():
    assert stamp_spans(np.empty(0), np.r_[np.nan, 0.0, 0.0, 0.1, 0.0, 0.1]).tolist() == [
        1, 1, 2, 3, 1, 2]


# -- the detector and the census ---------------------------------------------------

@pytest.mark.parametrize("s0", [0.0, 0.2])
@pytest.mark.parametrize("early", [1.0, 0.1])
def test_a_stale_first_stamp_gives_the_lengths_of_exact_stamps(s0, early):
    # the first scan stamped 1 s (or 0.1 s: 1.1 m, a stretch the detector would
    # link across) early: a car right at the start read 9.9 m in the detector and
    # 15.5 m in the census; it is as long as with exact stamps, within a scan
    scans = run_from(s0)
    exact = parked_lengths(scans)
    stale = parked_lengths(stale_first(scans, early))
    for a, b in zip(exact, stale, strict=True):
        assert len(a) == len(b) == 1
        assert b[0] == pytest.approx(a[0], abs=ONE_SCAN + 1e-9)
        assert b[0] < 4.6


@pytest.mark.parametrize("s0", [0.0, 0.2])
def test_stamps_that_repeat_at_the_start_give_the_lengths_of_exact_stamps(s0):
    # the first 4 scans stamped alike (a fine clock that started late): the car
    # read 3.56-3.72 m (18 % short) in the detector, 4.69 m in the census
    scans = run_from(s0)
    exact = parked_lengths(scans)
    for a, b in zip(exact, parked_lengths(equal_first(scans, 4)), strict=True):
        assert b == pytest.approx(a, abs=1e-6)


def test_a_gap_the_numbers_show_at_the_start_is_lost_scans():
    # the scan numbers jump too (7 scans lost after the first): no stale stamp but
    # lost scans, linked as anywhere (1.0 m): the car seen on both sides spans them
    scans = run_from(0.0)
    lost = [scans[0]] + scans[8:]
    det = fitted().detect(lost, all_objects=True)
    parked = det[det["label"] == "parked"]
    assert len(parked) == 1 and parked["first_scan"].iloc[0] == 0
    renumbered = [scans[0]] + [dataclasses.replace(r, scan=i + 1)
                               for i, r in enumerate(scans[8:])]
    det = fitted().detect(renumbered, all_objects=True)  # numbers run on: stale
    parked = det[det["label"] == "parked"]
    assert len(parked) == 1 and parked["first_scan"].iloc[0] == 1


@pytest.mark.parametrize("change", ["stale", "equal", "short"])
def test_any_chunking_equals_batch_at_a_run_start(change):
    scans = run_from(0.0)
    if change == "stale":
        scans = stale_first(scans, 1.0)
    elif change == "equal":
        scans = equal_first(scans, 4)
    else:  # a run shorter than the differences its period is read over
        scans = scans[:20]
    est = fitted()
    table = est.detect(scans, all_objects=True)
    rows = [tuple(r) for r in table.itertuples(index=False)]
    for chunk in (1, 7, 10_000):
        state = est.start_stream()
        out = []
        for i in range(0, len(scans), chunk):
            out.extend(state.push_many(scans[i:i + chunk]))
        out.extend(state.close())
        assert [r.scan for r in out] == [r.scan for r in scans]
        assert [row for r in out for row in r.payload["finished_objects"]] == rows


def test_stamps_that_never_advance_are_refused_naming_the_run():
    scans = restamped(run_from(0.0), np.zeros(70))
    with pytest.raises(ValueError, match="stamps of run 'r' do not advance"):
        fitted().detect(scans)
    with pytest.raises(ValueError, match="span some time"):
        scan_distances([r.stamp for r in scans], SPEED)


def test_a_clock_that_resets_mid_run_is_refused_naming_the_run_and_scans():
    scans = run_from(0.0)
    reset = restamped(scans, [r.stamp - (10.0 if i >= 40 else 0.0)
                              for i, r in enumerate(scans)])
    with pytest.raises(ValueError, match=r"run 'r' are not sorted: scan 40"):
        fitted().detect(reset)
    with pytest.raises(ValueError, match="non-decreasing; scan 40"):
        scan_distances([r.stamp for r in reset], SPEED)



@pytest.mark.parametrize("n", [2, 3, 4])
def test_a_run_too_short_to_read_a_period_from_builds_no_object(n):
    # 2-4 scans on one stamp (a 40-50 ms clock at 75 scans/s): raised "do not
    # advance" and killed a detect of many runs; no period, so no object, and the
    # other runs as alone
    short = [dataclasses.replace(r, run="tail")
             for r in restamped(run_from(0.2)[:n], np.full(n, 99.0))]
    assert len(fitted().detect(short, all_objects=True)) == 0
    long = run_from(0.2)
    assert fitted().detect(long + short).equals(fitted().detect(long))
    state = fitted().start_stream()  # scan by scan, as in batch
    out = [o for r in long + short for o in state.push(r)] + list(state.close())
    assert [r.scan for r in out] == [r.scan for r in long + short]
    rows = [tuple(r) for r in fitted().detect(long, all_objects=True).itertuples(
        index=False)]
    assert [row for r in out for row in r.payload["finished_objects"]] == rows


def test_stamps_frozen_after_a_stale_first_stamp_are_refused():
    # [0, 1, 1, 1, ...]: read at 1/75 s (a 25 Hz car 1.467 m, "other") and in the
    # census 11 m, then 0 m
    scans = run_from(0.0)
    frozen = restamped(scans, np.r_[0.0, np.ones(len(scans) - 1)])
    with pytest.raises(ValueError, match=r"stamps of run 'r' do not advance: its "
                                         r"scans 1 to 69"):
        fitted().detect(frozen)
    with pytest.raises(ValueError, match="advance after the clock's first step"):
        scan_distances([r.stamp for r in frozen], SPEED)


def test_scans_lost_in_a_stall_are_read_once_for_the_jitter():
    # 5 scans on one stamp, then a step over their 5 periods and 7 lost scans: the
    # jitter allowance counts once, (5 + 1.5) periods, not 2.5 x 5 = 12.5 periods
    values = np.r_[np.nan, np.full(60, PERIOD), 0.0, 0.0, 0.0, 0.0, 12 * PERIOD,
                   np.full(40, PERIOD)]
    period, gap, spans = period_and_gap(np.empty(0), values)
    assert spans[65] == 5
    assert 6 * PERIOD < gap[65] < 7 * PERIOD <= values[65]  # about 6.5 periods
    # the car over the stall read 3.541 m (the 7 lost scans unseen)
    scans = list(make_run([car(0.2), car(8.0)], ["parked"] * 2, n_scans=130,
                          speed=SPEED).scans)
    kept = scans[:65] + scans[72:]
    stamps = [r.stamp for r in kept]
    stamps[60:65] = [stamps[60]] * 5
    kept = [dataclasses.replace(r, stamp=t, scan=i)
            for i, (r, t) in enumerate(zip(kept, stamps, strict=True))]
    lengths, _ = parked_lengths(kept)
    assert lengths[1] == pytest.approx(4.4, abs=0.1)


@pytest.mark.parametrize("n", [4, 10, 40])
def test_census_gives_stamps_that_repeat_at_the_start_a_period_each(n):
    # the first n scans on one stamp, the clock then running on without catching
    # up: the census shared one period among them (4.18 / 3.344 / 0.11 m for a
    # 4.4 m car) where the detector gives each a period
    scans = run_from(0.2)
    stamps = np.array([r.stamp for r in scans])
    stamps[:n] = stamps[0]
    stamps[n:] -= (n - 1) * PERIOD
    detector, census = parked_lengths(restamped(scans, stamps))
    assert census == pytest.approx(detector, abs=1e-6)
    assert census == pytest.approx(parked_lengths(scans)[1], abs=1e-6)


@pytest.mark.parametrize("clock", [0.03, 0.05])
@pytest.mark.parametrize("phase", [0.0, 0.0123, 0.021])
def test_a_coarse_clock_at_the_start_gives_the_length_within_a_scan(clock, phase):
    # the clock's steps fall anywhere between the scans: the first step may come
    # after one scan or after several (a car right at the start, 4.4 m)
    scans = run_from(0.2, 60)
    stamps = np.floor((np.array([r.stamp for r in scans]) + phase) / clock + 1e-9) * clock
    for lengths in parked_lengths(restamped(scans, stamps)):
        assert len(lengths) == 1
        assert lengths[0] == pytest.approx(4.4, abs=ONE_SCAN)


@pytest.mark.parametrize("after", [0, 1, 2, 3, 4])
def test_the_census_reads_a_jump_in_the_first_four_scans_as_a_stale_stamp(after):
    # a 0.5 s jump after scan `after`: within the run's first four scans a stale
    # stamp (no metres), from the fifth scan on lost scans (5.5 m nobody saw)
    stamps = np.arange(100) / 75
    stamps[after + 1:] += 0.5
    d = scan_distances(stamps, SPEED)
    lost = 0.0 if after < 3 else 0.5 * SPEED
    assert d[-1, 1] == pytest.approx(100 * ONE_SCAN + lost)
    assert d[after + 1, 0] - d[after, 1] == pytest.approx(lost)


@pytest.mark.parametrize("rate", [75.0, 25.0])
@pytest.mark.parametrize("stuck", [19, 39, 69])
def test_a_clock_that_starts_too_late_to_read_a_period_is_refused(stuck, rate):
    # the first `stuck` scans on one stamp, the clock catching up at the last scan:
    # no stamp difference after the step gives the period of the scans before it;
    # measured at a guessed one a car at 25 scans a second read 1.47 m of 4.4 m,
    # and the census gave NaN to every scan
    scans = run_from(0.2, 70)[:stuck + 1]
    times = scans[0].stamp + np.arange(stuck + 1) / rate
    late = restamped(scans, np.r_[np.full(stuck, times[0]), times[stuck]])
    if stuck <= 32:  # a short run: no object
        assert len(fitted().detect(late, all_objects=True)) == 0
    else:
        with pytest.raises(ValueError, match=rf"run 'r' give no scan period: its "
                                             rf"clock first advances at scan {stuck}"):
            fitted().detect(late)
    with pytest.raises(ValueError, match=rf"first advances at scan {stuck}, too late"):
        scan_distances([r.stamp for r in late], SPEED)


@pytest.mark.parametrize("n", [32, 33])
def test_one_stamp_over_more_scans_than_a_period_is_read_from_is_refused(n):
    # 32 scans on one stamp (a coarse clock, a short run) build no object; 33 are a
    # clock that does not advance
    scans = restamped(run_from(0.2)[:n], np.full(n, 5.0))
    if n <= 32:
        assert len(fitted().detect(scans, all_objects=True)) == 0
    else:
        with pytest.raises(ValueError, match="do not advance"):
            fitted().detect(scans)
