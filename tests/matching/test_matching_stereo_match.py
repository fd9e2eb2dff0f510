"""match_stereo with ready detector and matcher instances; the refinement window and the
image size."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

import hopmatch
from hopmatch.errors import InvalidArgumentError, InvalidTypeError
from hopmatch.matching import stereo_match
from hopmatch.matching.refine import REFINE_RADIUS, refine_disparities
from hopmatch.matching.stereo_match import refine_radius, split_parameters, stereo_pipeline

RNG = np.random.default_rng(1)
LEFT = (RNG.random((120, 160)) * 255).astype(np.uint8)
RIGHT = np.roll(LEFT, -6, axis=1)


def _same(a, b):
    for name in ("points_left", "points_right", "query_idx", "train_idx", "distances"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_instances_give_what_keywords_give():
    by_keywords = hopmatch.match_stereo(LEFT, RIGHT, max_disparity=12, nms_size=5, seed=3)
    det = hopmatch.DericheMoravecDetector(nms_size=5)
    mat = hopmatch.HopfieldMatcher(max_disparity=12, seed=3)
    _same(by_keywords, hopmatch.match_stereo(LEFT, RIGHT, detector=det, matcher=mat))
    assert mat.empty()  # its pair information is left untouched


def test_instances_and_their_keywords_do_not_mix():
    det = hopmatch.DericheMoravecDetector()
    with pytest.raises(InvalidArgumentError, match="`detector` instance.*nms_size"):
        hopmatch.match_stereo(LEFT, RIGHT, detector=det, nms_size=5)
    with pytest.raises(InvalidTypeError, match="`matcher` must be a HopfieldMatcher"):
        hopmatch.match_stereo(LEFT, RIGHT, matcher=object())


def test_split_parameters_is_the_one_rule():
    det, mat = split_parameters({"preset": "paper", "nms_size": 5, "theta": 3.0})
    assert det == {"preset": "paper", "nms_size": 5}
    assert mat == {"preset": "paper", "theta": 3.0}
    with pytest.raises(InvalidArgumentError, match="batch got unknown parameter"):
        split_parameters({"nope": 1}, caller="batch")
    d, m = stereo_pipeline({"nms_size": 5, "theta": 3.0})
    assert d.getNmsSize() == 5 and m.getTheta() == 3.0


def test_refine_radius_keeps_7x7_on_the_shared_scenes_and_grows_beyond():
    assert refine_radius((500, 741)) == REFINE_RADIUS == 3  # motorcycle
    assert refine_radius((376, 1241)) == 3  # KITTI
    assert refine_radius((1110, 1282)) == 4  # aloe, full size
    assert refine_radius((2000, 2964)) == 6  # full-size Middlebury 2014
    sizes = [(h, int(1.5 * h)) for h in range(100, 4000, 50)]
    radii = [refine_radius(s) for s in sizes]
    assert radii == sorted(radii) and radii[0] == 3


def _fourier_shift(image, dx):
    kx = np.fft.fftfreq(image.shape[1])
    return np.real(np.fft.ifft2(np.fft.fft2(image) * np.exp(-2j * np.pi * kx * dx)[None, :]))


def test_the_wider_window_fixes_upsampled_disparities_better():
    # A texture four times upsampled (as a full-size image of a scene whose detail is
    # coarser than its pixels), shifted by 1.2 px, with sensor noise on both images: the
    # 7 x 7 window sees too little of it; the radius the rule gives at 2964 x 2000 sees more.
    rng = np.random.default_rng(0)
    n = 96
    base = rng.random((n, n)) * 255

    def up(a):
        big = cv2.resize(a.astype(np.float32), (4 * n, 4 * n), interpolation=cv2.INTER_CUBIC)
        return big + rng.normal(0, 3, big.shape).astype(np.float32)

    left, right = up(base), up(_fourier_shift(base, -0.3))
    ys, xs = np.mgrid[40:4 * n - 40:9, 40:4 * n - 40:9]
    pts = np.c_[xs.ravel(), ys.ravel()].astype(np.float64) + 0.37
    start = pts[:, 0] - 1.2 + rng.uniform(-0.8, 0.8, len(pts))
    errors = {}
    for radius in (REFINE_RADIUS, refine_radius((2000, 2964))):
        r = refine_disparities(left, right, pts, start, pts[:, 1], radius=radius)
        assert r.ok.mean() > 0.9
        errors[radius] = float(np.median(np.abs(pts[r.ok, 0] - r.x[r.ok] - 1.2)))
    assert errors[6] < 0.75 * errors[3], errors


def test_match_stereo_refines_with_the_radius_of_its_image_size(monkeypatch):
    seen = []

    def spy(*args, radius, **kwargs):
        seen.append(radius)
        return refine_disparities(*args, radius=radius, **kwargs)

    monkeypatch.setattr(stereo_match, "refine_disparities", spy)
    rng = np.random.default_rng(2)
    big = cv2.resize((rng.random((250, 250)) * 255).astype(np.float32), (1000, 1000),
                     interpolation=cv2.INTER_CUBIC)
    big = np.clip(big, 0, 255).astype(np.uint8)
    mask = np.zeros(big.shape, np.uint8)
    mask[400:600, 400:600] = 1  # detect in a small part only: the images stay 1 Mpixel
    res = hopmatch.match_stereo(big, np.roll(big, -8, axis=1), mask_left=mask,
                                mask_right=np.roll(mask, -8, axis=1), max_disparity=16)
    assert seen == [refine_radius(big.shape)] * 2 == [4, 4]  # each run of both_features
    assert res.refinement is not None and res.refinement.ok.mean() > 0.8
    good = res.refinement.ok
    assert np.median(np.abs(res.disparities[good] - 8.0)) < 0.1
    seen.clear()
    hopmatch.match_stereo(LEFT, RIGHT, max_disparity=12, both_features=False)
    assert seen == [REFINE_RADIUS]


def test_a_pair_found_off_its_rows_after_the_tone_map_is_matched_as_unrectified(motorcycle):
    """Motorcycle's right view rotated 3 degrees, shifted 10 px down and darkened by gamma
    2.5: the first match, on views of unlike grey levels, finds too few look-alikes to
    tell the pair is off its rows; the second match through the tone map does, and the
    defaults then match the pair as an unrectified one (before 2026-12-05 they searched
    its rows: 88 matches, and a warning). The right points mapped back through the
    rotation lie within 1 px of the ground truth."""
    import warnings

    from hopmatch.errors import UnrectifiedPairWarning
    from hopmatch.evaluate import correct_matches, score_matches

    left, right, disparity = motorcycle
    h, w = right.shape[:2]
    m = np.vstack([cv2.getRotationMatrix2D(((w - 1) / 2, (h - 1) / 2), 3.0, 1.0),
                   [0, 0, 1]])
    m = np.array([[1, 0, 0], [0, 1, 10.0], [0, 0, 1]]) @ m
    moved = cv2.warpAffine(right, m[:2], (w, h), flags=cv2.INTER_LINEAR,
                           borderMode=cv2.BORDER_REFLECT)
    dark = np.clip(255.0 * (moved.astype(np.float32) / 255.0) ** 2.5, 0, 255).astype(np.uint8)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = hopmatch.match_stereo(left, dark)
    said = [str(c.message) for c in caught if issubclass(c.category, UnrectifiedPairWarning)]
    assert len(said) == 1 and "matched as an unrectified pair" in said[0]
    assert res.fundamental_matrix is not None and len(res.query_idx) > 2000
    back = cv2.transform(res.matched_right[None].astype(np.float64),
                         np.linalg.inv(m)[:2])[0]
    scores = score_matches(res.matched_left, back, disparity, thresholds=(1.0,))
    ok, known = correct_matches(scores, res.matched_left, back, 1.0)
    assert known.sum() > 1000 and (ok & known).sum() / known.sum() > 0.95


def test_a_right_view_of_another_width_keeps_the_guided_pass_and_the_refinement():
    """Rows of one height but a right view 30 px narrower (cropped on its right): a width
    warning, and the same steps after the network as for the full pair (before
    2026-12-05 the guided pass and the refinement ran only on images of one size), the
    matches as right."""
    from synthetic_pairs import texture

    from hopmatch.errors import ImageSizeWarning

    scene = texture(160, 260, seed=4, sigma=1.3).astype(np.uint8)
    left, right = scene[:, 10:250], scene[:, 16:256]  # disparity 6
    full = hopmatch.match_stereo(left, right, max_disparity=16)
    with pytest.warns(ImageSizeWarning, match="240 px wide and `right` 210 px"):
        cut = hopmatch.match_stereo(left, right[:, :210], max_disparity=16)
    assert cut.refinement is not None and np.any(cut.passes == 1)
    assert len(cut.query_idx) >= 0.8 * len(full.query_idx)
    assert np.mean(np.abs(cut.disparities - 6.0) <= 0.5) > 0.98
