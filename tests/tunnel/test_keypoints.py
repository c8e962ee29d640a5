import numpy as np
import pytest

from tunnelsense import FrameRecord, FrameSequence, ImageFile, ScanRecord
from tunnelsense.exceptions import InputFormatError
from tunnelsense.io import load_model, save_model
from tunnelsense.tunnel import (
    IntensityKeypointSampler,
    indicator_band,
    sample_keypoints,
)
from tunnelsense.utils import record_stage_checks, sklearn_api_checks


def brute_force(image, low, high, rs=7, cs=6, ro=0, co=0):
    out = []
    for r in range(ro, image.shape[0], rs):
        for c in range(co, image.shape[1], cs):
            if low <= image[r, c] <= high:
                out.append((r, c, int(image[r, c])))
    return np.array(out, dtype=np.int32).reshape(-1, 3)


@pytest.mark.parametrize("offsets", [(0, 0), (3, 2), (6, 5)])
def test_matches_brute_force(global_random_seed, offsets):
    rng = np.random.default_rng(global_random_seed)
    image = rng.integers(140, 211, (61, 83)).astype(np.uint8)
    ro, co = offsets
    got = sample_keypoints(image, 160, 190, row_offset=ro, col_offset=co)
    assert got.dtype == np.int32
    assert np.array_equal(got, brute_force(image, 160, 190, ro=ro, co=co))
    # raster order
    assert np.all(np.diff(got[:, 0] * 10_000 + got[:, 1]) > 0)


def test_band_is_inclusive_and_grid_strides():
    image = np.zeros((30, 30), np.uint8)
    image[0, 0], image[7, 6], image[14, 12], image[7, 7] = 160, 190, 191, 175
    kp = sample_keypoints(image)
    assert kp.tolist() == [[0, 0, 160], [7, 6, 190]]


def test_band_outside_dtype_gives_no_keypoints():
    image = np.full((20, 20), 255, np.uint8)
    assert sample_keypoints(image, 300, 400).shape == (0, 3)
    assert sample_keypoints(image, 190, 160).shape == (0, 3)


def test_uint16_frames_use_the_band_in_raw_counts():
    image = np.full((40, 40), 7000, np.uint16)
    image[14:30, 12:20] = 8200
    X = FrameSequence.from_array(image[None])
    kp = IntensityKeypointSampler(8000, 8400).fit_transform(X)[0].payload["keypoints"]
    assert kp.dtype == np.int32 and len(kp) > 0
    assert np.all(kp[:, 2] == 8200)
    assert IntensityKeypointSampler().fit_transform(X)[0].payload["keypoints"].shape == (0, 3)


def labelled_frames(seed, n_frames=4, mean=175.0, sd=5.0, dtype=np.uint8):
    rng = np.random.default_rng(seed)
    images, boxes = [], []
    for _ in range(n_frames):
        image = rng.normal(100, 10, (120, 160))
        top, left = rng.integers(5, 80), rng.integers(5, 120)
        image[top : top + 30, left : left + 12] = rng.normal(mean, sd, (30, 12))
        images.append(np.clip(np.rint(image), 0, np.iinfo(dtype).max).astype(dtype))
        boxes.append(np.array([[left, top, 12, 30]], dtype=float))
    return FrameSequence.from_array(np.stack(images), tour="lab"), boxes


def test_learned_band_follows_the_three_sigma_rule(global_random_seed):
    X, y = labelled_frames(global_random_seed, mean=175, sd=5)
    est = IntensityKeypointSampler(band="learned").fit(X, y)
    # the median and MAD of 1,440 pixels: within about 2 grey levels over seeds 0-99
    assert est.low_ == pytest.approx(160, abs=2.5)
    assert est.high_ == pytest.approx(190, abs=2.5)
    kp = est.transform(X)[0].payload["keypoints"]
    assert np.all((kp[:, 2] >= est.low_) & (kp[:, 2] <= est.high_))
    # the fixed band ignores y
    fixed = IntensityKeypointSampler(150, 200).fit(X, y)
    assert (fixed.low_, fixed.high_) == (150.0, 200.0)


def test_learned_band_on_16_bit_frames(global_random_seed):
    X, y = labelled_frames(global_random_seed, mean=8200, sd=40, dtype=np.uint16)
    est = IntensityKeypointSampler(band="learned").fit(X, y)
    assert est.low_ == pytest.approx(8080, abs=20)
    assert est.high_ == pytest.approx(8320, abs=20)


def test_indicator_band_matches_numpy():
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, (50, 50)).astype(np.uint8)
    boxes = np.array([[3.5, 2, 10, 7], [40, 45, 20, 20]])
    pixels = np.concatenate([image[2:9, 4:14].ravel(), image[45:50, 40:50].ravel()])
    low, high = indicator_band([image], [boxes], n_sigma=2, estimator="mean")
    assert low == pytest.approx(pixels.mean() - 2 * pixels.std())
    assert high == pytest.approx(pixels.mean() + 2 * pixels.std())


def test_median_band_ignores_the_wall_in_the_boxes(global_random_seed):
    """Boxes drawn a pixel around the plates (a rim of wall, as hand-drawn or
    simulated boxes are; 20 % of the box): the robust estimate stays near the
    plate's 3-sigma band [160, 190] (about [152, 194]), the plain moments widen it
    to about [68, 252]."""
    X, y = labelled_frames(global_random_seed, mean=175, sd=5)
    loose = [b + np.array([[-1, -1, 2, 2]]) for b in y]  # 14 x 32 around 12 x 30
    median = IntensityKeypointSampler(band="learned").fit(X, loose)
    mean = IntensityKeypointSampler(band="learned", band_estimator="mean").fit(X, loose)
    assert 148 < median.low_ < 160 and 190 < median.high_ < 198
    assert mean.low_ < 100 and mean.high_ > 230


def test_grouped_median_between_two_levels():
    """Half the pixels at 170, half at 180: the median mid-gap (175), the MAD 5."""
    img = np.array([[170, 180, 170, 180]], np.uint8)
    low, high = indicator_band([img], [np.array([[0, 0, 4, 1.]])], n_sigma=1 / 1.4826)
    assert (low, high) == pytest.approx((170.0, 180.0))


def test_indicator_band_needs_8_or_16_bit_frames():
    with pytest.raises(ValueError, match="image 0: the image must be a 2-D uint8 or uint16"):
        indicator_band([np.array([[170, 180]])], [np.array([[0, 0, 2, 1.]])])
    # 8- and 16-bit frames together are counted on the longer histogram
    band = indicator_band(
        [np.array([[175]], np.uint8), np.array([[175]], np.uint16)],
        [np.array([[0, 0, 1, 1.]])] * 2, estimator="mean",
    )
    assert band == (175.0, 175.0)


def test_grouped_median_is_not_quantized():
    # levels spread over [v - 0.5, v + 0.5]: the median 175, the MAD 0.5 (not 0 or 1)
    assert indicator_band([np.array([[174, 175, 175, 176]], np.uint8)],
                          [np.array([[0, 0, 4, 1.]])], n_sigma=1 / 1.4826) == (174.5, 175.5)


def test_errors_are_clear():
    X, y = labelled_frames(0)
    with pytest.raises(ValueError, match="requires y"):
        IntensityKeypointSampler(band="learned").fit(X)
    with pytest.raises(ValueError, match="no indicator box"):
        IntensityKeypointSampler(band="learned").fit(X, [np.empty((0, 4))] * len(X))
    with pytest.raises(ValueError, match="low must not exceed high"):
        IntensityKeypointSampler(200, 100).fit(X)
    with pytest.raises(ValueError, match="band"):
        IntensityKeypointSampler(band="learnt").fit(X)
    bad = [FrameRecord("t", 1, np.zeros((8, 8), np.float32))]
    with pytest.raises(ValueError, match="uint8 or uint16"):
        IntensityKeypointSampler().fit(bad).transform(bad)
    with pytest.raises(TypeError, match="FrameRecord"):
        IntensityKeypointSampler().fit([ScanRecord("r", 0, np.ones(3), 0.0, None)])


def test_records_keep_identity_and_other_payload():
    X, _ = labelled_frames(1)
    X = FrameSequence(r.evolve(note="kept") for r in X)
    out = IntensityKeypointSampler().fit(X).transform(list(X)[::-1])
    assert [r.key for r in out] == [r.key for r in list(X)[::-1]]
    assert all(r.payload["note"] == "kept" for r in out)


def _wide(X):
    """The same frames as 16-bit raw counts."""
    return FrameSequence(FrameRecord(r.tour, r.frame, r.image.astype(np.uint16) * 257)
                         for r in X)


def test_frames_of_another_bit_depth_are_refused():
    X, y = labelled_frames(0)
    est = IntensityKeypointSampler().fit(X)
    assert est.pixel_dtype_ == "uint8"
    with pytest.raises(InputFormatError, match=r"X\[0\] \('lab', frame 1\): a uint16 "
                                               r"frame, but the sampler was fitted on "
                                               r"uint8 frames"):
        est.transform(_wide(X))
    wide = IntensityKeypointSampler(band="learned").fit(_wide(X), y)
    assert wide.pixel_dtype_ == "uint16"
    with pytest.raises(InputFormatError, match=r"a uint8 frame, but the sampler was "
                                               r"fitted on uint16 frames"):
        wide.transform(X)


def test_a_fixed_band_missing_every_sign_pixel_is_refused_naming_the_units():
    """The paper's 8-bit band on 14-bit counts: refused at fit, naming the band,
    the frames' pixel type and where the signs' pixels lie."""
    X, y = labelled_frames(0)
    wide = FrameSequence.from_array(
        np.stack([r.image.astype(np.uint16) * 64 for r in X]), tour="lab")
    match = (r"fixed keypoint band \[160, 190\] \(low, high\) holds none of the "
             r"pixels inside the indicator boxes y: those of the uint16 training "
             r"frames lie in \[\d+, \d+\]")
    with pytest.raises(ValueError, match=match):
        IntensityKeypointSampler().fit(wide, y)
    # the same band in the frames' units is served; so are 8-bit levels in
    # 16-bit words (the band then holds the signs' pixels)
    assert IntensityKeypointSampler(160 * 64, 190 * 64).fit(wide, y).low_ == 160 * 64
    words = FrameSequence.from_array(
        np.stack([r.image.astype(np.uint16) for r in X]), tour="lab")
    out = IntensityKeypointSampler().fit_transform(words, y)
    assert sum(len(r.payload["keypoints"]) for r in out) > 0
    # without boxes nothing is checked (no sign to miss)
    assert IntensityKeypointSampler().fit(wide).pixel_dtype_ == "uint16"


def test_the_paper_preset_on_14_bit_frames_says_why_it_cannot_be_fitted():
    from tunnelsense import to_xy
    from tunnelsense.datasets import make_tunnel_tour
    from tunnelsense.tunnel import make_indicator_pipeline

    X, y, _ = to_xy([make_tunnel_tour(40, random_state=1, bit_depth=14,
                                      indicator_spacing_m=40.0)])
    with pytest.raises(ValueError, match=r"band \[160, 190\] \(low, high\).*uint16"):
        make_indicator_pipeline(preset="paper", random_state=0).fit(X, y)


def test_fit_refuses_frames_of_two_bit_depths(tmp_path):
    """Lazily decoded frames too: the learned band would mix two scales."""
    import cv2

    X, y = labelled_frames(0, n_frames=2)
    paths = [tmp_path / "a.png", tmp_path / "b.png"]
    cv2.imwrite(str(paths[0]), X[0].image)
    cv2.imwrite(str(paths[1]), X[1].image.astype(np.uint16) * 257)
    lazy = FrameSequence(FrameRecord("lab", i, ImageFile(p))
                         for i, p in enumerate(paths, 1))
    match = r"X\[1\] \('lab', frame 2\): a uint16 frame, but the other frames are uint8"
    with pytest.raises(InputFormatError, match=match):
        IntensityKeypointSampler(band="learned").fit(lazy, y)


def test_pixel_dtype_survives_a_skops_round_trip(tmp_path):
    X, _ = labelled_frames(0)
    est = IntensityKeypointSampler().fit(_wide(X))
    back = load_model(save_model(est, tmp_path / "m.skops"))
    assert back.pixel_dtype_ == "uint16" and type(back.pixel_dtype_) is str
    with pytest.raises(InputFormatError, match="fitted on uint16 frames"):
        back.transform(X)


def test_a_sampler_fitted_before_pixel_dtype_works_as_before(tmp_path):
    """A model saved without ``pixel_dtype_`` takes frames of any depth, unchecked."""
    X, _ = labelled_frames(0)
    est = IntensityKeypointSampler(8000, 60000).fit(X)
    del est.pixel_dtype_
    back = load_model(save_model(est, tmp_path / "old.skops"))
    assert not hasattr(back, "pixel_dtype_")
    out = back.transform(_wide(X))
    expected = sample_keypoints(_wide(X)[0].image, 8000, 60000)
    assert len(expected) and np.array_equal(out[0].payload["keypoints"], expected)


_X, _Y = labelled_frames(3, n_frames=3)


@pytest.mark.parametrize(
    "estimator", [IntensityKeypointSampler(), IntensityKeypointSampler(band="learned")]
)
def test_record_stage_checks(estimator):
    for name, check in record_stage_checks(estimator, _X, _Y):
        check()  # raises AssertionError naming the check
        assert name.startswith("check_")


@pytest.mark.parametrize(
    "name, check", list(sklearn_api_checks(IntensityKeypointSampler()))
)
def test_sklearn_api_checks(name, check):
    check()
