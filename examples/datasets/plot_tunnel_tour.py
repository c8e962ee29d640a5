"""
==========================================
A simulated far-infrared tour of a tunnel
==========================================

:func:`tunnelsense.datasets.make_tunnel_tour` drives a calibrated far-infrared camera
through a motorway tunnel. Emergency-telephone indicators (red) stand every 200 m on
the left wall; ordinary lamps (yellow) line both upper walls; vehicles (blue) drive
ahead with warm road patches beneath them (green). The ground truth gives each object's
box, class and persistent id per frame.
"""

# %%
# Simulate a short tour with heavy traffic; the first indicator stands 60 m ahead.
import matplotlib.pyplot as plt
import numpy as np

from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.plotting import plot_frame

tour = make_tunnel_tour(240, scenario="heavy", random_state=7, first_indicator_m=60.0)
print({k: tour.info[k] for k in sorted(tour.info)[:8]})
print(tour.gt.groupby("class")["id"].nunique().rename("objects per class"))

# %%
# A few frames with their ground-truth boxes, coloured by class. The indicator grows
# as the camera approaches it; lamps near the camera saturate and bloom.
gt = tour.gt
indicator = gt[gt["class"] == 1].groupby("id").filter(lambda t: t["bb_height"].max() > 60)
first_id = indicator["id"].iloc[0]
track = indicator[indicator["id"] == first_id].sort_values("frame")
frames = track["frame"].to_numpy()[[0, len(track) // 2, int(len(track) * 0.85), -3]]

fig, axes = plt.subplots(2, 2, figsize=(12.8, 9.6))
for ax, frame in zip(axes.ravel(), frames, strict=True):
    plot_frame(tour.frames[int(frame) - 1].image, gt[gt["frame"] == frame], ax=ax)
    ax.set_title(f"frame {frame}")
fig.tight_layout()

# %%
# The indicator's image trajectory: its box centre moves along a straight line away
# from the vanishing point, faster and faster, growing to about 80 px tall.
cx = track["bb_left"] + track["bb_width"] / 2
cy = track["bb_top"] + track["bb_height"] / 2
r = np.corrcoef(cx, cy)[0, 1]
fig, ax = plt.subplots(figsize=(6.4, 4.8))
sc = ax.scatter(cx, cy, c=track["bb_height"], s=8, cmap="viridis")
ax.set_xlim(0, 640)
ax.set_ylim(480, 0)
ax.set_xlabel("box centre x (px)")
ax.set_ylabel("box centre y (px)")
ax.set_title(f"indicator {first_id}: Pearson r = {r:.4f}")
fig.colorbar(sc, label="box height (px)")
print(f"{tour.name}: {len(tour)} frames, indicator {first_id} in view for {len(track)} "
      f"frames, its image path straight (Pearson r = {r:.4f})")

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
