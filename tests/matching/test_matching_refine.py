"""The sub-pixel refinement: its kernel against the NumPy reference, and its accuracy on
synthetic sub-pixel shifts of noise-free textures."""

from __future__ import annotations

import naive_guided as ng
import numpy as np
import pytest
from synthetic_pairs import texture

from hopmatch._kernels import refine as kr
from hopmatch.errors import InvalidArgumentError
from hopmatch.matching.refine import (
    REFINE_ITERATIONS,
    REFINE_LEVELS,
    REFINE_MAX_SHIFT,
    REFINE_RADIUS,
    REFINE_STEP,
    REFINE_TOL,
    SLANT_GRADIENT_LIMIT,
    SLANT_LEVELS,
    SLANT_RADIUS,
    SLANT_SIGMA,
    SLANT_STEP,
    disparity_gradients,
    refine_disparities,
)


def shifted(img, d):
    """``img`` moved left by d px (``out(x) = img(x + d)``), exactly for this periodic,
    band-limited texture (Fourier shift theorem)."""
    f = np.fft.fft2(img)
    fx = np.fft.fftfreq(img.shape[1])
    return np.real(np.fft.ifft2(f * np.exp(2j * np.pi * fx * d)[None, :]))


def grid_points(h, w, margin=20, step=6, offset=(0.37, 0.21)):
    return np.array([[x + offset[0], y + offset[1]] for y in range(margin, h - margin, step)
                     for x in range(margin + 20, w - margin, step)], np.float64)


def warped(img, d0, gx, gy):
    """The right image of a plane of disparity ``d0 + gx x + gy y`` seen by ``img`` (left):
    ``out(x - d(x, y), y) = img(x, y)``, sampled by inverting x -> x - d row by row on a
    fine grid of the Fourier-interpolated rows (exact up to the grid, 1/64 px)."""
    h, w = img.shape
    fine = np.arange(0, w - 1, 1 / 64)
    out = np.empty_like(img, dtype=np.float64)
    f = np.fft.fft(img, axis=1)
    fx = np.fft.fftfreq(w)
    rows = np.real(np.fft.ifft(f[:, None, :] * np.exp(2j * np.pi * fx[None, None, :]
                                                       * (fine % 1)[None, :, None]), axis=2))
    for y in range(h):
        xs_l = fine
        vals = rows[y, np.arange(len(fine)), np.floor(fine).astype(int)]
        xs_r = xs_l - (d0 + gx * xs_l + gy * y)
        out[y] = np.interp(np.arange(w), xs_r, vals)
    return out


def test_kernel_matches_the_reference():
    rng = np.random.default_rng(3)
    img_l = texture(60, 90, 1)
    img_r = shifted(img_l, 5.3)
    pts = np.c_[rng.uniform(15, 75, 25), rng.uniform(12, 48, 25)]
    xr = pts[:, 0] - 5.3 + rng.uniform(-0.6, 0.6, 25)
    yr = pts[:, 1] + rng.uniform(-0.2, 0.2, 25)
    ref = refine_disparities(img_l, img_r, pts, xr, yr, slanted=False)
    for m in range(25):
        x, ok = ng.refine_one(img_l.astype(np.float32), img_r.astype(np.float32), pts[m, 0],
                              pts[m, 1], xr[m], yr[m], REFINE_RADIUS, REFINE_STEP,
                              REFINE_LEVELS, REFINE_ITERATIONS, REFINE_TOL, REFINE_MAX_SHIFT)
        assert ref.ok[m] == ok
        assert ref.x[m] == pytest.approx(x, abs=1e-6)
    assert ref.ok.mean() > 0.9


@pytest.mark.parametrize("cubic", [False, True])
def test_slanted_weighted_kernel_matches_the_reference(cubic):
    """The second stage's kernel (Gaussian weights, cubic or linear interpolation, a right
    window on a disparity plane) against the NumPy reference, point by point."""
    rng = np.random.default_rng(4)
    img_l = texture(60, 90, 1).astype(np.float32)
    img_r = shifted(img_l, 5.3).astype(np.float32)
    n = 20
    pts = np.c_[rng.uniform(18, 72, n), rng.uniform(15, 45, n)]
    xr = pts[:, 0] - 5.3 + rng.uniform(-0.3, 0.3, n)
    yr = pts[:, 1] + rng.uniform(-0.2, 0.2, n)
    gx, gy = rng.uniform(-0.3, 0.3, n), rng.uniform(-0.3, 0.3, n)
    x, ok, _, _ = kr.refine_rows(img_l, img_r, pts, xr, yr, gx, gy, SLANT_RADIUS,
                                 SLANT_RADIUS, SLANT_SIGMA, cubic, SLANT_STEP, SLANT_LEVELS,
                                 REFINE_ITERATIONS, REFINE_TOL, REFINE_MAX_SHIFT)
    for m in range(n):
        xm, okm = ng.refine_one_slanted(img_l, img_r, pts[m, 0], pts[m, 1], xr[m], yr[m],
                                        gx[m], gy[m], SLANT_RADIUS, SLANT_SIGMA, cubic,
                                        SLANT_STEP, SLANT_LEVELS, REFINE_ITERATIONS,
                                        REFINE_TOL, REFINE_MAX_SHIFT)
        assert ok[m] == okm
        assert x[m] == pytest.approx(xm, abs=1e-6)
    assert ok.mean() > 0.9


@pytest.mark.parametrize("sigma, radius, step, levels", [
    (0.0, REFINE_RADIUS, REFINE_STEP, REFINE_LEVELS),
    (SLANT_SIGMA, SLANT_RADIUS, SLANT_STEP, SLANT_LEVELS)])
def test_square_windows_from_whole_column_sums_agree_with_the_sampled_ones(sigma, radius, step,
                                                                          levels):
    # gradient (0, 0): the kernel mixes the sums of the windows at whole columns; a
    # gradient of 5e-324 px/px moves no sample (x - r * 5e-324 rounds to x) but takes the
    # general path, which interpolates every sample: the two agree within 1e-9 px
    img_l = texture(120, 200, seed=3)
    img_r = shifted(img_l, 7.3).astype(np.float32)
    img_l = img_l.astype(np.float32)
    pts = grid_points(120, 200, step=5, offset=(0.41, 0.13))
    rng = np.random.default_rng(4)
    xr = pts[:, 0] - 7.3 + rng.uniform(-0.6, 0.6, len(pts))
    yr = pts[:, 1].copy()
    zero = np.zeros(len(pts))
    tiny = np.full(len(pts), 5e-324)
    args = (radius, 3, sigma, False, step, levels, REFINE_ITERATIONS, REFINE_TOL,
            REFINE_MAX_SHIFT)
    fast = kr.refine_rows(img_l, img_r, pts, xr, yr, zero, zero, *args)
    slow = kr.refine_rows(img_l, img_r, pts, xr, yr, zero, tiny, *args)
    assert fast[1].mean() > 0.9
    np.testing.assert_array_equal(fast[1], slow[1])
    np.testing.assert_allclose(fast[0], slow[0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(fast[2], slow[2], rtol=0, atol=1e-9)
    np.testing.assert_allclose(fast[3], slow[3], rtol=1e-6)
    assert not np.array_equal(fast[0], xr)


def test_windows_shrink_near_the_border_down_to_the_minimum():
    """A point 6 px from the left border: too close for the 11 x 11 window, refined with a
    smaller one when the minimum allows it (the same as asking for that radius), not at all
    when it does not."""
    img_l = texture(60, 90, 2)
    img_r = shifted(img_l, 0.4)
    pts = np.array([[6.2, 30.0]])
    xr, yr, g = pts[:, 0] - 0.4 + 0.2, pts[:, 1], np.zeros(1)
    args = (SLANT_SIGMA, True, SLANT_STEP, SLANT_LEVELS, REFINE_ITERATIONS, REFINE_TOL,
            REFINE_MAX_SHIFT)
    x5, ok5, _, _ = kr.refine_rows(img_l, img_r, pts, xr, yr, g, g, 5, 5, *args)
    x_any, ok_any, _, _ = kr.refine_rows(img_l, img_r, pts, xr, yr, g, g, 5, 1, *args)
    fits = [kr.refine_rows(img_l, img_r, pts, xr, yr, g, g, r, r, *args) for r in (1, 2, 3)]
    assert not ok5[0] and ok_any[0]
    best = max(r for r, f in zip((1, 2, 3), fits) if f[1][0])
    assert x_any[0] == fits[best - 1][0][0]
    assert abs((pts[0, 0] - x_any[0]) - 0.4) < 0.05


def test_disparity_gradients_of_a_plane():
    rng = np.random.default_rng(7)
    pts = np.c_[rng.uniform(0, 200, 400), rng.uniform(0, 100, 400)]
    d = 12 + 0.2 * pts[:, 0] - 0.1 * pts[:, 1]
    d[::17] += 30  # wrong matches: left out of each plane as far from its median
    gx, gy = disparity_gradients(pts, d)
    fitted = gx != 0  # the rest had too few neighbours for a plane: square windows
    assert fitted.mean() > 0.95
    np.testing.assert_allclose(gx[fitted], 0.2, atol=1e-5)  # float32 positions
    np.testing.assert_allclose(gy[fitted], -0.1, atol=1e-5)
    np.testing.assert_array_equal(gy[~fitted], 0.0)
    steep = disparity_gradients(pts, 3 * d)[0]  # 0.6: clipped where a plane is fitted
    assert (steep != 0).sum() > 50
    np.testing.assert_array_equal(steep[steep != 0], SLANT_GRADIENT_LIMIT)
    lone = disparity_gradients(np.array([[5.0, 5.0], [100.0, 50.0]]), np.array([3.0, np.nan]))
    np.testing.assert_array_equal(lone[0], [0.0, 0.0])


def test_slanted_windows_recover_a_slanted_plane():
    """A noise-free plane of disparity 4 + 0.3 x - 0.2 y: the two-stage refinement's median
    error is below 0.05 px (about 0.015) and well below the square windows' (the first
    stage alone, about 0.17: the right window is 0.3 narrower and sheared)."""
    img_l = texture(90, 150, 3, 1.5)
    gx, gy = 0.3, -0.2
    img_r = warped(img_l, 4.0, gx, gy)
    pts = grid_points(90, 150, margin=16, step=5)
    truth = 4.0 + gx * pts[:, 0] + gy * pts[:, 1]
    keep = (pts[:, 0] - truth > 20) & (pts[:, 0] - truth < 130)
    pts, truth = pts[keep], truth[keep]
    rng = np.random.default_rng(8)
    start = pts[:, 0] - truth + rng.uniform(-0.4, 0.4, len(pts))
    flat = refine_disparities(img_l, img_r, pts, start, pts[:, 1], slanted=False)
    both = refine_disparities(img_l, img_r, pts, start, pts[:, 1])
    err_flat = np.abs(pts[flat.ok, 0] - flat.x[flat.ok] - truth[flat.ok])
    err = np.abs(pts[both.ok, 0] - both.x[both.ok] - truth[both.ok])
    assert both.ok.mean() > 0.95
    assert np.median(err) < 0.05, np.median(err)
    assert np.median(err) < 0.7 * np.median(err_flat), (np.median(err), np.median(err_flat))


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
