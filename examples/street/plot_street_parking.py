"""
Street-parked vehicles from a vertically scanning laser
=======================================================

The paper's method (Fig. 6) on a simulated street: a scan's clusters in the region of
interest (Fig. 4), the dendrogram of that scan with the 0.6 m cut (Fig. 5), and the
panoramic range image with the detected objects.
"""

# %%
import matplotlib.pyplot as plt

from tunnelsense.datasets import make_street_scans
from tunnelsense.metrics import street_confusion_matrix, street_scores
from tunnelsense.street import (
    ScanClusterer,
    plot_clusters,
    plot_dendrogram,
    plot_objects,
)

run = make_street_scans(1200, scenario="dense", random_state=0)
clusterer = ScanClusterer().fit(run.scans)
objects = clusterer.detect(run.scans)
print(objects.head())
scores = street_scores(run.gt, objects)
print(scores)
print(street_confusion_matrix(run.gt, objects))

# %%
# Fig. 4 and Fig. 5: the scan in the middle of the first parked vehicle.
records = clusterer.transform(run.scans)
first = objects[objects.label == "parked"].iloc[0]
scan = records[(first.first_scan + first.last_scan) // 2]
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(14, 4))
plot_clusters(scan, ax=ax1)
plot_dendrogram(scan, cut=clusterer.cut, ax=ax2)

# %%
# The panoramic range image, ground truth above/below, detections beside it.
fig, ax = plt.subplots(figsize=(14, 3.5))
plot_objects(run, objects, ax=ax)
fig.tight_layout()
parked = scores["parked"]
print(f"{run.name}: {parked['tp']} parked vehicles found, {parked['fp']} false, "
      f"{parked['fn']} missed (recall {parked['recall']:.2f}, "
      f"precision {parked['precision']:.2f})")

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
