"""hopmatch.feature.sharpness: two views of unequal sharpness made nearly equal before
detection (``sharpness_ratio``)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from synthetic_pairs import texture

import hopmatch
from hopmatch.feature import sharpness as sh


def _image(seed=0, shape=(300, 320), sigma=0.8):
    return texture(*shape, seed=seed, sigma=sigma).astype(np.float32)


def _naive_sharpness(image: np.ndarray) -> float:
    """The measure written out pixel by pixel over the rows :func:`sharpness` reads."""
    rows = image[::sh.ROW_STEP].astype(np.float64)
    second = first = 0.0
    for row in rows:
        for x in range(2, len(row) - 2):
            second += abs(row[x - 2] - 2 * row[x] + row[x + 2])
            first += abs(row[x + 2] - row[x - 2])
    return second / first


def test_sharpness_matches_the_pixel_loop_and_ignores_gain_and_offset():
    img = _image()[:40, :50]
    assert sh.sharpness(img) == pytest.approx(_naive_sharpness(img), rel=1e-5)
    assert sh.sharpness(3.0 * img + 40.0) == pytest.approx(sh.sharpness(img), rel=1e-5)
    assert sh.sharpness(cv2.GaussianBlur(img, (0, 0), 1.0)) < 0.8 * sh.sharpness(img)
    assert np.isnan(sh.sharpness(np.full((20, 20), 9, np.float32)))
    assert np.isnan(sh.sharpness(np.zeros((20, 4), np.float32)))


def test_central_rows_are_the_middle_rows():
    assert sh.central_rows(600) == slice(172, 172 + sh.BAND_ROWS)
    assert sh.central_rows(10) == slice(0, sh.BAND_ROWS)


def test_only_valid_triples_are_measured():
    """Pixels outside ``valid`` (a warped view's empty corners) count for nothing."""
    img = _image(seed=8)[:60, :80]
    valid = np.ones(img.shape, bool)
    valid[:, :30] = False
    noisy = img.copy()
    noisy[:, :29] = np.random.default_rng(0).uniform(0, 255, (60, 29))  # 29: not valid
    assert sh.sharpness(noisy, valid) == pytest.approx(sh.sharpness(img[:, 30:]), rel=1e-6)
    assert sh.sharpness(noisy) > sh.sharpness(img)


@pytest.mark.parametrize("sigma", [0.7, 1.0, 1.6])
def test_matching_sigma_recovers_a_known_blur(sigma):
    sharp = _image(seed=3)
    target = sh.sharpness(cv2.GaussianBlur(sharp, (0, 0), sigma))
    assert sh.matching_sigma(sharp, target) == pytest.approx(sigma, abs=0.1)
    # not sharper than the target: nothing to do
    assert sh.matching_sigma(cv2.GaussianBlur(sharp, (0, 0), sigma), sh.sharpness(sharp)) == 0.0


def test_matching_sigma_stops_at_its_largest_sigma():
    sharp = _image(seed=4)
    assert sh.matching_sigma(sharp, 1e-6) == sh.MAX_SIGMA


def test_equal_views_are_returned_untouched():
    left = _image(seed=1).astype(np.uint8)
    right = np.roll(left, -5, axis=1)
    out_l, out_r, record = sh.equalise_sharpness(left, right, 1.1)
    assert out_l is left and out_r is right
    assert record.sigma_left == record.sigma_right == 0.0
    assert record.sharpness_left == pytest.approx(record.sharpness_right, rel=0.05)


@pytest.mark.parametrize("blurred_side", ["left", "right"])
def test_the_sharper_view_is_blurred_to_within_the_residual(blurred_side):
    sharp = _image(seed=2)
    soft = cv2.GaussianBlur(sharp, (0, 0), 1.2)
    pair = (soft, sharp) if blurred_side == "left" else (sharp, soft)
    out_l, out_r, record = sh.equalise_sharpness(*pair, 1.1)
    expected = np.sqrt(1.2 ** 2 - sh.RESIDUAL_SIGMA ** 2)
    if blurred_side == "left":  # the right view was the sharper one
        assert out_l is soft and record.sigma_left == 0.0
        assert record.sigma_right == pytest.approx(expected, abs=0.1)
        np.testing.assert_allclose(out_r, cv2.GaussianBlur(sharp, (0, 0), record.sigma_right))
    else:
        assert out_r is soft and record.sigma_right == 0.0
        assert record.sigma_left == pytest.approx(expected, abs=0.1)
        np.testing.assert_allclose(out_l, cv2.GaussianBlur(sharp, (0, 0), record.sigma_left))


def test_a_difference_within_the_residual_is_left_alone():
    sharp = _image(seed=5)
    soft = cv2.GaussianBlur(sharp, (0, 0), 0.8 * sh.RESIDUAL_SIGMA)
    out_l, out_r, record = sh.equalise_sharpness(sharp, soft, 1.0)
    assert out_l is sharp and out_r is soft and record.sigma_left == 0.0


def test_no_ratio_or_a_flat_view_never_blurs():
    sharp = _image(seed=6)
    soft = cv2.GaussianBlur(sharp, (0, 0), 1.5)
    out_l, _, record = sh.equalise_sharpness(sharp, soft, None)
    assert out_l is sharp and record.sigma_left == 0.0
    assert record.sharpness_left > record.sharpness_right
    flat = np.full_like(sharp, 50.0)
    out_l, out_r, record = sh.equalise_sharpness(sharp, flat, 1.1)
    assert out_l is sharp and out_r is flat and np.isnan(record.sharpness_right)


def test_match_stereo_equalises_and_says_so():
    """A right view blurred by 1.5 px: the left one is blurred before detection, and more
    correct matches come back than with ``sharpness_ratio=None``."""
    h, w, d = 220, 300, 7
    base = texture(h, w + d, seed=11, sigma=0.7)
    left = np.clip(base[:, :w], 0, 255).astype(np.uint8)
    right = cv2.GaussianBlur(np.clip(base[:, d:], 0, 255).astype(np.uint8), (0, 0), 1.5)

    def correct(res):
        return int(np.sum(np.abs(res.disparities - d) <= 1.0))

    on = hopmatch.match_stereo(left, right, max_disparity=16)
    with pytest.warns(hopmatch.errors.HopmatchWarning):  # few or no matches: it says why
        off = hopmatch.match_stereo(left, right, max_disparity=16, sharpness_ratio=None)
    assert on.sharpness.sigma_left > 1.0 and on.sharpness.sigma_right == 0.0
    assert off.sharpness.sigma_left == 0.0
    assert off.sharpness.sharpness_left > 1.1 * off.sharpness.sharpness_right
    assert correct(on) > correct(off)
    paper = hopmatch.match_stereo(left, right, preset="paper")
    assert paper.sharpness.sigma_left == 0.0 and paper.network.config.sharpness_ratio is None


@pytest.mark.parametrize("value, exc", [(0.5, ValueError), ("1.2", TypeError),
                                        (float("nan"), ValueError)])
def test_sharpness_ratio_is_checked(value, exc):
    left = _image(seed=7).astype(np.uint8)
    with pytest.raises(exc, match="sharpness_ratio"):
        hopmatch.match_stereo(left, left, sharpness_ratio=value)


def test_grey_levels_near_the_float32_limit_blur_without_overflow():
    """A float32 view of +-3.4e38 (refused by nothing: finite) was blurred in float32,
    whose sums overflowed to infinity, and the sharpness of the blurred view then
    subtracted infinities (a RuntimeWarning, and a NaN in the bisection)."""
    import warnings

    g = texture(60, 80, seed=3)
    huge = np.where(g > 128, 3.4e38, -3.4e38).astype(np.float32)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        out = sh.blurred(huge, 2.0)
        measured = sh.sharpness(out)
    assert out.dtype == np.float32 and np.isfinite(out).all()
    assert np.abs(out).max() <= 3.4e38 and np.isfinite(measured)
    scaled = sh.blurred((huge / np.float32(3.4e36)), 2.0) * np.float32(3.4e36)
    assert np.allclose(out, scaled, rtol=1e-4, atol=3.4e38 * 1e-6)
