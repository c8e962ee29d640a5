"""The positioning picture: the fused error gets a panel on its own scale."""

import matplotlib
import numpy as np

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

from tunnelsense import TunnelPositioner  # noqa: E402
from tunnelsense.datasets import (  # noqa: E402
    make_tunnel_kinematics,
    make_tunnel_odometry,
    simulate_indicator_detections,
)
from tunnelsense.positioning import plot_positioning  # noqa: E402
from tunnelsense.positioning._evaluate import dead_reckoning  # noqa: E402


def test_the_fused_error_has_a_zoomed_panel():
    truth = make_tunnel_kinematics(2000.0, random_state=1)
    positions, odometry, indicators = make_tunnel_odometry(truth, scale_error=0.03,
                                                           random_state=1)
    detections = simulate_indicator_detections(truth, random_state=1)
    estimate, fixes = TunnelPositioner().fit(indicators).predict(
        detections, odometry, return_fixes=True)
    s = positions["chainage"].to_numpy()
    err = np.abs(estimate["chainage"].to_numpy() - s)
    band = 2 * estimate["sigma"].to_numpy()
    drift = np.abs(dead_reckoning(odometry, initial_chainage=s[0]) - s)
    # from the first fix on, the fused estimate's own scale
    first = estimate["frame"].to_numpy() > fixes.loc[fixes["accepted"],
                                                      "pass_frame"].min()
    fused = max(err[first].max(), band[first].max())
    assert drift.max() > 20 * fused  # the case the panel is for

    ax = plot_positioning(positions, estimate, odometry, fixes,
                          indicator_map=indicators)
    overview, zoom = ax.figure.axes
    assert overview is ax
    assert overview.get_ylim()[1] >= drift.max()  # the drift is drawn whole above
    low, high = zoom.get_ylim()
    # below, the fused error and its band fill the panel
    assert -low >= fused and high >= fused
    assert high <= 1.2 * fused
    labels = {line.get_label() for line in zoom.get_lines()}
    assert {"fused", "fix", "indicator passed"} <= labels
    assert "dead reckoning alone" not in labels
    assert zoom.get_xlim() == overview.get_xlim()  # the same time axis
    plt.close(ax.figure)

    # into a given Axes: one panel, as before
    fig, one = plt.subplots()
    assert plot_positioning(positions, estimate, odometry, ax=one) is one
    assert len(fig.axes) == 1
    plt.close(fig)
