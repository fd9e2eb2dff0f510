"""Tests of hopmatch.stereo.points: cv2 keypoints and matches to point arrays and back,
and disparities."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from hopmatch.errors import InvalidArgumentError, InvalidTypeError
from hopmatch.stereo import keypoints_and_matches, match_disparities, matched_points


class TestKeypointsAndMatches:
    def test_round_trip(self):
        rng = np.random.default_rng(0)
        left = rng.uniform(0, 600, (12, 2)).astype(np.float32)
        right = rng.uniform(0, 600, (12, 2)).astype(np.float32)
        kl, kr, dm = keypoints_and_matches(left, right, distances=np.arange(12) * 0.5)
        assert all(isinstance(k, cv2.KeyPoint) for k in kl + kr)
        assert all(isinstance(m, cv2.DMatch) for m in dm)
        assert [m.distance for m in dm] == [i * 0.5 for i in range(12)]
        l2, r2 = matched_points(kl, kr, dm)
        np.testing.assert_array_equal(l2, left)
        np.testing.assert_array_equal(r2, right)
        assert l2.dtype == np.float32 and l2.shape == (12, 2)
        # cv2 accepts them as they are
        img = np.zeros((600, 600), np.uint8)
        out = cv2.drawMatches(img, list(kl), img, list(kr), list(dm), None)
        assert out.shape[:2] == (600, 1200)

    def test_with_a_real_matcher(self):
        rng = np.random.default_rng(1)
        dq = rng.random((20, 16), dtype=np.float32)
        perm = rng.permutation(20)
        dt = dq[perm]
        q = [cv2.KeyPoint(float(i), 2.0 * i, 3) for i in range(20)]
        t = [cv2.KeyPoint(float(100 + j), 0.0, 3) for j in range(20)]
        matches = cv2.BFMatcher(cv2.NORM_L2).match(dq, dt)
        left, right = matched_points(q, t, matches)
        inv = np.argsort(perm)  # query i is train inv[i]
        for m, lp, rp in zip(matches, left, right):
            assert inv[m.queryIdx] == m.trainIdx
            assert tuple(lp) == q[m.queryIdx].pt and tuple(rp) == t[m.trainIdx].pt

    def test_index_array_and_point_arrays(self):
        q = np.array([[1, 2], [3, 4], [5, 6]])
        t = np.array([[7, 8], [9, 10]])
        left, right = matched_points(q, t, np.array([[2, 0], [0, 1]]))
        assert left.tolist() == [[5, 6], [1, 2]] and right.tolist() == [[7, 8], [9, 10]]

    def test_empty(self):
        left, right = matched_points((), (), [])
        assert left.shape == right.shape == (0, 2) and left.dtype == np.float32
        kl, kr, dm = keypoints_and_matches(np.zeros((0, 2)), np.zeros((0, 2)))
        assert kl == kr == dm == ()

    def test_out_of_range_names_the_match(self):
        q = [cv2.KeyPoint(1, 1, 1)]
        t = [cv2.KeyPoint(1, 1, 1), cv2.KeyPoint(2, 2, 1)]
        pattern = r"matches\[1\]\.queryIdx.* = 1 .*query_kpts.*swapped"
        with pytest.raises(InvalidArgumentError, match=pattern):
            matched_points(q, t, [cv2.DMatch(0, 1, 0), cv2.DMatch(1, 0, 0)])
        with pytest.raises(InvalidArgumentError, match=r"trainIdx.*train_kpts"):
            matched_points(t, q, [cv2.DMatch(0, 1, 0)])

    def test_knn_lists_are_refused_with_a_hint(self):
        q = [cv2.KeyPoint(1, 1, 1)]
        with pytest.raises(InvalidTypeError, match=r"knnMatch.*ratio|distance < 0.8"):
            matched_points(q, q, [[cv2.DMatch(0, 0, 0), cv2.DMatch(0, 0, 1)]])
        with pytest.raises(InvalidTypeError, match="cv2.DMatch"):
            matched_points(q, q, [(0, 0)])
        with pytest.raises(InvalidTypeError, match="matches"):
            matched_points(q, q, "nope")

    def test_bad_lengths_and_distances(self):
        with pytest.raises(InvalidArgumentError, match=r"same length.*got 2 and 1"):
            keypoints_and_matches([[0, 0], [1, 1]], [[0, 0]])
        with pytest.raises(InvalidArgumentError, match=r"`distances` must have shape \(1,\)"):
            keypoints_and_matches([[0, 0]], [[0, 0]], distances=[1, 2])
        with pytest.raises(InvalidArgumentError, match="size"):
            keypoints_and_matches([[0, 0]], [[0, 0]], size=0)


class TestMatchDisparities:
    def test_match_disparities(self):
        d = match_disparities([[10, 1], [5.5, 2]], [[4, 1], [6, 2]])
        assert d.dtype == np.float32 and d.tolist() == [6.0, -0.5]
