"""Writing a simulated tour or laser run to a folder: ``tunnelsense simulate``."""

from __future__ import annotations

from pathlib import Path

__all__ = ["simulate_to_folder"]


def simulate_to_folder(kind, outdir, n, *, scenario=None, random_state=0, overwrite=False,
                       progress=None) -> str:
    """Simulate a labelled tunnel tour or laser street run and write it to a folder.

    Parameters
    ----------
    kind : {"tunnel", "street"}
        A far-infrared tour (MOTChallenge folder, :func:`make_tunnel_tour`) or a
        laser run (``scans.npz`` + ``gt.csv``, :func:`make_street_scans`).
    outdir : str or Path
        The folder to write; it must be new or empty unless ``overwrite``.
    n : int
        Frames of a tour, scans of a run.
    scenario : str, default=None
        The simulator's scenario (default: its first).
    random_state : int, default=0
    overwrite : bool, default=False
        Write into a folder that exists and holds files.
    progress : callable, default=None
        ``progress(total, desc)`` returns a progress bar (or None) for a tour's
        rendering and writing.

    Returns
    -------
    what : str
        What was written: size, scenario, seed and the labelled objects.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "run"
    >>> simulate_to_folder("street", out, 300, random_state=1)  # doctest: +ELLIPSIS
    '300 scans, scenario sparse, seed 1, ... parked and ... passing vehicles'
    >>> sorted(p.name for p in out.iterdir())
    ['gt.csv', 'scans.npz']
    """
    from tunnelsense.datasets import (
        STREET_SCENARIOS,
        TUNNEL_SCENARIOS,
        make_street_scans,
        make_tunnel_tour,
    )
    from tunnelsense.io import write_run, write_tour

    out, bar = Path(outdir), progress or (lambda total, desc: None)
    if out.exists() and (not out.is_dir() or any(out.iterdir())) and not overwrite:
        raise FileExistsError(f"{out}: exists and is not an empty folder; refusing to "
                              "write over it (pass --force to replace its files)")
    if kind == "tunnel":
        scenario = scenario or TUNNEL_SCENARIOS[0]
        tour = make_tunnel_tour(n, scenario=scenario, name=out.name,
                                random_state=random_state,
                                progress=bar(n, "rendering frames"))
        write_tour(tour, out, progress=bar(len(tour), "writing frames"))
        signs = tour.gt[tour.gt["class"] == 1]
        return (f"{len(tour)} frames, scenario {scenario}, seed {random_state}, "
                f"{signs['id'].nunique()} indicators in view, "
                f"{signs.loc[signs['bb_height'] >= 14, 'id'].nunique()} of them seen at "
                "least 14 px tall (what 'evaluate tunnel' counts)")
    if kind != "street":
        raise ValueError(f"kind must be 'tunnel' or 'street', got {kind!r}")
    scenario = scenario or STREET_SCENARIOS[0]
    run = make_street_scans(n, scenario=scenario, name=out.name, random_state=random_state)
    write_run(run, out)
    counts = run.gt["label"].value_counts()
    return (f"{len(run)} scans, scenario {scenario}, seed {random_state}, "
            f"{counts.get('parked', 0)} parked and {counts.get('passing', 0)} "
            "passing vehicles")
