"""hopmatch.matching.both_features: the pair matched on both feature images, the second
run's matches added where the first matched nothing near and supports them."""

from __future__ import annotations

import warnings
from types import SimpleNamespace
from unittest import mock

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from synthetic_pairs import texture
from unrect_scene import render_pair

import hopmatch
from hopmatch.errors import BudgetExceededError, BudgetExceededWarning, FewMatchesWarning
from hopmatch.matching import both_features
from hopmatch.matching.geometry import symmetric_epipolar_error
from hopmatch.matching.stereo_result import PASS_GUIDED, PASS_NETWORK

DISPARITY = 6


def slow_neighbour_medians(points, others, values, radius):
    """Obviously correct: every pair's distance, the median of the values within reach."""
    count = np.zeros(len(points), dtype=np.int64)
    median = np.full(len(points), np.nan)
    for k, p in enumerate(points):
        near = [values[j] for j, o in enumerate(others)
                if np.hypot(*(np.asarray(p, float) - np.asarray(o, float))) <= radius]
        count[k] = len(near)
        if near:
            median[k] = np.median(near)
    return count, median


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 40), st.integers(0, 40), st.integers(0, 2**31 - 1),
       st.sampled_from([0.5, 3.0, 12.0]), st.sampled_from([1, 3, 8, 65_536]))
def test_neighbour_medians_equal_the_slow_reference(n, m, seed, radius, block):
    """Also when the points are taken ``block`` at a time (``MEDIAN_BLOCK``, 65,536 by
    default: one block here)."""
    rng = np.random.default_rng(seed)
    points = np.round(rng.random((n, 2)) * 30, 1)  # ties and points at exactly `radius`
    others = np.round(rng.random((m, 2)) * 30, 1)
    values = np.round(rng.normal(5, 3, m), 0)  # repeated values: the median of ties
    other = np.round(rng.normal(0, 0.7, m), 1)
    with mock.patch.object(both_features, "MEDIAN_BLOCK", block):
        count, median = both_features.neighbour_medians(points, others, values, radius)
        count2, both = both_features.neighbour_medians(points, others,
                                                       np.column_stack([values, other]), radius)
    want_count, want_median = slow_neighbour_medians(points, others, values, radius)
    np.testing.assert_array_equal(count, want_count)
    # (a median read back off the sort key ``point * span + value`` is off by a rounding)
    np.testing.assert_allclose(median, want_median, atol=1e-9, equal_nan=True)
    # two columns at once (disparity and yl - yr): each the median of its own column
    np.testing.assert_array_equal(count2, want_count)
    assert both.shape == (n, 2)
    np.testing.assert_allclose(both[:, 0], want_median, atol=1e-9, equal_nan=True)
    np.testing.assert_allclose(both[:, 1], slow_neighbour_medians(points, others, other,
                                                                  radius)[1], atol=1e-9,
                               equal_nan=True)


def test_far_from_and_supported_draw_the_documented_lines():
    first = np.array([[10.0, 10.0], [50.0, 20.0]])
    second = np.array([[10.0 + both_features.SEPARATION, 10.0], [11.0, 11.0], [30.0, 30.0]])
    sep = both_features.SEPARATION
    assert both_features.far_from(second, first, sep).tolist() == [False, False, True]
    assert both_features.far_from(second, first[:0], sep).all()
    # MIN_SUPPORT matches on a circle inside the radius, disparity 7
    n, r, tol = (both_features.MIN_SUPPORT, both_features.SUPPORT_RADIUS,
                 both_features.SUPPORT_TOLERANCE)
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ring = 100 + 0.9 * r * np.column_stack([np.cos(angles), np.sin(angles)])
    query = np.full((3, 2), 100.0)
    d_query = np.array([7.0 + 0.9 * tol, 7.0 + 1.1 * tol, 7.0])
    assert both_features.supported(query, d_query, ring, np.full(n, 7.0)).tolist() == [
        True, False, True]
    assert not both_features.supported(query, d_query, ring[1:], np.full(n - 1, 7.0)).any()
    far_ring = 100 + 1.1 * r * np.column_stack([np.cos(angles), np.sin(angles)])
    assert not both_features.supported(query, d_query, far_ring, np.full(n, 7.0)).any()


def textured_pair(h=160, w=220):
    scene = texture(h, w + DISPARITY, seed=4, sigma=1.2)
    left = np.clip(scene[:, :w], 0, 255).astype(np.uint8)
    right = np.clip(scene[:, DISPARITY:], 0, 255).astype(np.uint8)  # disparity DISPARITY
    return left, right


def test_the_merged_result_keeps_both_runs_and_the_layout():
    left, right = textured_pair()
    first = hopmatch.match_stereo(left, right, max_disparity=16, both_features=False)
    second = hopmatch.match_stereo(left, right, max_disparity=16, on="intensity",
                                   both_features=False)
    res = hopmatch.match_stereo(left, right, max_disparity=16)  # both_features by default
    keep = both_features.added_matches(first, second)
    assert 0 < keep.sum() < len(keep)
    m1 = len(first.query_idx)
    # the first run's matches come first, unchanged; then the second's that were added
    np.testing.assert_array_equal(res.matched_left[:m1], first.matched_left)
    np.testing.assert_array_equal(res.matched_right[:m1], first.matched_right)
    np.testing.assert_array_equal(res.matched_left[m1:], second.matched_left[keep])
    np.testing.assert_array_equal(res.matched_right[m1:], second.matched_right[keep])
    np.testing.assert_array_equal(res.distances[m1:], second.distances[keep])
    np.testing.assert_array_equal(res.passes[:m1], first.passes)
    np.testing.assert_array_equal(res.passes[m1:], second.passes[keep] + 2)
    assert set(res.passes.tolist()) <= {PASS_NETWORK, PASS_GUIDED, 2, 3}
    # detected right points before guided ones; the first network's indices still valid
    assert res.n_detected_right == first.n_detected_right + second.n_detected_right
    np.testing.assert_array_equal(res.points_right[:first.n_detected_right],
                                  first.points_right[:first.n_detected_right])
    np.testing.assert_array_equal(
        res.points_left[res.network.query_idx], first.points_left[first.network.query_idx])
    assert len(res.responses_right) == len(res.points_right)
    assert len(res.refinement.x) == len(res.query_idx)
    assert res.second is not None and res.second.second is None
    np.testing.assert_array_equal(res.second.matched_left, second.matched_left)
    # real cv2 objects over the merged arrays
    assert len(res.matches) == len(res.query_idx) and len(res.keypoints_left) == len(
        first.points_left) + len(second.points_left)
    assert isinstance(res.matches[-1], cv2.DMatch)
    # every added match is 1 px off the true disparity at most
    assert np.all(np.abs(res.disparities - DISPARITY) < 1.0)


def run_of(left, disparity, dy, geometry=None):
    """What :func:`both_features.added_matches` reads of a run's result."""
    left = np.asarray(left, dtype=np.float32)
    right = left - np.column_stack([disparity, dy]).astype(np.float32)
    rows_f = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # yl = yr
    return SimpleNamespace(matched_left=left, matched_right=right,
                           disparities=np.asarray(disparity, np.float32), geometry=geometry,
                           fundamental_matrix=None if geometry is None else rows_f)


@pytest.mark.parametrize("estimated", [False, True])
def test_the_vertical_offset_and_an_estimated_geometry_are_tested_too(estimated):
    ys, xs = np.mgrid[0:60:5, 0:60:5]
    grid = np.column_stack([xs.ravel(), ys.ravel()]).astype(np.float64)
    geometry = object() if estimated else None
    first = run_of(grid, np.full(len(grid), 5.0), np.zeros(len(grid)), geometry)
    between = np.array([[22.5, 22.5], [32.5, 32.5], [42.5, 27.5]])
    # agrees; 0.8 px off the rows (supported, but off the epipolar lines); 2 px off them
    second = run_of(between, [5.3, 5.0, 5.0], [0.2, 0.8, 2.0], geometry)
    keep = both_features.added_matches(first, second)
    assert keep.tolist() == [True, not estimated, False]


def slow_acceptance(res):
    """Whether each added match of ``res`` passes the module's tests, one match at a time."""
    first = res.passes < 2
    fl, fr = res.matched_left[first].astype(np.float64), res.matched_right[first].astype(
        np.float64)
    ok = []
    for (xl, yl), (xr, yr) in zip(res.matched_left[~first].astype(np.float64),
                                  res.matched_right[~first].astype(np.float64)):
        dist = np.hypot(fl[:, 0] - xl, fl[:, 1] - yl)
        near = dist <= both_features.SUPPORT_RADIUS
        good = dist.min() > both_features.SEPARATION and near.sum() >= both_features.MIN_SUPPORT
        if good:
            tol = both_features.SUPPORT_TOLERANCE
            good = (abs(np.median(fl[near, 0] - fr[near, 0]) - (xl - xr)) <= tol
                    and abs(np.median(fl[near, 1] - fr[near, 1]) - (yl - yr)) <= tol)
        ok.append(good)
    return np.array(ok, dtype=bool)


@pytest.mark.parametrize("kind", ["rectified", "unrectified"])
def test_every_added_match_passes_the_tests_of_a_slow_reference(kind):
    if kind == "rectified":
        left, right = textured_pair()
        res = hopmatch.match_stereo(left, right, max_disparity=16)
    else:
        left, right, _ = render_pair()
        res = hopmatch.match_stereo(left, right, rectified=False)
        assert res.geometry is not None
    added = res.passes >= 2
    assert added.sum() > 20
    assert slow_acceptance(res).all()
    if kind == "unrectified":  # within half a pixel of the first run's epipolar lines
        e = symmetric_epipolar_error(res.fundamental_matrix, res.matched_left[added],
                                     res.matched_right[added])
        assert e.max() <= both_features.EPIPOLAR_TOLERANCE


def test_instances_and_presets_are_honoured_and_left_unchanged():
    left, right = textured_pair()
    matcher = hopmatch.HopfieldMatcher(max_disparity=16, both_features=True)
    detector = hopmatch.DericheMoravecDetector()
    res = hopmatch.match_stereo(left, right, detector=detector, matcher=matcher)
    assert res.second is not None and (res.passes >= 2).any()
    assert matcher.getBothFeatures() is True and detector.getOn() == "gradient"
    by_keywords = hopmatch.match_stereo(left, right, max_disparity=16, both_features=True)
    np.testing.assert_array_equal(res.matched_left, by_keywords.matched_left)
    # the detector on grey levels: the second run is on the gradient
    grey = hopmatch.match_stereo(left, right, max_disparity=16, on="intensity",
                                 both_features=True)
    assert grey.second is not None
    assert grey.second.network.config is not None
    plain = hopmatch.match_stereo(left, right, preset="paper")
    assert plain.second is None and hopmatch.HopfieldMatcher(preset="paper").getBothFeatures() \
        is False


def test_the_second_runs_warnings_are_not_given():
    """A flat right half for grey levels only would warn twice; the first run speaks."""
    flat = np.zeros((64, 64), np.uint8)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = hopmatch.match_stereo(flat, flat, both_features=True)
    assert len(res.query_idx) == 0 and res.second is not None
    assert len([w for w in caught if issubclass(w.category, FewMatchesWarning)]) == 1


def test_a_second_run_over_the_budget_is_left_out_with_a_warning():
    left, right = textured_pair()
    budget = {"max_disparity": 16, "max_neurons": 4000}
    first = hopmatch.match_stereo(left, right, both_features=False, **budget)  # fits...
    with pytest.raises(BudgetExceededError):  # ...where the grey-level run does not
        hopmatch.match_stereo(left, right, on="intensity", both_features=False, **budget)
    with pytest.warns(BudgetExceededWarning, match="second run, on the intensity image"):
        res = hopmatch.match_stereo(left, right, both_features=True, **budget)
    assert res.second is None and len(res.query_idx) > 0
    np.testing.assert_array_equal(res.matched_left, first.matched_left)
    np.testing.assert_array_equal(res.matched_right, first.matched_right)


@pytest.mark.parametrize("threads", [1, 2, 3, 4])
def test_deterministic_for_any_thread_count(threads):
    left, right = textured_pair()
    one = hopmatch.match_stereo(left, right, max_disparity=16, both_features=True, threads=1)
    other = hopmatch.match_stereo(left, right, max_disparity=16, both_features=True,
                                  threads=threads)
    np.testing.assert_array_equal(one.matched_right, other.matched_right)
    np.testing.assert_array_equal(one.distances, other.distances)
