"""
Indicator detections, drawn like the paper's figures
=====================================================

The FIR indicator detector (:func:`tunnelsense.tunnel.make_indicator_pipeline`) is
trained on one simulated tour and run on another.  Each frame is drawn as in Figs.
1b, 4 and 5 of the paper: keypoint clusters as rectangles, **red** when the appearance
machine (:class:`~tunnelsense.tunnel.WeightedAdaBoost`) labels them positive and
**green** when negative; trajectories as lines, **yellow** when the motion check
(:class:`~tunnelsense.tunnel.PCCVerifier`) labels them positive and **white** when
negative.  ``tunnelsense detect tunnel --draw DIR`` writes the same pictures.
"""

# %%
# Simulate a training tour and a test tour with an indicator early on.
import matplotlib.pyplot as plt
import numpy as np

from tunnelsense import to_xy
from tunnelsense.datasets import make_tunnel_tour
from tunnelsense.metrics import indicator_scores
from tunnelsense.plotting import draw_detections
from tunnelsense.tunnel import make_indicator_pipeline

train = make_tunnel_tour(300, scenario="heavy", random_state=0, first_indicator_m=40.0)
test = make_tunnel_tour(240, scenario="heavy", random_state=7, first_indicator_m=60.0)

# %%
# Train the six stages (smaller k-means than the paper's, to run in seconds).
X, y, _ = to_xy([train])
model = make_indicator_pipeline(
    verifier__n_positive_clusters=20, verifier__n_negative_clusters=100, random_state=0
).fit(X, y)

# %%
# Detect, score, and draw three frames where the indicator is in view.
Xt, yt, _ = to_xy([test])
records = model.predict(Xt)
scores = indicator_scores(records, yt)
print(scores)

pictures = list(draw_detections(records))
detected = [i for i, r in enumerate(records) if len(r.payload["detections"])]
negative = [i for i, r in enumerate(records) if (~r.payload["trajectory_positive"]).any()]
shown = [*np.array(detected)[[len(detected) // 2, -1]], negative[len(negative) // 2]]
fig, axes = plt.subplots(1, 3, figsize=(15, 4))
for ax, i in zip(axes, shown, strict=True):
    rec, pic = pictures[i]
    ax.imshow(pic[:, :, ::-1])  # BGR to RGB
    ax.set_title(f"{rec.tour}, frame {rec.frame}")
    ax.axis("off")
fig.tight_layout()
cluster, trajectory = scores["cluster"], scores["trajectory"]
print(f"{test.name}: {trajectory['detected']} of {trajectory['indicators']} indicators "
      f"found, {cluster['correct']} of {cluster['total']} clusters on them detected, "
      f"{cluster['false_alarms']} false alarms")

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
