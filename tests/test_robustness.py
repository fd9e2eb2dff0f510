"""Bad inputs across the public API: each gives an error of hopmatch's vocabulary whose
message names the argument and says what was expected (docs/robustness.md), or a
well-formed empty result where that is the right answer."""

from __future__ import annotations

import pickle
import warnings

import cv2
import numpy as np
import pytest

import hopmatch
from hopmatch import DericheMoravecDetector, HopfieldMatcher, hopfield_match, match_stereo
from hopmatch.errors import (
    BudgetExceededError,
    DisparityRangeWarning,
    FewMatchesWarning,
    HopmatchError,
    HopmatchWarning,
    ImageSizeWarning,
    InvalidArgumentError,
    InvalidTypeError,
    PairInfoError,
    UnrectifiedPairWarning,
)

RNG = np.random.default_rng(7)
IMG = cv2.GaussianBlur((RNG.random((72, 96)) * 255).astype(np.uint8), (0, 0), 1.0)
DET = DericheMoravecDetector.create()
KPS, DES = DET.detectAndCompute(IMG, None)
PTS = cv2.KeyPoint_convert(KPS)
N = len(KPS)


def _matcher(**params):
    m = HopfieldMatcher.create(max_disparity=16, **params)
    m.setPairInfo(KPS, KPS, IMG.shape[1::-1], IMG.shape[1::-1])
    return m


def _read_yml(tmp_path, body, cls=HopfieldMatcher):
    path = tmp_path / "params.yml"
    path.write_text("%YAML:1.0\n---\n" + body)
    cls().read(path)


def _pickled_state(state):
    obj = HopfieldMatcher.__new__(HopfieldMatcher)
    obj.__setstate__(state)


# (id, call, exception, regex the message must match). Every regex names the argument.
CASES = [
    # -- images --------------------------------------------------------------------------
    ("image-none", lambda: DET.detect(None), InvalidTypeError, r"`image`.*numpy array"),
    ("image-list", lambda: DET.detect([[1, 2], [3, 4]]), InvalidTypeError, r"`image`.*numpy"),
    ("image-bool", lambda: DET.detect(np.zeros((9, 9), bool)), InvalidTypeError,
     r"`image`.*dtype.*got bool.*astype"),
    ("image-int32", lambda: DET.detect(np.zeros((9, 9), np.int32)), InvalidTypeError,
     r"`image`.*got int32"),
    ("image-float16", lambda: DET.detect(np.zeros((9, 9), np.float16)), InvalidTypeError,
     r"`image`.*got float16"),
    ("image-complex", lambda: DET.detect(np.zeros((9, 9), np.complex64)), InvalidTypeError,
     r"`image`.*complex64"),
    ("image-0d", lambda: DET.detect(np.array(3, np.uint8)), InvalidArgumentError,
     r"`image`.*\(H, W\).*got shape \(\)"),
    ("image-4d", lambda: DET.detect(np.zeros((2, 2, 2, 2), np.uint8)), InvalidArgumentError,
     r"`image`.*got shape \(2, 2, 2, 2\)"),
    ("image-2-channels", lambda: DET.detect(np.zeros((9, 9, 2), np.uint8)),
     InvalidArgumentError, r"`image`.*BGR.*got shape \(9, 9, 2\)"),
    ("image-empty", lambda: DET.detect(np.zeros((0, 5), np.uint8)), InvalidArgumentError,
     r"`image` must not be empty.*\(0, 5\)"),
    ("image-empty-bgr", lambda: DET.detect(np.zeros((4, 0, 3), np.uint8)),
     InvalidArgumentError, r"`image` must not be empty"),
    ("image-nan", lambda: DET.detect(np.full((9, 9), np.nan, np.float32)),
     InvalidArgumentError, r"`image`.*NaN.*nan_to_num"),
    ("image-inf-f64", lambda: DET.detectAndCompute(np.full((9, 9), -np.inf), None),
     InvalidArgumentError, r"`image`.*infinite"),
    ("image-beyond-float32", lambda: DET.detect(np.full((9, 9), 1e300)),
     InvalidArgumentError, r"`image`.*beyond the float32 range.*rescale"),
    ("image-below-float32", lambda: DET.detect(np.full((9, 9), 1e-300)),
     InvalidArgumentError, r"`image`.*no larger than 1e-300.*below the float32 range.*all 0"
                           r".*rescale"),
    ("gradient-fn-overflow",
     lambda: hopmatch.deriche_gradient(np.full((9, 9), 3e38, np.float32) *
                                       (np.arange(9) % 2)[None, :].astype(np.float32)),
     InvalidArgumentError, r"`image`.*gradient overflows"),
    # OpenCV's Deriche coefficients divide by sin(omega): omega = 0 gave NaN everywhere,
    # and extreme parameters overflow them; the image is not to blame for either
    ("detector-omega-zero", lambda: DericheMoravecDetector(omega=0.0), InvalidArgumentError,
     r"`omega` must be a finite number in \(0.0, inf\], got 0.0"),
    ("gradient-fn-omega-zero", lambda: hopmatch.deriche_gradient(IMG, omega=0),
     InvalidArgumentError, r"`omega` must be a finite number in \(0.0"),
    ("detector-alpha-extreme", lambda: DericheMoravecDetector(alpha=1e-300).detect(IMG),
     InvalidArgumentError, r"non-finite values with alpha=1e-300 and omega=0.001"),
    ("gradient-fn-alpha-extreme", lambda: hopmatch.deriche_gradient(IMG, alpha=1e-300),
     InvalidArgumentError, r"non-finite values with alpha=1e-300"),
    ("image-pixel-budget", lambda: DericheMoravecDetector(max_pixels=100).detect(IMG),
     BudgetExceededError, r"`image` has 72 x 96 = 6912 pixels.*max_pixels=100.*max_pixels=6912"),
    ("match-stereo-pixel-budget",
     lambda: match_stereo(IMG, IMG, max_pixels=1000), BudgetExceededError,
     r"`left`.*max_pixels=1000"),
    ("moravec-response-str", lambda: hopmatch.moravec_response("img"), InvalidTypeError,
     r"`image` must be a numpy array"),
    ("moravec-points-3d", lambda: hopmatch.moravec_points(np.zeros((3, 3, 3))),
     InvalidArgumentError, r"`response` must be a 2-dimensional"),
    # -- masks ---------------------------------------------------------------------------
    ("mask-int32", lambda: DET.detect(IMG, np.ones(IMG.shape, np.int32)), InvalidTypeError,
     r"`mask`.*uint8 or bool.*got int32.*astype\(np.uint8\)"),
    ("mask-float", lambda: DET.detectAndCompute(IMG, np.ones(IMG.shape, np.float32)),
     InvalidTypeError, r"`mask`.*got float32"),
    ("mask-shape", lambda: DET.detect(IMG, np.ones((10, 10), np.uint8)), InvalidArgumentError,
     r"`mask` must have shape \(72, 96\).*got \(10, 10\).*cv2.resize"),
    ("mask-transposed", lambda: DET.detect(IMG, np.ones((96, 72), np.uint8)),
     InvalidArgumentError, r"`mask` must have shape \(72, 96\)"),
    ("mask-3-channels", lambda: DET.detect(IMG, np.ones((72, 96, 3), np.uint8)),
     InvalidArgumentError, r"`mask`.*give one channel"),
    ("mask-list", lambda: DET.detect(IMG, [[1]]), InvalidTypeError, r"`mask`.*numpy array"),
    ("mask-per-image-count", lambda: DET.detect([IMG, IMG], [None]), InvalidArgumentError,
     r"`mask`.*list of 2 masks.*got a list of 1"),
    ("match-stereo-mask-right", lambda: match_stereo(IMG, IMG, mask_right=np.ones((3, 3), bool)),
     InvalidArgumentError, r"`mask_right` must have shape"),
    ("matcher-mask-shape", lambda: _matcher().match(DES, DES, np.ones((3, 3), np.uint8)),
     InvalidArgumentError, r"`mask`.*\(n_query, n_train\)"),
    ("knn-mask-shape", lambda: _matcher().knnMatch(DES, DES, 2, mask=np.ones((N, 1), bool)),
     InvalidArgumentError, r"`mask`.*\(n_query, n_train\)"),
    ("knn-mask-dtype", lambda: _matcher().knnMatch(DES, DES, 2, mask=np.ones((N, N))),
     InvalidTypeError, r"`mask`.*uint8 or bool.*float64"),
    # -- keypoints -----------------------------------------------------------------------
    ("compute-kps-none", lambda: DET.compute(IMG, None), InvalidTypeError,
     r"`keypoints`.*cv2.KeyPoint.*None"),
    ("compute-kps-array", lambda: DET.compute(IMG, PTS), InvalidTypeError,
     r"`keypoints`.*ndarray.*KeyPoint_convert"),
    ("compute-kps-mixed", lambda: DET.compute(IMG, [KPS[0], (1.0, 2.0)]), InvalidTypeError,
     r"`keypoints` must hold only cv2.KeyPoint.*tuple"),
    ("compute-kps-nan", lambda: DET.compute(IMG, [cv2.KeyPoint(float("nan"), 3.0, 3.0)]),
     InvalidArgumentError, r"`keypoints`.*NaN"),
    ("compute-list-count", lambda: DET.compute([IMG, IMG], [KPS]), InvalidArgumentError,
     r"`keypoints`.*one keypoint sequence per image"),
    ("provided-kps-missing",
     lambda: DET.detectAndCompute(IMG, None, useProvidedKeypoints=True),
     InvalidArgumentError, r"`keypoints` must be given"),
    ("pairinfo-shape", lambda: _matcher().setPairInfo(np.zeros((4, 3)), PTS),
     InvalidArgumentError, r"`queryKpts`.*\(N, 2\).*got shape \(4, 3\)"),
    ("pairinfo-strings", lambda: _matcher().setPairInfo(PTS, "abc"), InvalidTypeError,
     r"`trainKpts`"),
    ("pairinfo-complex", lambda: _matcher().setPairInfo(PTS.astype(np.complex64), PTS),
     InvalidTypeError, r"`queryKpts` must hold numbers"),
    ("pairinfo-inf", lambda: _matcher().setPairInfo(PTS, np.full((3, 2), np.inf)),
     InvalidArgumentError, r"`trainKpts`.*infinite"),
    ("pairinfo-beyond-float32", lambda: _matcher().setPairInfo(np.full((3, 2), 1e300), PTS),
     InvalidArgumentError, r"`queryKpts`.*beyond the float32 range"),
    ("pairinfo-huge-coordinates",
     lambda: _matcher().setPairInfo(np.array([[0, 0], [1e30, 1e30]], np.float32), PTS),
     InvalidArgumentError, r"`queryKpts`.*magnitude 1e\+30.*1048576"),
    ("pairinfo-size-float", lambda: _matcher().setPairInfo(PTS, PTS, (96.0, 72.0)),
     InvalidTypeError, r"`queryImageSize`.*two integers"),
    ("pairinfo-size-negative", lambda: _matcher().setPairInfo(PTS, PTS, None, (-1, 5)),
     InvalidArgumentError, r"`trainImageSize` must be positive"),
    ("hopfield-match-mixed-kps", lambda: hopfield_match([KPS[0], 3], PTS, DES, DES),
     InvalidTypeError, r"`left_pts`|mixes cv2.KeyPoint"),
    # -- descriptors ---------------------------------------------------------------------
    ("desc-list", lambda: _matcher().match(DES.tolist(), DES), InvalidTypeError,
     r"`queryDescriptors` must be a numpy array"),
    ("desc-3d", lambda: _matcher().match(DES, DES[:, :, None]), InvalidArgumentError,
     r"`trainDescriptors`.*2-D.*got shape"),
    ("desc-zero-columns",
     lambda: _matcher().match(np.zeros((N, 0), np.float32), np.zeros((N, 0), np.float32)),
     InvalidArgumentError, r"`queryDescriptors` has \d+ rows but 0 columns"),
    ("desc-nan", lambda: _matcher().match(np.full_like(DES, np.nan), DES),
     InvalidArgumentError, r"`queryDescriptors` contains NaN"),
    ("desc-bool", lambda: _matcher().match(DES > 0, DES > 0), InvalidTypeError,
     r"`queryDescriptors` must be float32 or uint8.*bool"),
    ("desc-complex", lambda: _matcher().match(DES.astype(np.complex64), DES), InvalidTypeError,
     r"`queryDescriptors`.*complex64"),
    ("desc-beyond-float32", lambda: _matcher().match(DES.astype(np.float64) * 1e300, DES),
     InvalidArgumentError, r"`queryDescriptors`.*beyond the float32 range"),
    ("desc-count", lambda: _matcher().match(DES[:-1], DES), PairInfoError,
     r"descriptor counts.*setPairInfo"),
    ("desc-types-differ", lambda: _matcher().match(DES, np.zeros_like(DES, np.uint8)),
     InvalidArgumentError, r"`queryDescriptors`.*`trainDescriptors`.*same type"),
    ("desc-widths-differ", lambda: _matcher().match(DES, DES[:, :-1]), InvalidArgumentError,
     r"same type and length"),
    # -- pair info and matcher calls ------------------------------------------------------
    ("no-pair-info", lambda: HopfieldMatcher().match(DES, DES), PairInfoError,
     r"setPairInfo"),
    ("energy-before-match", lambda: HopfieldMatcher().energy(), PairInfoError,
     r"match\(\) first"),
    ("fundamental-str", lambda: _matcher().setFundamentalMatrix("F"), InvalidTypeError,
     r"`F` must be a 3 x 3"),
    ("fundamental-shape", lambda: _matcher().setFundamentalMatrix(np.eye(9, 3)),
     InvalidArgumentError, r"`F` must be a 3x3 matrix, got shape \(9, 3\).*FM_7POINT"),
    ("fundamental-zero", lambda: _matcher().setFundamentalMatrix(np.zeros((3, 3))),
     InvalidArgumentError, r"`F` must be finite and not all zero"),
    ("knn-k-zero", lambda: _matcher().knnMatch(DES, DES, 0), InvalidArgumentError,
     r"`k` must be in \[1, "),
    ("knn-k-float", lambda: _matcher().knnMatch(DES, DES, 2.0), InvalidTypeError, r"`k`"),
    ("radius-str", lambda: _matcher().radiusMatch(DES, DES, "0.5"), InvalidTypeError,
     r"`maxDistance` must be a number"),
    ("radius-nan", lambda: _matcher().radiusMatch(DES, DES, float("nan")),
     InvalidArgumentError, r"`maxDistance`.*NaN"),
    # -- parameters and presets ----------------------------------------------------------
    ("param-typo", lambda: HopfieldMatcher.create(max_disparty=3), InvalidArgumentError,
     r"unknown parameter\(s\) \['max_disparty'\].*max_disparity"),
    ("detector-param-typo", lambda: DericheMoravecDetector.create(windowsize=3),
     InvalidArgumentError, r"\['windowsize'\].*window_size"),
    ("match-stereo-typo", lambda: match_stereo(IMG, IMG, nms=3), InvalidArgumentError,
     r"match_stereo got unknown parameter\(s\) \['nms'\].*nms_size"),
    ("param-nan", lambda: HopfieldMatcher.create(theta=float("nan")), InvalidArgumentError,
     r"`theta` must be a finite number"),
    ("param-str", lambda: HopfieldMatcher.create(max_disparity="64"), InvalidTypeError,
     r"`max_disparity` must be a number, got str"),
    ("param-even-window", lambda: DericheMoravecDetector.create(window_size=4),
     InvalidArgumentError, r"`window_size` must be odd"),
    ("param-bool-as-int", lambda: DericheMoravecDetector.create(nms_size=True),
     InvalidTypeError, r"`nms_size` must be an integer"),
    ("param-out-of-range", lambda: HopfieldMatcher.create(seed=-1), InvalidArgumentError,
     r"`seed` must be in \[0, "),
    ("param-max-pixels-zero", lambda: DericheMoravecDetector.create(max_pixels=0),
     InvalidArgumentError, r"`max_pixels` must be in \[1, "),
    ("disparity-order", lambda: HopfieldMatcher.create(min_disparity=10, max_disparity=5),
     InvalidArgumentError, r"`max_disparity` \(5.0\) must not be below `min_disparity`"),
    ("setter-disparity-order", lambda: HopfieldMatcher(max_disparity=5).setMinDisparity(9),
     InvalidArgumentError, r"must not be below"),
    ("preset-typo", lambda: HopfieldMatcher.create(preset="papr"), InvalidArgumentError,
     r"`preset` must be one of \['default', 'paper'\], got 'papr'"),
    ("preset-type", lambda: DericheMoravecDetector.create(preset=1), InvalidTypeError,
     r"`preset` must be one of"),
    # -- budgets ---------------------------------------------------------------------------
    ("neuron-budget", lambda: _matcher(max_neurons=5).match(DES, DES), BudgetExceededError,
     r"neurons.*max_neurons=5.*raise max_neurons"),
    ("interaction-budget", lambda: _matcher(max_interactions=5).match(DES, DES),
     BudgetExceededError, r"max_interactions=5"),
    ("crowded-points",
     lambda: hopfield_match(np.zeros((3000, 2), np.float32), np.full((3000, 2), 500, np.float32),
                            np.ones((3000, 4), np.float32), np.ones((3000, 4), np.float32),
                            max_disparity=10, max_interactions=1_000_000),
     BudgetExceededError, r"neighbour lists.*max_interactions=1000000.*duplicate"),
    ("energy-trace-budget",
     lambda: hopfield_match(PTS, PTS, DES, DES, max_disparity=8, max_iterations=2**40,
                            record_energy=True),
     BudgetExceededError, r"record_energy.*max_iterations=1099511627776"),
    # -- files and pickles -------------------------------------------------------------------
    ("read-missing", lambda: HopfieldMatcher().read("/nonexistent/params.yml"),
     InvalidArgumentError, r"`fs`: no such file"),
    ("write-suffix", lambda: HopfieldMatcher().write("/tmp/params.txt"), InvalidArgumentError,
     r"`fs` path must end in .yml"),
    ("read-wrong-object", lambda: HopfieldMatcher().read(42), InvalidTypeError,
     r"`fs` must be a path, a cv2.FileStorage or a cv2.FileNode"),
    ("pickle-state-none", lambda: _pickled_state(None), InvalidArgumentError,
     r"cannot restore a HopfieldMatcher from NoneType"),
    ("pickle-state-no-params", lambda: _pickled_state({}), InvalidArgumentError,
     r"expected \{'params'"),
    ("pickle-state-bad-value", lambda: _pickled_state({"params": {"theta": "x"}}),
     InvalidTypeError, r"`theta` must be a number"),
    ("pickle-state-unknown", lambda: _pickled_state({"params": {"thetaa": 1.0}}),
     InvalidArgumentError, r"unknown parameter"),
]


@pytest.mark.parametrize("call, exc, pattern", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input(call, exc, pattern):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HopmatchWarning)
        with pytest.raises(exc, match=pattern) as info:
            call()
    # one vocabulary: hopmatch's own classes, which are ValueError or TypeError
    assert isinstance(info.value, HopmatchError)
    assert isinstance(info.value, (ValueError, TypeError))


def test_matrix_is_large_enough():
    assert len({c[0] for c in CASES}) == len(CASES) >= 40


# -- FileStorage files with wrong contents ----------------------------------------------------


@pytest.mark.parametrize("body, exc, pattern", [
    ("hopmatch_HopfieldMatcher:\n   theta: abc\n", InvalidTypeError, r"`theta` must be a number"),
    ("hopmatch_HopfieldMatcher:\n   seed: 1.5\n", InvalidTypeError, r"`seed` must be an integer"),
    ("hopmatch_HopfieldMatcher:\n   cross_check: 2\n", InvalidTypeError,
     r"`cross_check` must be True or False"),
    ("hopmatch_HopfieldMatcher:\n   theta: [1, 2]\n", InvalidTypeError,
     r"`theta` holds a sequence"),
    ("hopmatch_HopfieldMatcher:\n   theta: {a: 1}\n", InvalidTypeError, r"`theta` holds a map"),
    ("hopmatch_HopfieldMatcher:\n   preset: nope\n", InvalidArgumentError, r"`preset` must be one"),
    ("other_node:\n   x: 1\n", InvalidArgumentError, r"no node named 'hopmatch_HopfieldMatcher'"),
], ids=["str-for-float", "float-for-int", "int-for-bool", "sequence", "map", "preset", "no-node"])
def test_bad_filestorage(tmp_path, body, exc, pattern):
    with pytest.raises(exc, match=pattern):
        _read_yml(tmp_path, body)


def test_garbage_file_is_refused(tmp_path):
    path = tmp_path / "garbage.yml"
    path.write_bytes(b"\x00\xff\x13 not yaml {[")
    with pytest.raises(InvalidArgumentError, match="`fs`"):
        HopfieldMatcher().read(path)


def test_failed_read_keeps_parameters(tmp_path):
    m = HopfieldMatcher(theta=3.0)
    with pytest.raises(InvalidTypeError):
        path = tmp_path / "p.yml"
        path.write_text("%YAML:1.0\n---\nhopmatch_HopfieldMatcher:\n   theta: abc\n")
        m.read(path)
    assert m.getTheta() == 3.0


def test_pickle_round_trip_and_foreign_pickle():
    m = HopfieldMatcher(theta=3.0, max_disparity=20)
    assert pickle.loads(pickle.dumps(m)).get_params() == m.get_params()
    d = DericheMoravecDetector(max_pixels=1234)
    assert pickle.loads(pickle.dumps(d)).getMaxPixels() == 1234


# -- well-formed empty results ------------------------------------------------------------------


@pytest.mark.parametrize("image", [
    np.zeros((50, 60), np.uint8), np.full((50, 60), 7, np.uint16), np.ones((50, 60, 3), np.float32),
    np.zeros((1, 1), np.uint8), np.zeros((1, 200), np.uint8), np.zeros((3, 3, 4), np.int16),
], ids=["blank", "flat-16bit", "flat-bgr-float", "1x1", "1-row", "tiny-bgra"])
def test_blank_images_give_empty_results(image):
    kps, desc = DET.detectAndCompute(image, None)
    assert kps == () and desc.shape == (0, DET.descriptorSize()) and desc.dtype == np.float32
    # match_stereo says why nothing came (cv2's detectAndCompute, above, stays silent as
    # cv2's detectors do)
    with pytest.warns(FewMatchesWarning, match="the left image has no keypoint: it is "
                      "(flat|.* too small for the detector's 9 x 9 windows).*; the right"):
        res = match_stereo(image, image)
    assert res.matches == () and res.disparities.shape == (0,)
    assert res.points_left.shape == (0, 2) and res.points_left.dtype == np.float32


def test_all_zero_mask_gives_empty_result():
    kps, desc = DET.detectAndCompute(IMG, np.zeros(IMG.shape, np.uint8))
    assert kps == () and desc.shape == (0, DET.descriptorSize())
    with pytest.warns(FewMatchesWarning) as caught:
        res = match_stereo(IMG, IMG, mask_left=np.zeros(IMG.shape, bool))
    assert res.matches == () and res.query_idx.dtype == np.int32
    said = [str(w.message) for w in caught if w.category is FewMatchesWarning]
    assert said == ["no matches: the left image has no keypoint: its mask excludes every "
                    "pixel"]


def test_a_mask_smaller_than_a_window_says_so():
    """A mask that keeps fewer pixels than one descriptor window holds is named as the
    cause (it was taken for faint texture before 2026-12-06)."""
    mask = np.zeros(IMG.shape, bool)
    mask[30, 40] = True
    with pytest.warns(FewMatchesWarning) as caught:
        res = match_stereo(IMG, IMG, mask_left=mask)
    assert res.matches == ()
    said = [str(w.message) for w in caught if w.category is FewMatchesWarning]
    assert said == ["no matches: the left image has no keypoint: its mask keeps only 1 "
                    "pixel, fewer than one of the detector's 9 x 9 windows"]


def test_no_keypoints_from_texture_names_the_threshold():
    with pytest.warns(FewMatchesWarning, match="left image has no keypoint: its texture is "
                      "too faint for the detector .lower its `threshold`"):
        res = match_stereo(IMG, IMG, threshold=1e30)
    assert res.matches == ()


def test_zero_keypoints_give_empty_matches():
    m = HopfieldMatcher(max_disparity=8)
    empty = np.zeros((0, 2), np.float32)
    m.setPairInfo(empty, PTS, (96, 72), (96, 72))
    assert m.match(np.zeros((0, DES.shape[1]), np.float32), DES) == ()
    assert m.knnMatch(np.zeros((0, DES.shape[1]), np.float32), DES, k=2) == []
    m.setPairInfo(PTS, [], (96, 72), (96, 72))
    assert m.match(DES, np.zeros((0, 0), np.float32)) == ()
    rows = m.knnMatch(DES, np.zeros((0, 0), np.float32), k=3)
    assert len(rows) == N and all(r == [] for r in rows)


def test_keypoints_outside_the_image_are_dropped():
    far = [cv2.KeyPoint(1e9, 5.0, 3.0), cv2.KeyPoint(-1e9, -5.0, 3.0),
           cv2.KeyPoint(3e38, 3e38, 3.0), KPS[0]]
    kept, desc = DET.compute(IMG, far)
    assert kept == (KPS[0],) and desc.shape == (1, DET.descriptorSize())


def test_huge_k_is_capped_by_the_train_set():
    rows = _matcher().knnMatch(DES, DES, k=10**12)
    assert len(rows) == N and all(len(r) == N for r in rows)


def test_big_endian_and_strided_images_match_native():
    img16 = (IMG.astype(np.uint16) * 200)
    ref = DET.detect_points(img16)[0]
    np.testing.assert_array_equal(DET.detect_points(img16.astype(">u2"))[0], ref)
    np.testing.assert_array_equal(DET.detect_points(np.asfortranarray(img16))[0], ref)
    wide = np.zeros((72, 192), np.uint16)
    wide[:, ::2] = img16
    np.testing.assert_array_equal(DET.detect_points(wide[:, ::2])[0], ref)


def test_ten_thousand_square_image_is_refused_cleanly():
    # a read-only broadcast view: nothing of 10^8 pixels is allocated before the refusal
    huge = np.broadcast_to(np.uint8(0), (10_000, 10_000))
    with pytest.raises(BudgetExceededError, match=r"10000 x 10000 = 100000000 pixels.*"
                                                  r"max_pixels=50000000.*GiB"):
        DET.detectAndCompute(huge, None)
    with pytest.raises(BudgetExceededError, match="`right`"):
        match_stereo(np.zeros((8, 8), np.uint8), huge)


# -- warnings -----------------------------------------------------------------------------------


def _texture(h=160, w=200, seed=3):
    rng = np.random.default_rng(seed)
    return cv2.GaussianBlur((rng.random((h, w)) * 255).astype(np.uint8), (0, 0), 1.2)


def test_width_mismatch_warns():
    left = _texture()
    with pytest.warns(ImageSizeWarning, match=r"`left` is 200 px wide and `right` 150 px"):
        match_stereo(left, left[:, :150], max_disparity=16)


def test_height_mismatch_is_an_error():
    left = _texture()
    with pytest.raises(InvalidArgumentError, match="same height.*fundamental_matrix"):
        match_stereo(left, left[:150], max_disparity=16)


def test_matcher_size_mismatch_warns():
    m = HopfieldMatcher(max_disparity=8)
    m.setPairInfo(PTS, PTS, (96, 72), (96, 70))
    with pytest.warns(ImageSizeWarning, match="96 x 72.*96 x 70"):
        m.match(DES, DES)


def test_disparity_range_wider_than_image_warns():
    with pytest.warns(DisparityRangeWarning, match=r"\[0, 500\].*width \(96 px\)"):
        match_stereo(IMG, IMG, max_disparity=500)
    with pytest.warns(DisparityRangeWarning):
        _matcher(min_disparity=-200).match(DES, DES)


def test_unrectified_pair_warns_and_rectified_does_not():
    left = _texture()
    right = np.roll(left, -6, axis=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", HopmatchWarning)
        res = match_stereo(left, right, max_disparity=16)  # rectified: silent
    assert len(res.matches) > 50
    with pytest.warns(UnrectifiedPairWarning, match=r"median 5\.\d px"):
        match_stereo(left, np.roll(right, 5, axis=0), max_disparity=16)
    # with the fundamental matrix of that vertical shift (content 5 px lower on the right:
    # y_r = y_l + 5, i.e. x_r^T F x_l = y_l - y_r + 5) there is nothing to warn about. The
    # sign of F's last entry was -5 before issue 20, which matched nothing, silently: the
    # few-matches warning caught it
    F = np.array([[0, 0, 0], [0, 0, -1], [0, 1, 5.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error", HopmatchWarning)
        res = match_stereo(left, np.roll(right, 5, axis=0), max_disparity=16,
                           fundamental_matrix=F)
    assert len(res.matches) > 50


def test_warnings_are_hopmatch_warnings():
    for cls in (ImageSizeWarning, DisparityRangeWarning, UnrectifiedPairWarning):
        assert issubclass(cls, HopmatchWarning) and issubclass(cls, UserWarning)


def test_detector_normalises_images_whose_gradient_would_overflow():
    """Before issue 20 the detector refused this image (its float32 gradient overflowed:
    "too large for the float32 gradient filter"); it now scales each image to a common
    spread of grey levels first (feature.gradient.normalised_intensity), so the image is
    measured as the same pattern at any gain. The pure deriche_gradient still refuses it
    (case gradient-fn-overflow)."""
    pattern = np.where(np.indices((20, 20)).sum(0) % 2, 1.0, -1.0).astype(np.float32)
    kps = DET.detect(pattern * np.float32(3e38))
    assert cv2.KeyPoint_convert(kps).tolist() == cv2.KeyPoint_convert(DET.detect(pattern)).tolist()
