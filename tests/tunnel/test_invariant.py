"""The appearance features computed for all clusters of a frame at once equal their
per-patch definition (plain NumPy, one patch at a time), value for value."""

import cv2
import numpy as np
import pytest

from tunnelsense.tunnel import box_histograms
from tunnelsense.tunnel._common import bin_lut
from tunnelsense.tunnel._invariant import invariant_features, patch_features


def _crop(image, box, margin):
    left, top, bw, bh = box
    h, w = image.shape
    pad = margin * bh
    c0 = min(max(int(round(left - pad)), 0), w - 1)
    r0 = min(max(int(round(top - pad)), 0), h - 1)
    c1 = max(min(int(round(left + bw + pad)), w), c0 + 1)
    r1 = max(min(int(round(top + bh + pad)), h), r0 + 1)
    return image[r0:r1, c0:c1]


_SPREAD = 16 + 1  # the column of the spread (16 bins)


def _reference_features(patch, box_hw, bins=16):
    """The definition of invariant_features, patch by patch."""
    p = np.ascontiguousarray(patch)
    if p.dtype != np.uint8:
        p = np.clip(p, 0, 255).astype(np.uint8)
    if min(p.shape) >= 3:
        p = cv2.medianBlur(p, 3)
    lo, hi = np.percentile(p, [10, 90])
    span = max(hi - lo, 1.0)
    z = (p.astype(np.float64) - lo) / span
    hist, _ = np.histogram(np.clip(z, -0.5, 1.5), bins=bins, range=(-0.5, 1.5))
    bright = z > 0.5
    inner = z[bright]
    rows, cols = np.flatnonzero(bright.any(1)), np.flatnonzero(bright.any(0))
    extent = (np.log((rows[-1] - rows[0] + 1) / (cols[-1] - cols[0] + 1))
              if rows.size else 0.0)
    return np.concatenate([hist / z.size, [
        bright.mean(), inner.std() if inner.size > 1 else 0.0,
        np.median(np.concatenate([z[0], z[-1], z[:, 0], z[:, -1]])), extent,
        np.log(max(box_hw[0], 1.0) / max(box_hw[1], 1.0)), span / max(lo, 1.0),
    ]])


def _reference_histograms(image, boxes, margin, bins):
    lut = bin_lut(image.dtype, bins)
    out = []
    for box in boxes.tolist():
        counts = np.bincount(lut[_crop(image, box, margin)].ravel(), minlength=bins)
        out.append(counts / counts.sum())
    return np.array(out).reshape(len(boxes), bins)


def _case(rng, kind):
    h, w = rng.integers(1, 50, 2)
    if kind == "noise":
        img = rng.integers(0, 256, (h, w)).astype(np.uint8)
    elif kind == "flat":
        img = np.full((h, w), rng.integers(0, 256), np.uint8)
    elif kind == "levels":
        img = (rng.integers(0, 3, (h, w)) * 80).astype(np.uint8)
    else:  # a sign on a wall
        img = np.clip(rng.normal(100, 5, (h, w)), 0, 255).astype(np.uint8)
        img[h // 4:3 * h // 4 + 1, w // 3:2 * w // 3 + 1] = rng.integers(150, 200)
    m = rng.integers(0, 6)
    boxes = np.column_stack([rng.integers(-5, w + 2, m), rng.integers(-5, h + 2, m),
                             rng.integers(1, 20, m), rng.integers(1, 25, m)])
    return img, boxes.astype(np.float64) + rng.choice([0.0, 0.5])


@pytest.mark.parametrize("kind", ["noise", "flat", "levels", "sign"])
@pytest.mark.parametrize("margin", [0.0, 0.25, 0.5])
def test_frame_at_once_equals_patch_by_patch(global_random_seed, kind, margin):
    rng = np.random.default_rng(global_random_seed)
    for _ in range(40):
        img, boxes = _case(rng, kind)
        want = np.array([_reference_features(_crop(img, b, margin), (b[3], b[2]))
                         for b in boxes.tolist()]).reshape(len(boxes), 22)
        got = invariant_features(img, boxes, margin=margin)
        # every figure exact but the spread, a sum of squares summed in another
        # order than ndarray.std sums it (equal to rounding)
        other = np.arange(22) != _SPREAD
        np.testing.assert_array_equal(got[:, other], want[:, other])
        np.testing.assert_allclose(got[:, _SPREAD], want[:, _SPREAD], rtol=1e-12,
                                   atol=1e-15)
        for image, bins in ((img, 32), (img.astype(np.uint16) * 257, 16)):
            np.testing.assert_array_equal(
                box_histograms(image, boxes, margin=margin, bins=bins),
                _reference_histograms(image, boxes, margin, bins))


def test_one_patch_equals_its_row_of_a_frame():
    rng = np.random.default_rng(0)
    img, boxes = _case(rng, "sign")
    boxes = np.array([[3, 2, 9, 14.0], [0, 0, 4, 4.0]])
    rows = invariant_features(img, boxes)
    for row, b in zip(rows, boxes.tolist(), strict=True):
        np.testing.assert_array_equal(patch_features(_crop(img, b, 0.25), (b[3], b[2])),
                                      row)
    assert invariant_features(img, np.empty((0, 4))).shape == (0, 22)


def test_at_most_counts_as_the_comparison_does():
    # the binary search over the rows laid end to end gives, row by row, the count
    # of entries <= each query, as the plain comparison does (empty rows, ties,
    # queries below, at and above every entry)
    from tunnelsense.tunnel._invariant import _at_most

    rng = np.random.default_rng(0)
    for _ in range(200):
        m = int(rng.integers(1, 7))
        counts = rng.integers(0, 4, (m, int(rng.integers(1, 12)))) * rng.integers(0, 2, (m, 1))
        cdf = np.cumsum(counts, axis=1)
        k = rng.integers(0, cdf[:, -1].max() + 3, (2, m))
        np.testing.assert_array_equal(_at_most(cdf, k),
                                      (cdf <= k[..., None]).sum(axis=-1))


def test_median_of_all_patches_at_once_equals_each_patch_filtered_alone(
        global_random_seed):
    # one filter over a canvas of the patches (wider and narrower than OpenCV's
    # fast path, patches 1-2 px thin left as they are, 16-bit and float patches
    # clipped) gives each patch's own 3 x 3 median, edge replicated
    from tunnelsense.tunnel._invariant import _median_3x3

    rng = np.random.default_rng(global_random_seed)
    for n_patches in (1, 2, 5, 30):
        patches = []
        for _ in range(n_patches):
            h, w = (int(v) for v in rng.integers(1, 60, 2))
            patch = rng.integers(0, 256, (h, w)).astype(np.uint8)
            kind = rng.integers(0, 4)
            if kind == 1:
                patch = (patch.astype(np.uint16) * 3)
            elif kind == 2:
                patch = patch * 1.7 - 40.0
            elif kind == 3:  # a view with strides, as a crop of a frame is
                patch = np.pad(patch, 3)[2:-1, 1:-2]
            patches.append(patch)
        for got, patch in zip(_median_3x3(patches), patches, strict=True):
            want = patch
            if want.dtype != np.uint8:
                want = np.clip(want, 0, 255).astype(np.uint8)
            if min(want.shape) >= 3:
                want = cv2.medianBlur(np.ascontiguousarray(want), 3)
            assert got.dtype == np.uint8
            np.testing.assert_array_equal(got, want)
