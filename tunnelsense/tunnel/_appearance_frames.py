"""How :class:`~tunnelsense.tunnel.WeightedAdaBoost` describes and scores frames.

:class:`AppearanceFramesMixin` holds the frame-record side of the machine: the
histograms and features of every cluster's rectangle (and of the ``augment`` copies
of it for training), and the records evolved with the machine's scores, with the
bright cores of ``core`` where those score better.  It reads the estimator's
parameters (``bins``, ``intensity_range``, ``margin``, ``features``, ``widest_sign``,
``augment``, ``core``) and its ``_decision``.
"""

from __future__ import annotations

import numpy as np

from tunnelsense._payload import (
    APPEARANCE,
    APPEARANCE_SCORE,
    CLUSTER_BOXES,
    CLUSTER_HISTOGRAMS,
    boxes_of,
    frame_image,
)
from tunnelsense.tunnel._appearance_features import (
    _chunked_features,
    _interleaved,
    _invariant_rows,
    _patch_histograms,
)
from tunnelsense.tunnel._common import bin_lut
from tunnelsense.tunnel._contrast import core_boxes
from tunnelsense.tunnel._invariant import _crop_bounds, box_patches, perturb_patch

__all__ = ["AppearanceFramesMixin"]


class AppearanceFramesMixin:
    """Frame-record features and scoring of :class:`WeightedAdaBoost`."""

    def _frame_histograms(self, records):
        """Per frame: record, boxes, raw histograms and the stumps' features."""
        margin = float(self.margin)
        for i, r in enumerate(records):
            boxes = boxes_of(r, i, "WeightedAdaBoost")
            if len(boxes) == 0:
                yield r, boxes, np.empty((0, self.bins)), np.empty((0, self._n_features()))
                continue
            image = frame_image(r, i)
            lut = bin_lut(image.dtype, self.bins, self.intensity_range)
            # the same patches for the histograms and the invariant features
            # (box_histograms and invariant_features, one crop for both)
            rects = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
            patches = box_patches(image, rects, margin)
            H = _patch_histograms(patches, self.bins, lut)
            if self.features != "histogram":
                F = _invariant_rows(patches, rects[:, [3, 2]].tolist(), self.features,
                                self.widest_sign)
            else:
                F = H
            yield r, boxes, H, F

    def _core_scores(self, record, index, score):
        """Each cluster's score and box, or those of the best of its bright cores
        (:func:`core_boxes` at the fractions ``core``) when its score is larger."""
        boxes = np.asarray(boxes_of(record, index, "WeightedAdaBoost"),
                           dtype=np.float64).reshape(-1, 4)
        image = frame_image(record, index)
        cores = core_boxes(image, boxes, margin=float(self.margin), fractions=self.core)
        owner = np.repeat(np.arange(len(boxes)), cores.shape[1])
        rects = cores.reshape(-1, 4)
        other = (rects != boxes[owner]).any(axis=1)
        if not other.any():
            return score, boxes
        owner, rects = owner[other], rects[other]
        patches = box_patches(image, rects, float(self.margin))
        if self.features != "histogram":
            F = _invariant_rows(patches, rects[:, [3, 2]].tolist(), self.features,
                                self.widest_sign)
        else:
            F = _patch_histograms(patches, self.bins,
                                  bin_lut(image.dtype, self.bins, self.intensity_range))
        score, boxes = score.copy(), boxes.copy()
        for o, rect, s in zip(owner.tolist(), rects, self._decision(F).tolist(),
                              strict=True):
            if s > score[o]:
                score[o], boxes[o] = s, rect
        return score, boxes

    def _augmented(self, record, index, boxes, rng):
        """Features of the frame's clusters as ``augment`` other cameras see them."""
        image = frame_image(record, index)
        lut = bin_lut(image.dtype, self.bins, self.intensity_range)
        bounds = np.column_stack(
            _crop_bounds(boxes, image.shape, float(self.margin))).tolist()
        patches = [image[r0:r1, c0:c1] for c0, r0, c1, r1 in bounds]
        # every copy drawn first (the draws in the same order as copy by copy),
        # then the features of all of them at once: each row is its patch's alone
        seen = [perturb_patch(patch, rng, (box[3], box[2]))
                for _ in range(int(self.augment))
                for patch, box in zip(patches, boxes.tolist(), strict=True)]
        if self.features != "histogram":
            rows = _invariant_rows([q for q, _ in seen], [hw for _, hw in seen],
                                   self.features, self.widest_sign)
        else:
            rows = []
            for q, _ in seen:
                counts = np.bincount(lut[q].ravel(), minlength=self.bins)
                rows.append(counts / counts.sum())
        rows = np.array(rows).reshape(int(self.augment), len(boxes), -1)
        return list(rows)

    def _described_frames(self, records, rng):
        """Per frame ``(record, boxes, histograms, features, augmented)`` as
        :meth:`_frame_histograms` and :meth:`_augmented` give them (``augmented``:
        the features of the ``augment`` copies, an empty list without), with the
        invariant features of all frames' patches computed at once (each row is its
        patch's alone: the same values, without a call per frame)."""
        if self.features == "histogram":
            out = []
            for i, (r, b, h, f) in enumerate(self._frame_histograms(records)):
                augmented = (self._augmented(r, i, b, rng) if self.augment and len(b)
                             else [])
                out.append((r, b, h, f, augmented))
            return out
        margin = float(self.margin)
        n_aug = int(self.augment)
        frames, patches, hws, seen = [], [], [], []
        for i, r in enumerate(records):
            b = boxes_of(r, i, "WeightedAdaBoost")
            if len(b) == 0:
                frames.append((r, b, np.empty((0, self.bins)), 0))
                continue
            image = frame_image(r, i)
            lut = bin_lut(image.dtype, self.bins, self.intensity_range)
            rects = np.asarray(b, dtype=np.float64).reshape(-1, 4)
            crops = box_patches(image, rects, margin)
            frames.append((r, b, _patch_histograms(crops, self.bins, lut), len(crops)))
            patches.extend(crops)
            hws.extend(rects[:, [3, 2]].tolist())
            # the copies drawn frame by frame, in _augmented's order
            if n_aug:
                seen.extend(perturb_patch(patch, rng, (box[3], box[2]))
                            for _ in range(n_aug)
                            for patch, box in zip(crops, b.tolist(), strict=True))
        F = _chunked_features(patches, hws, features=self.features,
                              widest=self.widest_sign)
        G = _chunked_features([q for q, _ in seen], [hw for _, hw in seen],
                              features=self.features, widest=self.widest_sign)
        out, at_f, at_g = [], 0, 0
        for r, b, h, m in frames:
            f = F[at_f:at_f + m]
            g = G[at_g:at_g + n_aug * m].reshape(n_aug, m, G.shape[1]) if m else []
            at_f, at_g = at_f + m, at_g + n_aug * m
            out.append((r, b, h, f, list(g)))
        return out

    def _scored_with_cores(self, records, described=None):
        """:meth:`_scored` of frames with ``core``: the invariant features of every
        frame's clusters' patches and of their distinct bright cores' patches in one
        call, scored in one call (each row is its patch's alone: the same values as
        a call per frame and per kind of patch).  ``described`` (from ``fit``), per
        frame ``(record, histograms, features)`` of its clusters, which are then
        not computed again: only the cores' features are."""
        margin = float(self.margin)
        frames, patches, hws, given = [], [], [], []
        for i, r in enumerate(records):
            boxes = boxes_of(r, i, "WeightedAdaBoost")
            if len(boxes) == 0:
                frames.append((r, None, None, None, None))
                continue
            image = frame_image(r, i)
            rects = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
            if described is None:
                crops = box_patches(image, rects, margin)
                H = _patch_histograms(crops, self.bins, bin_lut(
                    image.dtype, self.bins, self.intensity_range))
                patches += crops
                hws.append(rects[:, [3, 2]])
            else:
                _, H, F = described[i]
                given.append(F)
            cores = core_boxes(image, rects, margin=margin, fractions=self.core)
            owner = np.repeat(np.arange(len(rects)), cores.shape[1])
            core_rects = cores.reshape(-1, 4)
            other = (core_rects != rects[owner]).any(axis=1)
            owner, core_rects = owner[other], core_rects[other]
            frames.append((r, rects, H, owner, core_rects))
            patches += box_patches(image, core_rects, margin)
            hws.append(core_rects[:, [3, 2]])
        # the cores of a whole training tour in chunks (their tables stay small)
        rows = _invariant_rows if described is None else _chunked_features
        decision = (self._decision(rows(
            patches, np.concatenate(hws).tolist(), features=self.features,
            widest=self.widest_sign))
                    if patches else np.empty(0))
        if described is not None:
            # clusters' rows first, then the cores', frame by frame, as below
            decision = _interleaved(
                self._decision(np.concatenate(given)) if given else np.empty(0),
                decision, [(len(f[1]), len(f[3])) for f in frames if f[1] is not None])
        out, at = [], 0
        for r, rects, H, owner, core_rects in frames:
            if rects is None:
                out.extend(self._scored([(r, np.empty((0, self.bins)),
                                          np.empty((0, self._n_features())))]))
                continue
            m, k = len(rects), len(owner)
            score, boxes = decision[at:at + m], rects
            if k:
                score, boxes = score.copy(), rects.copy()
                for o, rect, s in zip(owner.tolist(), core_rects,
                                      decision[at + m:at + m + k].tolist(), strict=True):
                    if s > score[o]:
                        score[o], boxes[o] = s, rect
            at += m + k
            out.append(r.evolve(**{
                APPEARANCE: score > 0,
                APPEARANCE_SCORE: score,
                CLUSTER_HISTOGRAMS: H,
                CLUSTER_BOXES: boxes,
            }))
        return out

    def _scored(self, described):
        """The records evolved with the machine's labels of their clusters."""
        out = []
        for i, (r, H, F) in enumerate(described):
            score = self._decision(F) if len(F) else np.empty(0)
            cored = {}
            if self.core is not None and len(F):
                score, cored[CLUSTER_BOXES] = self._core_scores(r, i, score)
            out.append(
                r.evolve(**{
                    APPEARANCE: score > 0,
                    APPEARANCE_SCORE: score,
                    CLUSTER_HISTOGRAMS: H,
                    **cored,
                })
            )
        return out
