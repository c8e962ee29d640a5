"""Training the indicator detector on whole tours, as ``train tunnel`` does.

:func:`fit_indicator_detector`: the frames decoded once in reader threads (or a
sample of them in time), then :func:`~tunnelsense.tunnel.make_indicator_pipeline`
fitted, or its thresholds grid-searched with ``GroupKFold`` over tours.
"""

from __future__ import annotations

import contextlib

from tunnelsense._records import FrameSequence
from tunnelsense.io._sources import decode_tours
from tunnelsense.tunnel._pipeline import make_indicator_pipeline
from tunnelsense.tunnel._search_grid import SEARCH_GRID

__all__ = ["SEARCH_GRID", "fit_indicator_detector"]


def fit_indicator_detector(tours, *, search=False, random_state=0, n_jobs=1,
                           dask_scheduler=None, progress=None, search_progress=None,
                           sample_rate=None, _decoding=None):
    """Fit the indicator detector on labelled tours, as ``train tunnel`` does.

    The frames are decoded once, in ``n_jobs`` reader threads; the fit equals
    ``make_indicator_pipeline(random_state=random_state).fit(X, y)`` on
    ``X, y = to_xy(tours)`` (sampled in time with ``sample_rate``).

    Parameters
    ----------
    tours : list of Tour
        Labelled tours.
    search : bool, default=False
        Grid-search :data:`SEARCH_GRID` with ``GroupKFold`` over the tours (at least
        2), then refit the best setting on all of them.  The steps the grid does not
        vary (keypoints, verifier, clusters) are fitted once per fold
        (:class:`~tunnelsense._search.PrefixGridSearch`; the same result as
        :class:`~sklearn.model_selection.GridSearchCV`).
    random_state : int, default=0
        Seed of the pipeline.
    n_jobs : int, default=1
        Reader threads and the search's parallel fits (k-means runs on one thread).
    dask_scheduler : str or None, default=None
        Run the search's fits on this Dask cluster (e.g. ``"tcp://10.0.0.5:8786"``;
        needs the ``distributed`` extra); the workers must see the tours' files.
    progress : callable or None, default=None
        ``progress(stage, done, total)`` as the work goes on, ``stage`` naming it:
        ``"decoding frames"``; then ``"fitting <step>"`` before each step of a plain
        fit (``done`` steps of ``total``), or the search's fits done and its refit.
    search_progress : callable or None, default=None
        ``search_progress(done, total)`` after each fit of a search.
    sample_rate : float or None, default=None
        Frames per second of each tour the fit sees (every ``k``-th frame,
        ``k = floor(frame rate / sample_rate)``, at least 1; the others are not
        decoded); None: every frame.  Only the keypoint band, the verifier and the
        appearance stage learn, and each from single frames (the trajectory stages
        learn nothing), so a sample in time fits them at a fraction of the decoding
        and fitting; it changes the fitted model, hence off by default.  The
        training scores are those of the sample, read as a recording at its rate.
        A search (``search=True``) fits and scores every frame (its scores follow
        whole trajectories).

    Returns
    -------
    model : Pipeline
        The fitted pipeline.
    summary : dict
        Tours, parameters, keypoint band and training scores (a model card).

    Examples
    --------
    >>> from tunnelsense.datasets import make_tunnel_tour
    >>> from tunnelsense.tunnel import fit_indicator_detector
    >>> tour = make_tunnel_tour(60, random_state=0, first_indicator_m=20.0)
    >>> model, summary = fit_indicator_detector([tour])
    >>> summary["tours"][0]["frames"]
    60
    """
    from tunnelsense._fitting import counted, fit_pipeline, search_ticks

    if search and len(tours) < 2:
        raise ValueError("search needs at least 2 tours (folds are whole tours)")
    if search and sample_rate is not None:
        raise ValueError("sample_rate: a search fits every frame; give one or the other")
    # _decoding (private): decode_tours(tours) started by the caller (the command,
    # before its imports), else started here
    if _decoding is None:
        _decoding = decode_tours(tours, n_threads=max(n_jobs, 1),
                                 sample_rate=sample_rate)
    frames, y, groups, n_frames = _decoding
    frames = counted(frames, "decoding frames", n_frames, progress)
    decoded = [first] if (first := next(frames, None)) is not None else []
    X = FrameSequence(decoded + list(frames))
    # k-means keeps its one BLAS thread: spinning BLAS or OpenMP threads make a fit
    # several times slower on a loaded machine, and the centres do not depend on it
    model = make_indicator_pipeline(random_state=random_state)
    found = None
    if search:
        # model selection and scoring (they import SciPy's stats) only for a search
        from sklearn.model_selection import GroupKFold

        from tunnelsense._search import PrefixGridSearch
        from tunnelsense.metrics import make_tunnel_scorer

        # keypoints, verifier and clusters (the k-means) are fitted once per fold
        found = PrefixGridSearch(
            model, SEARCH_GRID, cv=GroupKFold(n_splits=min(len(tours), 3)),
            scoring=make_tunnel_scorer("youden"), n_jobs=n_jobs,
            progress=search_ticks(progress, SEARCH_GRID, min(len(tours), 3),
                                  search_progress),
        )
        with _dask(dask_scheduler) if dask_scheduler else contextlib.nullcontext():
            found.fit(X, y, groups=groups)
        model = found.best_estimator_
        output = model.predict(X)
    else:
        model, output = fit_pipeline(model, X, y, progress=progress and (
            lambda name, k, n: progress(f"fitting {name}" if name else "fitted", k, n)))
    return model, _summary(tours, model, output, y, found, sample_rate)


def _dask(address):
    """joblib's Dask backend on a cluster (imported only when asked for: it is slow)."""
    try:
        import joblib
        from distributed import Client
    except ImportError:
        raise ValueError("dask_scheduler needs Dask's distributed scheduler: pip "
                         "install 'tunnelsense[distributed]'") from None
    stack = contextlib.ExitStack()
    stack.enter_context(Client(address))
    stack.enter_context(joblib.parallel_config(backend="dask"))
    return stack


def _summary(tours, model, output, y, search, sample_rate) -> dict:
    """Tours, parameters and scores stored in a model file (``tunnelsense info``)."""
    from tunnelsense.metrics import indicator_scores

    kp = model.named_steps["keypoints"]
    summary = {
        "detector": "tunnel indicator (make_indicator_pipeline)",
        "tours": [
            {"name": t.name, "frames": len(t),
             "indicators": int(t.gt.loc[t.gt["class"] == 1, "id"].nunique()),
             **{k: t.info[k] for k in ("scenario", "seed") if k in t.info}}
            for t in tours
        ],
        "parameters": {k: v for k, v in model.get_params(deep=True).items()
                       if "__" in k and not hasattr(v, "get_params")},
        # the band in use (learned from the training tours by default)
        "keypoint_band": [round(float(kp.low_), 2), round(float(kp.high_), 2)],
        # the frames fitted (and scored): every frame, or a sample in time
        "sample_rate": sample_rate,
        "frames_fitted": len(output),
        "training_scores": indicator_scores(output, y),
    }
    if search is not None:
        summary["search"] = {
            "grid": SEARCH_GRID, "best_parameters": search.best_params_,
            "best_score": float(search.best_score_),
            "scoring": "youden (GroupKFold over tours)",
        }
    return summary
