"""hopmatch.feature.padding: the black padding a warp leaves around an image."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from hopmatch.feature.padding import black_padding, fill_padding


def texture(seed: int, shape=(200, 300)) -> np.ndarray:
    """Blurred noise stretched to 1-255: no pixel is 0."""
    noise = np.random.default_rng(seed).random(shape).astype(np.float32)
    blurred = cv2.GaussianBlur(noise, (0, 0), 1.5)
    lo, hi = blurred.min(), blurred.max()
    return (1 + 254 * (blurred - lo) / (hi - lo)).astype(np.uint8)


def rotated(img):
    A = cv2.getRotationMatrix2D((149.5, 99.5), 5.0, 0.97)
    A[1, 2] += 12
    out = cv2.warpAffine(img, A, (300, 200), flags=cv2.INTER_LINEAR)
    outside = cv2.warpAffine(np.full(img.shape, 255, np.uint8), A, (300, 200),
                             flags=cv2.INTER_NEAREST) == 0
    return out, outside


def test_black_padding_is_found_and_filled():
    img = texture(5)
    assert not black_padding(img).any() and fill_padding(img) is img
    turned, outside = rotated(img)
    pad = black_padding(turned)
    assert pad.sum() >= 0.9 * outside.sum() and not (pad & ~outside).any()
    filled = fill_padding(turned)
    assert (filled[pad] == np.median(turned[~pad])).all()
    assert (filled[~pad] == turned[~pad]).all()
    # a few black pixels in a corner are content, not padding
    few = img.copy()
    few[:3, :3] = 0
    assert not black_padding(few).any()


@pytest.mark.parametrize("dtype", [np.uint16, np.float64, np.int16, np.float32])
def test_black_padding_of_any_dtype_is_that_of_its_8_bit_twin(dtype):
    """OpenCV's floodFill takes 8-bit and float32 images only: a 16-bit or float64 image
    padded by a warp gives the same padding (no cv2.error)."""
    turned, _ = rotated(texture(7))
    pad = black_padding(turned)
    assert pad.any()
    np.testing.assert_array_equal(black_padding(turned.astype(dtype)), pad)
    filled = fill_padding(turned.astype(dtype))
    assert filled.dtype == dtype and (filled[pad] == np.median(turned[~pad])).all()


def test_a_dark_corner_that_leaves_no_convex_picture_is_no_padding():
    """An underexposed photo's darkest level may fill a corner, but what is left is the
    scene's outline, not the convex image of a rectangle: no padding."""
    img = texture(9)
    dark = img.copy()
    yy, xx = np.mgrid[:200, :300]
    dark[(xx < 150) & ((yy < 60) | (yy > 140) | (xx < 40))] = 0  # a C-shaped dark corner
    assert not black_padding(dark).any() and fill_padding(dark) is dark
