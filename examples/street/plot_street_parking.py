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

run = make_street_scans(1500, scenario="dense", random_state=0)
clusterer = ScanClusterer().fit(run.scans)
objects = clusterer.detect(run.scans)
print(objects.head())
print(street_scores(run.gt, objects))
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
plt.show()
