"""The parameters of :class:`~tunnelsense.street.ScanClusterer`: their constraints
and defaults (documented on the estimator), and the class keywords they give.
"""

from __future__ import annotations

import numbers

from sklearn.base import BaseEstimator

from tunnelsense.utils._sklearn_compat import Interval, StrOptions

__all__ = []


class _ScanClustererParams(BaseEstimator):
    """The parameters of :class:`~tunnelsense.street.ScanClusterer` (see there)."""


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
        "speed": [Interval(numbers.Real, 0, None, closed="neither"),
                  StrOptions({"paper"}), None],
        "roof_width": [Interval(numbers.Real, 0, None, closed="left")],
        "min_clearance": [Interval(numbers.Real, None, None, closed="neither")],
        "min_body_fraction": [Interval(numbers.Real, 0, 1, closed="both")],
        "occlusion_margin": [Interval(numbers.Real, 0, None, closed="left")],
        "bridge_occluded": ["boolean"],
        "occluded_length": [Interval(numbers.Real, 0, None, closed="neither"), None],
        "max_pending_length": [Interval(numbers.Real, 0, None, closed="neither"), None],
        "region_depth": [StrOptions({"mean", "near", "span", "across"})],
        "min_car_length": [Interval(numbers.Real, 0, None, closed="left")],
        "min_raised_fraction": [Interval(numbers.Real, 0, 1, closed="both")],
        "min_roof_height": [Interval(numbers.Real, None, None, closed="neither")],
        "beam_occlusion": ["boolean"],
        "spray_beams": [Interval(numbers.Integral, 0, None, closed="left")],
        "separate_ground": ["boolean"],
        "object_ends": ["boolean"],
        "follow_kerb": ["boolean"],
        "kerb_depth": [Interval(numbers.Real, 0, None, closed="neither")],
        "min_across_length": [Interval(numbers.Real, 0, None, closed="left"), None],
        "min_across_raised": [Interval(numbers.Real, 0, 1, closed="both")],
        "min_across_top": [Interval(numbers.Real, None, None, closed="neither")],
        "van_height": [Interval(numbers.Real, None, None, closed="neither")],
        "van_length": [Interval(numbers.Real, 0, None, closed="neither")],
        "motorbike_width": [Interval(numbers.Real, 0, None, closed="left")],
        "carve_protrusions": ["boolean"],
        "seen_evidence": ["boolean"],
        "flat_by_ground": ["boolean"],
        "min_gap_length": [Interval(numbers.Real, 0, None, closed="left")],
        "min_gap_scans": [Interval(numbers.Integral, 1, None, closed="left")],
        "max_missing_length": [Interval(numbers.Real, 0, None, closed="left"), None],
        "end_on_faces": ["boolean"],
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
        max_pending_length=80.0,
        region_depth="across",
        min_car_length=2.4,
        min_raised_fraction=0.2,
        min_roof_height=0.5,
        beam_occlusion=True,
        spray_beams=2,
        separate_ground=True,
        object_ends=True,
        follow_kerb=True,
        kerb_depth=6.45,
        min_across_length=0.5,
        min_across_raised=0.3,
        min_across_top=1.05,
        van_height=1.8,
        van_length=7.0,
        motorbike_width=1.2,
        carve_protrusions=True,
        seen_evidence=False,
        flat_by_ground=True,
        min_gap_length=0.5,
        min_gap_scans=3,
        max_missing_length=1.5,
        end_on_faces=False,
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
        self.max_pending_length = max_pending_length
        self.region_depth = region_depth
        self.min_car_length = min_car_length
        self.min_raised_fraction = min_raised_fraction
        self.min_roof_height = min_roof_height
        self.beam_occlusion = beam_occlusion
        self.spray_beams = spray_beams
        self.separate_ground = separate_ground
        self.object_ends = object_ends
        self.follow_kerb = follow_kerb
        self.kerb_depth = kerb_depth
        self.min_across_length = min_across_length
        self.min_across_raised = min_across_raised
        self.min_across_top = min_across_top
        self.van_height = van_height
        self.van_length = van_length
        self.motorbike_width = motorbike_width
        self.carve_protrusions = carve_protrusions
        self.seen_evidence = seen_evidence
        self.flat_by_ground = flat_by_ground
        self.min_gap_length = min_gap_length
        self.min_gap_scans = min_gap_scans
        self.max_missing_length = max_missing_length
        self.end_on_faces = end_on_faces

    def _class_params(self):
        """The keywords of :func:`~tunnelsense.street.vehicle_class`."""
        return dict(van_height=self.van_height, van_length=self.van_length,
                    motorbike_width=self.motorbike_width,
                    min_car_length=self.min_car_length)
