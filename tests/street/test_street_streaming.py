"""ScanClusterer online: streaming equals batch, bounded memory, shipped models."""

import subprocess
import sys
import textwrap

import numpy as np
import pytest
from _street_scenes import make_run, sedan

from tunnelsense import ScanSequence
from tunnelsense._streaming import StreamingPipeline
from tunnelsense.datasets import STREET_SCENARIOS, make_street_scans
from tunnelsense.metrics import street_scores
from tunnelsense.street import (
    OBJECT_COLUMNS,
    ScanClusterer,
    make_parking_pipeline,
    stream_objects,
)
from tunnelsense.street._stream import CHECK_EVERY


def _rows(table):
    return [tuple(r) for r in table[list(OBJECT_COLUMNS)].itertuples(index=False)]


def _finished(records):
    """The object-table rows the released records carry, in release order."""
    return [row for r in records for row in r.payload["finished_objects"]]


@pytest.mark.parametrize("scenario", STREET_SCENARIOS)
def test_streaming_equals_batch(scenario, global_random_seed):
    run = make_street_scans(700, scenario=scenario, random_state=global_random_seed)
    X = run.scans
    pipe = make_parking_pipeline().fit(X)
    est = pipe.named_steps["cluster"]
    batch = pipe.transform(X)
    table = est.detect(X, all_objects=True)
    stream = StreamingPipeline(pipe)
    out = []
    for record in X:  # one scan at a time, rows carried by the released records
        out.extend(stream.push(record))
    out.extend(stream.close())
    rows = _finished(out)
    assert list(stream_objects(pipe, X, all_objects=True)) == rows
    assert [r.scan for r in out] == [r.scan for r in batch]
    for a, b in zip(out, batch, strict=True):
        assert np.array_equal(a.payload["objects"], b.payload["objects"])
        assert np.array_equal(a.payload["in_view"], b.payload["in_view"])
        assert np.array_equal(a.payload["points"], b.payload["points"])
        assert a.payload["tilt"] == b.payload["tilt"]
    assert rows == _rows(table)
    assert len(rows) > 5
    # the ids are those of predict, counted by first scan
    ids = [r[1] for r in rows]
    assert ids == list(range(1, len(rows) + 1))
    pred = pipe.predict(X)
    assert all(np.array_equal(p, r.payload["in_view"]) for p, r in zip(pred, out,
                                                                         strict=True))


def test_chunking_and_runs(global_random_seed):
    """Any chunking gives the same; a new run name starts afresh; batch sorts runs."""
    a = make_street_scans(400, scenario="dense", random_state=global_random_seed,
                          name="a")
    b = make_street_scans(300, scenario="crowded", random_state=global_random_seed + 1,
                          name="b")
    X = list(b.scans) + list(a.scans)  # batch sorts: run a first
    est = ScanClusterer().fit(X)
    table = est.detect(X, all_objects=True)
    for chunk in (1, 7, 64, 10_000):
        state = est.start_stream()
        ordered = list(a.scans) + list(b.scans)
        out = []
        for i in range(0, len(ordered), chunk):
            out.extend(state.push_many(ordered[i:i + chunk]))
        out.extend(state.close())
        assert len(out) == len(X)
        assert _finished(out) == _rows(table)
    assert set(table["run"]) == {"a", "b"}
    assert (table.groupby("run")["id"].min()["a"] == 1)


def test_stream_rejects_disorder(global_random_seed):
    run = make_street_scans(50, random_state=global_random_seed)
    state = ScanClusterer().fit(run.scans).start_stream()
    state.push(run.scans[5])
    with pytest.raises(ValueError, match=r"in increasing scan order: \(.*, 3\) came "
                       r"after \(.*, 5\)"):
        state.push(run.scans[3])
    with pytest.raises(ValueError, match="scan 5 of run .* came twice"):
        state.push(run.scans[5])


def _cars_run(n_scans):
    """Sedans every 8 m in region II, for as long as the run lasts."""
    speed, rate = 11.0, 75.0
    length = n_scans / rate * speed
    boxes = [dict(s0=s, s1=s + 4.4, depth=5.0, top=lambda u: sedan(u))
             for s in np.arange(3.0, length - 6.0, 8.0)]
    return make_run(boxes, ["parked"] * len(boxes), n_scans=n_scans, n_beams=181)


def test_memory_follows_objects_not_run_length():
    short, long_ = _cars_run(500), _cars_run(1800)
    est = ScanClusterer().fit(short.scans)
    held = []
    for run in (short, long_):
        state = est.start_stream()
        n_out = most = 0
        for record in run.scans:
            n_out += len(state.push(record))
            most = max(most, state.n_held)
        n_out += len(state.close())
        assert n_out == len(run.scans)
        held.append(most)
    # a car is 30 scans; a decision needs 4 m more (27 scans) and the history
    assert held[0] == held[1]
    assert held[1] < 120
    table = est.detect(long_.scans)
    assert len(table) == len(long_.gt)
    assert (table["label"] == "parked").all()


def test_long_wall_is_other():
    """A wall longer than max_length is not a vehicle (streamed as in batch)."""
    wall = dict(s0=2.0, s1=40.0, depth=5.0, top=1.8)
    car = dict(s0=45.0, s1=49.4, depth=5.0, top=lambda u: sedan(u))
    run = make_run([wall, car], [None, "parked"], n_scans=450, n_beams=181)
    est = ScanClusterer().fit(run.scans)
    table = est.detect(run.scans, all_objects=True)
    assert table["label"].tolist() == ["other", "parked"]
    state = est.start_stream()
    out = []
    for record in run.scans:
        out.extend(state.push(record))
    out.extend(state.close())
    assert _finished(out) == _rows(table)


_FRESH = textwrap.dedent("""
    import sys, numpy as np
    from tunnelsense.datasets import make_street_scans
    from tunnelsense.io import load_model
    model = load_model(sys.argv[1], allow_pickle=sys.argv[1].endswith(".joblib"))
    X = make_street_scans(400, scenario="dense", random_state=7).scans
    y = model.predict(X)
    np.save(sys.argv[2], np.concatenate([np.c_[np.full(len(a), i), a]
                                         for i, a in enumerate(y)]))
""")


@pytest.mark.parametrize("suffix", [".skops", ".joblib"])
def test_model_round_trip_fresh_process(tmp_path, suffix):
    from tunnelsense.io import save_model

    X = make_street_scans(400, scenario="dense", random_state=7).scans
    pipe = make_parking_pipeline(cut=0.5).fit(X)
    path = save_model(pipe, tmp_path / f"model{suffix}", summary={"runs": ["r"]})
    subprocess.run([sys.executable, "-c", _FRESH, str(path), str(tmp_path / "y.npy")],
                   check=True, timeout=120)
    got = np.load(tmp_path / "y.npy")
    y = pipe.predict(X)
    want = np.concatenate([np.c_[np.full(len(a), i), a] for i, a in enumerate(y)])
    assert len(want) > 100
    assert np.array_equal(got, want)


def test_skops_trusts_the_fitted_detector(tmp_path):
    from tunnelsense.io import load_model, save_model

    X = ScanSequence(list(make_street_scans(100, random_state=0).scans))
    pipe = make_parking_pipeline().fit(X)
    path = save_model(pipe, tmp_path / "m.skops")
    loaded = load_model(path)  # raises on any untrusted type
    est = loaded.named_steps["cluster"]
    assert est.get_params() == pipe.named_steps["cluster"].get_params()
    assert np.array_equal(est.region_edges_, [4.0, 6.6])
    assert est.labels_ == ("passing", "parked", "roadside")


def test_a_model_saved_with_region_depth_near_keeps_it(tmp_path):
    # the default became "across"; a model saved with "near" (every model saved
    # before) must load with its stored value and detect exactly as before: on a
    # row of bays at right angles the two differ, so a reader falling back to the
    # default would show here
    from tunnelsense.io import load_model, save_model

    fit = make_street_scans(300, scenario="sparse", random_state=11)
    run = make_street_scans(1200, scenario="sparse", random_state=12,
                            angled_row_fraction=1.0, bay_angle_deg=90.0,
                            kerb_depth=7.5, parked_cluster_size=4.0)
    near = make_parking_pipeline(region_depth="near").fit(fit.scans)
    loaded = load_model(save_model(near, tmp_path / "near.skops"))
    est = loaded.named_steps["cluster"]
    assert est.region_depth == "near"
    before = near.named_steps["cluster"].detect(run.scans)
    assert est.detect(run.scans).equals(before)
    across = make_parking_pipeline().fit(fit.scans).named_steps["cluster"]
    assert across.region_depth == "across"
    assert not across.detect(run.scans).equals(before)


def _street_with_wall(n_scans):
    """A hedge 7 m away along the whole run (region III), sedans parked in region II
    and a vehicle in the next lane (region I) now and then, hiding both."""
    speed, rate = 11.0, 75.0
    length = n_scans / rate * speed
    wall = dict(s0=0.0, s1=length + 1.0, depth=7.0, top=1.2)
    cars = [dict(s0=s, s1=s + 4.4, depth=5.0, top=lambda u: sedan(u))
            for s in np.arange(3.0, length - 6.0, 9.0)]
    vans = [dict(s0=s, s1=s + 6.0, depth=2.5, width=1.8, top=2.6)
            for s in np.arange(20.0, length - 8.0, 57.0)]
    boxes = [wall, *cars, *vans]
    labels = [None, *(["parked"] * len(cars)), *(["passing"] * len(vans))]
    return make_run(boxes, labels, n_scans=n_scans, n_beams=121)


def test_roadside_wall_memory_bounded():
    """A wall along the whole run no longer holds the stream: the window is about
    equal for 2,000 and 8,000 scans (max_pending_length); streaming equals batch."""
    short, long_ = _street_with_wall(2000), _street_with_wall(8000)
    est = ScanClusterer().fit(short.scans)
    held = []
    for run in (short, long_):
        table = est.detect(run.scans, all_objects=True)
        state = est.start_stream()
        out, most = [], 0
        for i in range(0, len(run.scans), 32):
            out.extend(state.push_many(run.scans[i:i + 32]))
            most = max(most, state.n_held)
        out.extend(state.close())
        assert len(out) == len(run.scans)
        assert _finished(out) == _rows(table)
        held.append(most)
        # the wall comes out in pieces of about max_pending_length, never a vehicle
        wall = table[table["mean_depth"] > 6.6]
        assert len(wall) >= 3
        assert wall["label"].isin(["other", "roadside"]).all()
        assert wall["length"].max() <= est.max_pending_length + 64 * 11 / 75 + 1
        scores = street_scores(run.gt, table[table["label"].isin(["parked", "passing"])])
        assert scores["parked"]["recall"] >= 0.85  # cars wholly behind a van are lost
        assert scores["parked"]["precision"] >= 0.95
        assert scores["passing"]["recall"] == 1.0
    # 80 m at 11 m/s and 75 scans/s is 545 scans; a check every 64 scans; history
    assert abs(held[1] - held[0]) <= 64
    assert held[1] < 800
    # without the limit the wall holds everything after its start
    state = ScanClusterer(max_pending_length=None).fit(short.scans).start_stream()
    most = 0
    for i in range(0, len(short.scans), 32):
        state.push_many(short.scans[i:i + 32])
        most = max(most, state.n_held)
    state.close()
    assert most > 1500


def _closing_limit(whole, most=12.0):
    """A ``max_pending_length`` that closes an object-cluster of this run: at most
    ``most``, and half the metres that the longest-pending object outside the
    vehicle regions (region III: its limit is ``max_pending_length`` itself) had
    been pending at the last check (every ``CHECK_EVERY``-th scan) it reached.
    (The scans of a simulated run are numbered from 0: scan number = position.)"""
    far = whole[whole["region"] == 3]
    pending = []
    for first, last, length in far[["first_scan", "last_scan", "length"]].itertuples(
            index=False):
        check = (last + 1) // CHECK_EVERY * CHECK_EVERY  # scans seen at that check
        if check > first:  # it has a cluster in the newest scan there (it is alive)
            pending.append(length * (check - first) / (last + 1 - first))
    assert pending, "the run must have an object beyond region II across a check"
    return min(most, 0.5 * max(pending))


@pytest.mark.parametrize("scenario", ["dense", "crowded"])
def test_pending_limit_any_chunking(scenario, global_random_seed):
    """Object-clusters closed by max_pending_length (here short, so that many are,
    in every region) are the same for any chunking and in batch."""
    run = make_street_scans(900, scenario=scenario, random_state=global_random_seed)
    X = list(run.scans)
    whole = ScanClusterer(max_pending_length=None).fit(X).detect(X, all_objects=True)
    est = ScanClusterer(max_pending_length=_closing_limit(whole)).fit(X)
    table = est.detect(X, all_objects=True)
    assert _rows(table) != _rows(whole)  # the limit closed some object-clusters
    batch = est.transform(X)
    for chunk in (1, 5, 64, 100):
        state = est.start_stream()
        out = []
        for i in range(0, len(X), chunk):
            out.extend(state.push_many(X[i:i + chunk]))
        out.extend(state.close())
        assert _finished(out) == _rows(table)
        assert all(np.array_equal(a.payload["objects"], b.payload["objects"])
                   and np.array_equal(a.payload["in_view"], b.payload["in_view"])
                   for a, b in zip(out, batch, strict=True))
