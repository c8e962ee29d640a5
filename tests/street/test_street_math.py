"""Restoration, tilt estimate, ROI, single linkage and inter-scan linking."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.cluster.hierarchy import fcluster, single
from scipy.spatial.distance import pdist

from tunnelsense.street import (
    estimate_tilt,
    link_scans,
    no_return,
    restore_points,
    roi_mask,
    single_linkage,
)


def same_partition(a, b):
    a, b = np.asarray(a), np.asarray(b)
    pairs = set(zip(a.tolist(), b.tolist(), strict=True))
    return len(pairs) == len(set(a.tolist())) == len(set(b.tolist()))


def test_no_return_accepts_all_three_conventions():
    r = np.array([1.0, np.nan, np.inf, 8.191, 9.0, 0.01])
    assert no_return(r, 0.05, 8.191).tolist() == [False, True, True, True, True, True]


def test_restore_points_geometry():
    d, h = restore_points(np.array([[1.0, 2.0]]), np.array([-np.pi / 2, 0.0]), 1.5,
                          tilt=np.array([0.0]))
    np.testing.assert_allclose(d, [[0.0, 2.0]], atol=1e-12)
    np.testing.assert_allclose(h, [[0.5, 1.5]])


@pytest.mark.parametrize("tilt_deg", [-4.0, 0.0, 2.5, 6.0])
def test_tilt_estimate_with_car_beside_the_sensor(tilt_deg, global_random_seed):
    rng = np.random.default_rng(global_random_seed)
    angles = np.deg2rad(np.arange(-85.0, 30.0, 0.5))
    true = np.deg2rad(tilt_deg)
    phi = angles + true
    with np.errstate(divide="ignore"):
        road = np.where(phi < 0, -2.0 / np.sin(phi), np.inf)
    # a car side 1.0 m from the sensor hides the road from the steepest beams down
    # to where its 1.4 m roof is (the first beams do NOT hit the road)
    car = 1.0 / np.cos(phi)
    z = 2.0 + car * np.sin(phi)
    r = np.where((z > 0.2) & (z < 1.4), car, road)
    r[:30] = 1.0 / np.cos(phi[:30])  # first beams on the car's lower body too
    r = r + rng.normal(0, 0.01, r.shape)
    tilt, offset = estimate_tilt(r, angles, 2.0)
    assert abs(np.rad2deg(tilt) - tilt_deg) < 0.3
    assert abs(offset - 2.0) < 0.05


def test_tilt_estimate_nan_without_road():
    angles = np.deg2rad(np.arange(-85.0, 30.0, 0.5))
    tilt, offset = estimate_tilt(np.full(len(angles), np.nan), angles, 2.0)
    assert np.isnan(tilt) and np.isnan(offset)
    tilts, _ = estimate_tilt(np.full((3, len(angles)), 1.0 / np.cos(angles)), angles, 2.0)
    assert np.isnan(tilts).all()  # a wall everywhere: no road


def test_roi_band_and_no_return():
    d = np.array([3.0, 3.0, 3.0, 3.0, np.nan, -0.5])
    h = np.array([0.1, 0.11, 1.99, 2.0, 1.0, 1.0])
    assert roi_mask(d, h).tolist() == [False, True, True, False, False, False]


points_strategy = arrays(
    np.float64,
    st.tuples(st.integers(1, 60), st.just(2)),
    elements=st.one_of(
        st.floats(0, 4, allow_nan=False, width=32),
        st.sampled_from([0.0, 0.3, 0.6, 1.2, 1.8]),  # exact ties at the cut
    ),
)


@given(points_strategy)
def test_single_linkage_equals_scipy(points):
    labels = single_linkage(points, 0.6)
    if len(points) == 1:
        assert labels.tolist() == [0]
        return
    ref = fcluster(single(pdist(points)), 0.6, criterion="distance")
    assert same_partition(labels, ref)


def test_single_linkage_is_not_gap_splitting():
    # two legs in beam order: consecutive points jump between legs, yet the legs are
    # two clusters; a wall beside a narrow occluder joins across beams
    legs = np.array([[2.0, 0.2], [3.0, 0.2], [2.0, 0.4], [3.0, 0.4], [2.0, 0.6]])
    assert single_linkage(legs, 0.6).tolist() == [0, 1, 0, 1, 0]
    wall = np.array([[5.0, 0.2], [5.0, 0.5], [2.0, 0.8], [5.0, 0.8], [5.0, 1.1]])
    assert single_linkage(wall, 0.6).tolist() == [0, 0, 1, 0, 0]


def test_single_linkage_groups_never_join():
    pts = np.array([[1.0, 1.0], [1.1, 1.0], [1.0, 1.0], [3.0, 1.0]])
    assert single_linkage(pts, 0.6, groups=[0, 0, 1, 1]).tolist() == [0, 0, 0, 1]
    with pytest.raises(ValueError, match="contiguous"):
        single_linkage(pts, 0.6, groups=[0, 1, 0, 1])
    with pytest.raises(ValueError, match="points"):
        single_linkage(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="finite"):
        single_linkage(np.array([[np.nan, 1.0]]))


def test_single_linkage_empty_and_one_point():
    assert single_linkage(np.empty((0, 2))).tolist() == []
    assert single_linkage(np.array([[1.0, 1.0]])).tolist() == [0]


def test_link_scans_breaks_on_gap_and_depth():
    pos = np.array([0, 1, 1, 2, 4])
    depth = np.array([5.0, 5.4, 2.0, 5.85, 5.85])
    follows = np.array([False, True, True, True, True])
    # 5.0 -> 5.4 (0.4 < 0.5) -> 5.85 (0.45); 2.0 alone; pos 4 after a missing scan
    assert link_scans(pos, depth, follows).tolist() == [0, 0, 1, 0, 2]
    follows[1] = False  # a run boundary
    assert link_scans(pos, depth, follows).tolist() == [0, 1, 2, 1, 3]
    assert link_scans(pos, depth, follows, 0.3).tolist() == [0, 1, 2, 3, 4]


@given(st.integers(1, 40).flatmap(lambda n: st.tuples(
    st.just(n), st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)),
                         max_size=60))))
def test_components_equal_scipy(graph):
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from tunnelsense.street._clustering import components

    n, edges = graph
    a = np.array([e[0] for e in edges], dtype=np.int64)
    b = np.array([e[1] for e in edges], dtype=np.int64)
    labels = components(n, a, b)
    m = coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    assert same_partition(labels, connected_components(m, directed=False)[1])
    # every label is the smallest node of its component
    assert all(labels[i] == np.flatnonzero(labels == labels[i]).min() for i in range(n))


@given(st.lists(st.tuples(st.integers(0, 6), st.floats(0.0, 8.0)), max_size=40),
       st.lists(st.booleans(), min_size=7, max_size=7))
def test_link_scans_equals_the_rule_pair_by_pair(clusters, follows):
    """Two clusters link when their scans are consecutive, the later follows the
    earlier, and their mean depths differ by less than link_distance."""
    from tunnelsense.street._clustering import components

    clusters.sort(key=lambda c: c[0])
    pos = np.array([c[0] for c in clusters], dtype=np.int64)
    depth = np.array([c[1] for c in clusters])
    follows = np.array(follows)
    pairs = [(i, j) for i in range(len(pos)) for j in range(len(pos))
             if pos[j] == pos[i] + 1 and follows[pos[j]]
             and abs(depth[i] - depth[j]) < 0.5]
    want = components(len(pos), np.array([p[0] for p in pairs], dtype=np.int64),
                      np.array([p[1] for p in pairs], dtype=np.int64))
    got = link_scans(pos, depth, follows, 0.5)
    assert same_partition(got, want)
    if len(got):
        assert got[0] == 0 and np.all(np.diff(np.maximum.accumulate(got)) <= 1)


def test_link_scans_wants_clusters_in_scan_order():
    with pytest.raises(ValueError, match="position must be non-decreasing"):
        link_scans(np.array([1, 0]), np.array([2.0, 2.0]), np.array([False, True]))


def test_section_evidence_wall_and_hidden_lower_part():
    from tunnelsense.street import section_evidence

    # cluster 0: a van's near face reaching the ceiling, the beam above hits it again;
    # cluster 1: a pedestrian's upper body, the beam below hits a nearer car;
    # cluster 2: a pedestrian under a tree whose crown is 1 m behind (not the same face)
    d = np.array([4.5, 4.5, 4.5, 6.0, 6.0, 6.0, 6.0])
    h = np.array([0.3, 1.2, 1.97, 1.0, 1.7, 1.0, 1.8])
    c = np.array([0, 0, 0, 1, 1, 2, 2])
    b = np.array([10, 20, 30, 40, 45, 60, 65])
    above = np.full((7, 2), np.nan)
    below = np.full((7, 2), np.nan)
    above[2] = (4.5, 2.02)
    below[0] = (5.2, 0.0)
    below[3] = (2.0, 0.9)
    above[6] = (7.0, 2.3)
    roof, wall, raised, hidden = section_evidence(d, h, c, b, above, below)
    assert wall.tolist() == [True, False, False]
    assert raised.tolist() == [True, False, False]
    assert hidden.tolist() == [False, True, False]
    assert not roof.any()
    # no points, no clusters
    assert all(len(a) == 0 for a in section_evidence(
        np.empty(0), np.empty(0), np.empty(0, int), np.empty(0, int),
        np.empty((0, 2)), np.empty((0, 2))))
