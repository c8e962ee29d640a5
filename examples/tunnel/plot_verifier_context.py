"""
Why the keypoint verifier looks at a keypoint's context
========================================================

The paper's keypoint descriptor (section 3.2) is the intensity histogram of a small
patch on the keypoint.  Inside a sign's plate and inside any extended warm surface of
the same intensity (the road warmed behind a vehicle, a vehicle's body) such a patch
has the same histogram: the paper's noisy objects that "cannot be distinguished by
appearance".  :class:`~tunnelsense.tunnel.KMeansHistogramVerifier` therefore appends,
by default, the histogram of a larger 25 x 13 px patch around the keypoint
(``context_size``): a sign is a bounded plate on a cooler wall, a warm surface is not.

This example fits the verifier twice on one simulated heavy-traffic tour, with the
patch histogram alone (``context_size=None``) and with the context, and draws, on a
frame of another heavy-traffic tour, the keypoints each keeps.
"""

# %%
# Simulate a training tour and a test tour (heavy traffic, other seeds).
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Rectangle

from tunnelsense import to_xy
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.tunnel import IntensityKeypointSampler, KMeansHistogramVerifier


def points_in_boxes(rows, cols, boxes):
    """Which keypoints lie in any box (left, top, width, height)."""
    boxes = np.asarray(boxes, dtype=float).reshape(-1, 4)
    left, top, width, height = boxes.T[:, None, :]
    c, r = np.asarray(cols)[:, None], np.asarray(rows)[:, None]
    return ((left <= c) & (c < left + width) & (top <= r) & (r < top + height)).any(1)


train = make_tunnel_tour(400, scenario="heavy", random_state=20)
test = make_tunnel_tour(300, scenario="heavy", random_state=21, first_indicator_m=60.0)

# %%
# Fit the sampler and both verifiers on the training tour.
X, y, _ = to_xy([train])
sampler = IntensityKeypointSampler().fit(X, y)
Xk = sampler.transform(X)
verifiers = {
    "7 x 3 patch histogram alone": KMeansHistogramVerifier(
        context_size=None, max_distance=0.32, random_state=0
    ).fit(Xk, y),
    "with the 25 x 13 context histogram (default)": KMeansHistogramVerifier(
        random_state=0
    ).fit(Xk, y),
}

# %%
# Measure both on the test tour: indicators taller than 14 px that keep a verified
# keypoint, and negative keypoints (outside every indicator box) removed.
Xt, yt, _ = to_xy([test])
Xtk = sampler.transform(Xt)
outputs = {name: v.transform(Xtk) for name, v in verifiers.items()}
for name, out in outputs.items():
    hit = n = neg = neg_kept = 0
    for r, boxes in zip(out, yt, strict=True):
        s, k = r.payload["sampled_keypoints"], r.payload["keypoints"]
        for box in boxes[boxes[:, 3] > 14]:
            n += 1
            hit += bool(points_in_boxes(k[:, 0], k[:, 1], box[None]).any())
        neg += int((~points_in_boxes(s[:, 0], s[:, 1], boxes)).sum())
        neg_kept += int((~points_in_boxes(k[:, 0], k[:, 1], boxes)).sum())
    print(f"{name}: {hit / max(n, 1):.1%} of {n} indicators kept, "
          f"{1 - neg_kept / max(neg, 1):.1%} of {neg} negatives removed")

# %%
# Draw the frame (with an indicator in view) where the patch histogram alone keeps
# the most negative keypoints.
patch_alone = outputs["7 x 3 patch histogram alone"]


def negatives_kept(r, boxes):
    k = r.payload["keypoints"]
    return int((~points_in_boxes(k[:, 0], k[:, 1], boxes)).sum())


candidates = [i for i, b in enumerate(yt) if len(b) and b[:, 3].max() > 14]
i = max(candidates, key=lambda j: negatives_kept(patch_alone[j], yt[j]))
fig, axes = plt.subplots(1, 2, figsize=(13, 5))
for ax, (name, out) in zip(axes, outputs.items(), strict=True):
    r = out[i]
    s, k = r.payload["sampled_keypoints"], r.payload["keypoints"]
    ax.imshow(r.image, cmap="gray", vmin=0, vmax=255)
    ax.plot(s[:, 1], s[:, 0], "+", color="tab:blue", ms=5, label="rejected")
    ax.plot(k[:, 1], k[:, 0], "o", mfc="none", color="red", ms=6, label="verified")
    for left, top, width, height in yt[i]:
        ax.add_patch(Rectangle((left, top), width, height, fill=False, color="lime",
                               ls="--", lw=1.2))
    ax.set_title(f"{name}\n{len(k)} of {len(s)} keypoints kept, "
                 f"{negatives_kept(r, yt[i])} outside the indicator")
    ax.axis("off")
axes[0].legend(loc="lower left", fontsize=8)
fig.suptitle(f"{test.name}, frame {Xt[i].frame}: indicator dashed in green")
fig.tight_layout()
print(f"{test.name}, frame {Xt[i].frame}: " + "; ".join(
    f"{name.split(' (')[0]}: {len(out[i].payload['keypoints'])} kept, "
    f"{negatives_kept(out[i], yt[i])} outside the indicator"
    for name, out in outputs.items()))

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
