"""hopmatch.matching.tone: the map between two views' grey levels (a curve and a gain
that varies across the view), read off a first match, and the second match through it
(``tone_tolerance``, ``gain_field_tolerance``)."""

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
    curve = tone.tone_map(left, 0.7 * right + 12.0, pl, pr)
    assert curve is not None and curve.nonlinearity < 0.005 and curve.field_range < 0.01
    # right column x shows left column x + 6
    np.testing.assert_allclose(curve.apply(0.7 * right + 12.0)[:, :-6], left[:, 6:],
                               atol=0.5)


def test_a_gamma_is_recovered_and_undone():
    left, right, pl, pr = _pair_points(seed=2)
    curved = 255.0 * (right / 255.0) ** 1.8
    curve = tone.tone_map(left, curved, pl, pr)
    assert curve is not None and curve.nonlinearity > 0.04 and curve.field_range < 0.02
    mapped, seen = curve.apply(curved)[:, :-6], left[:, 6:]
    inside = ((curved >= curve.low) & (curved <= curve.high))[:, :-6]
    assert np.median(np.abs(mapped - seen)[inside]) < 1.0
    assert np.abs(mapped - seen)[inside].max() < 6.0


def test_wrong_matches_are_trimmed():
    left, right, pl, pr = _pair_points(seed=3)
    pr = pr.copy()
    pr[::5] = np.random.default_rng(1).uniform([8, 4], [300, 230], (len(pr[::5]), 2))
    curve = tone.tone_map(left, 0.5 * right, pl, pr)
    assert curve.nonlinearity < 0.01 and curve.n_matches < 0.9 * min(len(pl),
                                                                    tone.MAX_MATCHES)


def test_too_few_matches_or_a_flat_view_give_no_map():
    left, right, pl, pr = _pair_points(n=tone.MIN_MATCHES - 1)
    assert tone.tone_map(left, right, pl, pr) is None
    left, right, pl, pr = _pair_points()
    assert tone.tone_map(left, np.full_like(right, 40.0), pl, pr) is None


def test_a_decreasing_map_gives_no_map():
    left, right, pl, pr = _pair_points(seed=4)
    assert tone.tone_map(left, 255.0 - right, pl, pr) is None


def _map(field=(0.0,) * 6, bounds=(0.0, 0.0), shape=(1, 5)):
    return tone.ToneMap(np.array([0.0, 0.0, 100.0, 10.0]), 20.0, 120.0, np.array(field),
                        shape, bounds, 0.0, bounds[1] - bounds[0], 500)


def test_needs_rematch_reads_either_tolerance():
    m = tone.ToneMap(np.zeros(4), 0.0, 1.0, np.zeros(6), (2, 2), (0.0, 0.3), 0.05, 0.3, 500)
    assert tone.needs_rematch(m, 0.04, None) and tone.needs_rematch(m, None, 0.25)
    assert not tone.needs_rematch(m, 0.06, 0.35) and not tone.needs_rematch(m, None, None)


def test_apply_continues_the_end_slopes():
    out = _map().apply(np.array([[0.0, 20.0, 70.0, 120.0, 220.0]]))
    np.testing.assert_allclose(out, [[-10.0, 10.0, 60.0, 110.0, 210.0]], atol=1e-4)
    assert out.dtype == np.float32


def test_apply_multiplies_by_the_clipped_gain():
    """log gain = 0.5 u (u = -1 at x = 0, +1 at x = w): clipped to the bounds given."""
    m = _map(field=(0.0, 0.5, 0.0, 0.0, 0.0, 0.0), bounds=(-0.2, 0.3), shape=(2, 4))
    x = np.arange(4.0)
    expected_log = np.clip(0.5 * (x - 2.0) / 2.0, -0.2, 0.3)
    out = m.apply(np.full((2, 4), 70.0))
    np.testing.assert_allclose(out, 60.0 * np.exp(expected_log)[None, :].repeat(2, 0),
                               rtol=1e-6)


def test_vignetting_is_read_as_a_gain_field_and_undone():
    """The right view darkened towards its corners by ``1 - 0.4 r^2`` (r = 1 at a corner):
    a field that varies by about half, and no curve."""
    left, right, pl, pr = _pair_points(seed=5)
    h, w = right.shape
    ys, xs = np.mgrid[0:h, 0:w]
    r2 = ((xs - w / 2) / (w / 2)) ** 2 / 2 + ((ys - h / 2) / (h / 2)) ** 2 / 2
    vignetted = right * (1 - 0.4 * r2)
    found = tone.tone_map(left, vignetted, pl, pr)
    assert found.field_range > 0.3 and found.nonlinearity < 0.02
    mapped, seen = found.apply(vignetted)[:, :-6], left[:, 6:]
    assert np.median(np.abs(mapped - seen)) < 1.0


def _exposed_pair():
    """A textured pair whose right view went through a steep response curve."""
    h, w, d = 240, 320, 7
    base = texture(h, w + d, seed=11, sigma=0.9)
    left = np.clip(base[:, :w], 0, 255).astype(np.uint8)
    right = np.clip(255.0 * (base[:, d:] / 255.0) ** 2.2, 0, 255).astype(np.uint8)
    return left, right


def test_match_stereo_matches_again_through_the_map():
    """Above a tolerance the matches are those of the right view mapped through the first
    match's map; with both tolerances None there is no map."""
    left, right = _exposed_pair()
    params = dict(max_disparity=16, sharpness_ratio=None, both_features=False)  # one run
    res = hopmatch.match_stereo(left, right, tone_tolerance=0.04, gain_field_tolerance=None,
                                **params)
    found = res.tone_map
    assert found is not None and found.nonlinearity > 0.04 and found.used
    again = hopmatch.match_stereo(left, found.apply(right), tone_tolerance=None,
                                  gain_field_tolerance=None, **params)
    np.testing.assert_array_equal(res.matched_left, again.matched_left)
    np.testing.assert_array_equal(res.matched_right, again.matched_right)
    off = hopmatch.match_stereo(left, right, tone_tolerance=None, gain_field_tolerance=None,
                                **params)
    assert off.tone_map is None
    high = hopmatch.match_stereo(left, right, tone_tolerance=10.0, gain_field_tolerance=10.0,
                                 **params)
    assert high.tone_map.nonlinearity == pytest.approx(found.nonlinearity)
    assert not high.tone_map.used
    np.testing.assert_array_equal(high.matched_left, off.matched_left)


def test_a_second_match_with_fewer_pairs_is_not_kept():
    """rematch_through_map keeps the first match when the second finds no more pairs (a
    map read off a poor first match), and says so (``used`` False); with more pairs it
    returns the second and ``used`` True; with both tolerances None it reads nothing."""
    left, right = _exposed_pair()
    first = hopmatch.match_stereo(left, right, max_disparity=16, tone_tolerance=None,
                                  gain_field_tolerance=None)
    det = hopmatch.DericheMoravecDetector()
    gray_l = det.detect_and_describe(left, keep_gray=True)[4]
    gray_r = det.detect_and_describe(right, keep_gray=True)[4]
    n_first = len(first.query_idx)
    calls = []

    def second_with(pairs):
        def rematch(gray):
            calls.append(gray)
            rows = np.arange(pairs) % n_first  # the first match's pairs, as many as asked
            return first.matched_left[rows], first.matched_right[rows], "second"
        return rematch

    args = (gray_l, gray_r, first.matched_left, first.matched_right)
    found, second = tone.rematch_through_map(*args, 0.04, None, second_with(10), rounds=1)
    assert len(calls) == 1 and second is None
    assert found.nonlinearity > 0.04 and not found.used
    np.testing.assert_array_equal(calls[0], found.apply(gray_r))
    found, second = tone.rematch_through_map(*args, 0.04, None, second_with(n_first),
                                             rounds=1)
    assert len(calls) == 2 and second is None and not found.used
    found, second = tone.rematch_through_map(*args, 0.04, None, second_with(n_first + 1),
                                             rounds=1)
    assert len(calls) == 3 and second == "second" and found.used
    assert tone.rematch_through_map(*args, None, None, second_with(n_first + 1)) == (None,
                                                                                     None)
    assert len(calls) == 3


def test_later_rounds_read_the_map_off_the_last_match_kept(monkeypatch):
    """rematch_through_map with rounds=3: each second match is made through the map read
    off the one before it while that one has more pairs; the last kept comes back with
    the map it was made through; a round that finds no more pairs ends it, and so does a
    map that changed less than TONE_CHANGE (here the pairs are the first match's own, so
    the map barely changes: TONE_CHANGE 0 lets the rounds go on)."""
    left, right = _exposed_pair()
    det = hopmatch.DericheMoravecDetector()
    gray_l = det.detect_and_describe(left, keep_gray=True)[4]
    gray_r = det.detect_and_describe(right, keep_gray=True)[4]
    first = hopmatch.match_stereo(left, right, max_disparity=16, tone_tolerance=None,
                                  gain_field_tolerance=None)
    n_first = len(first.query_idx)
    seen, counts = [], iter([n_first + 10, n_first + 20])

    def rematch(gray):
        seen.append(gray)
        rows = np.arange(next(counts)) % n_first
        return first.matched_left[rows], first.matched_right[rows], len(seen)

    args = (gray_l, gray_r, first.matched_left, first.matched_right)
    found, second = tone.rematch_through_map(*args, 0.04, None, rematch, rounds=3)
    assert len(seen) == 1 and second == 1 and found.used  # the map did not change
    monkeypatch.setattr(tone, "TONE_CHANGE", 0.0)
    seen.clear()
    counts = iter([n_first + 10, n_first + 20, n_first + 5])
    found, second = tone.rematch_through_map(*args, 0.04, None, rematch, rounds=3)
    assert len(seen) == 3 and second == 2 and found.used
    # the second round's grey view is the right view through the map read off the first
    # round's pairs, and the map kept is that one
    rows = np.arange(n_first + 10) % n_first
    again = tone.tone_map(gray_l, gray_r, first.matched_left[rows], first.matched_right[rows])
    np.testing.assert_allclose(seen[1], again.apply(gray_r), rtol=1e-5, atol=1e-3)
    np.testing.assert_allclose(found.apply(gray_r), seen[1], rtol=1e-5, atol=1e-3)
    seen.clear()
    counts = iter([n_first + 10, n_first + 20])
    found, second = tone.rematch_through_map(*args, 0.04, None, rematch, rounds=1)
    assert len(seen) == 1 and second == 1


def test_the_paper_never_remaps_and_the_tolerance_is_checked():
    left, right = _exposed_pair()
    paper = hopmatch.match_stereo(left, right, preset="paper")
    assert paper.tone_map is None and paper.network.config.tone_tolerance is None
    assert paper.network.config.gain_field_tolerance is None
    for name in ("tone_tolerance", "gain_field_tolerance"):
        with pytest.raises(ValueError, match=name):
            hopmatch.match_stereo(left, right, **{name: -0.1})
        with pytest.raises(TypeError, match=name):
            hopmatch.match_stereo(left, right, **{name: "0.1"})


def test_negative_levels_get_a_curve_and_no_field():
    """Float views below 0 (a gain is a ratio of positive levels): no field, no NaN."""
    left, right, pl, pr = _pair_points(seed=6)
    found = tone.tone_map(-300.0 + left, -300.0 + 0.5 * right, pl, pr)
    assert found is not None and found.field_range == 0.0
    assert np.isfinite(found.coefficients).all() and found.nonlinearity < 0.01


def test_piecewise_linear_continues_the_end_segments():
    knots, values = np.array([10.0, 20.0, 50.0]), np.array([0.0, 40.0, 70.0])
    x = np.array([0.0, 10.0, 15.0, 20.0, 35.0, 50.0, 60.0])
    expected = [-40.0, 0.0, 20.0, 40.0, 55.0, 70.0, 80.0]
    np.testing.assert_allclose(tone.piecewise_linear(x, knots, values), expected)


def test_the_histogram_map_gives_the_right_view_the_left_views_levels():
    """A view brightened by 2.2 and clipped (59 % of its pixels at 255): the map read off
    the two histograms undoes the gain below the clipped pile, has no gain field,
    and is far from a line (the clipped pile); a flat view gives none."""
    left = texture(240, 320, seed=11, sigma=0.9)
    bright = np.clip(2.2 * left, 0, 255)
    found = tone.histogram_tone_map(left, bright)
    assert found.n_matches == 0 and found.table is not None and found.field_range == 0.0
    assert found.nonlinearity > 0.04
    assert 0.3 < (bright < 255).mean() < 0.6
    # below the pile's knot (between the last knot under it and 255 the map is a guess)
    below = bright <= found.table[0][-2]
    assert below.mean() > 0.3
    np.testing.assert_allclose(found.apply(bright)[below], left[below], atol=1.5)
    assert tone.histogram_tone_map(left, np.full_like(left, 9.0)) is None
    assert tone.histogram_tone_map(np.full_like(left, 9.0), left) is None


def test_a_first_match_too_poor_for_a_map_is_matched_again_through_the_histograms():
    """The right view brightened by 2.2 and clipped: the first match finds nothing, so
    there is no map to read off it; the histograms' map finds thousands of matches, each
    within 1 px of the true disparity, and no warning. Without tone_tolerance the pair
    keeps no match and the warning says the right view is overexposed (it called the
    views unrelated before 2026-12-05)."""
    import warnings

    h, w, d = 240, 320, 7
    base = texture(h, w + d, seed=11, sigma=0.9)
    left = np.clip(base[:, :w], 0, 255).astype(np.uint8)
    right = np.clip(2.2 * base[:, d:], 0, 255).astype(np.uint8)
    params = dict(max_disparity=16, sharpness_ratio=None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = hopmatch.match_stereo(left, right, **params)
    assert [str(c.message) for c in caught] == []
    assert res.tone_map.n_matches == 0 and res.tone_map.used
    assert len(res.query_idx) > 1000
    disparity = res.matched_left[:, 0] - res.matched_right[:, 0]
    assert np.abs(disparity - d).max() < 1.0
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        off = hopmatch.match_stereo(left, right, tone_tolerance=None, **params)
    assert len(off.query_idx) == 0
    messages = [str(c.message) for c in caught]
    assert len(messages) == 1 and "right image" in messages[0]
    assert "overexposed" in messages[0]


def test_map_change_is_the_median_difference_over_the_rise():
    """map_change against a direct evaluation on its levels and grid; 0 for one map."""
    gray = np.random.default_rng(0).uniform(0, 255, (40, 60))
    a = _map(shape=(40, 60))
    b = _map(field=(np.log(1.1), 0.2, 0.0, 0.0, 0.0, 0.0), bounds=(-0.5, 0.5), shape=(40, 60))
    assert tone.map_change(a, a, gray) == 0.0
    low, high = np.percentile(gray[::4, ::4], tone.SPAN_PERCENTILES)
    levels = np.linspace(low, high, tone.CHANGE_LEVELS)
    diffs = []
    for y in np.linspace(0, 39, tone.CHANGE_GRID):
        for x in np.linspace(0, 59, tone.CHANGE_GRID):
            for v in levels:
                va = a.curve(np.array([v]))[0] * np.exp(a.log_gain(np.array([x]),
                                                                   np.array([y]))[0])
                vb = b.curve(np.array([v]))[0] * np.exp(b.log_gain(np.array([x]),
                                                                   np.array([y]))[0])
                diffs.append(abs(va - vb))
    rise = a.curve(levels)[-1] - a.curve(levels)[0]
    assert tone.map_change(a, b, gray) == pytest.approx(np.median(diffs) / rise, rel=1e-9)
