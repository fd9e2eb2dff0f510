"""The neighbour window's growth for sparse keypoints
(``hopmatch.matching.neighbourhood.grown_for_density``, the ``min_neighbours`` parameter):
when it applies, by how much, and what it changes in a match."""

from __future__ import annotations

import warnings
from types import SimpleNamespace

import numpy as np
import pytest
from synthetic_pairs import texture

import hopmatch
from hopmatch.errors import BudgetExceededError
from hopmatch.matching import neighbourhood
from hopmatch.matching.diagnostics import few_matches_cause
from hopmatch.matching.params import PRESETS, matcher_config


def grid(step_x, step_y, nx=30, ny=20):
    xs, ys = np.meshgrid(np.arange(nx) * step_x + 10.0, np.arange(ny) * step_y + 10.0)
    return np.ascontiguousarray(np.c_[xs.ravel(), ys.ravel()], dtype=np.float32)


def test_dense_points_keep_the_window():
    """On a 5 px grid an inner point has 9 x 5 - 1 = 44 others in the 40 x 20 window: far
    above 8."""
    config = matcher_config({})
    out, factor = neighbourhood.grown_for_density(config, grid(5.0, 5.0))
    assert out is config and factor == 1.0


@pytest.mark.parametrize("step_x,step_y,median", [(20.0, 20.0, 2), (10.0, 30.0, 4),
                                                (200.0, 200.0, 0)])
def test_sparse_points_grow_the_window_and_theta_to_reach_the_target(step_x, step_y, median):
    """A grid of ``step_x x step_y`` px: the median point has ``median`` others in the
    40 x 20 window (those within 20 px on its own row), so the window and theta grow by
    sqrt(8 / median) (0 counted as 0.5), at most 4-fold."""
    pts = grid(step_x, step_y)
    assert neighbourhood.median_neighbours(pts, 40.0, 20.0, 1000) == median
    config = matcher_config({})
    out, factor = neighbourhood.grown_for_density(config, pts)
    want = min(4.0, float(np.sqrt(8.0 / max(median, 0.5))))
    assert factor == pytest.approx(want)
    assert (out.neighbour_width, out.neighbour_height, out.theta) == pytest.approx(
        (40.0 * want, 20.0 * want, 2.0 * want))
    assert out.slope == config.slope and out.input_bias == config.input_bias


@pytest.mark.parametrize("n", [600, 1500, 3000])
def test_points_of_even_density_get_about_the_target(n):
    """Uniformly random points, 0.4 to 2 neighbours on average in the 40 x 20 window: in
    the grown window the median point has about 8 (the median of a count is an integer,
    so the growth overshoots or falls short by a step)."""
    rng = np.random.default_rng(n)
    pts = np.ascontiguousarray(rng.uniform(0, [1500, 1000], (n, 2)), dtype=np.float32)
    before = neighbourhood.median_neighbours(pts, 40.0, 20.0, 1000)
    assert before < 8
    out, factor = neighbourhood.grown_for_density(matcher_config({}), pts)
    after = neighbourhood.median_neighbours(pts, out.neighbour_width, out.neighbour_height,
                                            1000)
    assert factor > 1.0 and 5 <= after <= 16


def test_min_neighbours_zero_and_the_paper_keep_the_window():
    pts = grid(30.0, 30.0)
    for config in (matcher_config({"min_neighbours": 0.0}), matcher_config({"preset": "paper"})):
        out, factor = neighbourhood.grown_for_density(config, pts)
        assert out is config and factor == 1.0
    assert PRESETS["paper"]["min_neighbours"] == 0.0


def test_the_median_counts_a_stride_sample():
    """More points than the sample: the sample is a stride over them (every second one of
    4,000), and the median is that of the sample: 1,000 crowded points counted to the cap
    8 and 1,000 isolated ones with 0 give (0 + 8) / 2."""
    dense = grid(2.0, 2.0, 50, 40)                      # 2000 points, many neighbours
    sparse = grid(50.0, 50.0, 40, 50) + 1000.0          # 2000 isolated points
    pts = np.concatenate([dense, sparse])
    assert neighbourhood.median_neighbours(pts, 40.0, 20.0, 8) == 4.0
    assert neighbourhood.median_neighbours(sparse, 40.0, 20.0, 8) == 0.0
    assert neighbourhood.median_neighbours(dense, 40.0, 20.0, 8) == 8.0


def shifted_texture(d=8):
    t = texture(200, 340, seed=3).astype(np.uint8)
    return np.ascontiguousarray(t[:, :300]), np.ascontiguousarray(t[:, d:d + 300])


@pytest.mark.parametrize("nms_size", [15, 21])
def test_sparse_keypoints_are_matched_where_the_given_window_keeps_none(nms_size):
    """The detector's points spread out (one per 15 or 21 px): with the window as given the
    network keeps no neuron (and says that the points have too few neighbours); grown, it
    matches nearly every point, at the pair's disparity."""
    left, right = shifted_texture()
    with pytest.warns(hopmatch.errors.FewMatchesWarning,
                      match=r"the median left keypoint has [0-3] other left keypoints in the "
                            r"neighbour window \(40 x 20 px\), too few"):
        given = hopmatch.match_stereo(left, right, max_disparity=20, guided=False,
                                      nms_size=nms_size, min_neighbours=0)
    assert len(given.matched_left) == 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        grown = hopmatch.match_stereo(left, right, max_disparity=20, guided=False,
                                      nms_size=nms_size, both_features=False)
    d = grown.matched_left[:, 0] - grown.matched_right[:, 0]
    assert len(d) >= 0.8 * len(grown.points_left)
    assert np.all(np.abs(d - 8) <= 1)
    assert grown.network.config.neighbour_width > 40.0


def test_the_detectors_own_density_keeps_the_defaults_window():
    left, right = shifted_texture()
    res = hopmatch.match_stereo(left, right, max_disparity=20, guided=False)
    assert res.network.config.neighbour_width == 40.0
    assert res.network.config.theta == 2.0


def test_a_grown_window_over_the_budget_says_it_was_grown():
    """Sparse points with one crowded spot: the median point is alone, the window grows
    4-fold, and the crowded spot's lists then exceed max_interactions: the error says the
    window was grown and how to keep it."""
    sparse = grid(200.0, 200.0, 20, 20)                   # 400 points, none near another
    crowd = np.c_[np.arange(300) * 3.0 + 5.0, np.full(300, 2005.0)]  # a row, 3 px apart
    pts = np.ascontiguousarray(np.concatenate([sparse, crowd]), dtype=np.float32)
    desc = np.random.default_rng(0).normal(size=(len(pts), 81)).astype(np.float32)
    matcher = hopmatch.HopfieldMatcher.create(max_disparity=10, max_interactions=10_000)
    matcher.setPairInfo(pts, pts, (4200, 4200), (4200, 4200))
    with pytest.raises(BudgetExceededError, match="grown to 160 x 80 px"):
        matcher.match(desc, desc)
    matcher.setMinNeighbours(0)
    matcher.match(desc, desc)  # the given window keeps the crowd's lists within budget


@pytest.mark.parametrize("width,min_neighbours,sparse", [(40.0, 0.0, True), (160.0, 8.0, True),
                                                        (40.0, 8.0, False)])
def test_a_network_that_kept_nothing_is_said_to_lack_neighbours(width, min_neighbours,
                                                                sparse):
    """The few-matches cause of a network that kept no neuron: points 50 px apart have no
    other point in a 40 x 20 window (fewer than 4) and 6 in a 160 x 80 one (a window grown
    4-fold; fewer than min_neighbours, 8): too few either way; a 10 px grid has enough."""
    pts = grid(50.0, 50.0) if sparse else grid(10.0, 10.0)
    desc = np.random.default_rng(0).normal(size=(len(pts), 81)).astype(np.float32)
    config = matcher_config({"neighbour_width": width, "neighbour_height": width / 2,
                             "min_neighbours": min_neighbours, "max_disparity": 10.0})
    result = SimpleNamespace(neuron_left=np.arange(5), n_interactions=10,
                             state=np.zeros(5, dtype=bool))
    cause = few_matches_cause(result, desc, desc, config, pts, pts)
    if sparse:
        assert (f"in the neighbour window ({width:g} x {width / 2:g} px), too few to support "
                "one another" in cause), cause
    else:
        assert "input_bias, slope, theta" in cause, cause
