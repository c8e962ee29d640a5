"""
Simulated laser street run
==========================

A laser range finder on a measurement vehicle scans the vertical plane across the
street, toward the kerb, 75 times a second while the vehicle drives at about 40 km/h.
:func:`tunnelsense.datasets.make_street_scans` simulates such a run: the road with its
camber, the kerb and sidewalk, parked cars, vans and motorbikes, vehicles passing in the
lane between, pedestrians, bins, bollards, hedges and trees, with range noise, dropouts
and the sensor's 8.191 m for everything beyond 8 m.

This example shows one scan on the depth-height plane (as Fig. 4 of the paper: road
points black, the region of interest green, points above 2 m red, the max-range arc
blue) and the panoramic range image of the run, with the ground-truth intervals of the
parked and passing vehicles.
"""

# %%
# Simulate a crowded street
# -------------------------
import matplotlib.pyplot as plt

from tunnelsense.datasets import make_street_scans
from tunnelsense.plotting import plot_range_image, plot_scan

run = make_street_scans(1200, scenario="crowded", random_state=3)
print(run.name, len(run), "scans;", run.info["n_parked"], "parked,",
      run.info["n_passing"], "passing; true roll",
      f"{run.info['roll_deg_mean']:.2f} deg (not in the geometry)")
print(run.gt.head())

# %%
# One scan through a parked vehicle, one through a passing one
# ------------------------------------------------------------
# The scan plane cuts a vehicle across its length, so successive scans show its
# cross-section at successive positions: bumper, bonnet, cabin, boot.  A passing
# vehicle in the lane between hides the parked ones behind it.
parked = run.gt[run.gt["label"] == "parked"].iloc[2]
passing = run.gt[run.gt["label"] == "passing"].iloc[0]
fig, axes = plt.subplots(1, 2, figsize=(13, 5))
for ax, row in zip(axes, (parked, passing), strict=True):
    scan = (row.first_scan + row.last_scan) // 2
    plot_scan(run.scans[scan], ax=ax)
    ax.set_title(f"scan {scan}: {row.label} vehicle {row.id}")
fig.tight_layout()

# %%
# The panoramic range image
# -------------------------
# Scans run left to right, beams bottom (road next to the vehicle) to top; the colour
# is the depth across the street.  Parked vehicles (4-6.6 m) and passing ones (< 4 m)
# are marked below and above the image.
fig, ax = plt.subplots(figsize=(13, 4))
plot_range_image(run, ax=ax)
fig.tight_layout()
print(f"{run.name}: {len(run)} scans, {run.info['n_parked']} parked and "
      f"{run.info['n_passing']} passing vehicles in the ground truth")

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
