"""hopmatch.matching.both_features: the pair matched on both feature images, the second
run's matches added where the first matched nothing near and supports them."""

from __future__ import annotations

import warnings

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from synthetic_pairs import texture

import hopmatch
from hopmatch.errors import BudgetExceededError, BudgetExceededWarning, FewMatchesWarning
from hopmatch.matching import both_features
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
       st.sampled_from([0.5, 3.0, 12.0]))
def test_neighbour_medians_equal_the_slow_reference(n, m, seed, radius):
    rng = np.random.default_rng(seed)
    points = np.round(rng.random((n, 2)) * 30, 1)  # ties and points at exactly `radius`
    others = np.round(rng.random((m, 2)) * 30, 1)
    values = np.round(rng.normal(5, 3, m), 0)  # repeated values: the median of ties
    count, median = both_features.neighbour_medians(points, others, values, radius)
    want_count, want_median = slow_neighbour_medians(points, others, values, radius)
    np.testing.assert_array_equal(count, want_count)
    np.testing.assert_allclose(median, want_median, equal_nan=True)


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
    first = hopmatch.match_stereo(left, right, max_disparity=16)
    second = hopmatch.match_stereo(left, right, max_disparity=16, on="intensity")
    res = hopmatch.match_stereo(left, right, max_disparity=16, both_features=True)
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
    first = hopmatch.match_stereo(left, right, **budget)  # fits the budget...
    with pytest.raises(BudgetExceededError):  # ...where the grey-level run does not
        hopmatch.match_stereo(left, right, on="intensity", **budget)
    with pytest.warns(BudgetExceededWarning, match="second run, on the intensity image"):
        res = hopmatch.match_stereo(left, right, both_features=True, **budget)
    assert res.second is None and len(res.query_idx) > 0
    np.testing.assert_array_equal(res.matched_left, first.matched_left)
    np.testing.assert_array_equal(res.matched_right, first.matched_right)


@pytest.mark.parametrize("threads", [1, 2])
def test_deterministic_for_any_thread_count(threads):
    left, right = textured_pair()
    one = hopmatch.match_stereo(left, right, max_disparity=16, both_features=True, threads=1)
    other = hopmatch.match_stereo(left, right, max_disparity=16, both_features=True,
                                  threads=threads)
    np.testing.assert_array_equal(one.matched_right, other.matched_right)
    np.testing.assert_array_equal(one.distances, other.distances)
