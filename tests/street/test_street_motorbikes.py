"""Motorbikes across the kerb: raised over a beam that passes, and a gap the beams
see through between two vehicles standing close."""

import numpy as np

from tunnelsense.street import passed_under, section_evidence
from tunnelsense.street._objects import (
    PASSED_FLAG,
    RAISED_FLAG,
    bridged,
    see_through,
)
from tunnelsense.street._vehicles import is_vehicle


def test_a_beam_passing_under_a_body():
    # a motorbike's screen (0.8-1.3 m) seen from the road: the beam just below its
    # lowest point returns nothing within range (it passes under, beyond the kerb)
    h = np.array([0.8, 1.05, 1.3, 0.05, 0.6])
    c = np.array([0, 0, 0, 1, 1])
    passes = np.array([True, False, False, False, True])
    # a person: the beam under the torso passes between the legs, the lowest point
    # is a foot on the ground
    assert passed_under(h, c, passes, n_clusters=2).tolist() == [True, False]
    assert passed_under(h, c, ~passes, n_clusters=2).tolist() == [False, False]
    # the raised-body evidence does not change: nothing returned below
    nan = np.full((3, 2), np.nan)
    raised = section_evidence(np.full(3, 5.9), h[:3], c[:3], np.array([40, 41, 42]),
                              nan, nan)[2]
    assert raised.tolist() == [False]


def test_passing_under_counts_for_a_whole_short_object_only():
    cum = np.arange(12) * 0.15
    near = np.full(11, np.inf)
    seen = np.arange(3, 7)  # 0.6 m along the street, seen whole
    rule = dict(min_length=1.5, max_length=25.0, link_distance=0.5,
                min_body_fraction=0.3, min_car_length=2.4, min_raised_fraction=0.2,
                min_across_length=0.35, min_across_raised=0.3, top=1.3,
                min_across_top=1.05)
    passed = np.full(4, PASSED_FLAG)
    assert is_vehicle(seen, passed | RAISED_FLAG, 5.5, 0.0, cum, near, **rule)
    # its screen alone at its sides: a beam passes under it, its only body evidence
    assert is_vehicle(seen, passed, 5.5, 0.0, cum, near, **rule)
    assert not is_vehicle(seen, np.zeros(4, np.int8), 5.5, 0.0, cum, near, **rule)
    body = passed | 0b0001  # a roof-wide top: a body, and a beam passing under it
    assert is_vehicle(seen, body, 5.5, 0.0, cum, near, **rule)
    assert not is_vehicle(seen, np.full(4, 0b0001), 5.5, 0.0, cum, near, **rule)
    # at the start of a run (its first scans cut it), a beam passing under it is
    # no evidence; a raised body still is
    assert not is_vehicle(seen, body, 5.5, 0.0, cum, near, **rule, inside=False)
    assert is_vehicle(seen, body | RAISED_FLAG, 5.5, 0.0, cum, near, **rule,
                      inside=False)
    # a 2.0 m object is not across the kerb: passing under is no raised body there
    long = np.arange(0, 11)
    assert not is_vehicle(long, np.full(11, 0b0001 | PASSED_FLAG), 5.5, 0.0, cum, near,
                          **rule)
    assert is_vehicle(long, np.full(11, 0b0001 | RAISED_FLAG), 5.5, 0.0, cum, near,
                      **rule)


def test_a_gap_seen_through_splits_two_vehicles():
    cum = np.arange(12) * 0.15  # 0.15 m per scan: a 3-scan gap is 0.45 m
    near = np.full(11, 4.7)
    rule = dict(link_distance=0.5, merge_gap=0.5, occlusion_margin=1.0,
                bridge_occluded=True)
    step = 0.5
    hidden = np.full((11, 17), np.inf)  # no beam passes: nothing seen in the gap
    seen = hidden.copy()
    seen[4:7, :] = 0.05  # the beams of scans 4-6 reach the road beyond 4.7 m
    args = (4.7, 4.75, 4, 7, cum, near)
    # fragments 0-3 and 7-10, tops 1.3 and 1.45
    assert bridged(*args, **rule, horizon=hidden, step=step, tops=(1.3, 1.45))
    assert not bridged(*args, **rule, horizon=seen, step=step, tops=(1.3, 1.45))
    assert bridged(*args, **rule)  # without the horizon (the paper's): joined
    # seen over a low bonnet only, not under the bodies' half height: one body
    over = hidden.copy()
    over[4:7, :] = 0.9
    assert bridged(*args, **rule, horizon=over, step=step, tops=(1.3, 1.45))
    assert see_through(seen[4:7], step, 4.7, 1.3)
    assert not see_through(seen[3:7], step, 4.7, 1.3)  # scan 3 not seen through
    assert not see_through(seen[4:4], step, 4.7, 1.3)  # no gap scan: no evidence



def test_the_footway_does_not_carry_a_motorbike_across_the_kerb():
    from tunnelsense.street._clustering import components, first_appearance, link_pairs

    # clusters of five scans past a motorbike across the kerb, its rear on the
    # footway: the footway alone (mean depth 7.1 m, 0.17 m high), at the motorbike's
    # ends its screen alone (6.85 m, 1.3 m high) beside the footway, the whole
    # machine in the middle (mean depth 6.1 m)
    position = np.array([0, 1, 1, 2, 3, 3, 4])
    depth = np.array([7.1, 7.1, 6.85, 6.1, 6.86, 7.1, 7.1])
    top = np.array([0.17, 0.17, 1.30, 1.30, 1.31, 0.17, 0.17])
    follows = np.ones(5, bool)

    def objects(pairs):
        return first_appearance(components(7, *pairs)).tolist()

    # the paper's link by mean depth: the screen at each end joins the footway
    assert objects(link_pairs(position, depth, follows)) == [0, 0, 0, 1, 2, 2, 2]
    # the footway, a surface near road level, never links with a raised cluster
    ground = link_pairs(position, depth, follows, top=top, ground_height=0.3)
    assert objects(ground) == [0, 0, 1, 2, 3, 4, 4]
    # a raised cluster still links with a raised one: a low wall, not the footway
    top[[0, 1, 5, 6]] = 0.4
    assert objects(link_pairs(position, depth, follows, top=top,
                              ground_height=0.3)) == [0, 0, 0, 1, 2, 2, 2]


def test_separate_ground_finds_a_motorbike_on_the_footway():
    from tunnelsense.datasets import make_street_scans
    from tunnelsense.metrics import street_scores
    from tunnelsense.street import ScanClusterer

    run = make_street_scans(600, scenario="sparse", random_state=112,
                            motorbike_fraction=0.6, motorbike_across_fraction=0.6,
                            motorbike_footway_fraction=0.5, parked_cluster_size=4.0,
                            parked_gap_m=12.0)
    # (object_ends off: on this run it finds the same motorbike by itself)
    scores = [street_scores(run.gt, ScanClusterer(separate_ground=sg, object_ends=False)
                            .fit(run.scans).detect(run.scans))["parked"]
              for sg in (False, True)]
    assert scores[1]["tp"] > scores[0]["tp"]
    assert scores[1]["fp"] <= scores[0]["fp"]


def test_object_ends_find_a_motorbike_on_the_footway():
    from tunnelsense.datasets import make_street_scans
    from tunnelsense.metrics import street_scores
    from tunnelsense.street import ScanClusterer

    # with either setting of separate_ground, on the run where each finds more
    for seed, ground in ((112, False), (113, True)):
        run = make_street_scans(600, scenario="sparse", random_state=seed,
                                motorbike_fraction=0.6, motorbike_across_fraction=0.6,
                                motorbike_footway_fraction=0.5, parked_cluster_size=4.0,
                                parked_gap_m=12.0)
        scores = [street_scores(run.gt, ScanClusterer(
            object_ends=oe, separate_ground=ground).fit(run.scans).detect(
            run.scans))["parked"] for oe in (False, True)]
        assert scores[1]["tp"] > scores[0]["tp"]
        assert scores[1]["fp"] <= scores[0]["fp"]


def test_an_end_links_only_when_it_hangs_in_the_air():
    from tunnelsense.street._clustering import end_of

    # scan 0: the screen alone (6.64-6.72 m, top 1.27 m); scan 1: the whole
    # motorbike (5.8-6.7 m, top 1.27 m); the same pair as a wall standing on the
    # ground (narrow, top 1.2 m) beside a car joined to that wall (4.8-7.1 m)
    span = np.array([[6.64, 6.72], [5.8, 6.7], [7.0, 7.1], [4.8, 7.1]])
    top = np.array([1.27, 1.27, 1.2, 1.2])
    earlier, later = np.array([0, 2]), np.array([1, 3])
    assert end_of(earlier, later, span, top, 0.1).tolist() == [True, True]
    suspended = np.array([True, False, False, False])
    assert end_of(earlier, later, span, top, 0.1, suspended).tolist() == [True, False]
    # a top elsewhere, or an extent beyond the other's, is not an end
    assert not end_of(earlier[:1], later[:1], span, np.array([1.0, 1.27, 0, 0]),
                      0.1, suspended)[0]
    span[0] = (6.64, 6.95)
    assert not end_of(earlier[:1], later[:1], span, top, 0.1, suspended)[0]


def test_end_match_follows_the_top():
    from tunnelsense.street._vehicles import end_match

    upper = np.array([[6.6, 1.25], [6.65, 1.3]])
    hedge = np.array([[6.5, 0.12], [7.2, 1.3], [7.2, 1.0], [7.3, 1.6]])
    assert len(end_match(upper, hedge, 0.1)) == 0  # the hedge behind: no end
    with_screen = np.vstack([hedge, [[6.62, 1.28]]])
    assert end_match(upper, with_screen, 0.1).tolist() == [[6.62, 1.28]]
    assert len(end_match(upper[:0], with_screen, 0.1)) == 0


def test_a_short_object_hanging_in_the_air_is_a_motorbike():
    from tunnelsense.street._objects import SUSPENDED_FLAG

    cum = np.arange(15) * 0.15
    near = np.full(14, np.inf)
    seen = np.arange(1, 13)  # 1.8 m: longer than min_length, shorter than a car
    rule = dict(min_length=1.5, max_length=25.0, link_distance=0.5,
                min_body_fraction=0.3, min_car_length=2.4, min_raised_fraction=0.2)
    flags = np.zeros(12, np.int8)
    flags[4:8] = SUSPENDED_FLAG  # a third of its scans: its body over the gap
    flags[[4, 7]] |= RAISED_FLAG
    assert is_vehicle(seen, flags, 5.2, 0.0, cum, near, **rule)
    # raised alone in 2 of 12 scans is too little, and standing on the ground nothing
    assert not is_vehicle(seen, flags & RAISED_FLAG, 5.2, 0.0, cum, near, **rule)
    assert not is_vehicle(seen, np.zeros(12, np.int8), 5.2, 0.0, cum, near, **rule)


def test_a_motorbike_seen_over_a_passing_roof_keeps_the_evidence_it_shows():
    from tunnelsense.street._objects import HIDDEN_FLAG, SUSPENDED_FLAG

    # a parallel motorbike (1.7 m seen) behind a passing car: its lower part hidden
    # in 9 of 11 scans (the beam below it ends on the car), the last two see it
    # hanging over the gap between its wheels, one of them raised
    cum = np.arange(40) * 0.15
    near = np.full(39, 1.9)
    near[:4] = np.inf
    seen = np.arange(4, 15)
    rule = dict(min_length=1.5, max_length=25.0, link_distance=0.5,
                min_body_fraction=0.3, min_car_length=2.4, min_raised_fraction=0.2)
    flags = np.full(11, HIDDEN_FLAG, np.int8)
    flags[9:] = SUSPENDED_FLAG
    flags[10] |= RAISED_FLAG
    assert not is_vehicle(seen, flags, 5.3, 7.8, cum, near, **rule)  # diluted
    assert is_vehicle(seen, flags, 5.3, 7.8, cum, near, **rule, where_seen=True)
    # one scan's evidence is too little to stand for the object
    one = flags.copy()
    one[9] = 0
    assert not is_vehicle(seen, one, 5.3, 7.8, cum, near, **rule, where_seen=True)
    # a body as long as a car takes its evidence over all its length
    long = np.arange(4, 24)
    flags20 = np.full(20, HIDDEN_FLAG, np.int8)
    flags20[18:] = RAISED_FLAG | SUSPENDED_FLAG
    assert not is_vehicle(long, flags20, 5.3, 0.0, cum, near, **rule, where_seen=True)


def test_seen_evidence_finds_motorbikes_behind_passing_vehicles():
    from tunnelsense.datasets import make_street_scans
    from tunnelsense.metrics import street_scores
    from tunnelsense.street import make_parking_pipeline

    fit = make_street_scans(1000, scenario="sparse", random_state=11)
    run = make_street_scans(2000, scenario="sparse", random_state=101,
                            motorbike_fraction=0.6, motorbike_across_fraction=0.6,
                            motorbike_footway_fraction=0.5, parked_cluster_size=4.0,
                            parked_gap_m=12.0)
    on = make_parking_pipeline(seen_evidence=True).fit(fit.scans)[-1]
    off = make_parking_pipeline().fit(fit.scans)[-1]
    a = street_scores(run.gt, on.detect(run.scans))["parked"]
    b = street_scores(run.gt, off.detect(run.scans))["parked"]
    assert a["tp"] > b["tp"] and a["fp"] <= b["fp"]
