"""Tests of hopmatch.stereo.epipolar: epipolar distances, estimate_fundamental and
rectify_uncalibrated."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from stereo_rig import K1, K2, R, T, project, render_blobs

from hopmatch.errors import BudgetExceededError, InvalidArgumentError
from hopmatch.stereo import (
    epipolar_distance_matrix,
    epipolar_distances,
    estimate_fundamental,
    rectify_uncalibrated,
)


class TestEpipolar:
    def test_true_pairs_near_zero_shuffled_large(self, calibration, scene):
        F = calibration.fundamental_matrix()
        left = project(scene, K1)
        right = project(scene, K2, R, T)
        d = epipolar_distances(left, right, F)
        assert d.dtype == np.float32 and d.shape == (len(scene),)
        assert d.max() < 1e-3
        shuffled = epipolar_distances(left, np.roll(right, 7, axis=0), F)
        assert np.median(shuffled) > 5.0
        dmax = epipolar_distances(left, np.roll(right, 7, axis=0), F, reduce="max")
        assert (dmax >= shuffled - 1e-4).all()

    def test_matrix_agrees_with_pairs(self, calibration, scene):
        F = calibration.fundamental_matrix()
        left = project(scene[:10], K1)
        right = project(scene[:10], K2, R, T)
        m = epipolar_distance_matrix(left, right, F)
        assert m.shape == (10, 10) and m.dtype == np.float32
        np.testing.assert_allclose(np.diag(m), epipolar_distances(left, right, F), atol=1e-4)
        np.testing.assert_allclose(m[2, 5], epipolar_distances(left[2:3], right[5:6], F)[0],
                                   rtol=1e-4)
        assert epipolar_distance_matrix(left[:0], right, F).shape == (0, 10)

    def test_matrix_budget(self):
        F = np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0.0]])
        pts = np.zeros((30, 2))
        with pytest.raises(BudgetExceededError, match=r"30 x 30.*900 pairs.*max_pairs=100"):
            epipolar_distance_matrix(pts, pts, F, max_pairs=100)
        assert isinstance(BudgetExceededError("x"), ValueError)

    def test_estimate_fundamental(self, calibration, scene):
        left = project(scene, K1)
        right = project(scene, K2, R, T)
        rng = np.random.default_rng(3)
        noisy_r = right + rng.normal(0, 0.05, right.shape)
        for method in (cv2.FM_8POINT, cv2.FM_RANSAC, cv2.FM_LMEDS):
            F, inliers = estimate_fundamental(left, noisy_r, method=method)
            assert F.shape == (3, 3) and F.dtype == np.float64
            assert inliers.dtype == np.bool_ and inliers.shape == (len(scene),)
            assert inliers.mean() > 0.9
            assert np.median(epipolar_distances(left, right, F)) < 0.1
        # outliers are found
        bad = noisy_r.copy()
        bad[:6] += 40
        F, inliers = estimate_fundamental(left, bad, threshold=1.0)
        assert not inliers[:6].any() and inliers[6:].mean() > 0.9

    def test_estimate_fundamental_errors(self):
        pts = np.random.default_rng(0).uniform(0, 100, (7, 2))
        with pytest.raises(InvalidArgumentError, match="at least 8 matches.*got 7"):
            estimate_fundamental(pts, pts + 1)
        pts8 = np.vstack([pts, [[5, 5]]])
        with pytest.raises(InvalidArgumentError, match=r"`method` must be one of .*cv2.FM_RANSAC"):
            estimate_fundamental(pts8, pts8, method=cv2.FM_7POINT)
        with pytest.raises(InvalidArgumentError, match="`confidence`"):
            estimate_fundamental(pts8, pts8, confidence=1.5)
        line = np.column_stack([np.arange(10.0), np.zeros(10)])
        with pytest.raises(InvalidArgumentError, match="degenerate"):
            estimate_fundamental(line, line, method=cv2.FM_8POINT)

    def test_epipolar_errors(self):
        with pytest.raises(InvalidArgumentError, match=r"`F` must be a 3x3 matrix, got shape \(9"):
            epipolar_distances([[0, 0]], [[0, 0]], np.ones(9))
        with pytest.raises(InvalidArgumentError, match="all zeros"):
            epipolar_distances([[0, 0]], [[0, 0]], np.zeros((3, 3)))
        with pytest.raises(InvalidArgumentError, match="'mean', 'max'; got 'sum'"):
            epipolar_distances([[0, 0]], [[0, 0]], np.eye(3), reduce="sum")


class TestRectifyUncalibrated:
    def test_uncalibrated(self, calibration, scene, blob_scene):
        F = calibration.fundamental_matrix()
        left_pts, right_pts = project(scene, K1), project(scene, K2, R, T)
        img_l = render_blobs(project(blob_scene, K1), (480, 640))
        img_r = render_blobs(project(blob_scene, K2, R, T), (480, 640))
        lr, rr, H1, H2 = rectify_uncalibrated(img_l, img_r, left_pts, right_pts, F)
        assert lr.shape == img_l.shape and H1.shape == H2.shape == (3, 3)
        ql = cv2.perspectiveTransform(left_pts.reshape(-1, 1, 2), H1).reshape(-1, 2)
        qr = cv2.perspectiveTransform(right_pts.reshape(-1, 1, 2), H2).reshape(-1, 2)
        assert np.abs(ql[:, 1] - qr[:, 1]).max() < 0.05
        with pytest.raises(InvalidArgumentError, match="at least 8 matches"):
            rectify_uncalibrated(img_l, img_r, left_pts[:5], right_pts[:5], F)
        with pytest.raises(InvalidArgumentError, match="stereoRectifyUncalibrated failed"):
            rectify_uncalibrated(img_l, img_r, left_pts, right_pts + [0, 50], F, threshold=1.0)
