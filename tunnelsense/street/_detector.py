"""The street-parked vehicle detector as a scikit-learn estimator on scan records.

:class:`ScanClusterer` runs the whole of the paper's Fig. 6 on a sequence of scans:
restoration, tilt compensation, region of interest, intra-scan single linkage,
inter-scan linking, three-region merging and labelling; plus, beyond the paper, the
splitting of nose-to-tail vehicles merged into one object and the rejection of objects
too short to be a vehicle (pedestrians, bins, bollards).

The parameters' constraints and defaults are in ``_detector_params``, what the
estimator returns (its online state, records and object table) in
``_detector_outputs``.
"""

from __future__ import annotations

import numpy as np

from tunnelsense._records import check_scans
from tunnelsense.street._detector_outputs import OBJECT_COLUMNS, _ScanClustererOutputs
from tunnelsense.street._detector_params import _ScanClustererParams
from tunnelsense.utils._sklearn_compat import _fit_context

__all__ = ["OBJECT_COLUMNS", "ScanClusterer"]


class ScanClusterer(_ScanClustererOutputs, _ScanClustererParams):
    """Detect street-parked and passing vehicles in vertical laser scans.

    The paper's pipeline (Fig. 6), run by :meth:`transform`, :meth:`predict` and
    :meth:`detect` over scans of one or several runs (sorted by ``(run, scan)``;
    objects never cross a run boundary or a stretch of missing scans longer than
    ``max_missing_length``):

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
       (``split_merged``); objects too short or long, or whose cross-sections show
       no vehicle body (see the parameters below) are labelled ``"other"``;
       vehicles cut short by a nearer occluder are extended (``occluded_length``).

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
        Split objects whose height profile shows two vehicles nose to tail; with
        ``region_depth="across"``, also objects whose near side shows vehicles in
        echelon (bays at an angle to the kerb, neighbours overlapping along the
        street): the near side (nearest body depth of every scan) has a ridge
        between two valleys, rising from each by at least half the object's median
        body depth extent across the street (a car's step, measured on the object);
        each part is at least ``min_car_length`` long, and only objects whose median
        body extent is at least ``roof_width`` are split.  The ridge is a corner (a
        flank falls away from it): one whose near side stays within a quarter of
        that step of it for half the step or more along the street is a face (a
        hedge or wall seen between two vehicles in front of it), never split at.
    split_ratio : float, default=0.6
        Largest valley-to-peak height ratio that splits (see :func:`~tunnelsense.street.split_profile`).
    min_length : float, default=1.5
        Shortest vehicle (m along the track); shorter objects are ``"other"``
        (pedestrians, bins, bollards); also the shortest part a split leaves.
    max_length : float, default=25.0
        Longest vehicle (m); longer objects (hedges, walls) are ``"other"``.
    merge_gap : float, default=0.5
        Largest gap (m along the track) across which fragments are merged.
    speed : float, "paper" or None, default=None
        Ego speed (m/s) turning scan counts into lengths.  None: every scan's own
        payload ``"speed"`` (as :func:`~tunnelsense.io.read_run` and a ROS bag's
        odometry give it; 0 while the car stands), a median over the scan and the
        4 before it against noise; a run whose scans carry none is refused
        (``ValueError`` naming ``speed``) rather than measured at a guessed speed.
        ``"paper"``: the paper's 40 km/h for every scan, whatever the scans carry.
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
        hidden scans (one classed ``"motorbike"`` to at most ``min_car_length``:
        it is shorter than any car; so is one that ``region_depth="across"`` puts
        in region II by its far side while it is shorter along the street than
        ``min_car_length``: a car seen end on shows its width along the street, not
        its length); None: no extension.
    max_pending_length : float or None, default=80.0
        Longest object-cluster (m along the track, from its first scan) the detector
        waits for.  One not yet final that reaches beyond it at a check (every 64th
        scan of a run) - a kerb, hedge or facade the three-region merge keeps
        joining - is closed up to that scan, split and labelled as usual, and its
        continuation starts a new object-cluster.  In a region labelled as vehicles
        the limit is at least ``max_length`` (it cannot be one vehicle).  This bounds
        the memory of the online detector; batch runs the same checks, so both agree.
        None: wait for every object-cluster to end (memory then follows the longest
        one).  See ``docs/street.md`` for how the default was chosen.
    region_depth : {"across", "near", "span", "mean"}, default="across"
        Depth deciding an object's region: ``"mean"`` its mean depth (the paper);
        ``"near"`` the same, but an object averaging beyond region II whose near side
        (median nearest depth of its intra-clusters above 0.3 m) is in it belongs to
        region II: a car half on the sidewalk, near side 6.2-6.6 m.
        ``"across"`` (beyond the paper; the default) does what ``"near"`` does and
        also: an object averaging in region I whose
        far side (median farthest depth of its intra-clusters above 0.3 m) lies in
        region II belongs to region II when its body stands across the street or
        obliquely to it, as traffic never does: its near side moves
        across the street by at least ``motorbike_width`` over at most
        ``van_length`` (a car in a bay at 45 degrees, cut obliquely; longer, it is
        several cars joined), or it is shorter along the street than
        ``min_car_length`` and its cross-sections are at least ``roof_width`` deep
        (a car in a bay at right angles, seen end on: its near end in the traffic
        lane, its body reaching into the parking lane); with ``end_on_faces``
        also a tall face seen end on (see there).  With ``split_merged`` it
        also cuts apart neighbours in bays at an angle joined into one object (see
        ``split_merged``).  It assumes that traffic drives along the street: a
        vehicle driving past keeps its near side and is as long as a car, so the
        traffic of a street narrower than the regions assume, reaching into region
        II, stays passing.  It is the default because a street may have bays at an
        angle to the kerb whatever the regions say, and an object standing along
        the street is labelled by it as by ``"near"``.  Its known cost: in a row of bays at right angles
        with motorbikes beside the cars, a car seen only over a passing car's roof
        can join a motorbike beside it across the hidden scans into one object that
        counts as a parked vehicle where ``"near"`` counts none.  ``"span"``: any
        object averaging in region I whose far side lies in region II belongs to
        region II (also traffic reaching into it).  Models saved with another value
        keep it.
    min_car_length : float, default=2.4
        Shortest car (m, city cars 2.5 m); shorter, a vehicle must be a motorbike.
    min_raised_fraction : float, default=0.2
        Smallest fraction of a short object's scans showing a body raised between
        wheels, or hanging in the air (its lowest point at least ``min_clearance``
        high, the beam below it passing farther): a motorbike; communal bins,
        wheelie bins and people stand on the ground.
    min_roof_height : float, default=0.5
        Lowest top (m) of a roof (a kerb and sidewalk are flat, wide and low).
    beam_occlusion : bool, default=True
        Occlusion from the geometry of each beam (beyond the paper): a cluster whose
        lower part something nearer hides (the beam just below it ends on the
        occluder) shows only what the beams passing over the occluder reach, so its
        mean depth says little; it links with the cluster of the neighbouring scan
        whose depth extent holds it (see ``docs/street.md``).
        A parked vehicle seen past a passing one keeps that evidence instead of
        becoming a separate piece.  False: the paper's link by mean depth only.
    spray_beams : int, default=2
        Echoes from raindrops and spray (beyond the paper): a run of at most this
        many consecutive beams whose beams just below and above both pass farther
        (to the surface behind it, or nowhere within range) is dropped before
        clustering; it builds no object and hides nothing.  0: keep every return.
    separate_ground : bool, default=True
        A cluster lying wholly below the kerb-and-sidewalk height (0.3 m: a
        kerb, the footway, a surface near road level) never links with one of the
        next scan that rises above it (beyond the paper): the footway under a
        motorbike parked across the kerb does not carry it into the footway object,
        or the hedge or wall behind.  False: the paper's link by mean depth.
        (A fragment already final still bars a bridge across it, as it did while
        pending, so that online and batch detection agree.)
    object_ends : bool, default=True
        An object's ends (beyond the paper): past the end of a narrow object - a
        motorbike parked across the kerb - a scan sees its widest part alone, its
        screen and handlebars, whose mean depth says little.  A cluster narrower
        than one of the neighbouring scan, lying within its depth extent and
        reaching its top (within two beam spacings at that depth) links with it.
        When such an end touches something behind (a hedge, a wall) and single
        linkage joins it to that, the scans past a short parked object whose
        points reach the object's top where the scan before saw it (at most
        ``merge_gap`` on each side) still count to its length and interval.
        False: the ends link by mean depth only.
    follow_kerb : bool, default=True
        Regions that follow the kerb (beyond the paper): ``regions`` are given for
        a street whose kerb stands ``kerb_depth`` from the sensor; every scan that
        shows the kerb step (the road's last return, at most three returns of the
        kerb's face, then the footway lying flat 5-35 cm above the road) gives the
        kerb's depth, and the region edges at an object's first scan move with the
        median of the last 151 such depths (once five are known; before that, and
        False: ``regions`` as given).  A narrower or wider street, or the
        measurement vehicle in another lane, keeps the parking lane in region II.
    kerb_depth : float, default=6.45
        Depth (m) of the kerb that ``regions`` are given for (the paper's street).
    min_across_length : float or None, default=0.5
        Shortest motorbike parked at right angles to the kerb (m along the street;
        handlebars 0.7-0.85 m).  An object of the region labelled ``"parked"``
        shorter than ``min_length`` but not than this, seen whole, is such a
        motorbike when a body raised between wheels
        (its wheels at both ends of its depth, the road between them) shows in at
        least ``min_across_raised`` of its scans; wheelie bins, posts and people
        stand on the ground.  None: objects shorter than ``min_length`` are never
        vehicles.
    min_across_raised : float, default=0.3
        See ``min_across_length``.
    min_across_top : float, default=1.05
        Lowest top (m) of a motorbike across the kerb (handlebars and screen,
        1.05-1.4 m); the bonnet or boot of a car, broken off its body by a
        pedestrian or a post in front, stays lower.
    van_height : float, default=1.8
        Vehicle classes (the ``vehicle_class`` column, see
        :func:`~tunnelsense.street.vehicle_class` and ``docs/street.md``): the lowest
        height (m) of a van's body over most of its length (a car's roof covers less
        than half of it); a vehicle whose near face continues above ``max_height``
        is a van too.
    van_length : float, default=7.0
        Longest car (m); a longer vehicle is a ``"van"`` (lorries, trailers).
    motorbike_width : float, default=1.2
        Narrowest car (m; city cars are 1.5 m wide): a vehicle without a roof-wide top
        surface that is narrower than this one way (along the street or across it),
        or shorter than ``min_car_length`` (unless at least this long and at least
        ``min_car_length`` deep across the street: a car seen end on), is a
        ``"motorbike"``.
    carve_protrusions : bool, default=True
        A motorbike against a taller structure (beyond the paper): one whose far
        end touches a hedge or wall shares its intra-cluster with it in every scan.
        In an object that is not a parked vehicle, a run of scans shorter than
        ``min_car_length`` whose near side comes more than ``link_distance`` nearer
        than the object's face (its median near side), the face seen again on both
        sides, is carved out: its points nearer than the face (less two beam
        spacings) are a motorbike of the region labelled ``"parked"`` when at least
        ``min_across_length`` long, reaching ``min_across_top`` and raised between
        its wheels (the beam below its lowest point passing farther) in at least
        ``min_across_raised`` of its scans.  It is reported in :meth:`detect` and
        :meth:`predict`; its points stay with the structure's intra-clusters in
        :meth:`transform`'s ``"objects"``.  Walls, fences and facades just behind
        the kerb: an object longer than ``van_length`` whose face (the upper
        quartile of its near sides: a wall lies behind the vehicles in front of
        it) shows a roof, a raised body or a body hanging in the air in less than
        ``min_raised_fraction`` of its length, outside the runs of scans more than
        ``link_distance`` nearer than it, is a flat vertical face, no vehicle;
        every such run (up to ``max_length``, also at the object's ends) is carved
        out and is a vehicle of the region labelled ``"parked"`` when at least
        ``min_length`` long, with a body in ``min_body_fraction`` and a roof or a
        raised body in ``min_raised_fraction`` of its length.  False: structures
        keep them.
    seen_evidence : bool, default=False
        Evidence where it can be seen (beyond the paper): an object seen shorter
        than ``min_car_length`` (only a motorbike can be) takes the shares of its
        length showing a body (``min_body_fraction``; a body hanging in the air
        counts), a body raised or hanging (``min_raised_fraction``) or a beam
        passing under it (``min_across_raised``) over the length where its lower
        part is not hidden by something nearer (the beam just below it ends on the
        occluder), when at least two scans show that evidence.  A scan seeing a
        parked motorbike's upper half over a passing car's roof cannot show the
        body between its wheels; it says nothing either way.  False (the default):
        shares of all its length.  Not the default: it finds more of the
        motorbikes parked behind passing traffic, but at twice the scan rate, at
        20 km/h and with the kerb at 7.3 m it also lets a short false object
        through.
    flat_by_ground : bool, default=True
        Walls judged where their face meets the ground (beyond the paper): the
        face of an object longer than ``van_length`` whose depth lies outside the
        region labelled ``"passing"`` (behind the parking lane) is flat unless, over
        ``min_raised_fraction`` of the face's length, it shows the space under a
        body: its lowest point in a scan stands above ``min_clearance`` with the
        beam just below it passing farther or leaving no point in the region of
        interest (a body raised between wheels), or, over ``min_gap_length``
        metres and ``min_gap_scans`` consecutive scans, the beam just below its
        lowest point returns more than two beam spacings farther *and* lower (it
        passed under the body to the ground: a car whose body comes down to
        0.15 m, so long as its clearance exceeds those two beam spacings at the
        face's depth, about 0.11 m at 0.5 deg and 6.5 m, 0.23 m at 1 deg).  A
        face standing on the ground (a wall, a hedge on the footway) ends the next
        beam down on itself or on the ground in front of it; beams into a hedge's
        foliage end farther but not lower, and through its gaps in a scan or two.
        A roof-wide top (a thick hedge's) says nothing either way.  False: a roof,
        a raised body at any point or a body hanging in the air count
        (``carve_protrusions``), and a hedge right behind the kerb with the cars in
        front of it is taken for a van.  A face with a gap at the bottom (a
        fence on posts, a railing, a hedge bare at its foot) shows that space and
        is not set aside.
    min_gap_length : float, default=0.5
        Shortest stretch (m along the street) of consecutive scans whose beams
        pass under a face to the ground that counts as the space under a body
        (``flat_by_ground``): the space between a car's wheels is over 2 m long.
    min_gap_scans : int, default=3
        Fewest consecutive scans in such a stretch, whatever their spacing: a beam
        through a gap in foliage lasts a scan or two, which at a low scan rate or a
        high speed may span ``min_gap_length`` (at 25 Hz and 40 km/h a scan covers
        0.44 m).
    max_missing_length : float or None, default=1.5
        Longest stretch (m along the street) of missing scans - scans a recorder or
        a network link lost, seen as a jump in the scan numbers or a stamp gap of
        2.5 scan periods or more (less is stamp jitter) - across which the
        objects of the scans on either side are linked as if the scans followed
        each other (beyond the paper).  A missing stretch is no evidence, not an
        empty street: its length is the time it lasted times the mean of the
        speeds reported by the scans on both sides of it (0 m while the car
        stands on both sides, whatever the number of scans; a start from a
        standstill during it, at a steady acceleration, exactly; a running
        median of the recent speeds would lag such a start); with ``speed``
        given, that speed.  Its metres count to the length of an object seen on
        both sides (linked across it), not to one that ends right before it or
        starts right after it.  The default is ``min_length``'s 1.5 m, the shortest
        vehicle: a longer stretch could hold a whole motorbike or the whole gap
        between two vehicles, so objects end there (the parts on either side are
        not cut by the data: each is tested on what was seen of it).  Two vehicles
        whose gap lies wholly inside a shorter stretch are linked into one object
        (the height-profile split may still cut it).  None: objects end at every
        missing scan.
    end_on_faces : bool, default=False
        With ``region_depth="across"``, an object in region I whose face stands
        taller than the region of interest along at least half its length, at
        least ``motorbike_width`` but less than ``min_car_length`` long along the
        street and not cut by the run's first or last scan, belongs to region II
        (beyond the paper): a van in a bay at right angles to the kerb seen end on
        shows its face only, taller than the sensor, its body out of sight behind
        it.  Traffic drives along the street and is seen at least as long as it is,
        unless it overtakes the probe car at more than twice its speed: off by
        default because a probe car crawling in traffic (8 km/h) is overtaken so,
        and a van driving past then looks like one seen end on.

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
    >>> det = ScanClusterer(speed=11.1)   # the ego speed (m/s): the scans carry none
    >>> det.fit(X).detect(X)[["id", "first_scan", "last_scan", "label"]]
       id  first_scan  last_scan   label
    0   1          10         39  parked
    """

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
