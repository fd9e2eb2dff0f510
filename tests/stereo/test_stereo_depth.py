"""Tests of hopmatch.stereo.depth: sparse disparity images, depth, reprojection, triangulation."""

from __future__ import annotations

import numpy as np
import pytest
from stereo_rig import K1, K2, SIZE, R, T, project, relative_error

from hopmatch.errors import InvalidArgumentError, InvalidTypeError
from hopmatch.stereo import (
    depth_from_disparity,
    keypoints_and_matches,
    match_disparities,
    reproject_points,
    sparse_disparity_image,
    triangulate_matches,
)


class TestSparseDisparityImage:
    def test_sparse_image(self):
        img = sparse_disparity_image([[0, 0], [3.4, 2.6], [3.2, 3.0], [1, 1]],
                                     [1.0, 2.0, 7.0, np.nan], (4, 5, 3))
        assert img.shape == (4, 5) and img.dtype == np.float32
        assert img[0, 0] == 1.0 and img[3, 3] == 7.0  # two points on one pixel: the largest
        assert np.isnan(img[1, 1])  # NaN disparity ignored
        assert np.isfinite(img).sum() == 2

    def test_sparse_image_outside(self):
        with pytest.raises(InvalidArgumentError, match=r"1 points outside.*\(4, 5\).*row 1"):
            sparse_disparity_image([[0, 0], [5, 0]], [1, 1], (4, 5))
        with pytest.raises(InvalidTypeError, match="shape"):
            sparse_disparity_image([[0, 0]], [1], (4.0, 5.0))
        with pytest.raises(InvalidArgumentError, match=r"shape \(1,\)"):
            sparse_disparity_image([[0, 0]], [1, 2], (4, 5))


class TestDepth:
    def test_focal_baseline_exact_on_rectified_pair(self, scene):
        f, b, cx = 500.0, 0.1, 320.0
        X, Y, Z = scene.T
        xl = f * X / Z + cx
        xr = f * (X - b) / Z + cx
        z = depth_from_disparity(xl - xr, focal=f, baseline=b)
        assert z.dtype == np.float32 and z.shape == Z.shape
        np.testing.assert_allclose(z, Z, rtol=1e-6)
        # with different principal points (Middlebury's doffs = cx_right - cx_left)
        cx_r = 337.5
        xr2 = f * (X - b) / Z + cx_r
        z2 = depth_from_disparity(xl - xr2, focal=f, baseline=b, doffs=cx_r - cx)
        np.testing.assert_allclose(z2, Z, rtol=1e-6)
        assert depth_from_disparity(25.0, focal=f, baseline=b) == pytest.approx(2.0)

    def test_invalid_disparities_are_nan(self):
        z = depth_from_disparity(np.array([10.0, 0.0, -3.0, np.nan]), focal=500, baseline=0.1)
        assert z[0] == pytest.approx(5.0) and np.isnan(z[1:]).all()
        z = depth_from_disparity([2.0, 5.0], focal=500, baseline=0.1, doffs=-4.0)
        assert np.isnan(z[0]) and z[1] == pytest.approx(50.0)

    def test_q_matches_rectified_depth(self, calibration, scene):
        cal = calibration.with_rectification()
        rect = scene @ cal.R1.T
        xl = project(rect, cal.P1[:, :3])
        xr = (cal.P2 @ np.vstack([rect.T, np.ones(len(rect))])).T
        xr = xr[:, :2] / xr[:, 2:]
        z = depth_from_disparity(xl[:, 0] - xr[:, 0], Q=cal.Q)
        np.testing.assert_allclose(z, rect[:, 2], rtol=1e-5)
        # same through focal / baseline from P2 (zero disparity: same cx)
        fb = depth_from_disparity(xl[:, 0] - xr[:, 0], focal=cal.P1[0, 0],
                                  baseline=-cal.P2[0, 3] / cal.P2[0, 0])
        np.testing.assert_allclose(fb, z, rtol=1e-5)

    def test_errors(self):
        Q = np.eye(4)
        with pytest.raises(InvalidArgumentError, match="either `Q` or `focal`"):
            depth_from_disparity(1.0, Q=Q, focal=1.0, baseline=1.0)
        with pytest.raises(InvalidArgumentError, match="missing baseline"):
            depth_from_disparity(1.0, focal=1.0)
        with pytest.raises(InvalidArgumentError, match="doffs"):
            depth_from_disparity(1.0, Q=Q, doffs=2.0)
        with pytest.raises(InvalidArgumentError, match=r"`focal` must be a finite number in \(0"):
            depth_from_disparity(1.0, focal=-5.0, baseline=1.0)
        with pytest.raises(InvalidArgumentError, match=r"`Q` must be a 4x4 matrix, got shape"):
            depth_from_disparity(1.0, Q=np.eye(3))
        with pytest.raises(InvalidTypeError, match="disparity"):
            depth_from_disparity("10", focal=1.0, baseline=1.0)


class TestTriangulation:
    def test_recovers_points(self, scene):
        left = project(scene, K1)
        right = project(scene, K2, R, T)
        P1 = K1 @ np.hstack([np.eye(3), np.zeros((3, 1))])
        P2 = K2 @ np.hstack([R, T.reshape(3, 1)])
        xyz = triangulate_matches(left, right, P1, P2)
        assert xyz.dtype == np.float32 and xyz.shape == scene.shape
        assert relative_error(xyz, scene).max() < 1e-3

    def test_keypoints_in(self, scene):
        left = project(scene[:3], K1)
        right = project(scene[:3], K2, R, T)
        kl, kr, _ = keypoints_and_matches(left, right)
        P1 = K1 @ np.hstack([np.eye(3), np.zeros((3, 1))])
        P2 = K2 @ np.hstack([R, T.reshape(3, 1)])
        assert relative_error(triangulate_matches(kl, kr, P1, P2), scene[:3]).max() < 1e-3

    def test_empty_and_errors(self):
        P = np.eye(3, 4)
        assert triangulate_matches(np.zeros((0, 2)), np.zeros((0, 2)), P, P).shape == (0, 3)
        with pytest.raises(InvalidArgumentError, match=r"`P2` must be a 3x4 matrix"):
            triangulate_matches([[0, 0]], [[0, 0]], P, np.eye(3))
        with pytest.raises(InvalidArgumentError, match="`P1` contains NaN"):
            triangulate_matches([[0, 0]], [[0, 0]], np.full((3, 4), np.nan), P)
        with pytest.raises(InvalidArgumentError, match=r"`left_pts` must have shape \(N, 2\)"):
            triangulate_matches(np.zeros((2, 3)), np.zeros((2, 2)), P, P)


class TestReprojectPoints:
    @pytest.mark.parametrize("zero_disparity", [True, False])
    def test_reproject_points_recovers_points(self, calibration, scene, zero_disparity):
        cal = calibration.with_rectification(zero_disparity=zero_disparity)
        assert cal.rectified and cal.image_size == SIZE
        rect = scene @ cal.R1.T  # points in the rectified left frame
        h = np.vstack([rect.T, np.ones(len(rect))])
        xl = (cal.P1 @ h).T
        xr = (cal.P2 @ h).T
        xl, xr = xl[:, :2] / xl[:, 2:], xr[:, :2] / xr[:, 2:]
        np.testing.assert_allclose(xl[:, 1], xr[:, 1], atol=1e-6)  # rows agree
        xyz = reproject_points(xl, match_disparities(xl, xr), cal.Q)
        assert xyz.dtype == np.float32 and xyz.shape == (len(scene), 3)
        assert relative_error(xyz, rect).max() < 1e-3
        assert relative_error(xyz @ cal.R1, scene).max() < 1e-3  # back to the left frame

    def test_nan_and_infinity_rows(self):
        Q = np.array([[1, 0, 0, -320], [0, 1, 0, -240], [0, 0, 0, 500], [0, 0, 10, 0.0]])
        xyz = reproject_points([[320, 240], [1, 1], [2, 2]], [10, np.nan, 0], Q)
        assert xyz[0].tolist() == [0, 0, 5] and np.isnan(xyz[1:]).all()
        assert reproject_points(np.zeros((0, 2)), [], Q).shape == (0, 3)
