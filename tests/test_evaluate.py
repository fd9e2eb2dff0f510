"""Tests of hopmatch.evaluate: hand-built cases with known answers, a slow naive reference
for random inputs, input errors, and one real scene end to end."""

from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np
import pytest

from hopmatch.errors import InvalidArgumentError, InvalidTypeError
from hopmatch.evaluate import MatchScore, error_histogram, repeatability, score_matches

H, W = 40, 60


def gt_map(value: float = 5.0) -> np.ndarray:
    """Constant disparity, unknown in the 5 leftmost columns."""
    d = np.full((H, W), value, np.float32)
    d[:, :5] = np.nan
    return d


def grid_points(n: int = 12) -> np.ndarray:
    xs = np.linspace(10, W - 3, n)
    ys = np.linspace(2, H - 3, n)
    return np.column_stack([xs, ys]).astype(np.float32)


# --------------------------------------------------------------------------------------
# Naive references: per-point loops, obviously correct
# --------------------------------------------------------------------------------------


def naive_gt(x, y, disp):
    xi, yi = math.floor(x + 0.5), math.floor(y + 0.5)
    if 0 <= xi < disp.shape[1] and 0 <= yi < disp.shape[0] and np.isfinite(disp[yi, xi]):
        return float(disp[yi, xi])
    return None


def naive_score(left, right, disp, thresholds, vt, lk=None, rk=None):
    correct = {t: 0 for t in thresholds}
    n_scored = 0
    errors = []
    for (xl, yl), (xr, yr) in zip(left.tolist(), right.tolist()):
        d = naive_gt(xl, yl, disp)
        if d is None:
            continue
        n_scored += 1
        err = np.float32(np.float32(xl) - np.float32(xr)) - np.float32(d)
        errors.append(err)
        for t in thresholds:
            v = t if vt is None else vt
            if abs(err) <= t and abs(np.float32(yl) - np.float32(yr)) <= v:
                correct[t] += 1
    matchable = None
    if lk is not None:
        matchable = {}
        for t in thresholds:
            v = t if vt is None else vt
            count = 0
            for xl, yl in lk.tolist():
                d = naive_gt(xl, yl, disp)
                if d is None:
                    continue
                tx = np.float32(xl) - np.float32(d)
                if any(abs(tx - xr) <= t and abs(yl - yr) <= v for xr, yr in rk.tolist()):
                    count += 1
            matchable[t] = count
    return n_scored, correct, np.array(errors, np.float32), matchable


def naive_repeatability(left, right, disp, tol):
    n_gt = n_rep = 0
    for xl, yl in left.tolist():
        d = naive_gt(xl, yl, disp)
        if d is None:
            continue
        n_gt += 1
        tx = float(np.float32(xl) - np.float32(d))
        if any(math.hypot(tx - xr, yl - yr) <= tol for xr, yr in right.tolist()):
            n_rep += 1
    return n_gt, n_rep


# --------------------------------------------------------------------------------------
# score_matches
# --------------------------------------------------------------------------------------


class TestScoreMatches:
    def test_perfect_matcher(self):
        left = grid_points()
        right = left - np.float32([5, 0])
        s = score_matches(left, right, gt_map())
        assert isinstance(s, MatchScore)
        assert s.n_matches == 12 and s.n_scored == 12
        assert s.thresholds == (0.5, 1.0, 2.0)
        assert s.correct == {0.5: 12, 1.0: 12, 2.0: 12}
        assert s.precision == {0.5: 1.0, 1.0: 1.0, 2.0: 1.0}
        assert s.recall is None and s.matchable is None
        assert s.errors.dtype == np.float32 and s.errors.shape == (12,)
        np.testing.assert_array_equal(s.errors, 0)
        assert s.scored.dtype == np.bool_ and s.scored.all()

    def test_shift_by_1_5_px(self):
        left = grid_points()
        right = left - np.float32([5 + 1.5, 0])  # disparity 6.5 instead of 5
        s = score_matches(left, right, gt_map())
        assert s.correct == {0.5: 0, 1.0: 0, 2.0: 12}
        assert s.precision[2.0] == 1.0 and s.precision[1.0] == 0.0
        np.testing.assert_allclose(s.errors, 1.5)  # signed: estimated - true

    def test_negative_error_sign(self):
        left = grid_points(3)
        s = score_matches(left, left - np.float32([4, 0]), gt_map())
        np.testing.assert_allclose(s.errors, -1.0)

    def test_empty_matcher(self):
        empty = np.zeros((0, 2), np.float32)
        s = score_matches(empty, empty, gt_map(), right_keypoints=grid_points(),
                          left_keypoints=grid_points())
        assert s.n_matches == 0 and s.n_scored == 0
        assert s.correct == {0.5: 0, 1.0: 0, 2.0: 0}
        assert all(math.isnan(p) for p in s.precision.values())
        assert s.errors.shape == (0,) and s.errors.dtype == np.float32
        assert s.scored.shape == (0,) and s.scored.dtype == np.bool_
        # The right keypoints are not at xl - 5: nothing matchable, recall NaN.
        assert s.matchable == {0.5: 0, 1.0: 0, 2.0: 0}
        assert all(math.isnan(r) for r in s.recall.values())
        # Something matchable but nothing found: recall 0.
        s = score_matches(empty, empty, gt_map(), right_keypoints=grid_points() - [5, 0],
                          left_keypoints=grid_points())
        assert s.matchable == {0.5: 12, 1.0: 12, 2.0: 12}
        assert s.recall == {0.5: 0.0, 1.0: 0.0, 2.0: 0.0}

    def test_empty_list_and_keypoint_sequence(self):
        s = score_matches([], [], gt_map())
        assert s.n_matches == 0
        kps_l = [cv2.KeyPoint(20.0, 10.0, 3.0)]
        kps_r = [cv2.KeyPoint(15.0, 10.0, 3.0)]
        s = score_matches(kps_l, kps_r, gt_map())
        assert s.correct[0.5] == 1

    def test_unknown_and_outside_not_scored(self):
        left = np.array([[2, 5], [20, 5], [-3, 5], [20, 50], [59.4, 39.4]], np.float32)
        right = left - np.float32([5, 0])
        s = score_matches(left, right, gt_map())
        assert s.n_matches == 5 and s.n_scored == 2
        np.testing.assert_array_equal(s.scored, [False, True, False, False, True])
        assert s.precision[0.5] == 1.0

    def test_nearest_pixel_lookup(self):
        d = np.zeros((4, 4), np.float32)
        d[1, 2] = 3.0  # only pixel (x=2, y=1) has disparity 3
        left = np.array([[1.6, 1.4], [2.4, 0.6], [1.4, 1.0], [2.0, 1.6]], np.float32)
        right = left - np.float32([3, 0])
        s = score_matches(left, right, d, thresholds=(0.5,))
        np.testing.assert_array_equal(np.abs(s.errors) <= 0.5, [True, True, False, False])

    def test_half_pixel_rounds_up(self):
        d = np.zeros((3, 3), np.float32)
        d[1, 1] = 2.0
        s = score_matches([[0.5, 0.5]], [[-1.5, 0.5]], d, thresholds=(0.1,))
        assert s.correct[0.1] == 1

    def test_inf_is_unknown(self):
        d = gt_map()
        d[:, 30:] = np.inf
        left = np.array([[20, 5], [40, 5]], np.float32)
        s = score_matches(left, left - np.float32([5, 0]), d)
        assert s.n_scored == 1

    def test_vertical_tolerance(self):
        left = np.array([[20, 10], [30, 10], [40, 10]], np.float32)
        right = left - np.float32([5, 0])
        right[:, 1] += np.float32([0.0, 0.8, 3.0])
        # Default: |dy| <= t, the same tolerance as for the disparity.
        s = score_matches(left, right, gt_map())
        assert s.correct == {0.5: 1, 1.0: 2, 2.0: 2}
        s = score_matches(left, right, gt_map(), vertical_tolerance=1.0)
        assert s.correct == {0.5: 2, 1.0: 2, 2.0: 2}
        s = score_matches(left, right, gt_map(), vertical_tolerance=0)
        assert s.correct == {0.5: 1, 1.0: 1, 2.0: 1}
        s = score_matches(left, right, gt_map(), vertical_tolerance=5.0)
        assert s.correct == {0.5: 3, 1.0: 3, 2.0: 3}
        assert s.vertical_tolerance == 5.0

    def test_recall_against_matchable(self):
        left_kp = np.array([[20, 5], [30, 10], [40, 15], [50, 20], [2, 25]], np.float32)
        right_kp = np.array(
            [
                [15, 5],  # exactly at 20 - 5
                [25.8, 10],  # 0.8 px from 30 - 5
                [36.5, 15],  # 1.5 px from 40 - 5
                [45, 23],  # 3 px off vertically from 50 - 5
                [0, 0],  # matches nothing
            ],
            np.float32,
        )
        # The matcher found the first two correctly and paired the third wrongly.
        left = left_kp[:3]
        right = right_kp[[0, 1, 4]]
        s = score_matches(left, right, gt_map(), right_keypoints=right_kp, left_keypoints=left_kp)
        # Left kp 5 has no ground truth (x = 2), so it is never matchable.
        assert s.matchable == {0.5: 1, 1.0: 2, 2.0: 3}
        assert s.correct == {0.5: 1, 1.0: 2, 2.0: 2}
        assert s.recall == {0.5: 1.0, 1.0: 1.0, 2.0: pytest.approx(2 / 3)}
        s = score_matches(left, right, gt_map(), vertical_tolerance=3.0,
                          right_keypoints=right_kp, left_keypoints=left_kp)
        assert s.matchable == {0.5: 2, 1.0: 3, 2.0: 4}

    def test_several_right_keypoints_count_once(self):
        left_kp = np.array([[20, 5]], np.float32)
        right_kp = np.array([[15, 5], [15.2, 5], [14.9, 5.1]], np.float32)
        s = score_matches(np.zeros((0, 2)), np.zeros((0, 2)), gt_map(),
                          right_keypoints=right_kp, left_keypoints=left_kp)
        assert s.matchable == {0.5: 1, 1.0: 1, 2.0: 1}
        assert s.recall == {0.5: 0.0, 1.0: 0.0, 2.0: 0.0}

    def test_thresholds_forms(self):
        left = grid_points(4)
        s = score_matches(left, left - np.float32([5, 0]), gt_map(), thresholds=1)
        assert s.thresholds == (1.0,)
        s = score_matches(left, left - np.float32([5, 0]), gt_map(),
                          thresholds=np.array([2.0, 1.0, 2.0]))
        assert s.thresholds == (2.0, 1.0)

    def test_as_dict(self):
        left = grid_points(4)
        right = left - np.float32([6.5, 0])
        row = score_matches(left, right, gt_map(), thresholds=(1.0, 2.0)).as_dict()
        assert row["n_matches"] == 4 and row["n_scored"] == 4
        assert row["correct@1"] == 0 and row["precision@2"] == 1.0
        assert row["mean_abs_error"] == pytest.approx(1.5)
        assert row["median_abs_error"] == pytest.approx(1.5)
        assert "recall@1" not in row
        row = score_matches(left, right, gt_map(), thresholds=(0.5,),
                            right_keypoints=right, left_keypoints=left).as_dict()
        assert row["matchable@0.5"] == 0 and math.isnan(row["recall@0.5"])
        empty = score_matches([], [], gt_map()).as_dict()
        assert math.isnan(empty["mean_abs_error"]) and math.isnan(empty["precision@0.5"])

    def test_frozen_and_repr(self):
        s = score_matches(grid_points(3), grid_points(3), gt_map())
        with pytest.raises(dataclasses.FrozenInstanceError):
            s.n_scored = 3
        assert "MatchScore(n_matches=3" in repr(s)

    @pytest.mark.parametrize("vt", [None, 0.7])
    def test_against_naive_reference(self, vt):
        rng = np.random.default_rng(7)
        disp = rng.uniform(0, 10, (H, W)).astype(np.float32)
        disp[rng.random((H, W)) < 0.2] = np.nan
        n = 400
        left = np.column_stack([rng.uniform(-2, W + 2, n), rng.uniform(-2, H + 2, n)])
        left = left.astype(np.float32)
        d_true = np.array([naive_gt(x, y, disp) or 0.0 for x, y in left.tolist()], np.float32)
        right = left - np.column_stack([d_true, np.zeros(n)]).astype(np.float32)
        right += rng.normal(0, 1.0, (n, 2)).astype(np.float32)
        lk = np.vstack([left, rng.uniform(0, W, (50, 2))]).astype(np.float32)
        rk = np.vstack([right[::2], rng.uniform(0, W, (80, 2))]).astype(np.float32)
        ts = (0.5, 1.0, 2.0, 3.0)
        s = score_matches(left, right, disp, ts, vt, right_keypoints=rk, left_keypoints=lk)
        n_scored, correct, errors, matchable = naive_score(left, right, disp, ts, vt, lk, rk)
        assert s.n_scored == n_scored and s.correct == correct and s.matchable == matchable
        np.testing.assert_array_equal(s.errors, errors)
        for t in ts:
            assert s.precision[t] == correct[t] / n_scored


class TestScoreMatchesErrors:
    def test_unequal_counts(self):
        with pytest.raises(InvalidArgumentError, match="same number of rows.*3 and 2"):
            score_matches(grid_points(3), grid_points(2), gt_map())

    def test_wrong_point_shape(self):
        with pytest.raises(InvalidArgumentError, match=r"`left_pts` must have shape \(N, 2\)"):
            score_matches(np.zeros((3, 3)), np.zeros((3, 2)), gt_map())

    def test_nan_points(self):
        bad = grid_points(3)
        bad[1, 0] = np.nan
        with pytest.raises(InvalidArgumentError, match="`right_pts` contains NaN"):
            score_matches(grid_points(3), bad, gt_map())

    def test_point_type(self):
        with pytest.raises(InvalidTypeError, match="`left_pts`"):
            score_matches("abc", grid_points(3), gt_map())

    def test_disparity_shape(self):
        with pytest.raises(InvalidArgumentError,
                           match=r"`disparity_gt` must be a 2-dim.*\(4, 4, 3\)"):
            score_matches(grid_points(3), grid_points(3), np.zeros((4, 4, 3)))

    def test_disparity_type(self):
        with pytest.raises(InvalidTypeError, match="`disparity_gt` must be a numpy array"):
            score_matches(grid_points(3), grid_points(3), [[1.0]])
        with pytest.raises(InvalidTypeError, match="dtype bool"):
            score_matches(grid_points(3), grid_points(3), np.zeros((3, 3), bool))

    def test_disparity_empty(self):
        with pytest.raises(InvalidArgumentError, match="must not be empty"):
            score_matches(grid_points(3), grid_points(3), np.zeros((0, 3)))

    @pytest.mark.parametrize("bad", [(), (0.0,), (-1.0,), (math.inf,)])
    def test_bad_thresholds(self, bad):
        with pytest.raises(InvalidArgumentError, match="`thresholds`"):
            score_matches(grid_points(3), grid_points(3), gt_map(), thresholds=bad)

    def test_threshold_type(self):
        with pytest.raises(InvalidTypeError, match="`thresholds`"):
            score_matches(grid_points(3), grid_points(3), gt_map(), thresholds="1")
        with pytest.raises(InvalidTypeError, match="`thresholds`"):
            score_matches(grid_points(3), grid_points(3), gt_map(), thresholds=(True,))

    def test_bad_vertical_tolerance(self):
        with pytest.raises(InvalidArgumentError,
                           match=r"`vertical_tolerance` must be a finite number in \[0.0, inf\]"):
            score_matches(grid_points(3), grid_points(3), gt_map(), vertical_tolerance=-1)

    def test_only_one_keypoint_set(self):
        with pytest.raises(InvalidArgumentError, match="both.*got only `right_keypoints`"):
            score_matches(grid_points(3), grid_points(3), gt_map(), right_keypoints=grid_points())

    def test_errors_are_value_errors(self):
        with pytest.raises(ValueError):
            score_matches(grid_points(3), grid_points(2), gt_map())


# --------------------------------------------------------------------------------------
# error_histogram
# --------------------------------------------------------------------------------------


class TestErrorHistogram:
    def test_default_edges(self):
        counts, edges = error_histogram(np.array([0.1, -0.7, 1.5, -3.0, 10.0], np.float32))
        assert counts.tolist() == [1, 1, 1, 1, 1] and counts.dtype == np.int64
        assert edges.tolist() == [0.0, 0.5, 1.0, 2.0, 4.0, math.inf]

    def test_signed(self):
        counts, _ = error_histogram([-1.5, -0.2, 0.3, 0.4], bins=[-2, 0, 2], absolute=False)
        assert counts.tolist() == [2, 2]

    def test_int_bins(self):
        counts, edges = error_histogram([0.0, 1.0, 2.0, 4.0], bins=4)
        assert counts.tolist() == [1, 1, 1, 1] and edges.tolist() == [0, 1, 2, 3, 4]

    def test_empty_keeps_shape(self):
        counts, edges = error_histogram(np.zeros(0, np.float32), bins=3)
        assert counts.tolist() == [0, 0, 0] and edges.shape == (4,)

    def test_errors(self):
        with pytest.raises(InvalidArgumentError, match="1-dimensional"):
            error_histogram(np.zeros((2, 2)), bins=2)
        with pytest.raises(InvalidArgumentError, match="NaN"):
            error_histogram([np.nan], bins=2)
        with pytest.raises(InvalidArgumentError, match="increasing"):
            error_histogram([1.0], bins=[2, 1])
        with pytest.raises(InvalidArgumentError, match=">= 1"):
            error_histogram([1.0], bins=0)
        with pytest.raises(InvalidTypeError, match="`errors`"):
            error_histogram(["a"], bins=2)


# --------------------------------------------------------------------------------------
# repeatability
# --------------------------------------------------------------------------------------


class TestRepeatability:
    def test_hand_built(self):
        left = np.array([[20, 5], [30, 10], [40, 15], [50, 20], [2, 25]], np.float32)
        right = np.array(
            [
                [15, 5],  # exact
                [25.6, 10.6],  # 0.85 px (Euclidean) from 30 - 5: repeated at 1
                [35.8, 15.8],  # 1.13 px: Chebyshev would say 0.8, Euclidean says no
                [0, 0],
            ],
            np.float32,
        )
        frac, n_gt, n_rep = repeatability(left, right, gt_map(), tolerance=1.0)
        assert (n_gt, n_rep) == (4, 2) and frac == 0.5
        assert repeatability(left, right, gt_map(), tolerance=1.2) == (0.75, 4, 3)
        assert repeatability(left, right, gt_map(), tolerance=0) == (0.25, 4, 1)

    def test_no_ground_truth(self):
        frac, n_gt, n_rep = repeatability([[1, 1]], [[0, 0]], gt_map())
        assert math.isnan(frac) and (n_gt, n_rep) == (0, 0)

    def test_no_right_points(self):
        assert repeatability(grid_points(3), np.zeros((0, 2)), gt_map()) == (0.0, 3, 0)

    def test_against_naive_reference(self):
        rng = np.random.default_rng(3)
        disp = rng.uniform(0, 8, (H, W)).astype(np.float32)
        disp[rng.random((H, W)) < 0.3] = np.nan
        left = rng.uniform(0, [W, H], (300, 2)).astype(np.float32)
        right = rng.uniform(0, [W, H], (300, 2)).astype(np.float32)
        frac, n_gt, n_rep = repeatability(left, right, disp, tolerance=1.5)
        assert (n_gt, n_rep) == naive_repeatability(left, right, disp, 1.5)
        assert frac == n_rep / n_gt

    def test_errors(self):
        with pytest.raises(InvalidArgumentError, match="`tolerance`"):
            repeatability(grid_points(3), grid_points(3), gt_map(), tolerance=-1)
        with pytest.raises(InvalidArgumentError, match=r"`right_pts` must have shape \(N, 2\)"):
            repeatability(grid_points(3), np.zeros(4), gt_map())


# --------------------------------------------------------------------------------------
# A real scene end to end
# --------------------------------------------------------------------------------------


@pytest.mark.shared_data
def test_tsukuba_ground_truth_matcher(shared_data):
    from hopmatch.datasets import load

    scene = load("middlebury/tsukuba", root=shared_data)
    rng = np.random.default_rng(0)
    ys, xs = np.nonzero(scene.valid)
    pick = rng.choice(xs.size, 500, replace=False)
    left = np.column_stack([xs[pick], ys[pick]]).astype(np.float32)
    right = left - np.column_stack([scene.disparity[ys[pick], xs[pick]], np.zeros(500)])
    right = right.astype(np.float32)
    s = score_matches(left, right, scene.disparity)
    assert s.n_scored == 500 and s.precision == {0.5: 1.0, 1.0: 1.0, 2.0: 1.0}
    s = score_matches(left, right - np.float32([1.5, 0]), scene.disparity)
    assert s.precision == {0.5: 0.0, 1.0: 0.0, 2.0: 1.0}
    s = score_matches(left, right, scene.disparity, right_keypoints=right, left_keypoints=left)
    assert s.recall == {0.5: 1.0, 1.0: 1.0, 2.0: 1.0}
    assert repeatability(left, right, scene.disparity, tolerance=0.5) == (1.0, 500, 500)


# --------------------------------------------------------------------------------------
# correct_matches: the per-match flag
# --------------------------------------------------------------------------------------


def test_correct_matches_agrees_with_the_counts():
    from hopmatch.evaluate import correct_matches

    rng = np.random.default_rng(5)
    gt = np.full((40, 60), 3.0, np.float32)
    gt[:, :10] = np.nan
    left = (rng.random((200, 2)) * [59, 39]).astype(np.float32)
    right = left - np.float32([3, 0]) + rng.normal(0, 1.0, (200, 2)).astype(np.float32)
    s = score_matches(left, right, gt, thresholds=(0.5, 1.0, 2.0))
    for t in s.thresholds:
        correct, known = correct_matches(s, left, right, t)
        assert int(correct.sum()) == s.correct[t]
        assert np.array_equal(known, s.scored) and not (correct & ~known).any()
    vt = score_matches(left, right, gt, thresholds=(1.0,), vertical_tolerance=0.25)
    assert int(correct_matches(vt, left, right, 1.0)[0].sum()) == vt.correct[1.0]


def test_correct_matches_bad_arguments():
    from hopmatch.evaluate import correct_matches

    gt = np.full((10, 20), 4.0, np.float32)
    left = np.array([[10, 2]], np.float32)
    s = score_matches(left, left - [4, 0], gt)
    with pytest.raises(InvalidTypeError, match="score") as info:
        correct_matches({"scored": []}, left, left)
    assert info.value.argument == "score"
    with pytest.raises(InvalidArgumentError, match="1 matches"):
        correct_matches(s, np.zeros((2, 2), np.float32), np.zeros((2, 2), np.float32))
    with pytest.raises(InvalidArgumentError, match="tolerance"):
        correct_matches(s, left, left - [4, 0], 0.0)


def test_huge_tolerances_give_no_runtime_warning_and_recall_refuses_them_first():
    """A threshold of 1e300 was cast to float32 against the float32 errors (an overflow
    RuntimeWarning); with keypoints, recall would have enumerated every keypoint pair."""
    import time
    import warnings

    gt = np.full((10, 20), 4.0, np.float32)
    left = np.array([[10, 2], [12, 5]], np.float32)
    right = np.array([[6, 2], [6.5, 5]], np.float32)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        s = score_matches(left, right, gt, thresholds=(1e300, 1.0), vertical_tolerance=1e300)
    assert s.correct == {1e300: 2, 1.0: 1}
    rng = np.random.default_rng(0)
    kps = rng.uniform(0, 19, (20_000, 2)).astype(np.float32)
    t0 = time.perf_counter()
    with pytest.raises(InvalidArgumentError, match="at most 64 px") as e:
        score_matches(left, right, gt, thresholds=(1e300,), left_keypoints=kps,
                      right_keypoints=kps)
    assert e.value.argument == "thresholds" and time.perf_counter() - t0 < 1.0
    assert score_matches(left, right, gt, thresholds=(64.0,), left_keypoints=left,
                         right_keypoints=right).recall[64.0] == 1.0
