"""Pictures of laser runs: bounded sizes, and marks inside the axes."""

import io

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

from tunnelsense import to_xy  # noqa: E402
from tunnelsense.datasets import make_street_scans  # noqa: E402
from tunnelsense.plotting import (  # noqa: E402
    draw_run,
    plot_dendrogram,
    plot_range_image,
)
from tunnelsense.street import make_parking_pipeline  # noqa: E402

GT_COLOURS = [(44, 160, 44), (148, 103, 189)]  # tab:green, tab:purple


@pytest.fixture(scope="module")
def run():
    return make_street_scans(3200, scenario="dense", random_state=3)


def _rgb(fig):
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=fig.dpi)
    buf.seek(0)
    return (plt.imread(buf)[..., :3] * 255).round().astype(int)


def _pixel_box(artist, height):
    """Rows and columns of an artist's extent in the saved picture (origin top left)."""
    b = artist.get_window_extent()
    return (int(height - b.y1) - 1, int(height - b.y0) + 1,
            int(b.x0) - 1, int(b.x1) + 1)


def test_range_image_marks_stay_inside_the_axes(run):
    """A window of a long run: the ground-truth bars are drawn inside the axes only."""
    fig, ax = plt.subplots(figsize=(10, 3), dpi=100, layout="constrained")
    plot_range_image(run, ax=ax)
    ax.set_xlim(1500, 3000)
    rgb = _rgb(fig)
    assert rgb.shape[:2] == (300, 1000)
    mark = np.zeros(rgb.shape[:2], bool)
    for colour in GT_COLOURS:
        mark |= (np.abs(rgb - colour) <= 2).all(axis=2)
    outside = mark.copy()
    for artist in (ax, ax.get_legend(), fig.axes[1]):  # axes, legend, colour bar
        r0, r1, c0, c1 = _pixel_box(artist, rgb.shape[0])
        outside[max(r0, 0):r1, max(c0, 0):c1] = False
    r0, r1, c0, c1 = _pixel_box(ax, rgb.shape[0])
    assert mark[r0:r1, c0:c1].sum() > 100  # the bars are there
    assert not outside.any()
    plt.close(fig)


def test_draw_run_writes_pictures_of_a_bounded_size(run, tmp_path):
    X, y, _ = to_xy(run)
    pipe = make_parking_pipeline().fit(X, y)
    X = list(run.scans)
    if len(pipe.steps) > 1:
        X = pipe[:-1].transform(X)
    written = draw_run(run, pipe[-1], tmp_path, X=X)
    ranges = sorted(p for p in written if p.name.startswith("range_image"))
    assert [p.name for p in ranges] == ["range_image_000000.png",
                                        "range_image_001500.png",
                                        "range_image_003000.png"]
    for path in ranges:
        assert plt.imread(path).shape[:2] == (440, 1540)


@pytest.mark.parametrize("spacing", [0.05, 0.3, 1.5])
def test_dendrogram_axes_include_the_cut(run, spacing):
    """The cut line lies inside the axes, whether the merges are shorter or longer."""
    from tunnelsense.street import ScanClusterer

    rec = ScanClusterer().fit(run.scans[:200]).transform(run.scans[100:101])[0]
    pts = np.column_stack([4.0 + spacing * np.arange(12), np.full(12, 1.0)])
    rec = rec.evolve(points=pts, clusters=np.zeros(12, int))
    fig, ax = plt.subplots()
    plot_dendrogram(rec, cut=0.6, ax=ax)
    bottom, top = ax.get_ylim()
    assert bottom <= 0 and top > 0.6
    assert top >= spacing  # every merge is drawn too
    (line,) = [ln for ln in ax.get_lines() if ln.get_label() == "cut 0.6 m"]
    assert bottom < line.get_ydata()[0] < top
    plt.close(fig)
