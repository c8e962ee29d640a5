"""The parking census on hand-built object tables: segments, splitting, occupancy."""

import numpy as np
import pandas as pd
import pytest

from tunnelsense.street import (
    CENSUS_CLASSES,
    CENSUS_COLUMNS,
    census,
    parked_extents,
    scan_distances,
)

#: 1000 scans of 0.1 m each: 100 m of street.
DISTANCES = np.arange(1001) * 0.1


def objects(rows, *, classes=None):
    """An object table of (first_scan, last_scan, label) rows."""
    table = pd.DataFrame(rows, columns=["first_scan", "last_scan", "label"])
    table.insert(0, "id", range(len(table)))
    if classes is not None:
        table["vehicle_class"] = classes
    return table


def test_scan_distances_from_speed_and_periods():
    d = scan_distances([0.0, 0.1, 0.3, 0.4], [10.0, 10.0, 5.0, 20.0])
    # each scan: its speed times the time to the next scan (the last: the period before)
    np.testing.assert_allclose(d, [[0.0, 1.0], [1.0, 3.0], [3.0, 3.5], [3.5, 5.5]])
    np.testing.assert_allclose(scan_distances([0.0, 0.5], 2.0), [[0.0, 1.0], [1.0, 2.0]])


@pytest.mark.parametrize("stamps, speed, match", [
    ([0.0], 1.0, "at least two"),
    ([0.0, 0.1, 0.05], 1.0, "non-decreasing; scan 2"),
    ([0.2, 0.2, 0.2], 1.0, "span some time"),
    ([0.0, 0.1], [1.0, -2.0], "scan 1 has -2.0"),
    ([0.0, 0.1], float("nan"), "finite and not negative"),
    ([0.0, 0.1, 0.2], [1.0, 1.0], "one per scan"),
])
def test_scan_distances_refuses_bad_input(stamps, speed, match):
    with pytest.raises(ValueError, match=match):
        scan_distances(stamps, speed)



@pytest.mark.parametrize("clock", [0.02, 0.04, 0.05])
def test_stamps_of_a_coarse_clock_give_the_distance_of_exact_ones(clock):
    # 75 scans/s on a 20-50 ms clock: equal stamps and steps of 1.5-3.75 periods,
    # the same time (no step of the clock is a lost scan; the detector's rule)
    exact = np.arange(301) / 75.0
    coarse = np.round(exact / clock) * clock
    assert (np.diff(coarse) == 0).any()
    d = scan_distances(coarse, 11.0)
    assert d[-1, 0] == pytest.approx(scan_distances(exact, 11.0)[-1, 0], abs=0.11)
    assert (d[1:, 0] - d[:-1, 1]).max() < 1e-9  # no stretch left unseen


#: 75 scans/s at 11 m/s, scans 100-109 lost (numbered as received: a stamp jump).
LOST_STAMPS = np.delete(np.arange(400) / 75.0, np.arange(100, 110))


def test_lost_metres_count_only_to_an_object_seen_on_both_sides():
    d = scan_distances(LOST_STAMPS, 11.0)
    step = 11.0 / 75.0
    np.testing.assert_allclose(np.diff(d, axis=1), step)  # every scan its own period
    # the ten lost scans (1.47 m) lie between scans 99 and 100 of the table
    assert d[100, 0] - d[99, 1] == pytest.approx(10 * step)
    assert d[-1, 1] == pytest.approx(400 * step)  # the whole street driven
    rows = [(90, 99, "parked"),     # a car that ends right before the lost scans
            (100, 109, "parked"),   # one that starts right after them
            (200, 229, "parked"),   # seen on both sides below
            (300, 309, "parked")]
    table = objects(rows)
    table.loc[2, ["first_scan", "last_scan"]] = (95, 104)
    parked = parked_extents(table, d)
    np.testing.assert_allclose(parked["length_m"], [10 * step, 10 * step,
                                                    20 * step, 10 * step])
    # occupancy: the lost stretch is covered only by the object across it
    result = census(table.drop(index=2), d, segment_length=1e4)
    assert result["parked_length_m"].sum() == pytest.approx(30 * step)
    assert result["occupancy"].iloc[0] == pytest.approx(30 * step / (400 * step))


def test_lost_metres_take_the_mean_speed_of_both_sides():
    stamps = np.delete(np.arange(40) / 10.0, np.arange(20, 24))
    speed = np.where(np.arange(36) < 20, 2.0, 4.0)  # 2 m/s before, 4 m/s after
    d = scan_distances(stamps, speed)
    assert d[20, 0] - d[19, 1] == pytest.approx(4 * 0.1 * 3.0)

def test_a_stop_adds_no_distance():
    d = scan_distances([0.0, 1.0, 2.0, 3.0], [2.0, 0.0, 0.0, 2.0])
    np.testing.assert_allclose(d, [[0.0, 2.0], [2.0, 2.0], [2.0, 2.0], [2.0, 4.0]])
    # an object seen only while stopped covers no kerb but is still counted
    table = census(objects([(1, 2, "parked")]), d, segment_length=1.0)
    assert table["parked"].tolist() == [0, 0, 1, 0]  # at 2 m: the segment from 2 m
    assert table["occupancy"].sum() == 0.0


def test_segments_cover_the_street_the_last_one_shorter():
    table = census(objects([]), DISTANCES, segment_length=30.0)
    assert list(table.columns) == list(CENSUS_COLUMNS)
    np.testing.assert_allclose(table["start_m"], [0, 30, 60, 90])
    np.testing.assert_allclose(table["end_m"], [30, 60, 90, 100])
    np.testing.assert_allclose(table["kerb_length_m"], [30, 30, 30, 10])
    assert (table[[*CENSUS_CLASSES, "parked"]] == 0).all().all()
    assert (table["occupancy"] == 0).all()


def test_object_across_a_boundary_is_split_by_length_and_counted_once():
    # scans 40-69: 4.0 m to 7.0 m; the boundary at 5 m leaves 1 m before, 2 m after
    table = census(objects([(40, 69, "parked")]), DISTANCES, segment_length=5.0)
    np.testing.assert_allclose(table["parked_length_m"][:3], [1.0, 2.0, 0.0])
    np.testing.assert_allclose(table["occupancy"][:3], [0.2, 0.4, 0.0])
    # counted in the segment of its middle (5.5 m)
    assert table["parked"].tolist()[:3] == [0, 1, 0]
    assert table["parked"].sum() == 1
    np.testing.assert_allclose(table["parked_length_m"].sum(), 3.0)


def test_object_ending_exactly_on_a_boundary_stays_in_its_segment():
    # scans 0-49: 0.0 m to 5.0 m exactly, the first segment's length
    table = census(objects([(0, 49, "parked")]), DISTANCES, segment_length=5.0)
    np.testing.assert_allclose(table["parked_length_m"][:2], [5.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(table["occupancy"][:2], [1.0, 0.0], atol=1e-9)
    assert table["parked"].tolist()[:2] == [1, 0]


def test_occupancy_counts_overlapping_vehicles_once_and_stays_in_0_1():
    rows = [(0, 49, "parked"), (10, 39, "parked"), (45, 54, "parked"),
            (60, 69, "passing"), (70, 79, "roadside")]
    table = census(objects(rows), DISTANCES, segment_length=5.0)
    # segment 0 holds 5.0 + 3.0 + 0.5 m of vehicles but only 5 m of kerb
    np.testing.assert_allclose(table["parked_length_m"][0], 8.5)
    assert table["occupancy"][0] == pytest.approx(1.0)
    # segment 1: 0.5 m of the third object; passing and roadside objects not counted
    np.testing.assert_allclose(table["parked_length_m"][1], 0.5)
    assert table["occupancy"][1] == pytest.approx(0.1)
    assert table["parked"].sum() == 3
    assert table["occupancy"].between(0.0, 1.0).all()


def test_random_tables_keep_the_totals():
    rng = np.random.default_rng(0)
    first = rng.integers(0, 990, 60)
    last = np.minimum(first + rng.integers(0, 80, 60), 999)
    table = objects(list(zip(first, last, ["parked"] * 60, strict=True)),
                    classes=rng.choice(["car", "van", "motorbike", ""], 60))
    result = census(table, DISTANCES, segment_length=7.0)
    assert result["parked"].sum() == 60
    np.testing.assert_allclose(result["parked_length_m"].sum(),
                               ((last - first + 1) * 0.1).sum())
    assert result["occupancy"].between(0.0, 1.0).all()
    assert (result["occupancy"] * result["kerb_length_m"]
            <= result["parked_length_m"] + 1e-9).all()


def test_vehicle_class_column_is_counted_per_class():
    rows = [(0, 40, "parked"), (100, 140, "parked"), (200, 230, "parked"),
            (300, 310, "parked"), (400, 420, "passing")]
    table = objects(rows, classes=["car", "van", "motorbike", np.nan, ""])
    result = census(table, DISTANCES, segment_length=100.0)
    assert result.loc[0, ["car", "van", "motorbike", "unclassified", "parked"]
                      ].tolist() == [1, 1, 1, 1, 4]


def test_without_vehicle_class_every_parked_object_is_unclassified():
    table = objects([(0, 40, "parked"), (100, 140, "parked"), (200, 230, "passing")])
    result = census(table, DISTANCES, segment_length=100.0)
    assert result.loc[0, ["car", "van", "motorbike", "unclassified"]
                      ].tolist() == [0, 0, 0, 2]


def test_extents_come_from_the_distances_not_the_length_column():
    table = objects([(10, 19, "parked")])
    table["length"] = 99.0
    distances = np.concatenate([[0.0], np.cumsum(np.full(30, 0.5))])
    parked = parked_extents(table, distances)
    assert parked[["start_m", "end_m", "length_m"]].iloc[0].tolist() == [5.0, 10.0, 5.0]
    # the same as each scan's start and end
    parked = parked_extents(table, np.column_stack([distances[:-1], distances[1:]]))
    assert parked[["start_m", "end_m", "length_m"]].iloc[0].tolist() == [5.0, 10.0, 5.0]


@pytest.mark.parametrize("change, match", [
    (lambda t: t.drop(columns="label"), "lacks column"),
    (lambda t: t.assign(last_scan=[1000]), "< 1000"),
    (lambda t: t.assign(vehicle_class=["lorry"]), "'lorry'"),
    (lambda t: t.assign(run=["a"]).pipe(
        lambda u: pd.concat([u, u.assign(run="b")])), "2 runs"),
])
def test_bad_tables_are_refused(change, match):
    with pytest.raises(ValueError, match=match):
        census(change(objects([(0, 5, "parked")])), DISTANCES)


@pytest.mark.parametrize("value", [0, -5.0, float("nan"), float("inf"), True, "50"])
def test_bad_segment_length_is_refused(value):
    with pytest.raises(ValueError, match="segment_length"):
        census(objects([]), DISTANCES, segment_length=value)


def test_distances_that_do_not_move_are_refused():
    with pytest.raises(ValueError, match="did not move"):
        census(objects([]), np.zeros(11))


def test_stretches_that_overlap_are_refused():
    with pytest.raises(ValueError, match="non-decreasing"):
        census(objects([]), [[0.0, 2.0], [1.0, 3.0]])
    with pytest.raises(ValueError, match="n_scans, 2"):
        census(objects([]), np.zeros((3, 3)))
