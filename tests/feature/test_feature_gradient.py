"""hopmatch.feature.gradient's intensity normalisation (issue 20): points, descriptors and
matches independent of the images' gain and dtype."""

from __future__ import annotations

import warnings

import cv2
import numpy as np
import pytest

import hopmatch
from hopmatch.feature.gradient import (
    INTENSITY_RANGE,
    intensity_spread,
    normalised_intensity,
)


def _pair(seed=0, shape=(200, 260), shift=6):
    rng = np.random.default_rng(seed)
    img = cv2.GaussianBlur(rng.uniform(0, 255, shape).astype(np.float32), (0, 0), 1.5)
    img = cv2.normalize(img, None, 10, 245, cv2.NORM_MINMAX).astype(np.uint8)
    return img, np.roll(img, -shift, axis=1)


def test_spread_follows_gain_not_offset_or_dtype():
    left, _ = _pair()
    base = intensity_spread(left.astype(np.float32))
    assert intensity_spread(left.astype(np.float32) * 3 + 100) == pytest.approx(3 * base)
    assert intensity_spread(left.astype(np.uint16) * 257) == pytest.approx(257 * base)
    out = normalised_intensity(left)
    assert out.dtype == np.float32 and intensity_spread(out) == pytest.approx(INTENSITY_RANGE)
    flat = np.full((10, 10), 7, np.uint8)
    np.testing.assert_array_equal(normalised_intensity(flat), flat.astype(np.float32))


def test_spread_ignores_the_black_fill_of_a_warped_view():
    """A view warped with cv2.warpAffine's black border (rectification, a rotation) keeps
    the spread of its content: counted in, 4 % of fill pixels moved the 1st percentile
    to 0 and gave two views of equal gain scales 1.4x apart (the unrectified-path test pair)."""
    left, _ = _pair()
    h, w = left.shape
    A = cv2.getRotationMatrix2D((w / 2, h / 2), 5.0, 1.03)
    A[1, 2] += 12
    warped = cv2.warpAffine(left, A, (w, h), flags=cv2.INTER_LINEAR)
    assert (warped == 0).mean() > 0.04
    assert intensity_spread(warped) == pytest.approx(intensity_spread(left), rel=0.03)
    # an image that is mostly one level (two levels only) keeps the plain percentiles
    binary = np.zeros((40, 40), np.uint8)
    binary[:, 30:] = 200
    assert intensity_spread(binary) == 200.0


@pytest.mark.parametrize("label, make", [
    ("uint16 x257", lambda r: r.astype(np.uint16) * 257),
    ("float32 in [0, 1]", lambda r: r.astype(np.float32) / 255),
    ("half gain", lambda r: (r // 2).astype(np.uint8)),
    ("0.75 gain", lambda r: (r * 0.75).astype(np.uint8)),
    ("gain 2, float32", lambda r: r.astype(np.float32) * 2),
    ("offset", lambda r: (r.astype(np.int16) - 100)),
])
def test_matches_do_not_depend_on_the_right_images_gain_or_dtype(label, make):
    """Before issue 20 the first three gave 0 matches (and no warning), 0.75 gain 60 %."""
    left, right = _pair()
    with warnings.catch_warnings():
        warnings.simplefilter("error", hopmatch.errors.HopmatchWarning)
        want = hopmatch.match_stereo(left, right, max_disparity=16)
        got = hopmatch.match_stereo(left, make(right), max_disparity=16)
    assert len(want.matches) > 500
    assert len(got.matches) >= 0.9 * len(want.matches), label
    assert np.mean(np.abs(got.disparities - 6) <= 1) > 0.97


def test_both_images_as_floats_in_unit_range_match_as_uint8():
    left, right = _pair()
    want = hopmatch.match_stereo(left, right, max_disparity=16)
    got = hopmatch.match_stereo(left.astype(np.float32) / 255, right.astype(np.float32) / 255,
                                max_disparity=16)
    assert abs(len(got.matches) - len(want.matches)) <= 0.02 * len(want.matches)
