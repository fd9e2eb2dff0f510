"""The sub-pixel refinement: its kernel against the NumPy reference, and its accuracy on
synthetic sub-pixel shifts of noise-free textures."""

from __future__ import annotations

import cv2
import naive_guided as ng
import numpy as np
import pytest

from hopmatch.errors import InvalidArgumentError
from hopmatch.matching.refine import (
    REFINE_ITERATIONS,
    REFINE_LEVELS,
    REFINE_MAX_SHIFT,
    REFINE_RADIUS,
    REFINE_STEP,
    REFINE_TOL,
    refine_disparities,
)


def texture(h, w, seed=0, sigma=1.2):
    rng = np.random.default_rng(seed)
    t = cv2.GaussianBlur(rng.normal(size=(h, w)), (0, 0), sigma)
    return (t - t.min()) / (t.max() - t.min()) * 200 + 20


def shifted(img, d):
    """``img`` moved left by d px (``out(x) = img(x + d)``), exactly for this periodic,
    band-limited texture (Fourier shift theorem)."""
    f = np.fft.fft2(img)
    fx = np.fft.fftfreq(img.shape[1])
    return np.real(np.fft.ifft2(f * np.exp(2j * np.pi * fx * d)[None, :]))


def grid_points(h, w, margin=20, step=6, offset=(0.37, 0.21)):
    return np.array([[x + offset[0], y + offset[1]] for y in range(margin, h - margin, step)
                     for x in range(margin + 20, w - margin, step)], np.float64)


def test_kernel_matches_the_reference():
    rng = np.random.default_rng(3)
    img_l = texture(60, 90, 1)
    img_r = shifted(img_l, 5.3)
    pts = np.c_[rng.uniform(15, 75, 25), rng.uniform(12, 48, 25)]
    xr = pts[:, 0] - 5.3 + rng.uniform(-0.6, 0.6, 25)
    yr = pts[:, 1] + rng.uniform(-0.2, 0.2, 25)
    ref = refine_disparities(img_l, img_r, pts, xr, yr)
    for m in range(25):
        x, ok = ng.refine_one(img_l.astype(np.float32), img_r.astype(np.float32), pts[m, 0],
                              pts[m, 1], xr[m], yr[m], REFINE_RADIUS, REFINE_STEP,
                              REFINE_LEVELS, REFINE_ITERATIONS, REFINE_TOL, REFINE_MAX_SHIFT)
        assert ref.ok[m] == ok
        assert ref.x[m] == pytest.approx(x, abs=1e-6)
    assert ref.ok.mean() > 0.9


@pytest.mark.parametrize("sigma", [1.2, 2.0])
def test_synthetic_subpixel_shifts_are_recovered_without_pixel_locking(sigma):
    """Disparities 10 + f for f in 0, 0.1, ..., 1 on noise-free textures: the error is below
    0.05 px (median and mean, for every f), and the mean signed error does not follow the
    fractional part (no pull towards whole pixels). (Textures with power up to the Nyquist
    frequency, blurred by sigma 0.8 only, leave about 0.06 px: bilinear sampling is the
    limit there.)"""
    rng = np.random.default_rng(5)
    img_l = texture(96, 160, 2, sigma)
    pts = grid_points(96, 160)
    signed = []
    for f in np.arange(0.0, 1.01, 0.1):
        img_r = shifted(img_l, 10 + f)
        start = pts[:, 0] - 10 - np.round(f) + rng.uniform(-0.45, 0.45, len(pts))
        res = refine_disparities(img_l, img_r, pts, start, pts[:, 1])
        assert res.ok.mean() > 0.95
        err = (pts[res.ok, 0] - res.x[res.ok]) - (10 + f)
        assert np.median(np.abs(err)) < 0.05 and np.mean(np.abs(err)) < 0.05, (f, err)
        signed.append(np.mean(err))
    assert np.ptp(signed) < 0.04, signed


def test_refinement_ignores_gain_and_offset():
    img_l = texture(60, 90, 4)
    img_r = shifted(img_l, 6.6)
    pts = grid_points(60, 90, margin=14, step=8)
    start = pts[:, 0] - 7
    a = refine_disparities(img_l, img_r, pts, start, pts[:, 1])
    b = refine_disparities(img_l, 0.7 * img_r + 9, pts, start, pts[:, 1])
    np.testing.assert_array_equal(a.ok, b.ok)
    np.testing.assert_allclose(a.x, b.x, atol=1e-4)


def test_windows_off_the_image_are_left_as_they_are():
    img = texture(40, 60, 6)
    pts = np.array([[2.5, 20.0], [30.0, 1.0], [30.0, 20.0]])
    xr = np.array([1.0, 28.0, np.nan])
    res = refine_disparities(img, img, pts, xr, pts[:, 1])
    assert not res.ok.any()
    np.testing.assert_array_equal(res.x[:2], xr[:2])


def test_lengths_must_agree():
    img = texture(40, 60, 6)
    with pytest.raises(InvalidArgumentError, match="one row per match"):
        refine_disparities(img, img, np.zeros((3, 2)), np.zeros(2), np.zeros(3))
