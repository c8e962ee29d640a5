"""
Keypoints, verified keypoints and keypoint clusters (the paper's Figs. 2-3)
============================================================================

Stages 1-3 of the FIR indicator detector on a simulated frame:

* :class:`~tunnelsense.tunnel.IntensityKeypointSampler` samples a grid (6 px across,
  7 px down) and keeps the points whose intensity lies in [160, 190]: the keypoints
  (Fig. 2b);
* :class:`~tunnelsense.tunnel.KMeansHistogramVerifier`, fitted on another simulated
  tour, keeps the keypoints whose descriptor (the histogram of the 7 x 3 patch on
  the keypoint, then that of the 25 x 13 patch around it) lies near a positive
  centre and not farther from it than from the negative centres: **red circles**
  pass, **blue marks** fail (Fig. 3);
* :class:`~tunnelsense.tunnel.MSTClusterer` cuts the minimum spanning tree of the
  verified keypoints at 40 px; each cluster's smallest bounding rectangle is a
  detection hypothesis (**yellow**, Figs. 3c-d).  Ground-truth indicator boxes are
  drawn dashed in green.  The close-up also shows, in **cyan**, the rectangle of
  ``MSTClusterer(box="region")`` (the indicator pipeline's default): the keypoint
  rectangle refined to the in-band region around the keypoints, i.e. the sign itself.
"""

# %%
# Simulate a training tour and a test tour, each passing an indicator early on.
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Rectangle

from tunnelsense import to_xy
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.tunnel import (
    IntensityKeypointSampler,
    KMeansHistogramVerifier,
    MSTClusterer,
)

train = make_tunnel_tour(200, scenario="light", random_state=0, first_indicator_m=40.0)
test = make_tunnel_tour(120, scenario="heavy", random_state=5, first_indicator_m=50.0)

# %%
# Fit the three stages on the training tour (frame records in, frame records out).
X, y, _ = to_xy([train])
sampler = IntensityKeypointSampler().fit(X, y)
Xk = sampler.transform(X)
verifier = KMeansHistogramVerifier(random_state=0).fit(Xk, y)
clusterer = MSTClusterer(cut=40).fit(Xk)
regions = MSTClusterer(cut=40, box="region").fit(Xk)

# %%
# Run them on the test tour and pick the frame where the indicator is about 30 px tall.
Xt, yt, _ = to_xy([test])
verified = verifier.transform(sampler.transform(Xt))
records = clusterer.transform(verified)
heights = [b[:, 3].max() if len(b) else 0.0 for b in yt]
i = int(np.argmin(np.abs(np.array(heights) - 30.0)))
record, boxes = records[i], yt[i]
region_boxes = regions.transform(verified[i : i + 1])[0].payload["cluster_boxes"]
sampled = record.payload["sampled_keypoints"]
kept = record.payload["keypoints"]
rejected = sampled[~(sampled[:, None, :2] == kept[None, :, :2]).all(-1).any(-1)]

# %%
# Draw: (a) the frame, (b) keypoints, (c) verification and clusters.
fig, axes = plt.subplots(1, 3, figsize=(16, 4.6))
for ax in axes:
    ax.imshow(record.image, cmap="gray", vmin=0, vmax=255)
    ax.axis("off")
axes[0].set_title("(a) frame")
axes[1].set_title("(b) keypoints: grid points in [160, 190]")
axes[1].plot(sampled[:, 1], sampled[:, 0], "+", color="tab:blue", ms=5)
axes[2].set_title("(c) verified (red), rejected (blue), clusters")
axes[2].plot(rejected[:, 1], rejected[:, 0], "+", color="tab:blue", ms=5)
axes[2].plot(kept[:, 1], kept[:, 0], "o", mfc="none", color="red", ms=6)
for left, top, width, height in record.payload["cluster_boxes"]:
    axes[2].add_patch(Rectangle((left - 0.5, top - 0.5), width, height, fill=False,
                                color="yellow", lw=1.5))
for ax in axes[1:]:
    for left, top, width, height in boxes:
        ax.add_patch(Rectangle((left, top), width, height, fill=False, color="lime",
                               ls="--", lw=1))
fig.tight_layout()

# %%
# A close-up of the indicator in (c).
left, top, width, height = boxes[np.argmax(boxes[:, 3])]
fig2, ax = plt.subplots(figsize=(5, 5))
ax.imshow(record.image, cmap="gray", vmin=0, vmax=255)
ax.plot(rejected[:, 1], rejected[:, 0], "+", color="tab:blue", ms=10, mew=2)
ax.plot(kept[:, 1], kept[:, 0], "o", mfc="none", color="red", ms=12, mew=2)
for bl, bt, bw, bh in record.payload["cluster_boxes"]:
    ax.add_patch(Rectangle((bl - 0.5, bt - 0.5), bw, bh, fill=False, color="yellow",
                           lw=2))
for bl, bt, bw, bh in region_boxes:
    ax.add_patch(Rectangle((bl - 0.5, bt - 0.5), bw, bh, fill=False, color="cyan", lw=2))
ax.add_patch(Rectangle((left, top), width, height, fill=False, color="lime", ls="--"))
ax.set_xlim(left - 2 * height, left + width + 2 * height)
ax.set_ylim(top + 2 * height, top - height)
ax.set_title("close-up: keypoints (yellow) vs region (cyan)")
ax.axis("off")
print(f"{record.tour}, frame {record.frame}: {len(sampled)} keypoints, {len(kept)} "
      f"verified, {len(record.payload['cluster_boxes'])} clusters")

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
