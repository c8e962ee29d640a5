"""
A parking census along a street
===============================

Count the parked vehicles of a simulated street per 50 m segment, with the parked
length and the kerb occupancy of each segment, from the detector's objects and the
distance the measurement vehicle drove (its ego speed times the time between scans).
The detector labels every vehicle ``car``, ``van`` or ``motorbike`` (its
``vehicle_class`` column), so the census counts them per class; below, the same from
the ground truth with the simulator's classes.
"""

# %%
import matplotlib.pyplot as plt

from tunnelsense.datasets import make_street_scans
from tunnelsense.io import ego_speed
from tunnelsense.plotting import plot_census
from tunnelsense.street import census, parked_extents, scan_distances, train_detector

train = make_street_scans(1500, scenario="sparse", random_state=0)
run = make_street_scans(2500, scenario="hard", random_state=1)
model, _ = train_detector([train])
objects = model[-1].detect(run.scans)

distances = scan_distances([s.stamp for s in run.scans], ego_speed(run.info))
table = census(objects, distances, segment_length=50.0)
print(table.round(2).to_string(index=False))

# %%
# The census along the street: the occupancy of each segment with its count above,
# the parked vehicles below.
fig, ax = plt.subplots(figsize=(12, 3.5), layout="constrained")
plot_census(table, parked_extents(objects, distances), ax=ax, title="detected")

# %%
# The same street from its ground truth, each vehicle with the simulator's class
# (its ``vehicle_class`` column).
truth = run.gt
true_table = census(truth, distances, segment_length=50.0)
fig, ax = plt.subplots(figsize=(12, 3.5), layout="constrained")
plot_census(true_table, parked_extents(truth, distances), ax=ax, title="ground truth")
for name, t in (("detected", table), ("in the ground truth", true_table)):
    print(f"parked vehicles {name}: {t['parked'].sum()} "
          f"({', '.join(f'{t[c].sum()} {c}' for c in ('car', 'van', 'motorbike'))})")

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
