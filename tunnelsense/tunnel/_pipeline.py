"""The FIR indicator detector as one scikit-learn Pipeline of its six stages."""

from __future__ import annotations

from sklearn.pipeline import Pipeline

from tunnelsense.plotting._detections import DRAW_COLOURS, draw_detections  # noqa: F401 (moved)
from tunnelsense.tunnel._appearance import WeightedAdaBoost
from tunnelsense.tunnel._clustering import MSTClusterer
from tunnelsense.tunnel._keypoints import IntensityKeypointSampler
from tunnelsense.tunnel._motion import PCCVerifier
from tunnelsense.tunnel._tracking import TrajectoryLinker
from tunnelsense.tunnel._verification import KMeansHistogramVerifier

__all__ = [
    "INDICATOR_STEPS",
    "PAPER_SETTINGS",
    "PIPELINE_DEFAULTS",
    "make_indicator_pipeline",
]

#: Settings :func:`make_indicator_pipeline` uses where they differ from the steps'
#: own (paper) defaults; every one can be overridden (``box="keypoints"``,
#: ``max_gap=3`` give the paper's).  See ``docs/tunnel-detector.md``.
PIPELINE_DEFAULTS = {
    # the keypoint band by the paper's 3-sigma rule on the labelled indicators of the
    # training tours (robust estimate), not the paper's camera's outcome [160, 190]:
    # a camera with another gain puts its indicators elsewhere
    "keypoints__band": "learned",
    # a frame of another size (same aspect ratio: a 320x240 sensor with the
    # training camera's field of view) is resampled to the training frames' size
    # before the first stage, so every length in pixels of every stage keeps its
    # meaning; detections are mapped back.  Frames of the training size are
    # untouched.
    "keypoints__frame_size": "training",
    # keypoints on local contrast (a cell's grey level above its background
    # neighbourhood, relative to the training signs' contrast): a unit's gain and
    # offset and an automatic gain control scale or shift the background and the
    # sign together, so the band holds by construction; the band is widened to
    # 0.45-1.5 times the training contrast (a sign in warmer air or behind another
    # gain), the verifier trains on copies of each frame at a factor f of 0.45-1.0
    # times its contrast and at 1 / f (1.0-2.2 times: a sign in colder air), so
    # that it is indifferent to the sign's contrast both ways, and a cluster's rectangle is the region above half its brightest
    # keypoint's contrast.  The grey-level band (the earlier default) is
    # keypoints__radiometry="raw", verifier__augment_contrast=None,
    # clusters__box="region"; canonical radiometry (each frame mapped to the
    # training frames' background level and spread) is keypoints__radiometry="frame",
    # whose frame gain is corrected by what exceeds 8 % (log units), about two
    # thirds of one camera's median frame-to-frame variation (chosen on the tuning
    # tours)
    "keypoints__radiometry": "contrast",
    "keypoints__min_contrast": 0.45,
    "keypoints__max_contrast": 1.5,
    "keypoints__gain_tolerance": 0.08,
    "verifier__augment_contrast": (0.45, 1.0),
    "verifier__augment_draw": "reciprocal",
    "clusters__box": "contrast",
    # a 14-20 px indicator is about one grid step wide: the grid can miss it for a
    # few frames (0.2 s at 30 fps) as it moves; bridge such gaps
    "tracks__max_gap": 6,
    # the appearance machine learns its negatives from the clusters the verifier
    # lets through; with the context histogram a one-tour training set left too
    # few (369 negative clusters against 3,851, fixed band) and false alarms rose
    # above 1 %, so the detector verifies keypoints by the 7 x 3 patch histogram alone
    "verifier__context_size": None,
    "verifier__max_distance": 0.32,
    # appearance that a change of camera does not move: the stumps decide on the
    # median-filtered patch normalized by its own percentiles and on shape and
    # contrast figures, not on one camera's raw histogram bins, and training sees
    # every cluster also as two other cameras would (gain, offset, noise, blur,
    # scale within the range of plausible FIR cameras)
    "appearance__features": "invariant",
    "appearance__augment": 2,
    # a sign beside a lamp's halo: the cluster's rectangle spans part of the halo
    # (a smooth gradient) and looks like neither a sign nor a lamp; the bright core
    # above 0.7 of the cluster's contrast over its rim, where it scores better,
    # is the sign, and becomes the cluster's box
    "appearance__core": (0.7,),
    # an indicator's image path bends in a curving tunnel: a quadratic path's
    # multiple correlation instead of the straight line's Pearson r; or, when
    # larger, that of its motion in time (both coordinates quadratic in time): a
    # short, nearly horizontal stretch of a far sign's path (a trajectory cut by
    # the end of the stream, a camera mounted near the signs' height) is swamped
    # by the body pitch's pixel of vertical jitter as a path y(x), not as a motion
    "motion__criterion": "quadratic-motion",
    # an indicator approaches: its trajectory travels at least a quarter of its own
    # height (a sign on the wall: about half over ten frames at 60 km/h, several
    # over its path); the far end of a curving row of lamps keeps its place in the
    # image and its rectangle's jitter can line up into a "path" (a tenth of its
    # height)
    "motion__min_travel": 0.25,
    # what a trajectory must show is an approach, not a count of frames: one
    # shorter than min_length (7 points at least) counts when the camera covered
    # 0.3 of its range to the object (its box grew by a factor 1 / 0.7), a ratio
    # of heights whatever the speed, lens, resolution or sign size; a near sign
    # seen from a fast car gives fewer frames than min_length
    "motion__min_approach": 0.3,
    # an approached object moves away from the focus of expansion, along a line
    # through it; a mark burned into the picture (a camera's grey-scale bar at the
    # edge) slides along itself as its thresholded rectangle changes: the line of a
    # trajectory's centres must pass within 0.8 of the half frame of the
    # frame's centre (a focus up to atan(0.4 W / f) off the axis across, atan(0.4 H /
    # f) up or down: 20.1 and 15.3 degrees with a 700 px lens at 640 x 480, 9.7 and
    # 7.3 with 1500 px); signs on every simulated condition passed within 0.25, a
    # grey-scale bar at the right edge lies at 0.97
    "motion__max_focus_offset": 0.8,
    # an approached object grows and moves away from the focus of expansion; the
    # warm parts of a vehicle pulling away shrink toward it, along a line through
    # it: a trajectory heading for the frame's centre from farther than 0.3 of
    # the half frame is no indicator (a focus up to atan(0.3 W / (2 f)) off the
    # axis across, atan(0.3 H / (2 f)) up or down: 7.8 and 5.9 degrees with a
    # 700 px lens at 640 x 480); nearer the centre a far sign's path may point
    # anywhere, and nothing is refused
    "motion__max_inward_offset": 0.3,
}

#: The paper's detector (Wang et al. 2013, sections 3.1-3.7), for
#: ``make_indicator_pipeline(preset="paper")``: fixed keypoint band [160, 190],
#: keypoint rectangles, the bare rectangle's raw 32-bin histogram, trajectories
#: bridging 3 frames, a straight-line Pearson r, and the verifier's paper settings.
PAPER_SETTINGS = {
    "keypoints__band": "fixed",
    "keypoints__radiometry": "raw",
    "keypoints__frame_size": "native",
    "keypoints__gain_tolerance": "learned",
    "verifier__context_size": None,
    "verifier__max_distance": 0.14,
    "verifier__margin": None,
    "verifier__n_centers": 10,
    "clusters__box": "keypoints",
    "appearance__margin": 0.0,
    "appearance__features": "histogram",
    "appearance__augment": 0,
    "appearance__core": None,
    "tracks__max_gap": 3,
    "motion__criterion": "pearson",
    "motion__min_travel": 0.0,
    "motion__min_approach": None,
}

#: Step names of :func:`make_indicator_pipeline`, in order.
INDICATOR_STEPS = ("keypoints", "verifier", "clusters", "appearance", "tracks", "motion")


def make_indicator_pipeline(*, verifier=True, preset="default", **params):
    """The six FIR stages (sections 3.1-3.7) as a :class:`~sklearn.pipeline.Pipeline`.

    The steps keep their own (the paper's) defaults except for
    :data:`PIPELINE_DEFAULTS`: the keypoint band learned from the training tours by
    the paper's 3-sigma rule (``keypoints__band="learned"``; the fixed [160, 190] is
    that rule's outcome on the paper's camera), cluster rectangles refined to the
    in-band region
    around the keypoints (``clusters__box="region"``), trajectories bridging gaps
    of up to 6 frames (``tracks__max_gap=6``), and keypoints verified by the 7 x 3
    patch histogram alone (``verifier__context_size=None``,
    ``verifier__max_distance=0.32``): the appearance machine learns its negatives
    from the clusters the verifier lets through, and the context histogram leaves
    too few of them in a one-tour training set (``docs/tunnel-detector.md``);
    camera-invariant appearance features with training-time augmentation
    (``appearance__features="invariant"``, ``appearance__augment=2``), a
    cluster's bright core scored as well where a lamp's halo stretches its
    rectangle (``appearance__core=(0.7,)``), the
    quadratic path criterion of the motion check, or the motion's fit in time where
    larger (``motion__criterion="quadratic-motion"``)
    and a trajectory that travels at least a quarter of its own height
    (``motion__min_travel=0.25``), a shorter trajectory (7 points or more)
    accepted when the camera covered 0.3 of its range to it
    (``motion__min_approach=0.3``, a near sign seen from a fast car), the line of a
    trajectory's centres passing within 0.8 of the half frame of the frame's centre
    (``motion__max_focus_offset=0.8``: a mark burned into the picture is no path),
    a trajectory heading for the frame's centre from farther than 0.3 of the half
    frame refused (``motion__max_inward_offset=0.3``: a vehicle pulling away),
    which keep the detector working on another camera and in a curving tunnel
    (``docs/validation.md``); frames of another size with the training frames'
    aspect ratio resampled to the training size (``keypoints__frame_size="training"``;
    detections are mapped back, another aspect ratio is refused); keypoints on
    local contrast rather than grey level (``keypoints__radiometry="contrast"``,
    band 0.45-1.5 times the training contrast, ``keypoints__min_contrast=0.45``,
    ``keypoints__max_contrast=1.5``), the verifier trained also on copies with a
    factor ``f`` of 0.45-1.0 times the contrast and with ``1 / f``
    (``verifier__augment_contrast=(0.45, 1.0)``,
    ``verifier__augment_draw="reciprocal"``) and cluster rectangles at
    half the brightest keypoint's contrast (``clusters__box="contrast"``), so that
    a unit's gain and offset or an automatic gain control does not move the band.
    The grey-level band is ``keypoints__radiometry="raw",
    verifier__augment_contrast=None, clusters__box="region"``; canonical
    radiometry is ``keypoints__radiometry="frame"``.

    Steps: ``keypoints`` (:class:`IntensityKeypointSampler`), ``verifier``
    (:class:`KMeansHistogramVerifier`), ``clusters`` (:class:`MSTClusterer`),
    ``appearance`` (:class:`WeightedAdaBoost`), ``tracks`` (:class:`TrajectoryLinker`),
    ``motion`` (:class:`PCCVerifier`).  ``fit(X, y)`` takes frame records and, per
    frame, the ``(k, 4)`` indicator boxes (:func:`tunnelsense.to_xy`); ``predict(X)``
    returns the frames with ``payload["detections"]`` (see :class:`PCCVerifier`).

    Parameters
    ----------
    verifier : bool, default=True
        ``False`` replaces the keypoint verifier by ``"passthrough"`` (every sampled
        keypoint is clustered), for ablation.
    preset : {"default", "paper"}, default="default"
        ``"default"``: :data:`PIPELINE_DEFAULTS`.  ``"paper"``: the paper's plain
        detector, :data:`PAPER_SETTINGS`, for comparison.  ``**params`` override
        either.
    **params
        Parameters of the steps, either as ``step__name`` (``motion__min_r=0.9``) or,
        when a name belongs to exactly one step, plainly (``min_r=0.9``, ``cut=30``,
        ``max_distance=0.2``, ``positive_weight=1``).  ``random_state`` goes to every
        step that has one.

    Returns
    -------
    pipeline : Pipeline

    Examples
    --------
    >>> from tunnelsense.tunnel import make_indicator_pipeline
    >>> pipe = make_indicator_pipeline(min_r=0.9, cut=30, random_state=0)
    >>> [name for name, _ in pipe.steps]
    ['keypoints', 'verifier', 'clusters', 'appearance', 'tracks', 'motion']
    >>> pipe.get_params()["motion__min_r"], pipe.get_params()["clusters__cut"]
    (0.9, 30)
    """
    steps = [
        ("keypoints", IntensityKeypointSampler()),
        ("verifier", KMeansHistogramVerifier() if verifier else "passthrough"),
        ("clusters", MSTClusterer()),
        ("appearance", WeightedAdaBoost()),
        ("tracks", TrajectoryLinker()),
        ("motion", PCCVerifier()),
    ]
    if preset not in ("default", "paper"):
        raise ValueError(f"preset must be 'default' or 'paper'; got {preset!r}")
    settings = PIPELINE_DEFAULTS if preset == "default" else PAPER_SETTINGS
    pipe = Pipeline(steps).set_params(**{
        k: v for k, v in settings.items()
        if verifier or not k.startswith("verifier__")
    })
    owners: dict = {}
    for name, step in steps:
        if step == "passthrough":
            continue
        for p in step.get_params(deep=False):
            owners.setdefault(p, []).append(name)
    resolved = {}
    for key, value in params.items():
        if "__" in key:
            resolved[key] = value
        elif key == "random_state":
            for name in owners.get("random_state", []):
                resolved[f"{name}__random_state"] = value
        elif key in owners:
            if len(owners[key]) > 1:
                raise TypeError(
                    f"parameter {key!r} belongs to several steps ({owners[key]}); "
                    f"write it as step__{key}"
                )
            resolved[f"{owners[key][0]}__{key}"] = value
        else:
            raise TypeError(
                f"make_indicator_pipeline got an unknown parameter {key!r}; the steps' "
                f"parameters are {sorted(owners)}"
            )
    return pipe.set_params(**resolved)
