"""Fitting a pipeline of record stages step by step, with progress and its training output.

:func:`fit_pipeline` does what :meth:`sklearn.pipeline.Pipeline.fit` does -- every
step but the last ``fit_transform`` on the output of the one before, the last step
``fit`` -- and also returns the last step's output on the training records, which a
training command needs for its scores (``Pipeline.fit`` followed by ``predict`` would
run every step a second time).  :func:`counted` and :func:`search_ticks` report
progress by named stage.
"""

from __future__ import annotations

__all__ = ["counted", "fit_pipeline", "search_ticks"]


def counted(items, stage, total, progress, *, every=16):
    """``items``, reporting ``progress(stage, done, total)`` every ``every`` items."""
    for k, item in enumerate(items, 1):
        if progress is not None and (k == total or k % every == 0):
            progress(stage, k, total)
        yield item


def search_ticks(progress, grid, n_folds, *also):
    """The ``progress(done, total)`` of a search, as ``progress(stage, done, total)``
    with the stage naming the grid (fits done: every fit, the refit included); each
    callable of ``also`` is called with ``(done, total)`` too.  None without any."""
    from sklearn.model_selection import ParameterGrid

    stage = f"grid search ({len(ParameterGrid(grid))} settings x {n_folds} folds), fits"
    calls = [c for c in also if c is not None]
    if progress is None and not calls:
        return None

    def ticks(done, total):
        if progress is not None:
            progress(stage, done, total)
        for call in calls:
            call(done, total)

    return ticks


def fit_pipeline(pipeline, X, y, *, progress=None):
    """Fit ``pipeline`` on ``(X, y)`` as ``Pipeline.fit`` does; give its training output.

    Parameters
    ----------
    pipeline : Pipeline
        Unfitted; fitted in place, as ``Pipeline.fit`` fits it.
    X : sequence of records
    y : sequence
        Per record targets.
    progress : callable or None, default=None
        Called as ``progress(step_name, k, n_steps)`` before each step is fitted.

    Returns
    -------
    pipeline : Pipeline
        The same object, fitted.
    output : sequence of records
        The last step's ``predict`` (or ``transform``) of the training records.

    Examples
    --------
    >>> from tunnelsense import make_indicator_pipeline, to_xy
    >>> from tunnelsense.datasets import make_tunnel_tour
    >>> from tunnelsense._fitting import fit_pipeline
    >>> tour = make_tunnel_tour(60, random_state=0, first_indicator_m=30.0)
    >>> X, y, _ = to_xy([tour])
    >>> model, out = fit_pipeline(make_indicator_pipeline(random_state=0), X, y)
    >>> len(out) == len(X) and "detections" in out[0].payload
    True
    """
    steps = [(name, step) for name, step in pipeline.steps
             if step is not None and step != "passthrough"]
    Xt = X
    for k, (name, step) in enumerate(steps[:-1]):
        if progress is not None:
            progress(name, k, len(steps))
        Xt = step.fit_transform(Xt, y)
    name, last = steps[-1]
    if progress is not None:
        progress(name, len(steps) - 1, len(steps))
    last.fit(Xt, y)
    out = last.predict(Xt) if hasattr(last, "predict") else last.transform(Xt)
    if progress is not None:
        progress(None, len(steps), len(steps))
    return pipeline, out
