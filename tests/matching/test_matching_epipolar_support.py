"""hopmatch.matching.epipolar_support: where the bootstrap inliers pin F down, and the
matches of match_stereo(rectified=False) that they do not vouch for."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from unrect_scene import fundamental, plane_correspondences, render_pair

import hopmatch
from hopmatch.errors import FewMatchesWarning, GeometryWarning
from hopmatch.matching import epipolar_support as es
from hopmatch.matching.geometry import EpipolarGeometry, estimate_geometry


@pytest.fixture(scope="module")
def correspondences():
    """True correspondences of the two planes, and the same with 0.3 px of noise."""
    left, right = plane_correspondences(400)
    rng = np.random.default_rng(3)
    return left, right, left + rng.normal(0, 0.3, left.shape), right + rng.normal(
        0, 0.3, right.shape)


def test_the_spread_is_small_among_the_inliers_and_grows_beyond_them(correspondences):
    """F fitted to noisy inliers of the left third of the image: its lines are pinned down
    there and extrapolated over the right third, where the spread is several times
    larger; with inliers everywhere it is small everywhere."""
    left, right, noisy_l, noisy_r = correspondences
    near, far = left[:, 0] < 160, left[:, 0] > 320
    assert near.sum() > 30 and far.sum() > 30
    spread = es.epipolar_spread(noisy_l[near], noisy_r[near], left, right)
    assert np.median(spread[far]) > 5 * np.median(spread[near])
    assert np.median(spread[near]) < 0.25 and np.percentile(spread[far], 10) > 0.5
    everywhere = es.epipolar_spread(noisy_l, noisy_r, left, right)
    assert everywhere.max() < es.SUPPORT_LIMIT
    again = es.epipolar_spread(noisy_l[near], noisy_r[near], left, right)
    np.testing.assert_array_equal(again, spread)  # a fixed seed: the same draws


def test_unsupported_marks_the_extrapolated_matches_and_judges_no_small_geometry(
        correspondences):
    left, right, noisy_l, noisy_r = correspondences
    near = left[:, 0] < 160
    geometry = EpipolarGeometry(fundamental(), noisy_l.astype(np.float32),
                                noisy_r.astype(np.float32), near, 0.3, "sift")
    marked = es.unsupported(geometry, (360, 480), left, right)
    assert marked[left[:, 0] > 320].mean() > 0.8 and marked[near].mean() < 0.1
    # a larger image: the bootstrap ran on a pyramid level, its limit doubles per level
    assert es.unsupported(geometry, (1440, 1920), left, right).sum() < marked.sum()
    few = near & (np.cumsum(near) <= es.SUPPORT_MIN_INLIERS - 1)
    small = EpipolarGeometry(fundamental(), noisy_l.astype(np.float32),
                             noisy_r.astype(np.float32), few, 0.3, "sift")
    assert not es.unsupported(small, (360, 480), left, right).any()
    none = EpipolarGeometry(None, noisy_l, noisy_r, near, float("nan"), "sift", "no F")
    assert not es.unsupported(none, (360, 480), left, right).any()


def test_too_few_distinct_inliers_give_nan_not_an_error():
    pts = np.array([[10.0, 10.0], [50.0, 12.0], [90.0, 40.0]])
    spread = es.epipolar_spread(pts, pts + [5.0, 0.0], pts, pts + [5.0, 0.0])
    assert spread.shape == (3,) and np.isnan(spread).all()


@pytest.fixture(scope="module")
def verged_pair():
    left, right, _ = render_pair()
    return left, right, hopmatch.match_stereo(left, right, rectified=False)


def test_every_unrectified_match_is_vouched_for_by_the_bootstrap(verged_pair):
    left, right, res = verged_pair
    assert len(res.query_idx) > 1000
    bootstrap = estimate_geometry(left, right)  # the same in any call: deterministic
    assert not es.unsupported(bootstrap, left.shape, res.matched_left,
                              res.matched_right).any()


def test_the_unsupported_matches_leave_the_result_whole(verged_pair, monkeypatch):
    """With a limit nothing meets, every match is dropped, the arrays stay consistent and
    the few-matches warning says so; a given F is trusted, never judged."""
    left, right, res = verged_pair
    monkeypatch.setattr(es, "SUPPORT_LIMIT", 0.0)
    with pytest.warns(FewMatchesWarning), pytest.warns(GeometryWarning,
                                                       match=r"dropped \d+ of its"):
        none = hopmatch.match_stereo(left, right, rectified=False)
    assert len(none.query_idx) == len(none.train_idx) == len(none.distances) == 0
    assert len(none.passes) == 0 and len(none.points_left) == len(res.points_left)
    assert none.guided is None or len(none.guided.query_idx) == 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        given = hopmatch.match_stereo(left, right, fundamental_matrix=res.fundamental_matrix)
    assert len(given.query_idx) > 1000


def test_a_large_drop_is_reported_and_a_small_one_is_not():
    assert es.support_notes(np.zeros(0, bool)) == []
    few = np.zeros(100, bool)
    few[:24] = True
    assert es.support_notes(few) == []
    few[:25] = True
    (message,) = es.support_notes(few)
    assert "dropped 25 of its 100 matches" in message and "fundamental_matrix" in message
