"""hopmatch.matching.disparity_range: max_disparity=None finds the range itself."""

from __future__ import annotations

import dataclasses
import re
import warnings

import cv2
import numpy as np
import pytest

import hopmatch
from hopmatch.errors import BudgetExceededError, DisparityRangeWarning, FewMatchesWarning
from hopmatch.matching import disparity_range as dr
from hopmatch.matching.candidates import candidate_pairs


def textured(shape=(200, 260), seed=0):
    rng = np.random.default_rng(seed)
    img = cv2.GaussianBlur(rng.random(shape).astype(np.float32), (0, 0), 1.5)
    return cv2.normalize(img, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)


def test_thin_points_keeps_one_point_per_cell():
    pts = np.random.default_rng(0).uniform(0, 100, (5000, 2)).astype(np.float32)
    keep = dr.thin_points(pts, 100)
    assert 60 <= len(keep) <= 130 and (np.diff(keep) > 0).all()
    assert len(dr.thin_points(pts[:50], 100)) == 50


def test_trimmed_extent_drops_isolated_extremes_only():
    v = np.r_[np.linspace(10, 50, 200), 300.0]
    assert dr.trimmed_extent(v, 20.0) == (10.0, 50.0)
    assert dr.trimmed_extent(np.r_[v, 301, 302, 303, 304, 305], 20.0)[1] == 305.0


def test_widen_moves_both_bounds_outwards():
    lo, hi = dr.widen(20.0, 60.0, 400.0)
    assert lo < 20.0 / dr.RANGE_FACTOR and hi > 60.0 * dr.RANGE_FACTOR
    lo, hi = dr.widen(-10.0, 5.0, 400.0)
    assert lo < -10.0 * dr.RANGE_FACTOR and hi > 5.0


def test_the_range_found_covers_a_uniform_shift_and_is_recorded():
    left = textured()
    right = np.roll(left, -9, axis=1)
    res = hopmatch.match_stereo(left, right)
    c = res.network.config
    assert c.min_disparity <= 9 <= c.max_disparity < 0.25 * left.shape[1]
    assert np.median(res.disparities) == pytest.approx(9.0, abs=0.5)


def test_min_disparity_none_lets_the_range_go_negative():
    """By default (min_disparity=None) the range found may go negative: a right image
    offset sideways keeps its matches; a range wholly negative is matched and warned about
    (two views in the wrong order look so). With the floor 0 it finds none."""
    left = textured(seed=1)
    right = np.roll(left, 7, axis=1)  # disparity -7 everywhere
    with pytest.warns(FewMatchesWarning, match="coarse pass found no range"):
        assert len(hopmatch.match_stereo(left, right, min_disparity=0).query_idx) < 20
    with pytest.warns(DisparityRangeWarning, match="every disparity the coarse pass found is "
                                                   r"negative.*right image given first"):
        res = hopmatch.match_stereo(left, right)
    assert res.network.config.min_disparity < -7 < res.network.config.max_disparity
    assert len(res.query_idx) > 100
    assert np.median(res.disparities) == pytest.approx(-7.0, abs=0.5)
    # a range partly negative (a sideways offset of a scene at several depths): no warning
    half = np.concatenate((np.roll(left, 4, axis=1)[:, :130], np.roll(left, -6, axis=1)[:, 130:]),
                          axis=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DisparityRangeWarning)
        mixed = hopmatch.match_stereo(left, half)
    assert mixed.network.config.min_disparity < -4 and mixed.network.config.max_disparity > 6


def test_a_given_max_disparity_is_used_as_given():
    left = textured(seed=2)
    res = hopmatch.match_stereo(left, np.roll(left, -5, axis=1), max_disparity=12)
    assert (res.network.config.min_disparity, res.network.config.max_disparity) == (0.0, 12.0)
    res = hopmatch.match_stereo(left, np.roll(left, -5, axis=1), max_disparity=12,
                                min_disparity=None)
    assert res.network.config.min_disparity == 0.0


def test_nothing_to_find_warns_that_the_fallback_range_was_searched():
    rng = np.random.default_rng(4)
    left = (rng.random((120, 160)) * 255).astype(np.uint8)
    right = (rng.random((120, 160)) * 255).astype(np.uint8)
    # two unrelated images: the one warning is the diagnosis (not a stereo pair), which
    # says more than the range fallback would; the fallback range was searched all the same
    from hopmatch.matching.diagnostics import NotStereoPairWarning

    with pytest.warns(NotStereoPairWarning):
        res = hopmatch.match_stereo(left, right, similarity_gate=0.0)
    assert len(res.query_idx) == 0
    # the positive disparities without a floor given (the coarse pass searched from -W/4)
    assert (res.network.config.min_disparity, res.network.config.max_disparity) == \
        pytest.approx((0.0, 0.25 * 160))
    with pytest.warns(NotStereoPairWarning):
        floor = hopmatch.match_stereo(left, right, similarity_gate=0.0, min_disparity=-8)
    assert (floor.network.config.min_disparity, floor.network.config.max_disparity) == \
        pytest.approx((-8.0, 0.25 * 160))


@pytest.fixture(scope="module")
def shifted_pair():
    """Keypoints and descriptors of a textured pair 10 px apart, and its match with the
    range found (``max_disparity=None``)."""
    left = textured((480, 640), seed=5)
    right = np.roll(left, -10, axis=1)
    det = hopmatch.DericheMoravecDetector()
    pl, _, dl, _ = det.detect_and_describe(left)
    pr, _, drr, _ = det.detect_and_describe(right)
    return pl, pr, dl, drr, hopmatch.hopfield_match(pl, pr, dl, drr, image_size=(640, 480),
                                                    min_disparity=0.0)


def test_a_found_range_over_every_budget_step_raises(shifted_pair):
    pl, pr, dl, drr, _ = shifted_pair
    with pytest.raises(BudgetExceededError):
        hopmatch.hopfield_match(pl, pr, dl, drr, image_size=(640, 480), max_neurons=10)


def test_estimated_pairs_scales_a_sample_and_stops_at_its_share_of_the_budget(shifted_pair):
    pl, pr, _, _, free = shifted_pair
    bounds = (free.config.min_disparity, free.config.max_disparity)
    true = len(candidate_pairs(pl, pr, *bounds, free.config.max_vertical, 10**9)[0])
    roomy = dataclasses.replace(free.config, max_neurons=10 * true)
    assert dr.estimated_pairs(pl, pr, *bounds, roomy) == pytest.approx(true, rel=0.1)
    tight = dataclasses.replace(free.config, max_neurons=true // 4)
    assert dr.estimated_pairs(pl, pr, *bounds, tight) == float("inf")
    assert dr.estimated_pairs(pl[:0], pr, *bounds, roomy) == 0.0


@pytest.mark.parametrize("step", range(len(dr.BUDGET_WIDENING)))
def test_a_found_range_over_budget_keeps_as_much_of_its_widening_as_fits(shifted_pair, step):
    """Between the widened range and the coarse matches' own extent, the first share of
    the widening (BUDGET_WIDENING) whose candidates fit the budget is searched, with a
    warning that names it."""
    pl, pr, dl, drr, free = shifted_pair
    asked = dataclasses.replace(free.config, max_disparity=None)  # min_disparity: its floor
    found = dr.resolve_disparity_range(asked, pl, pr, dl, drr, (640, 480),
                                       hopmatch.matching.network.run_hopfield_network)
    assert found.source == "coarse"
    assert (found.min_disparity, found.max_disparity) == (free.config.min_disparity,
                                                          free.config.max_disparity)
    lo, hi = found.found

    def searched(share):
        return (max(lo - dr.RANGE_PIXELS + share * (found.min_disparity - lo + dr.RANGE_PIXELS),
                    found.min_disparity),
                hi + dr.RANGE_PIXELS + share * (found.max_disparity - hi - dr.RANGE_PIXELS))

    def count(pts, bounds):
        return len(candidate_pairs(pts, pr, *bounds, 1.0, 10**9)[0])

    share = dr.BUDGET_WIDENING[step]
    wider = (1.0,) + dr.BUDGET_WIDENING[:step]  # what must not fit: the widened range first
    fits = count(pl, searched(share))
    coarse = count(pl[dr.thin_points(pl, dr.COARSE_POINTS)], (0.0, 160.0))
    tight = min(count(pl, searched(w)) for w in wider)
    budget = max(fits, coarse) + (tight - max(fits, coarse)) // 2
    assert max(fits, coarse) < budget < tight
    what = "the coarse matches' own range" if share == 0 else f"{share:.0%} of its widening"
    with pytest.warns(DisparityRangeWarning, match="exceeds a budget.*" + re.escape(what)):
        res = hopmatch.hopfield_match(pl, pr, dl, drr, image_size=(640, 480),
                                      max_neurons=budget, min_disparity=0.0)
    assert (res.config.min_disparity, res.config.max_disparity) == pytest.approx(searched(share))
    assert len(res.query_idx) > 50


def _thinning_budget(pl, pr, free):
    """A budget between the candidates of run_thinned's sample (and the coarse pass's)
    and those of every left point in the range found: the network can only run thinned."""
    bounds = (free.config.min_disparity, free.config.max_disparity)
    every = len(candidate_pairs(pl, pr, *bounds, free.config.max_vertical, 10**9)[0])
    sample = len(candidate_pairs(pl[dr.thin_points(pl, dr.THIN_SAMPLE)], pr, *bounds,
                                 free.config.max_vertical, 10**9)[0])
    coarse = len(candidate_pairs(pl[dr.thin_points(pl, dr.COARSE_POINTS)], pr, 0.0, 160.0,
                                 free.config.max_vertical, 10**9)[0])
    budget = (max(sample, coarse) + every) // 2
    assert max(sample, coarse) < budget < every and len(pl) > 3 * dr.THIN_MIN_POINTS
    return budget


def test_a_found_range_over_every_budget_step_runs_on_thinned_left_points(shifted_pair,
                                                                         monkeypatch):
    """When neither the range found nor any share of its widening fits the budget, the
    network runs on that range with the strongest left point of each cell of a grid (as
    many as fit), its neighbourhood scaled as the coarse pass's, and says so; the result
    is in the indices of every point (``thinned`` the points it ran on), its matches are
    right, and the same in a second call."""
    pl, pr, dl, drr, free = shifted_pair
    monkeypatch.setattr(dr, "BUDGET_WIDENING", ())
    budget = _thinning_budget(pl, pr, free)
    with pytest.warns(DisparityRangeWarning, match=r"exceeds a budget.*the network ran there "
                                                   rf"on \d+ of the {len(pl)} left points"):
        res = hopmatch.hopfield_match(pl, pr, dl, drr, image_size=(640, 480),
                                      max_neurons=budget, min_disparity=0.0)
    kept = res.thinned
    assert kept is not None and 0 < len(kept) < len(pl) and (np.diff(kept) > 0).all()
    assert np.isin(res.neuron_left, kept).all() and np.isin(res.query_idx, kept).all()
    assert len(res.neuron_left) <= budget
    # the unscaled parameters and the range found, as without the budget
    assert res.config == dataclasses.replace(free.config, max_neurons=budget)
    d = pl[res.query_idx, 0] - pr[res.train_idx, 0]
    assert len(d) > 0.5 * len(kept) and np.mean(np.abs(d - 10.0) <= 1.0) > 0.97
    with pytest.warns(DisparityRangeWarning):
        again = hopmatch.hopfield_match(pl, pr, dl, drr, image_size=(640, 480),
                                        max_neurons=budget, min_disparity=0.0)
    np.testing.assert_array_equal(again.query_idx, res.query_idx)
    np.testing.assert_array_equal(again.train_idx, res.train_idx)
    assert free.thinned is None


def test_thinning_refuses_budgets_below_its_sample_and_leaves_given_ranges_alone(
        shifted_pair, monkeypatch):
    """No thinning below the candidates of its sample (the first error is raised), nor
    for a range the caller gave (a budget error as before)."""
    pl, pr, dl, drr, free = shifted_pair
    monkeypatch.setattr(dr, "BUDGET_WIDENING", ())
    budget = _thinning_budget(pl, pr, free)
    with pytest.raises(BudgetExceededError, match=f"max_neurons={budget}"):
        hopmatch.hopfield_match(pl, pr, dl, drr, image_size=(640, 480),
                                max_disparity=free.config.max_disparity,
                                min_disparity=free.config.min_disparity, max_neurons=budget)
    monkeypatch.setattr(dr, "THIN_SAMPLE", len(pl))  # the sample: every point, over budget
    with pytest.raises(BudgetExceededError, match=f"max_neurons={budget}"):
        hopmatch.hopfield_match(pl, pr, dl, drr, image_size=(640, 480), max_neurons=budget,
                                min_disparity=0.0)


def test_the_range_covers_the_true_range_on_every_shared_scene(shared_data):
    """The 0.5th..99.5th percentiles of the ground truth lie in the range found, and at
    least 99 % of its pixels (a few pixels reach further on aloe and KITTI, where no
    keypoint matches either way)."""
    from hopmatch import datasets
    det = hopmatch.DericheMoravecDetector()
    for name in datasets.list_scenes(shared_data):
        s = datasets.load(name, root=shared_data)
        kl, dl = det.detectAndCompute(s.left, None)
        kr, drr = det.detectAndCompute(s.right, None)
        m = hopmatch.HopfieldMatcher()
        m.setPairInfo(kl, kr, s.image_size, s.image_size)
        c = m.run(dl, drr).config
        v = s.disparity[np.isfinite(s.disparity)]
        lo, hi = np.percentile(v, [0.5, 99.5])
        assert c.min_disparity <= lo and hi <= c.max_disparity, name
        assert np.mean((v >= c.min_disparity) & (v <= c.max_disparity)) >= 0.99, name


def test_points_at_negative_x_are_matched_as_the_same_points_moved_right():
    """Without image sizes the range is a fraction of the points' extent: points at
    negative x (which setPairInfo takes) gave a negative width, and a range refused as
    `max_disparity` below `min_disparity`, parameters the caller never set."""
    rng = np.random.default_rng(0)
    left = rng.uniform(0, 300, (400, 2)).astype(np.float32)
    right = left - [6.0, 0.0]
    desc = rng.normal(size=(400, 25)).astype(np.float32)
    found = []
    for shift in (0.0, -400.0):
        m = hopmatch.HopfieldMatcher.create()
        m.setPairInfo(left + [shift, 0.0], right + [shift, 0.0])
        found.append(sorted((d.queryIdx, d.trainIdx) for d in m.match(desc, desc)))
    assert len(found[0]) > 300 and found[1] == found[0]
    assert dr.search_width(None, left - 400, right - 400) == dr.search_width(None, left, right)
