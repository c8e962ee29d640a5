"""The street-parked vehicle detector as a scikit-learn estimator on scan records.

:class:`ScanClusterer` runs the whole of the paper's Fig. 6 on a sequence of scans:
restoration, tilt compensation, region of interest, intra-scan single linkage,
inter-scan linking, three-region merging and labelling; plus, beyond the paper, the
splitting of nose-to-tail vehicles merged into one object and the rejection of objects
too short to be a vehicle (pedestrians, bins, bollards).
"""

from __future__ import annotations

import numbers

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, TransformerMixin, _fit_context
from sklearn.pipeline import Pipeline
from sklearn.utils._param_validation import Interval
from sklearn.utils.validation import check_is_fitted

from tunnelsense._records import RUN_LABELS, ScanSequence, check_scans
from tunnelsense.street._clustering import _single_linkage_groups, link_scans
from tunnelsense.street._restoration import (
    compensate_tilt,
    estimate_tilt,
    no_return,
    restore_points,
)
from tunnelsense.street._roi import roi_mask
from tunnelsense.street._sections import section_evidence

_BODY, _HIDDEN = 0b0111, 0b1000  # bits of the per-scan evidence flags
#: Shortest visible part (m) of a vehicle cut short by an occluder.
_MIN_VISIBLE = 0.5

__all__ = ["OBJECT_COLUMNS", "ScanClusterer", "make_parking_pipeline", "split_profile"]

#: Columns of the object table returned by :meth:`ScanClusterer.detect`.
OBJECT_COLUMNS = (
    "run",
    "id",
    "first_scan",
    "last_scan",
    "label",
    "mean_depth",
    "region",
    "length",
    "top_height",
    "n_points",
)

#: Ego speed (m/s) assumed when neither the parameter nor the scans give one:
#: the paper's measurement vehicle drove at about 40 km/h.
DEFAULT_SPEED = 40 / 3.6

#: Scan period (s) assumed when a run's stamps do not give one (75 scans/s).
DEFAULT_SCAN_PERIOD = 1 / 75


def split_profile(top, step, *, min_length=2.0, ratio=0.6):
    """Where to split an object whose height profile has two humps.

    Two vehicles parked nose to tail and merged into one object show, along the track,
    two humps of the top height (roofs, 1.2-2 m) with a valley between them (bumpers,
    0.3-0.7 m, or the road seen through the gap).  A single vehicle has one hump:
    its low parts (bumpers, bonnet, boot) are at its ends.

    The split point is the scan of lowest ``top / min(left peak, right peak)`` among
    the scans that leave at least ``min_length`` metres on both sides; it is accepted
    when that ratio is at most ``ratio``.  Applied recursively to both parts.

    Parameters
    ----------
    top : ndarray of shape (n_scans,)
        Top height (m) of the object in each of its scans (NaN where not seen).
    step : float
        Distance (m) travelled between two scans.
    min_length : float, default=2.0
        Shortest part (m) a split may leave.
    ratio : float, default=0.6
        Largest valley-to-peak ratio that splits.

    Returns
    -------
    cuts : list of int
        Scan offsets where a new object starts (sorted).

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense.street import split_profile
    >>> car = np.r_[0.5, 0.9, 0.9, 1.4, 1.45, 1.4, 1.0, 0.5]
    >>> split_profile(np.r_[car, car], step=0.6)
    [8]
    >>> split_profile(car, step=0.6)
    []
    """
    top = np.asarray(top, dtype=np.float64)
    top = np.where(np.isnan(top), 0.0, top)
    n = len(top)
    k = max(int(np.ceil(min_length / max(step, 1e-9))), 1)
    if n < 2 * k + 1:
        return []
    left = np.maximum.accumulate(top)
    right = np.maximum.accumulate(top[::-1])[::-1]
    idx = np.arange(k, n - k)
    peak = np.minimum(left[idx - 1], right[idx + 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        score = np.where(peak > 0, top[idx] / peak, np.inf)
    j = int(np.argmin(score))
    if not score[j] <= ratio:
        return []
    cut = int(idx[j])
    # the valley scan goes with its higher neighbour (a bumper with its own body)
    start = cut + 1 if top[cut - 1] > top[cut + 1] else cut
    start = min(max(start, k), n - k)
    a = split_profile(top[:start], step, min_length=min_length, ratio=ratio)
    b = split_profile(top[start:], step, min_length=min_length, ratio=ratio)
    return [*a, start, *(start + c for c in b)]


class ScanClusterer(TransformerMixin, BaseEstimator):
    """Detect street-parked and passing vehicles in vertical laser scans.

    The paper's pipeline (Fig. 6), run by :meth:`transform`, :meth:`predict` and
    :meth:`detect` over scans of one or several runs (sorted by ``(run, scan)``;
    objects never cross a run boundary or a gap in the scan numbers):

    1. polar to ``(depth, height)`` with the sensor's ``mount_height``;
    2. tilt compensation from the returns of the road (robust vote, see
       :func:`~tunnelsense.street.estimate_tilt`); the road becomes height 0;
    3. region of interest ``min_height < height < max_height``, no-return beams
       (NaN, +inf, ``>= range_max``) dropped;
    4. intra-scan single linkage cut at ``cut``;
    5. inter-scan linking of clusters whose mean depths differ by less than
       ``link_distance``; an object ends when the next scan has nothing to link;
    6. three depth regions split at ``regions``: a small object-cluster (shorter than
       ``min_length``) or one mostly overlapping in time with a larger one of the same
       region is merged into it, when at most ``merge_gap`` metres apart;
    7. beyond the paper: objects with two humps in their height profile are split
       (``split_merged``); objects shorter than ``min_length`` or longer than
       ``max_length`` metres, or not seen over ``min_length`` metres (in all, and
       without a break), or whose cross-sections show no vehicle body (roof, wall
       or raised body in fewer than ``min_body_fraction`` of their scans) are
       labelled ``"other"`` (not vehicles); vehicles cut short by a nearer occluder
       are extended behind it (``occluded_length``).

    Objects are labelled by the region of their mean depth through ``region_labels``.

    Parameters
    ----------
    cut : float, default=0.6
        Intra-scan single-linkage cut (m).
    link_distance : float, default=0.5
        Inter-scan link: largest mean-depth difference (m), exclusive.
    regions : tuple of two floats, default=(4.0, 6.6)
        Depth (m) boundaries of regions I | II | III.
    region_labels : tuple of three str, default=("passing", "parked", "roadside")
        Label of the objects of region I, II and III (the paper's experiment: the
        measurement vehicle in the right lane).  Labels outside
        :data:`~tunnelsense.RUN_LABELS` are kept in :meth:`detect` with
        ``all_objects=True`` only.
    min_height, max_height : float, default=0.1, 2.0
        Region of interest (m above the road).
    tilt_compensation : bool, default=True
        Estimate the tilt of every scan from the road; False uses the nominal geometry.
    max_tilt : float, default=10.0
        Largest tilt (degrees) the estimate considers.
    split_merged : bool, default=True
        Split objects whose height profile shows two vehicles nose to tail.
    split_ratio : float, default=0.6
        Largest valley-to-peak height ratio that splits (see :func:`split_profile`).
    min_length : float, default=1.5
        Shortest vehicle (m along the track); shorter objects are ``"other"``
        (pedestrians, bins, bollards); also the shortest part a split leaves.
    max_length : float, default=25.0
        Longest vehicle (m); longer objects (hedges, walls) are ``"other"``.
    merge_gap : float, default=0.5
        Largest gap (m along the track) across which fragments are merged.
    speed : float or None, default=None
        Ego speed (m/s) turning scan counts into lengths.  None: the median of the
        scans' payload ``"speed"`` when the scans carry one, else 40 km/h (the
        paper's).
    roof_width : float, default=0.8
        Smallest depth extent (m) of a cluster's top surface that counts as a
        vehicle roof, bonnet or boot seen from above (see
        :func:`~tunnelsense.street.section_evidence`).
    min_clearance : float, default=0.2
        Lowest bottom (m) of a raised body (a vehicle between its wheels).
    min_body_fraction : float, default=0.3
        Smallest fraction of an object's seen scans showing a roof, a wall taller
        than the region of interest or a raised body for it to be a vehicle;
        rows of pedestrians, bins and bollards show none.  0 switches the rule off.
    occlusion_margin : float, default=1.0
        How much nearer (m) something must be to hide an object.
    bridge_occluded : bool, default=True
        Merge fragments of one region across a gap of any length hidden by
        something nearer (beyond the paper).
    occluded_length : float or None, default=4.0
        Length (m) to which a vehicle cut short by an occluder is extended into the
        hidden scans; None: no extension.

    Attributes
    ----------
    region_edges_ : ndarray of shape (2,)
        The validated region boundaries.
    labels_ : tuple of str
        The validated region labels.

    Examples
    --------
    >>> import numpy as np
    >>> from tunnelsense import LaserGeometry, ScanSequence
    >>> from tunnelsense.street import ScanClusterer
    >>> geom = LaserGeometry(np.deg2rad(-89.0), np.deg2rad(0.5), 0.05, 30.0, 2.0)
    >>> angles = geom.angles(181)
    >>> road = 2.0 / np.sin(-np.minimum(angles, -1e-3))
    >>> scans = np.tile(np.where(angles < 0, road, np.inf), (60, 1))
    >>> side = (angles > np.arctan(-1.8 / 5.0)) & (angles < np.arctan(-0.5 / 5.0))
    >>> scans[10:40, side] = 5.0 / np.cos(angles[side])   # a car side 5 m away
    >>> X = ScanSequence.from_arrays(scans, np.arange(60) / 75, geom, run="r")
    >>> ScanClusterer().fit(X).detect(X)[["id", "first_scan", "last_scan", "label"]]
       id  first_scan  last_scan   label
    0   1          10         39  parked
    """

    _parameter_constraints: dict = {
        "cut": [Interval(numbers.Real, 0, None, closed="neither")],
        "link_distance": [Interval(numbers.Real, 0, None, closed="neither")],
        "regions": ["array-like"],
        "region_labels": ["array-like"],
        "min_height": [Interval(numbers.Real, None, None, closed="neither")],
        "max_height": [Interval(numbers.Real, None, None, closed="neither")],
        "tilt_compensation": ["boolean"],
        "max_tilt": [Interval(numbers.Real, 0, 45, closed="right")],
        "split_merged": ["boolean"],
        "split_ratio": [Interval(numbers.Real, 0, 1, closed="both")],
        "min_length": [Interval(numbers.Real, 0, None, closed="left")],
        "max_length": [Interval(numbers.Real, 0, None, closed="neither")],
        "merge_gap": [Interval(numbers.Real, 0, None, closed="left")],
        "speed": [Interval(numbers.Real, 0, None, closed="neither"), None],
        "roof_width": [Interval(numbers.Real, 0, None, closed="left")],
        "min_clearance": [Interval(numbers.Real, None, None, closed="neither")],
        "min_body_fraction": [Interval(numbers.Real, 0, 1, closed="both")],
        "occlusion_margin": [Interval(numbers.Real, 0, None, closed="left")],
        "bridge_occluded": ["boolean"],
        "occluded_length": [Interval(numbers.Real, 0, None, closed="neither"), None],
    }

    def __init__(
        self,
        cut=0.6,
        link_distance=0.5,
        regions=(4.0, 6.6),
        region_labels=("passing", "parked", "roadside"),
        min_height=0.1,
        max_height=2.0,
        tilt_compensation=True,
        max_tilt=10.0,
        split_merged=True,
        split_ratio=0.6,
        min_length=1.5,
        max_length=25.0,
        merge_gap=0.5,
        speed=None,
        roof_width=0.8,
        min_clearance=0.2,
        min_body_fraction=0.3,
        occlusion_margin=1.0,
        bridge_occluded=True,
        occluded_length=4.0,
    ):
        self.cut = cut
        self.link_distance = link_distance
        self.regions = regions
        self.region_labels = region_labels
        self.min_height = min_height
        self.max_height = max_height
        self.tilt_compensation = tilt_compensation
        self.max_tilt = max_tilt
        self.split_merged = split_merged
        self.split_ratio = split_ratio
        self.min_length = min_length
        self.max_length = max_length
        self.merge_gap = merge_gap
        self.speed = speed
        self.roof_width = roof_width
        self.min_clearance = min_clearance
        self.min_body_fraction = min_body_fraction
        self.occlusion_margin = occlusion_margin
        self.bridge_occluded = bridge_occluded
        self.occluded_length = occluded_length

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False
        tags.requires_fit = True
        return tags

    # ------------------------------------------------------------------ fit
    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y=None):
        """Validate the parameters and the scans; nothing is learned.

        Parameters
        ----------
        X : sequence of ScanRecord
            Scans of one or several runs.
        y : sequence of ndarray of shape (k_i, 2), default=None
            Ignored (per-scan ``(object id, label code)``; see
            :meth:`tunnelsense.Run.targets`).

        Returns
        -------
        self : ScanClusterer
        """
        check_scans(X, y)
        edges = np.asarray(self.regions, dtype=np.float64)
        if edges.shape != (2,) or not np.all(np.isfinite(edges)) or edges[0] > edges[1]:
            raise ValueError(
                "regions must be two increasing depths (m) (I|II, II|III); "
                f"got {self.regions!r}"
            )
        labels = tuple(self.region_labels)
        if len(labels) != 3 or not all(isinstance(s, str) for s in labels):
            raise ValueError(
                "region_labels must be three strings (labels of regions I, II, III); "
                f"got {self.region_labels!r}"
            )
        if not self.min_height < self.max_height:
            raise ValueError(
                f"min_height ({self.min_height}) must be below max_height "
                f"({self.max_height})"
            )
        if not self.min_length < self.max_length:
            raise ValueError(
                f"min_length ({self.min_length}) must be below max_length "
                f"({self.max_length})"
            )
        self.region_edges_ = edges
        self.labels_ = labels
        return self

    # ------------------------------------------------------------ the method
    def _run_all(self, X):
        """Cluster all scans; returns a dict of arrays (see the code for keys)."""
        check_is_fitted(self)
        records, _ = check_scans(X)
        n = len(records)
        runs = np.array([r.run for r in records], dtype=object)
        scans = np.array([r.scan for r in records], dtype=np.int64)
        order = np.lexsort((scans, runs.astype(str))) if n else np.empty(0, np.int64)
        srec = [records[i] for i in order]
        sruns, sscans = runs[order], scans[order]
        dup = (sruns[1:] == sruns[:-1]) & (sscans[1:] == sscans[:-1])
        if dup.any():
            i = int(np.flatnonzero(dup)[0])
            raise ValueError(
                f"X holds scan {sscans[i]} of run {sruns[i]!r} twice: "
                "expected each (run, scan) once"
            )
        new_run = np.r_[True, sruns[1:] != sruns[:-1]] if n else np.empty(0, bool)
        follows = ~new_run & np.r_[False, sscans[1:] == sscans[:-1] + 1]
        run_starts = np.flatnonzero(new_run)
        run_ends = np.r_[run_starts[1:], n]
        xs, ys, ps, bs, abs_, bes = [], [], [], [], [], []
        tilt = np.zeros(n)
        step = np.zeros(n)  # metres travelled per scan, per scan
        for a, b in zip(run_starts, run_ends, strict=True):
            block = srec[a:b]
            ranges, geom = self._validate_run(block)
            stamps = np.array([r.stamp for r in block])
            if np.any(np.diff(stamps) < 0):
                i = int(np.flatnonzero(np.diff(stamps) < 0)[0])
                raise ValueError(
                    f"stamps of run {block[0].run!r} are not sorted: scan "
                    f"{block[i + 1].scan} ({stamps[i + 1]}) comes after scan "
                    f"{block[i].scan} ({stamps[i]}); expected non-decreasing stamps"
                )
            step[a:b] = self._speed(block) * _scan_period(stamps)
            r = np.where(no_return(ranges, geom.range_min, geom.range_max), np.nan, ranges)
            angles = geom.angles(r.shape[1])
            if self.tilt_compensation:
                t, off = estimate_tilt(
                    r, angles, geom.mount_height, max_tilt=self.max_tilt,
                    tolerance=self.min_height,
                )
                depth, height, t = compensate_tilt(r, angles, geom.mount_height, t, off)
            else:
                t = np.zeros(len(r))
                depth, height = restore_points(r, angles, geom.mount_height)
            tilt[a:b] = t
            m = roi_mask(depth, height, min_height=self.min_height,
                         max_height=self.max_height)
            rows, cols = np.nonzero(m)
            xs.append(depth[rows, cols])
            ys.append(height[rows, cols])
            ps.append(rows + a)
            bs.append(cols)
            # the returns of the beams just above and below every ROI point
            nb = depth.shape[1]
            up, dn = np.minimum(cols + 1, nb - 1), np.maximum(cols - 1, 0)
            ab = np.column_stack([depth[rows, up], height[rows, up]])
            ab[cols + 1 >= nb] = np.nan
            be = np.column_stack([depth[rows, dn], height[rows, dn]])
            be[cols == 0] = np.nan
            abs_.append(ab)
            bes.append(be)
        x = np.concatenate(xs) if xs else np.empty(0)
        y = np.concatenate(ys) if ys else np.empty(0)
        pos = np.concatenate(ps).astype(np.int64) if ps else np.empty(0, np.int64)
        beams = np.concatenate(bs).astype(np.int64) if bs else np.empty(0, np.int64)
        above = np.concatenate(abs_) if abs_ else np.empty((0, 2))
        below = np.concatenate(bes) if bes else np.empty((0, 2))
        # 4. intra-scan clusters
        local = _single_linkage_groups(x, y, pos, float(self.cut))
        n_cl = np.zeros(n, dtype=np.int64)
        if len(pos):
            np.maximum.at(n_cl, pos, local + 1)
        cl_start = np.cumsum(n_cl) - n_cl
        cid = cl_start[pos] + local
        k = int(n_cl.sum())
        cpos = np.repeat(np.arange(n), n_cl)
        npts = np.bincount(cid, minlength=k)
        cdepth = np.bincount(cid, weights=x, minlength=k) / np.maximum(npts, 1)
        ctop = np.full(k, -np.inf)
        np.maximum.at(ctop, cid, y)
        roof, wall, raised, hidden = section_evidence(
            x, y, cid, beams, above, below, n_clusters=k, roof_width=self.roof_width,
            max_height=self.max_height, cut=self.cut, min_clearance=self.min_clearance)
        cflag = (roof.astype(np.int8) | (wall.astype(np.int8) << 1)
                 | (raised.astype(np.int8) << 2) | (hidden.astype(np.int8) << 3))
        # 5. inter-scan linking
        cobj = link_scans(cpos, cdepth, follows, float(self.link_distance))
        # 6-7. objects
        objects, cobj, spans = self._objects(cpos, cdepth, ctop, npts, cobj, step,
                                             sruns, sscans, follows, cflag)
        return {
            "order": order, "beams": beams, "runs": sruns, "scans": sscans, "pos": pos, "x": x, "y": y,
            "local": local, "cid": cid, "cpos": cpos, "cobj": cobj, "tilt": tilt,
            "objects": objects, "spans": spans, "n_cl": n_cl, "cl_start": cl_start,
        }

    @staticmethod
    def _validate_run(block):
        geom = block[0].geometry
        nb = len(block[0].ranges)
        for r in block:
            if len(r.ranges) != nb:
                raise ValueError(
                    f"scan {r.scan} of run {r.run!r} has {len(r.ranges)} ranges but "
                    f"scan {block[0].scan} has {nb}: expected the same number of "
                    "beams (angles) in every scan of a run"
                )
            if r.geometry != geom:
                raise ValueError(
                    f"scan {r.scan} of run {r.run!r} has another LaserGeometry than "
                    f"scan {block[0].scan}: expected one geometry per run"
                )
        if nb == 0:
            raise ValueError(f"run {block[0].run!r}: scans have no beams")
        if not (np.isfinite(geom.mount_height) and np.isfinite(geom.angle_increment)):
            raise ValueError(f"run {block[0].run!r}: geometry is not finite: {geom}")
        ranges = np.stack([np.asarray(r.ranges, dtype=np.float64) for r in block])
        return ranges, geom

    def _speed(self, block):
        if self.speed is not None:
            return float(self.speed)
        v = [r.payload["speed"] for r in block if "speed" in r.payload]
        v = np.asarray(v, dtype=np.float64)
        v = v[np.isfinite(v) & (v > 0)]
        return float(np.median(v)) if len(v) else DEFAULT_SPEED

    def _region(self, depth):
        return np.searchsorted(self.region_edges_, depth, side="right")

    def _objects(self, cpos, cdepth, ctop, npts, cobj, step, runs, scans, follows,
                 cflag):
        """Merge, split and label object-clusters; return the object table."""
        w = npts.astype(np.float64)
        n_pos = len(step)
        # nearest cluster of every scan (to tell occlusion from an empty gap)
        near = np.full(n_pos, np.inf)
        if len(cpos):
            np.minimum.at(near, cpos, cdepth)
        prof = _Profiles(cobj, cpos, cdepth, ctop, w)
        if prof.n:
            parent = self._merge(prof, near, step, follows)
            _, cobj = np.unique(parent[cobj], return_inverse=True)
            cobj = cobj.ravel()
            if self.split_merged:
                cobj = self._split(_Profiles(cobj, cpos, cdepth, ctop, w), cobj, near,
                                   step)
        prof = _Profiles(cobj, cpos, cdepth, ctop, w, cflag)
        n_obj = prof.n
        # order objects by (first scan, depth); ids from 1
        order = np.lexsort((prof.depth, prof.first))
        rank = np.empty(n_obj, dtype=np.int64)
        rank[order] = np.arange(n_obj)
        cobj = rank[cobj] if len(cobj) else cobj
        o_first, o_last = prof.first[order], prof.last[order]
        o_pts, o_depth, o_top = prof.pts[order], prof.depth[order], prof.top[order]
        cum = np.r_[0.0, np.cumsum(step)]
        length = cum[o_last + 1] - cum[o_first]
        region = self._region(o_depth)
        label = np.asarray(self.labels_, dtype=object)[region]
        vehicle_like = length <= self.max_length
        body = np.zeros(n_obj)
        # scans before / after every object where something at least
        # occlusion_margin nearer hides it (its true end may lie behind)
        hid_before = np.zeros(n_obj, dtype=np.int64)
        hid_after = np.zeros(n_obj, dtype=np.int64)
        if self.occluded_length is not None:
            for i in np.flatnonzero(vehicle_like):
                hid_before[i], hid_after[i] = _hidden_ends(
                    near, follows, o_first[i], o_last[i],
                    o_depth[i] - self.occlusion_margin)
        hid_len = (cum[o_first] - cum[o_first - hid_before]) + (
            cum[o_last + 1 + hid_after] - cum[o_last + 1])
        # an object cut short by an occluder may be a vehicle when its visible part
        # is at least min_visible long; otherwise it must be min_length long
        cut_short = (hid_len > 0) & (length >= _MIN_VISIBLE)
        vehicle_like &= (length >= self.min_length) | (
            cut_short & (length + hid_len >= self.min_length))
        # a vehicle is one continuous surface: its longest stretch of consecutive
        # scans seen (or hidden by something nearer) must be vehicle-long too, and so
        # must the scans where it is actually seen; rows of pedestrians, bins or
        # bollards bridged by short gaps are not
        for i in np.flatnonzero(vehicle_like):
            o = order[i]
            pos, _ = prof.scan_profile(o)
            hidden = near < prof.depth[o] - self.link_distance
            seen = hidden[pos[0]:pos[-1] + 1].copy()
            seen[pos - pos[0]] = True
            brk = np.flatnonzero(~seen)
            edges = np.r_[-1, brk, len(seen)] + pos[0]
            run_len = cum[edges[1:]] - cum[edges[:-1] + 1]
            seen_len = (cum[pos + 1] - cum[pos]).sum()
            if cut_short[i]:
                vehicle_like[i] = (seen_len >= _MIN_VISIBLE) & (
                    run_len.max() + hid_len[i] >= self.min_length)
            else:
                vehicle_like[i] = min(run_len.max(), seen_len) >= self.min_length
            # cross-section evidence of a vehicle body (roof, wall or raised body) in
            # enough of the scans where it is seen
            fl = prof.scan_flags(o)
            body[i] = np.mean((fl & _BODY) > 0)
        vehicle_like &= body >= self.min_body_fraction
        # extend vehicles cut short by an occluder to occluded_length behind it
        if self.occluded_length is not None:
            o_first, o_last = o_first.copy(), o_last.copy()
            # not objects cut by a run boundary: their unseen part may lie beyond it
            at_start = ~follows[o_first]
            at_end = ~np.r_[follows[1:], False][o_last]
            ext = np.flatnonzero(vehicle_like & (hid_len > 0) & ~at_start & ~at_end)
            for i in ext:
                self._extend(i, o_first, o_last, hid_before, hid_after, region,
                             vehicle_like, cum)
            length = cum[o_last + 1] - cum[o_first]
        label = np.where(vehicle_like, label, "other").astype(object)
        table = pd.DataFrame({
            "run": runs[o_first].astype(object),
            "id": np.arange(1, n_obj + 1, dtype=np.int64),
            "first_scan": scans[o_first].astype(np.int64),
            "last_scan": scans[o_last].astype(np.int64),
            "label": label,
            "mean_depth": o_depth,
            "region": (region + 1).astype(np.int64),
            "length": length,
            "top_height": o_top,
            "n_points": o_pts.astype(np.int64),
        }, columns=list(OBJECT_COLUMNS))
        return table, cobj, (o_first, o_last)

    def _extend(self, i, first, last, hid_before, hid_after, region, vehicle, cum):
        """Extend object ``i`` into the scans where an occluder hides its ends.

        The visible part of a vehicle cut by an occluder is shorter than the
        vehicle; its best length estimate is the larger of the visible length and
        ``occluded_length`` (a typical vehicle), never beyond the hidden scans nor into
        another vehicle of the same region.  Both hidden ends share the extension.
        """
        want = self.occluded_length - (cum[last[i] + 1] - cum[first[i]])
        if want <= 0:
            return
        same = np.flatnonzero(vehicle & (region == region[i]))
        same = same[same != i]
        lo = first[i] - hid_before[i]
        hi = last[i] + hid_after[i]
        prev = last[same][last[same] < first[i]]
        nxt = first[same][first[same] > last[i]]
        if len(prev):
            lo = max(lo, int(prev.max()) + 1)
        if len(nxt):
            hi = min(hi, int(nxt.min()) - 1)
        room_b = cum[first[i]] - cum[lo]
        room_a = cum[hi + 1] - cum[last[i] + 1]
        take_b = min(room_b, max(want / 2, want - room_a))
        take_a = min(room_a, want - take_b)
        if take_b > 0:
            first[i] = int(np.searchsorted(cum, cum[first[i]] - take_b, side="left"))
            first[i] = max(first[i], lo)
        if take_a > 0:
            last[i] = int(np.searchsorted(cum, cum[last[i] + 1] + take_a, side="left")) - 1
            last[i] = min(last[i], hi)

    def _merge(self, prof, near, step, follows):
        """Three-region merging: union-find parent of every object-cluster.

        Fragment ``b`` (later start) joins fragment ``a`` of the same stretch of scans
        and the same region when they overlap in time over at least half of the
        shorter one (the paper's rule), or when ``b`` starts after ``a`` ends and the
        gap between them is bridged: ``a``'s last and ``b``'s first mean depths differ
        by less than ``link_distance`` and the gap is at most ``merge_gap`` metres or
        hidden in every scan of the gap by something at least ``2 * link_distance``
        nearer (occlusion by a passing vehicle).
        """
        first, last, depth = prof.first, prof.last, prof.depth
        n_obj = prof.n
        region = self._region(depth)
        seg = np.cumsum(~follows) - 1  # contiguous stretches of scans
        cum = np.r_[0.0, np.cumsum(step)]
        parent = np.arange(n_obj)

        def find(i):
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i

        reach = self.max_length + self.merge_gap
        order = np.lexsort((first, region, seg[first]))
        for j in range(1, n_obj):
            b = order[j]
            for jj in range(j - 1, -1, -1):
                a = order[jj]
                if seg[first[a]] != seg[first[b]] or region[a] != region[b]:
                    break
                if cum[first[b]] - cum[first[a]] > reach:
                    break
                overlap = min(last[a], last[b]) - max(first[a], first[b]) + 1
                shorter = min(last[a] - first[a], last[b] - first[b]) + 1
                if overlap > 0:
                    join = overlap >= 0.5 * shorter
                else:
                    lo, hi = (a, b) if last[a] < first[b] else (b, a)
                    join = abs(prof.end_depth[lo] - prof.start_depth[hi]) < (
                        self.link_distance
                    )
                    if join:
                        gap = cum[first[hi]] - cum[last[lo] + 1]
                        ref = min(prof.end_depth[lo], prof.start_depth[hi])
                        hidden = near[last[lo] + 1:first[hi]] < ref - self.occlusion_margin
                        join = gap <= self.merge_gap or (
                            self.bridge_occluded and bool(np.all(hidden)))
                if join:
                    ra, rb = find(a), find(b)
                    if ra != rb:
                        parent[max(ra, rb)] = min(ra, rb)
        return np.array([find(i) for i in range(n_obj)], dtype=np.int64)

    def _split(self, prof, cobj, near, step):
        """Split objects with a two-hump height profile; returns new object ids.

        Scans of the object's span where it has no cluster count as height 0 (a gap
        between two vehicles), unless something nearer hid it (then unknown).
        """
        new = cobj.copy()
        next_id = prof.n
        cum = np.r_[0.0, np.cumsum(step)]
        for o in range(prof.n):
            first, last = prof.first[o], prof.last[o]
            span = last - first + 1
            if cum[last + 1] - cum[first] < 2 * self.min_length:
                continue
            ds = (cum[last + 1] - cum[first]) / span
            top = np.zeros(span)
            seen_pos, seen_top = prof.scan_profile(o)
            hidden = near[first:last + 1] < prof.depth[o] - self.link_distance
            top[hidden] = np.nan
            top[seen_pos - first] = seen_top
            cuts = split_profile(top, ds, min_length=self.min_length,
                                 ratio=self.split_ratio)
            if not cuts:
                continue
            mine = np.flatnonzero(cobj == o)
            part = np.searchsorted(np.asarray(cuts), prof.cpos[mine] - first,
                                   side="right")
            new[mine] = np.where(part == 0, o, next_id + part - 1)
            next_id += len(cuts)
        return new

    # ------------------------------------------------------------- outputs
    def transform(self, X):
        """Per scan, the record with its clusters and objects in the payload.

        Parameters
        ----------
        X : sequence of ScanRecord

        Returns
        -------
        records : ScanSequence
            In the order of ``X``; payload ``"points"`` (n, 2) ROI ``(depth, height)``,
            ``"beams"`` (n,) their beam numbers, ``"clusters"`` (n,) intra-cluster
            number of every point, ``"objects"``
            (n_clusters,) object id (as in :meth:`detect`) of every intra-cluster,
            ``"tilt"`` the tilt (rad) used.
        """
        res = self._run_all(X)
        records, _ = check_scans(X)
        pts = np.column_stack([res["x"], res["y"]])
        p_bounds = np.searchsorted(res["pos"], np.arange(len(records) + 1))
        out = [None] * len(records)
        for i, orig in enumerate(res["order"]):
            a, b = p_bounds[i], p_bounds[i + 1]
            c0, nc = res["cl_start"][i], res["n_cl"][i]
            out[orig] = records[orig].evolve(
                points=pts[a:b], beams=res["beams"][a:b], clusters=res["local"][a:b],
                objects=res["cobj"][c0:c0 + nc] + 1, tilt=float(res["tilt"][i]),
            )
        return ScanSequence(out)

    def detect(self, X, *, all_objects=False):
        """The object table: one row per detected object.

        Parameters
        ----------
        X : sequence of ScanRecord
        all_objects : bool, default=False
            Keep objects of every label (``"roadside"``, ``"other"``); by default only
            those labelled with a key of :data:`~tunnelsense.RUN_LABELS`.

        Returns
        -------
        objects : DataFrame
            Columns :data:`OBJECT_COLUMNS`: ``run, id, first_scan, last_scan, label,
            mean_depth`` (m), ``region`` (1-3), ``length`` (m along the track),
            ``top_height`` (m), ``n_points``.
        """
        table = self._run_all(X)["objects"]
        if not all_objects:
            table = table[table["label"].isin(list(RUN_LABELS))].reset_index(drop=True)
        return table

    def predict(self, X):
        """Per scan, the ``(k, 2)`` array ``(object id, label code)`` of objects in view.

        The same layout as the targets ``y`` (:meth:`tunnelsense.Run.targets`), so that
        :mod:`tunnelsense.metrics` compares the two; only labels of
        :data:`~tunnelsense.RUN_LABELS` are reported.

        Parameters
        ----------
        X : sequence of ScanRecord

        Returns
        -------
        y_pred : list of ndarray of shape (k_i, 2), int64
        """
        res = self._run_all(X)
        table = res["objects"]
        n = len(res["order"])
        codes = table["label"].map(RUN_LABELS)
        keep = codes.notna().to_numpy()
        ids = table["id"].to_numpy()[keep]
        codes = codes.to_numpy()[keep].astype(np.int64)
        fp = res["spans"][0][keep]
        lp = res["spans"][1][keep]
        counts = lp - fp + 1
        per_pos = [[] for _ in range(n)]
        total = int(counts.sum())
        if total:
            owner = np.repeat(np.arange(len(ids)), counts)
            p = np.repeat(fp, counts) + (np.arange(total) - np.repeat(
                np.cumsum(counts) - counts, counts))
            srt = np.argsort(p, kind="stable")
            p, owner = p[srt], owner[srt]
            bounds = np.searchsorted(p, np.arange(n + 1))
            pairs = np.column_stack([ids[owner], codes[owner]])
            per_pos = [pairs[bounds[i]:bounds[i + 1]] for i in range(n)]
        else:
            per_pos = [np.empty((0, 2), np.int64) for _ in range(n)]
        out = [None] * n
        for i, orig in enumerate(res["order"]):
            out[orig] = np.asarray(per_pos[i], dtype=np.int64).reshape(-1, 2)
        return out


class _Profiles:
    """Per object-cluster aggregates and per-(object, scan) profiles."""

    def __init__(self, cobj, cpos, cdepth, ctop, w, cflag=None):
        self.cpos = cpos
        self.p_flag = np.empty(0, dtype=np.int8)
        n = int(cobj.max()) + 1 if len(cobj) else 0
        self.n = n
        if n == 0:
            e = np.empty(0, dtype=np.int64)
            self.p_obj = self.p_pos = self.first = self.last = e
            self.rows = np.zeros(1, dtype=np.int64)
            self.p_top = self.start_depth = self.end_depth = np.empty(0)
            self.pts = self.depth = self.top = np.empty(0)
            return
        order = np.lexsort((cpos, cobj))
        so, sp = cobj[order], cpos[order]
        # one row per (object, scan)
        key_new = np.r_[True, (so[1:] != so[:-1]) | (sp[1:] != sp[:-1])]
        starts = np.flatnonzero(key_new)
        sw = w[order]
        pw = np.add.reduceat(sw, starts) if len(starts) else np.empty(0)
        pdepth = (np.add.reduceat(sw * cdepth[order], starts) / np.maximum(pw, 1)
                  if len(starts) else np.empty(0))
        ptop = np.maximum.reduceat(ctop[order], starts) if len(starts) else np.empty(0)
        pobj, ppos = so[starts], sp[starts]
        if cflag is not None and len(starts):
            self.p_flag = np.bitwise_or.reduceat(cflag[order], starts)
        self.p_obj, self.p_pos, self.p_top = pobj, ppos, ptop
        obj_new = np.r_[True, pobj[1:] != pobj[:-1]] if len(pobj) else np.empty(0, bool)
        ofirst_row = np.flatnonzero(obj_new)
        olast_row = np.r_[ofirst_row[1:], len(pobj)] - 1
        self.rows = np.r_[ofirst_row, len(pobj)]
        self.first = ppos[ofirst_row]
        self.last = ppos[olast_row]
        self.start_depth = pdepth[ofirst_row]
        self.end_depth = pdepth[olast_row]
        self.pts = np.bincount(cobj, weights=w, minlength=n)
        self.depth = np.bincount(cobj, weights=w * cdepth, minlength=n) / np.maximum(
            self.pts, 1
        )
        self.top = ptop[ofirst_row] if n else np.empty(0)
        if n:
            self.top = np.maximum.reduceat(ptop, ofirst_row)

    def scan_profile(self, o):
        a, b = self.rows[o], self.rows[o + 1]
        return self.p_pos[a:b], self.p_top[a:b]

    def scan_flags(self, o):
        return self.p_flag[self.rows[o]:self.rows[o + 1]]


def _hidden_ends(near, follows, first, last, depth):
    """Consecutive scans right before ``first`` and after ``last`` (within one
    stretch of consecutive scans) whose nearest cluster is nearer than ``depth``."""
    n = len(near)
    before = 0
    p = first - 1
    while p >= 0 and follows[p + 1] and near[p] < depth:
        before += 1
        p -= 1
    after = 0
    p = last + 1
    while p < n and follows[p] and near[p] < depth:
        after += 1
        p += 1
    return before, after


def _scan_period(stamps):
    d = np.diff(np.asarray(stamps, dtype=np.float64))
    d = d[np.isfinite(d) & (d > 0)]
    return float(np.median(d)) if len(d) else DEFAULT_SCAN_PERIOD


def make_parking_pipeline(**params):
    """The street-parked vehicle detector as a one-step :class:`~sklearn.pipeline.Pipeline`.

    Parameters
    ----------
    **params
        Parameters of :class:`ScanClusterer` (``cut=0.6``, ``link_distance=0.5``, ...).

    Returns
    -------
    pipeline : Pipeline
        ``Pipeline([("cluster", ScanClusterer(**params))])``; grid-search its
        parameters as ``cluster__cut`` etc.

    Examples
    --------
    >>> from tunnelsense.street import make_parking_pipeline
    >>> make_parking_pipeline(cut=0.5).named_steps["cluster"].cut
    0.5
    """
    return Pipeline([("cluster", ScanClusterer(**params))])
