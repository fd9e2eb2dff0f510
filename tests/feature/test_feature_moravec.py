"""Moravec kernels (SPEC section 1, eqs. 1-2) and the window descriptor (eqs. 8-9) against the
loop references of ``tests/naive.py``."""

from __future__ import annotations

import naive
import numpy as np
import pytest

from hopmatch._kernels import moravec as _k
from hopmatch.errors import InvalidArgumentError, InvalidTypeError
from hopmatch.feature import gradient_windows, moravec_points, moravec_response
from hopmatch.feature.moravec import quantisation_step, quantise


def _quantised(img):
    """The image on the kernel's power-of-two grid (naive.quantise), as float32."""
    gq, step = naive.quantise(img)
    out = (gq * step).astype(np.float32)
    assert np.array_equal(out.astype(np.float64), gq * step)       # exact in float32
    return out


def reference_response(img, window_size):
    """Eq. 1 of the reference on the quantised image."""
    return naive.moravec_response(_quantised(img), window_size)


def _random_image(rng, shape, dtype):
    if dtype == np.uint8:
        return rng.integers(0, 256, shape).astype(np.uint8)
    if dtype == np.uint16:
        return rng.integers(0, 65536, shape).astype(np.uint16)
    return (rng.normal(size=shape) * 37.0).astype(np.float32)


class TestMoravecResponse:
    @pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
    @pytest.mark.parametrize("window_size", [1, 3, 5, 7, 9])
    def test_bit_identical_to_reference(self, dtype, window_size):
        rng = np.random.default_rng(window_size * 7 + np.dtype(dtype).itemsize)
        img = _random_image(rng, (19, 23), dtype)
        got = moravec_response(img, window_size=window_size)
        want = reference_response(img, window_size)
        assert got.dtype == np.float32 and got.shape == img.shape
        assert np.array_equal(got.view(np.uint32), want.view(np.uint32))
        if dtype != np.float32:
            # integer images lie on the grid already: eq. 1 on G itself, bit for bit
            raw = naive.moravec_response(img.astype(np.float32), window_size)
            assert np.array_equal(got.view(np.uint32), raw.view(np.uint32))
        # the interior is not trivially zero, the border band is
        m = window_size // 2 + 1
        assert (got[m:-m, m:-m] > 0).any()
        assert not got[:m].any() and not got[-m:].any()
        assert not got[:, :m].any() and not got[:, -m:].any()

    @pytest.mark.parametrize("window_size", [3, 5, 7])
    @pytest.mark.parametrize("window_sigma", [0.5, 0.85, 2.0])
    def test_gaussian_window_equals_reference(self, window_size, window_sigma):
        rng = np.random.default_rng(window_size * 13 + int(window_sigma * 100))
        img = _random_image(rng, (19, 23), np.uint8)   # integers: on the kernel's grid
        got = moravec_response(img, window_size=window_size, window_sigma=window_sigma)
        want = naive.weighted_moravec_response(img.astype(np.float32), window_size, window_sigma)
        assert got.dtype == np.float32 and got.shape == img.shape
        np.testing.assert_allclose(got, want, rtol=1e-6, atol=0)
        m = window_size // 2 + 1
        assert (got[m:-m, m:-m] > 0).all()
        assert not got[:m].any() and not got[-m:].any()
        assert not got[:, :m].any() and not got[:, -m:].any()
        # the weights matter: not the box of eq. 1
        assert not np.allclose(got, naive.moravec_response(img.astype(np.float32), window_size))

    def test_gaussian_window_limits(self):
        rng = np.random.default_rng(3)
        img = rng.integers(0, 256, (21, 17)).astype(np.float32)
        box = naive.moravec_response(img, 5)
        # sigma 0 is eq. 1 as printed, bit for bit; a 1-pixel window has nothing to weight
        assert np.array_equal(moravec_response(img, 5, window_sigma=0.0), box)
        assert np.array_equal(moravec_response(img, 1, window_sigma=0.85),
                              naive.moravec_response(img, 1))
        # a very wide Gaussian is flat over the window: the box again (weights sum to 25)
        np.testing.assert_allclose(moravec_response(img, 5, window_sigma=1e4), box, rtol=1e-6)
        # known value: an impulse, 3 x 3 window, weights (1, 2, 1) / 4 * 3 per axis; each
        # direction sees the impulse as q = p (weight 4 * 9/16) and as q + u = p (weight of
        # the neighbour q = p - u: 2 * 9/16 along an axis, 1 * 9/16 diagonally)
        imp = np.zeros((9, 9), np.float32)
        imp[4, 4] = 1.0
        sigma = 1.0 / np.sqrt(2.0 * np.log(2.0))   # exp(-1 / (2 sigma**2)) = 1/2
        v = moravec_response(imp, 3, window_sigma=sigma)
        assert v[4, 4] == pytest.approx(9 / 16 * (4 + 1), rel=1e-6)

    def test_gaussian_window_validation(self):
        with pytest.raises(InvalidArgumentError, match="window_sigma"):
            moravec_response(np.zeros((9, 9), np.float32), 3, window_sigma=-1.0)
        with pytest.raises(InvalidTypeError, match="window_sigma"):
            moravec_response(np.zeros((9, 9), np.float32), 3, window_sigma="wide")

    def test_kernel_directly(self):
        rng = np.random.default_rng(1)
        g = np.ascontiguousarray(rng.uniform(0, 1, (16, 13)).astype(np.float32))
        gq, step = naive.quantise(g)
        assert np.abs(gq).max() <= 2**19 and np.abs(gq).max() > 2**18
        on_grid = (gq * step).astype(np.float32)
        for radius in (0, 1, 2, 3):
            # the kernel quantises G itself: on_grid * (1 / step) is gq again
            got = _k.moravec_response(on_grid, 1.0 / step, radius, step * step)
            want = naive.moravec_response(on_grid, 2 * radius + 1)
            assert np.array_equal(got.view(np.uint32), want.view(np.uint32))
            # quantising inside the kernel is the rule of quantise(), bit for bit
            factor, scale = quantisation_step(g)
            assert scale == factor**-2
            got = _k.moravec_response(g, factor, radius, scale)
            gq2, scale2 = quantise(g)
            assert scale2 == scale
            want = naive.moravec_response((gq2 * factor**-1).astype(np.float32), 2 * radius + 1)
            assert np.array_equal(got.view(np.uint32), want.view(np.uint32))

    def test_kernel_rounds_ties_to_even_as_quantise_does(self):
        """The kernel quantises each pixel itself: values exactly halfway between two grid
        steps round to even, as ``np.rint`` in ``quantise`` does."""
        rng = np.random.default_rng(12)
        img = (rng.integers(-4000, 4000, (23, 29)) / 2.0).astype(np.float32)
        img[0, 0] = 2.0**19 - 1.0               # max |G|: the grid step is 1, so the
        factor, scale = quantisation_step(img)  # half-integers are exact ties
        assert factor == 1.0 and scale == 1.0
        halves = img.astype(np.float64) % 1.0 == 0.5
        assert halves.sum() > 200
        gq, _ = quantise(img)
        assert np.array_equal(gq, np.rint(img.astype(np.float64) * factor))
        for radius in (0, 1, 2):
            got = _k.moravec_response(img, factor, radius, scale)
            want = naive.moravec_response((gq / factor).astype(np.float32), 2 * radius + 1)
            assert np.array_equal(got.view(np.uint32), want.view(np.uint32))
            # truncation or rounding half away from zero would give other sums
            away = np.trunc(img.astype(np.float64) * factor + np.copysign(0.5, img))
            other = naive.moravec_response((away / factor).astype(np.float32), 2 * radius + 1)
            assert not np.array_equal(got, other)

    def test_blank_and_tiny_grids(self):
        assert quantisation_step(np.zeros((4, 5), np.float32)) == (1.0, 1.0)
        assert quantisation_step(np.full((4, 5), -0.0, np.float32)) == (1.0, 1.0)
        assert quantisation_step(np.zeros((0, 5), np.float32)) == (1.0, 1.0)
        g = np.zeros((9, 9), np.float32)
        g[4, 4] = -3.0                          # max |G| taken over negative values too
        assert quantisation_step(g) == quantisation_step(-g)

    @pytest.mark.parametrize("scale", [1e-6, 1.0, 3.0, 1e6])
    def test_quantisation_is_fine(self, scale):
        """On a float image the grid changes V by a tiny fraction of its range."""
        rng = np.random.default_rng(8)
        img = (rng.normal(size=(20, 20)) * scale).astype(np.float32)
        got = moravec_response(img, 5).astype(np.float64)
        exact = naive.moravec_response(img, 5).astype(np.float64)
        assert np.abs(got - exact).max() <= 1e-5 * exact.max()
        assert not np.array_equal(_quantised(img), img)

    def test_wide_dynamic_range(self):
        rng = np.random.default_rng(9)
        img = (rng.normal(size=(19, 23)) * 10.0 ** rng.integers(-4, 6, (19, 23)))
        img = img.astype(np.float32)
        got = moravec_response(img, 3)
        assert np.array_equal(got, reference_response(img, 3))

    @pytest.mark.parametrize("shape", [(1, 1), (3, 3), (5, 7), (7, 5), (2, 9), (8, 8)])
    @pytest.mark.parametrize("window_size", [1, 3, 5, 7])
    def test_small_images(self, shape, window_size):
        rng = np.random.default_rng(shape[0] * 31 + shape[1])
        img = rng.uniform(0, 255, shape).astype(np.float32)
        got = moravec_response(img, window_size=window_size)
        want = reference_response(img, window_size)
        assert got.shape == shape and got.dtype == np.float32
        assert np.array_equal(got, want)
        if min(shape) < 2 * (window_size // 2 + 1) + 1:
            assert not got.any()

    def test_small_image_with_interior(self):
        # 5 x 7 with a 1-pixel window keeps an interior: V is computed there
        img = np.arange(35, dtype=np.float32).reshape(5, 7) ** 2
        got = moravec_response(img, window_size=1)
        assert got[1:4, 1:6].all()
        assert np.array_equal(got, naive.moravec_response(img, 1))   # integers: on the grid

    def test_known_value(self):
        img = np.zeros((9, 9), np.float32)
        img[4, 4] = 1.0
        v = moravec_response(img, window_size=3)
        # every direction sees the impulse twice (as q and as q + u)
        assert v[4, 4] == 2.0
        assert np.array_equal(v, naive.moravec_response(img, 3))

    def test_directions_are_the_documented_ones(self):
        # an image constant along x: V_0 = 0 everywhere, so V = 0
        col = np.random.default_rng(0).uniform(0, 9, (12, 1)).astype(np.float32)
        assert not moravec_response(np.repeat(col, 10, axis=1), 3).any()
        # constant along the 135-degree step (-1, 1): G(x, y) = f(x + y)
        f = np.random.default_rng(1).uniform(0, 9, 50).astype(np.float32)
        yy, xx = np.mgrid[:12, :12]
        assert not moravec_response(f[xx + yy], 3).any()
        # constant along the 45-degree step (1, 1): G = f(x - y)
        assert not moravec_response(f[xx - yy + 12], 3).any()
        # constant along (2, 1), which is none of the four steps: V > 0 inside
        v = moravec_response(f[xx - 2 * yy + 30], 3)
        assert (v[2:-2, 2:-2] > 0).all()

    def test_blank_image(self):
        for value in (0.0, 17.0):
            img = np.full((20, 20), value, np.float32)
            v = moravec_response(img, 5)
            assert np.isfinite(v).all() and not v.any()
            pts, resp = moravec_points(v, nms_size=5)
            assert pts.shape == (0, 2) and pts.dtype == np.float32
            assert resp.shape == (0,) and resp.dtype == np.float32

    def test_transposed_image(self):
        """Under transposition V_0 and V_90 swap and V_45 maps onto itself; V_135 becomes
        the variance along (1, -1), i.e. V_135 of the window shifted by (1, -1). Assert the
        directional maps of the reference and the kernel's response on the transpose."""
        rng = np.random.default_rng(5)
        # on the kernel's grid every sum is exact, so the maps compare exactly
        img = _quantised(rng.uniform(0, 100, (17, 21)).astype(np.float32))
        r = 2
        m = r + 1
        vt = naive.directional_variances(img, 2 * r + 1)
        vt_t = naive.directional_variances(img.T.copy(), 2 * r + 1)
        assert np.array_equal(vt_t[0], vt[2].T)
        assert np.array_equal(vt_t[2], vt[0].T)
        assert np.array_equal(vt_t[1], vt[1].T)
        # V'_135 at p^T = V_135 at p + (dx, dy) = (1, -1), where both are defined
        h, w = img.shape
        for y in range(m + 1, h - m):
            for x in range(m, w - m - 1):
                assert vt_t[3, x, y] == vt[3, y - 1, x + 1]
        # the kernel on the transpose is the min of these maps (not simply V.T)
        want = np.zeros(img.T.shape)
        want[m:-m, m:-m] = np.minimum.reduce(
            [vt[2].T, vt[0].T, vt[1].T, vt_t[3]])[m:-m, m:-m]
        got = moravec_response(img.T, 2 * r + 1)
        assert np.array_equal(got, want.astype(np.float32))
        assert not np.array_equal(got, moravec_response(img, 2 * r + 1).T)
        # wherever the 135-degree variance is not the minimum on either side, V' = V.T
        v = moravec_response(img, 2 * r + 1)
        sym = np.zeros_like(v, dtype=bool)
        sym[m:-m, m:-m] = True
        sym &= vt[3] > vt[:3].min(axis=0)
        sym &= (vt_t[3] > vt_t[:3].min(axis=0)).T
        assert sym.sum() > 20
        assert np.array_equal(got.T[sym], v[sym])

    def test_thread_safety(self):
        from concurrent.futures import ThreadPoolExecutor

        rng = np.random.default_rng(2)
        img = rng.uniform(0, 1, (64, 64)).astype(np.float32)
        want = moravec_response(img, 5)
        with ThreadPoolExecutor(4) as ex:
            outs = list(ex.map(lambda _: moravec_response(img, 5), range(8)))
        assert all(np.array_equal(o, want) for o in outs)


class TestStrictMaxima:
    @pytest.mark.parametrize("radius", [0, 1, 2, 4])
    @pytest.mark.parametrize("margin", [0, 3])
    def test_equals_reference(self, radius, margin):
        rng = np.random.default_rng(radius * 10 + margin)
        # quantised values so that ties happen often
        v = rng.integers(0, 6, (23, 19)).astype(np.float32)
        for threshold in (0.0, 2.0, 4.5):
            pts, resp = moravec_points(v, nms_size=2 * radius + 1, threshold=threshold,
                                       margin=margin)
            want = naive.strict_maxima(v, radius, margin, threshold)
            got = {(int(y), int(x)) for x, y in pts}
            assert got == {tuple(p) for p in want.tolist()}
            assert len(pts) == len(want)
            assert (resp > threshold).all()

    def test_kernel_raster_order(self):
        rng = np.random.default_rng(3)
        v = rng.normal(size=(30, 30)).astype(np.float32)
        import cv2

        vmax = cv2.dilate(v, np.ones((5, 5), np.uint8), borderType=cv2.BORDER_CONSTANT,
                          borderValue=-np.inf)
        got, pts, resp = _k.strict_maxima(v, vmax, 2, 1, np.float32(-10.0), False)
        want = naive.strict_maxima(v, 2, 1, -10.0)
        assert got.dtype == np.int64 and len(want) > 5
        assert np.array_equal(got, want)
        assert pts.dtype == np.float32 and np.array_equal(pts, want[:, ::-1])
        assert resp.dtype == np.float32 and np.array_equal(resp, v[want[:, 0], want[:, 1]])

    def test_plateau_is_not_a_maximum(self):
        v = np.zeros((15, 15), np.float32)
        v[5:7, 5:7] = 3.0                    # a 2 x 2 plateau: no strict maximum
        v[11, 11] = 2.0                      # an isolated peak
        pts, resp = moravec_points(v, nms_size=3)
        assert pts.tolist() == [[11.0, 11.0]] and resp.tolist() == [2.0]
        assert naive.strict_maxima(v, 1, 0, 0.0).tolist() == [[11, 11]]
        v[6, 6] = 3.5                        # now the plateau has a strict top
        pts, _ = moravec_points(v, nms_size=3)
        assert [6.0, 6.0] in pts.tolist()

    def test_equal_neighbour_far_away_in_window(self):
        v = np.zeros((20, 20), np.float32)
        v[10, 10] = 5.0
        v[14, 6] = 5.0                       # equal value, Chebyshev distance 4
        assert len(moravec_points(v, nms_size=9)[0]) == 0
        assert len(moravec_points(v, nms_size=7)[0]) == 2

    def test_thresholds(self):
        v = np.zeros((30, 30), np.float32)
        for n, (y, x) in enumerate([(5, 5), (5, 20), (20, 5), (20, 20)]):
            v[y, x] = 10.0 * (n + 1)
        assert len(moravec_points(v, nms_size=5)[0]) == 4
        assert len(moravec_points(v, nms_size=5, threshold=20.0)[0]) == 2  # strict: 20 out
        assert len(moravec_points(v, nms_size=5, threshold=19.9)[0]) == 3
        assert len(moravec_points(v, nms_size=5, relative_threshold=0.5)[0]) == 2
        assert len(moravec_points(v, nms_size=5, relative_threshold=0.49)[0]) == 3

    def test_margin(self):
        v = np.zeros((20, 20), np.float32)
        v[2, 10] = 1.0                       # 2 px from the top
        v[10, 16] = 2.0                      # 3 px from the right
        v[10, 10] = 3.0
        assert len(moravec_points(v, nms_size=3)[0]) == 3
        assert len(moravec_points(v, nms_size=3, margin=2)[0]) == 3
        pts, _ = moravec_points(v, nms_size=3, margin=3)
        assert sorted(pts.tolist()) == [[10.0, 10.0], [16.0, 10.0]]
        pts, _ = moravec_points(v, nms_size=3, margin=4)
        assert pts.tolist() == [[10.0, 10.0]]

    def test_mask(self):
        rng = np.random.default_rng(4)
        v = rng.normal(size=(40, 40)).astype(np.float32)
        all_pts, _ = moravec_points(v, nms_size=5, threshold=0.0)
        mask = np.zeros((40, 40), np.uint8)
        mask[:, :20] = 1
        pts, _ = moravec_points(v, nms_size=5, mask=mask)
        assert 0 < len(pts) < len(all_pts)
        assert (pts[:, 0] < 20).all()
        want = sorted(p for p in all_pts.tolist() if p[0] < 20)
        assert sorted(pts.tolist()) == want
        pts_b, _ = moravec_points(v, nms_size=5, mask=mask.astype(bool))
        assert np.array_equal(pts, pts_b)

    def test_max_features_keeps_strongest(self):
        rng = np.random.default_rng(6)
        v = rng.permutation(50 * 50).reshape(50, 50).astype(np.float32)  # distinct values
        pts, resp = moravec_points(v, nms_size=5)
        assert len(pts) > 10
        assert (np.diff(resp) <= 0).all()                   # strongest first
        want = naive.strict_maxima(v, 2, 0, 0.0)
        want_resp = np.sort(v[want[:, 0], want[:, 1]])[::-1]
        for k in (1, 5, 10):
            p_k, r_k = moravec_points(v, nms_size=5, max_features=k)
            assert len(p_k) == k
            assert np.array_equal(r_k, want_resp[:k])
            assert np.array_equal(p_k, pts[:k])
            assert np.array_equal(v[p_k[:, 1].astype(int), p_k[:, 0].astype(int)], r_k)

    def test_subpixel_offsets_within_half_pixel(self):
        rng = np.random.default_rng(7)
        v = rng.normal(size=(40, 40)).astype(np.float32)
        pts_i, _ = moravec_points(v, nms_size=5)
        pts_s, resp_s = moravec_points(v, nms_size=5, subpixel=True)
        assert len(pts_s) == len(pts_i) > 5
        off = pts_s - pts_i
        assert (np.abs(off) <= 0.5).all() and np.abs(off).max() > 0.01
        assert np.array_equal(resp_s, v[pts_i[:, 1].astype(int), pts_i[:, 0].astype(int)])

    @pytest.mark.parametrize("nms_size", [1, 3, 5])
    @pytest.mark.parametrize("margin", [0, 2])
    def test_subpixel_equals_numpy_formula(self, nms_size, margin):
        """The offsets computed in the kernel are those of the NumPy formula
        (naive.quadratic_offsets) bit for bit, including its den >= 0 rule and clipping:
        with nms_size 1 every pixel above the threshold is a point, maxima or not."""
        rng = np.random.default_rng(nms_size * 10 + margin)
        v = rng.integers(0, 7, (21, 26)).astype(np.float32) * np.float32(0.37)
        v[3:6, 4:9] = 2.0                                       # a plateau
        v += rng.normal(size=v.shape).astype(np.float32) * (rng.random(v.shape) < 0.5)
        v = np.abs(v).astype(np.float32)
        for threshold in (0.0, 1.5):
            pts_i, resp_i = moravec_points(v, nms_size, threshold=threshold, margin=margin)
            pts_s, resp_s = moravec_points(v, nms_size, threshold=threshold, margin=margin,
                                           subpixel=True)
            assert np.array_equal(resp_i, resp_s) and len(pts_i) > 3
            yx = pts_i[:, ::-1].astype(np.int64)
            want = pts_i + naive.quadratic_offsets(v, yx)          # float32 + float32
            assert want.dtype == np.float32
            assert np.array_equal(pts_s.view(np.uint32), want.view(np.uint32))
        if nms_size == 1:  # the rule's branches are exercised
            c = v[yx[:, 0], yx[:, 1]].astype(np.float64)
            lo = v[yx[:, 0], np.clip(yx[:, 1] - 1, 0, 25)].astype(np.float64)
            hi = v[yx[:, 0], np.clip(yx[:, 1] + 1, 0, 25)].astype(np.float64)
            den = lo - 2.0 * c + hi
            assert (den >= 0).sum() > 5 and (den < 0).sum() > 5
            with np.errstate(divide="ignore", invalid="ignore"):
                raw = np.where(den < 0, 0.5 * (lo - hi) / den, 0.0)
            assert (np.abs(raw) > 0.5).sum() > 0               # clipped
            assert np.abs(pts_s - pts_i).max() <= 0.5

    def test_subpixel_on_one_pixel_wide_images(self):
        """Both neighbours clamp to the point itself: den = 0, no offset along that axis."""
        v = np.array([0.0, 1.0, 3.0, 2.0, 0.5, 0.2], np.float32)
        for img, yx in ((v[:, None], [[2, 0]]), (v[None, :], [[0, 2]])):
            img = np.ascontiguousarray(img)
            yx = np.array(yx, np.int64)
            pts, _ = moravec_points(img, 3, subpixel=True)
            want = yx[:, ::-1].astype(np.float32) + naive.quadratic_offsets(img, yx)
            assert np.array_equal(pts, want)
            clamped = 0 if img.shape[1] == 1 else 1          # x for a column, y for a row
            assert pts[0, clamped] == 0.0 and pts[0, 1 - clamped] != 2.0

    @pytest.mark.parametrize("x0,y0", [(10.3, 12.0), (15.0, 9.75), (12.45, 13.2)])
    def test_subpixel_recovers_parabola_peak(self, x0, y0):
        yy, xx = np.mgrid[:25, :30].astype(np.float64)
        v = (100.0 - 2.0 * (xx - x0) ** 2 - 3.0 * (yy - y0) ** 2).astype(np.float32)
        pts, _ = moravec_points(v, nms_size=7, subpixel=True)
        assert len(pts) == 1
        assert pts[0] == pytest.approx([x0, y0], abs=1e-3)


class TestGradientWindows:
    @pytest.mark.parametrize("size", [1, 3, 5, 7])
    def test_equals_reference_for_integer_points(self, size):
        rng = np.random.default_rng(size)
        g = rng.uniform(0, 255, (30, 40)).astype(np.float32)
        r = size // 2
        pts = np.column_stack([rng.integers(r, 40 - r, 25),
                               rng.integers(r, 30 - r, 25)]).astype(np.float32)
        got = gradient_windows(g, pts, size)
        want = naive.gradient_windows(g, pts, size)
        assert got.shape == (25, size * size) and got.dtype == np.float32
        assert np.allclose(got, want, atol=1e-4)
        assert np.abs(got.mean(axis=1, dtype=np.float64)).max() < 1e-4
        if size > 1:
            assert np.abs(got).max() > 1.0

    @pytest.mark.parametrize("size", [3, 9])
    def test_equals_bilinear_reference_for_subpixel_points(self, size):
        rng = np.random.default_rng(10 + size)
        g = rng.uniform(0, 255, (30, 40)).astype(np.float32)
        r = size // 2
        pts = np.column_stack([rng.uniform(r, 39 - r, 40),
                               rng.uniform(r, 29 - r, 40)]).astype(np.float32)
        got = gradient_windows(g, pts, size)
        want = naive.gradient_windows(g, pts, size)
        assert np.allclose(got, want, rtol=0, atol=1e-4)
        # the sampling is exact bilinear, not cv2.remap's 1/32-pixel fixed-point weights
        assert not np.allclose(got, naive.gradient_windows(g, np.round(pts * 32) / 32, size),
                               rtol=0, atol=1e-3)

    @pytest.mark.parametrize("size", [1, 3, 5, 9])
    def test_bit_identical_to_reference_inside_at_and_beyond_the_border(self, size):
        """The fast path (footprint inside the image, rows read in place) and the clamped
        path give the reference's values bit for bit (float64 sums, rounded to float32)."""
        rng = np.random.default_rng(20 + size)
        h, w = 17, 23
        g = rng.uniform(0, 255, (h, w)).astype(np.float32)
        r = size // 2
        pts = [
            [r, r], [w - 1 - r, h - 1 - r],                  # integer, window at the border
            [w - 2 - r, h - 2 - r],                          # integer, footprint just inside
            [w - 1 - r - 0.5, h - 1 - r - 0.25],             # sub-pixel, footprint inside
            [w - 1 - r + 0.25, h / 2],                       # footprint leaves on the right
            [r - 0.5, h / 2], [w / 2, r - 0.75],             # ... on the left, at the top
            [-3.5, 2.25], [w + 4.0, h + 1.5], [1e7, -1e7],   # outside, far outside
        ]
        pts += np.column_stack([rng.uniform(r, w - 1 - r, 40),
                                rng.uniform(r, h - 1 - r, 40)]).tolist()
        pts = np.array(pts, np.float32)
        pts[-20:] = np.round(pts[-20:])                      # some integer centres inside
        got = gradient_windows(g, pts, size)
        want = naive.gradient_windows(g, pts, size).astype(np.float32)
        assert np.array_equal(got.view(np.uint32), want.view(np.uint32))

    def test_rows_do_not_depend_on_the_other_points(self):
        """Points are described four at a time (interleaved sums): each row is the one the
        point gets alone, whatever the batch size, order or neighbours (NaN centres too: the
        kernel's behaviour, so through cut_windows, past gradient_windows's checks)."""
        from hopmatch.feature.descriptor import cut_windows as gradient_windows
        rng = np.random.default_rng(31)
        g = rng.uniform(0, 9, (25, 30)).astype(np.float32)
        pts = np.column_stack([rng.uniform(-2, 32, 11), rng.uniform(-2, 27, 11)])
        pts = pts.astype(np.float32)
        pts[4] = [np.nan, 3.0]
        pts[7] = [5.0, -np.nan]
        alone = np.concatenate([gradient_windows(g, pts[i:i + 1], 5) for i in range(11)])
        assert np.isnan(alone[[4, 7]]).all() and not np.isnan(np.delete(alone, [4, 7], 0)).any()
        assert np.array_equal(alone[[4, 7]].view(np.uint32),
                              np.full((2, 25), np.nan, np.float32).view(np.uint32))
        for n in range(1, 12):
            assert np.array_equal(gradient_windows(g, pts[:n], 5).view(np.uint32),
                                  alone[:n].view(np.uint32))
        perm = rng.permutation(11)
        assert np.array_equal(gradient_windows(g, pts[perm], 5).view(np.uint32),
                              alone[perm].view(np.uint32))

    def test_windows_leaving_the_image_replicate_the_border(self):
        rng = np.random.default_rng(3)
        g = rng.uniform(0, 255, (12, 15)).astype(np.float32)
        pts = np.array([[0.0, 0.0], [14.0, 11.0], [-3.5, 4.25], [20.2, -7.0]], np.float32)
        got = gradient_windows(g, pts, 5)
        assert np.allclose(got, naive.gradient_windows(g, pts, 5), rtol=0, atol=1e-4)

    def test_raster_order(self):
        g = np.arange(25, dtype=np.float32).reshape(5, 5)
        got = gradient_windows(g, np.array([[2, 2]], np.float32), 3)
        assert got.tolist() == naive.gradient_windows(g, [[2, 2]], 3).tolist()
        assert got.tolist() == [[-6.0, -5.0, -4.0, -1.0, 0.0, 1.0, 4.0, 5.0, 6.0]]

    def test_no_points(self):
        out = gradient_windows(np.zeros((9, 9), np.float32), np.zeros((0, 2), np.float32), 5)
        assert out.shape == (0, 25) and out.dtype == np.float32

    @pytest.mark.parametrize("points, words", [
        (np.array([[np.nan, 5]], np.float32), "`points` contains NaN"),
        (np.array([[10, 10, 10], [20, 20, 20]], np.float32), "`points` must have shape"),
        (np.zeros((1, 3), np.float32), "`points` must have shape"),
    ])
    def test_float32_points_are_checked_as_any_others(self, points, words):
        """float32 points skipped the checks: NaN centres gave NaN rows, and (N, 3) rows
        were read as 3N / 2 points."""
        g = np.random.default_rng(0).random((50, 50)).astype(np.float32)
        with pytest.raises((InvalidArgumentError, InvalidTypeError), match=words):
            gradient_windows(g, points, 3)

    def test_an_even_size_and_a_nonfinite_image_are_refused(self):
        g = np.random.default_rng(0).random((50, 50)).astype(np.float32)
        pts = np.array([[20, 20]], np.float32)
        with pytest.raises(InvalidArgumentError, match="odd") as e:
            gradient_windows(g, pts, 8)
        assert e.value.argument == "size"
        g[3, 4] = np.nan
        with pytest.raises(InvalidArgumentError, match="finite") as e:
            gradient_windows(g, pts, 9)
        assert e.value.argument == "g"


class TestStrongestFirst:
    @pytest.mark.parametrize("seed", range(4))
    def test_equals_stable_argsort(self, seed):
        from hopmatch.feature.moravec import strongest_first
        rng = np.random.default_rng(seed)
        resp = rng.choice(np.float32([0.0, 1e-30, 0.5, 0.5, 2.0, 3e38, 7.25]), 500)
        resp = np.concatenate([resp, rng.random(300).astype(np.float32)])
        assert np.array_equal(strongest_first(resp), np.argsort(-resp, kind="stable"))
        assert strongest_first(resp[:0]).tolist() == []


@pytest.mark.parametrize("shape", [(0, 2), (2, 0), (0, 0)])
def test_an_empty_response_has_no_point(shape):
    """moravec_response gives an empty response for an empty image; moravec_points finds
    no point on it (before 2026-12-06: cv2.error from the dilation)."""
    v = moravec_response(np.zeros(shape, np.float32))
    assert v.shape == shape
    pts, resp = moravec_points(v)
    assert pts.shape == (0, 2) and pts.dtype == np.float32
    assert resp.shape == (0,) and resp.dtype == np.float32
    pts, resp = moravec_points(np.zeros(shape, np.float32), subpixel=False, max_features=3)
    assert pts.shape == (0, 2)
