"""
Positioning in a tunnel: dead reckoning reset at each indicator
===============================================================

Where GPS fails, a vehicle integrates its odometry, and the error grows with the
distance driven: a wheel-speed scale error of 3 % is 60 m after 2 km.  The
emergency-telephone indicators stand every 200 m at surveyed chainages, so each one
the detector finds resets that error.  :class:`~tunnelsense.TunnelPositioner` fuses
the two: a 1-D Kalman filter over the chainage and the odometry's scale factor, a
position fix where each detected sign passes the camera (extrapolated from the growth
of its box height), and a gate that rejects fixes far from any indicator of the map.

First a 2-km tour whose detections are drawn from the pinhole model, with one sign
missed and one false alarm; then a short rendered tour with the real detector.
"""

# %%
# A 2-km tour: true chainage, odometry with a 3 % scale error, the indicator map,
# and the detector's output simulated (one sign missed, one false alarm).
import matplotlib.pyplot as plt

from tunnelsense import TunnelPositioner, to_xy
from tunnelsense.datasets import (
    make_tunnel_kinematics,
    make_tunnel_odometry,
    make_tunnel_tour,
    simulate_indicator_detections,
)
from tunnelsense.positioning import plot_positioning, position_errors
from tunnelsense.tunnel import make_indicator_pipeline

truth = make_tunnel_kinematics(2000.0, random_state=1)
positions, odometry, indicators = make_tunnel_odometry(truth, scale_error=0.03,
                                                       random_state=1)
missed = int(indicators["id"].iloc[4])
false_alarm = float(indicators["chainage"].iloc[6]) + 57.0
detections = simulate_indicator_detections(truth, missed=[missed],
                                           false_alarms=[false_alarm], random_state=1)

# %%
# Online (what the vehicle knows at each frame) and smoothed (offline, every fix).
online, fixes = TunnelPositioner().fit(indicators).predict(
    detections, odometry, return_fixes=True)
smoothed = TunnelPositioner(smooth=True).fit(indicators).predict(detections, odometry)
for name, estimate in (("online", online), ("smoothed", smoothed)):
    e = position_errors(positions, estimate, odometry, indicators)
    print(f"{name:9} max error {e['max']:5.2f} m, at the passes "
          f"{e['max_at_passes']:4.2f} m; dead reckoning max {e['dead_reckoning']['max']:.1f} m")
print(fixes[["track_id", "pass_frame", "indicator_id", "mahalanobis", "accepted",
             "reason"]].to_string(index=False))

# %%
# A rendered tour and the real detector, trained on another tour.
train = make_tunnel_tour(300, random_state=11, first_indicator_m=40.0)
tour = make_tunnel_tour(450, random_state=12, first_indicator_m=40.0, speed_kmh=90.0)
X, y, _ = to_xy([train])
model = make_indicator_pipeline(
    verifier__n_positive_clusters=20, verifier__n_negative_clusters=100, random_state=0
).fit(X, y)
records = model.predict(to_xy([tour])[0])
tour_positions, tour_odometry, tour_indicators = make_tunnel_odometry(tour)
tour_estimate, tour_fixes = TunnelPositioner(smooth=True).fit(tour_indicators).predict(
    records, tour_odometry, return_fixes=True)
e = position_errors(tour_positions, tour_estimate, tour_odometry, tour_indicators)
print(f"rendered tour: max error {e['max']:.2f} m, dead reckoning "
      f"{e['dead_reckoning']['max']:.2f} m")

# %%
# The chainage error against time: dead reckoning drifts, the fused estimate is
# reset at each sign (dots: fixes kept; crosses: rejected by the gate).
fig, axes = plt.subplots(2, 1, figsize=(9, 7), layout="constrained")
plot_positioning(positions, online, odometry, fixes, indicator_map=indicators,
                 ax=axes[0])
axes[0].set_title("2 km, 3 % scale error, a missed sign and a false alarm (online)")
axes[0].set_ylim(-5, 15)
plot_positioning(tour_positions, tour_estimate, tour_odometry, tour_fixes,
                 indicator_map=tour_indicators, ax=axes[1])
axes[1].set_title("rendered tour, real detector (smoothed)")

# sphinx_gallery_start_ignore
# Run as a plain script, the example saves its figures as PNG files into the folder
# named by TUNNELSENSE_EXAMPLES_OUT (default: the current folder), and shows them when
# matplotlib has an interactive backend.
import os  # noqa: E402
from pathlib import Path  # noqa: E402

if not os.environ.get("TUNNELSENSE_EXAMPLES_NO_SAVE"):
    out = Path(os.environ.get("TUNNELSENSE_EXAMPLES_OUT", "."))
    out.mkdir(parents=True, exist_ok=True)
    for number in plt.get_fignums():
        plt.figure(number).savefig(out / f"{Path(__file__).stem}-{number}.png", dpi=80)
    if plt.get_backend().lower() != "agg":
        plt.show()
# sphinx_gallery_end_ignore
