"""hopmatch.matching.tone: the curve between two views' grey levels, read off a first
match, and the second match through it (``tone_tolerance``)."""

from __future__ import annotations

import numpy as np
import pytest
from synthetic_pairs import texture

import hopmatch
from hopmatch.matching import tone


def _bilinear(image, x, y):
    x0, y0 = int(np.floor(x)), int(np.floor(y))
    ax, ay = x - x0, y - y0
    f = image.astype(np.float64)
    return ((1 - ay) * ((1 - ax) * f[y0, x0] + ax * f[y0, x0 + 1])
            + ay * ((1 - ax) * f[y0 + 1, x0] + ax * f[y0 + 1, x0 + 1]))


def test_grey_levels_match_a_pixel_loop():
    img = texture(60, 80, seed=1).astype(np.float32)
    pts = np.random.default_rng(0).uniform([2, 2], [76, 56], (40, 2))
    step = tone.SMOOTHING
    ref = [np.mean([_bilinear(img, x + dx, y + dy) for dx in (-step, 0, step)
                    for dy in (-step, 0, step)]) for x, y in pts]
    np.testing.assert_allclose(tone.grey_levels(img, pts), ref, rtol=1e-6)
    # beyond the image: its nearest pixels
    corner = tone.grey_levels(img, np.array([[0.0, 0.0], [79.0, 59.0]]))
    assert np.isfinite(corner).all()


def _pair_points(n=3000, seed=0, shape=(240, 320)):
    """Points of a texture and the same points 6 px to the left in its shifted copy."""
    h, w = shape
    img = texture(h, w + 6, seed=seed)
    left, right = img[:, :w], img[:, 6:]
    pts_l = np.random.default_rng(seed).uniform([8, 4], [w - 8, h - 4], (n, 2))
    return left, right, pts_l, pts_l - [6.0, 0.0]


def test_a_gain_and_offset_read_as_a_straight_line():
    left, right, pl, pr = _pair_points()
    curve = tone.tone_curve(left, 0.7 * right + 12.0, pl, pr)
    assert curve is not None and curve.nonlinearity < 0.005
    # right column x shows left column x + 6
    np.testing.assert_allclose(curve.apply(0.7 * right + 12.0)[:, :-6], left[:, 6:],
                               atol=0.5)


def test_a_gamma_is_recovered_and_undone():
    left, right, pl, pr = _pair_points(seed=2)
    curved = 255.0 * (right / 255.0) ** 1.8
    curve = tone.tone_curve(left, curved, pl, pr)
    assert curve is not None and curve.nonlinearity > 0.04
    mapped, seen = curve.apply(curved)[:, :-6], left[:, 6:]
    inside = ((curved >= curve.low) & (curved <= curve.high))[:, :-6]
    assert np.median(np.abs(mapped - seen)[inside]) < 1.0
    assert np.abs(mapped - seen)[inside].max() < 6.0


def test_wrong_matches_are_trimmed():
    left, right, pl, pr = _pair_points(seed=3)
    pr = pr.copy()
    pr[::5] = np.random.default_rng(1).uniform([8, 4], [300, 230], (len(pr[::5]), 2))
    curve = tone.tone_curve(left, 0.5 * right, pl, pr)
    assert curve.nonlinearity < 0.01 and curve.n_matches < 0.9 * min(len(pl),
                                                                    tone.MAX_MATCHES)


def test_too_few_matches_or_a_flat_view_give_no_curve():
    left, right, pl, pr = _pair_points(n=tone.MIN_MATCHES - 1)
    assert tone.tone_curve(left, right, pl, pr) is None
    left, right, pl, pr = _pair_points()
    assert tone.tone_curve(left, np.full_like(right, 40.0), pl, pr) is None


def test_a_decreasing_map_gives_no_curve():
    left, right, pl, pr = _pair_points(seed=4)
    assert tone.tone_curve(left, 255.0 - right, pl, pr) is None


def test_apply_continues_the_end_slopes():
    curve = tone.ToneCurve(np.array([0.0, 0.0, 100.0, 10.0]), 20.0, 120.0, 0.0, 500)
    out = curve.apply(np.array([0.0, 20.0, 70.0, 120.0, 220.0]))
    np.testing.assert_allclose(out, [-10.0, 10.0, 60.0, 110.0, 210.0], atol=1e-4)
    assert out.dtype == np.float32


def _exposed_pair():
    """A textured pair whose right view went through a steep response curve."""
    h, w, d = 240, 320, 7
    base = texture(h, w + d, seed=11, sigma=0.9)
    left = np.clip(base[:, :w], 0, 255).astype(np.uint8)
    right = np.clip(255.0 * (base[:, d:] / 255.0) ** 2.2, 0, 255).astype(np.uint8)
    return left, right


def test_match_stereo_matches_again_through_the_curve():
    """Above the tolerance the matches are those of the right view mapped through the
    first match's curve; with tone_tolerance=None there is no curve."""
    left, right = _exposed_pair()
    params = dict(max_disparity=16, sharpness_ratio=None)
    res = hopmatch.match_stereo(left, right, tone_tolerance=0.04, **params)
    curve = res.tone_curve
    assert curve is not None and curve.nonlinearity > 0.04
    again = hopmatch.match_stereo(left, curve.apply(right), tone_tolerance=None, **params)
    np.testing.assert_array_equal(res.matched_left, again.matched_left)
    np.testing.assert_array_equal(res.matched_right, again.matched_right)
    off = hopmatch.match_stereo(left, right, tone_tolerance=None, **params)
    assert off.tone_curve is None
    high = hopmatch.match_stereo(left, right, tone_tolerance=10.0, **params)
    assert high.tone_curve.nonlinearity == pytest.approx(curve.nonlinearity)
    np.testing.assert_array_equal(high.matched_left, off.matched_left)


def test_the_paper_never_remaps_and_the_tolerance_is_checked():
    left, right = _exposed_pair()
    paper = hopmatch.match_stereo(left, right, preset="paper")
    assert paper.tone_curve is None and paper.network.config.tone_tolerance is None
    with pytest.raises(ValueError, match="tone_tolerance"):
        hopmatch.match_stereo(left, right, tone_tolerance=-0.1)
    with pytest.raises(TypeError, match="tone_tolerance"):
        hopmatch.match_stereo(left, right, tone_tolerance="0.1")
