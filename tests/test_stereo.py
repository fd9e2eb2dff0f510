"""Tests of hopmatch.stereo on hand-built geometry (known K, R, T) and the shared data."""

from __future__ import annotations

import os

import cv2
import numpy as np
import pytest

from hopmatch import stereo
from hopmatch.errors import BudgetExceededError, InvalidArgumentError, InvalidTypeError
from hopmatch.stereo import (
    StereoCalibration,
    depth_from_disparity,
    epipolar_distance_matrix,
    epipolar_distances,
    estimate_fundamental,
    keypoints_and_matches,
    match_disparities,
    matched_points,
    rectify,
    rectify_points,
    rectify_uncalibrated,
    reproject_points,
    sparse_disparity_image,
    triangulate_matches,
    write_ply,
)

SIZE = (640, 480)  # (width, height)
K1 = np.array([[520.0, 0, 318.0], [0, 515.0, 242.0], [0, 0, 1]])
K2 = np.array([[510.0, 0, 325.0], [0, 512.0, 238.0], [0, 0, 1]])
R = cv2.Rodrigues(np.array([0.01, -0.02, 0.005]))[0]
T = np.array([-0.1, 0.003, -0.002])  # baseline ~0.1 m, right camera to the right
NO_DIST = np.zeros(5)


def relative_error(got, want):
    return np.linalg.norm(got - want, axis=1) / np.linalg.norm(want, axis=1)


@pytest.fixture
def scene():
    """60 random 3-D points in front of both cameras, in the left camera's frame."""
    rng = np.random.default_rng(7)
    n = 60
    xyz = np.column_stack([rng.uniform(-1, 1, n), rng.uniform(-0.7, 0.7, n), rng.uniform(2, 6, n)])
    return xyz


def project(xyz, K, R_=np.eye(3), T_=np.zeros(3), D=NO_DIST):
    rvec = cv2.Rodrigues(R_)[0]
    pts, _ = cv2.projectPoints(xyz.reshape(-1, 1, 3), rvec, np.asarray(T_, float), K, D)
    return pts.reshape(-1, 2)


@pytest.fixture
def calibration():
    return StereoCalibration(K1, NO_DIST, K2, NO_DIST, R, T, image_size=SIZE)


# --------------------------------------------------------------------------------------
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


# --------------------------------------------------------------------------------------
class TestDisparity:
    def test_match_disparities(self):
        d = match_disparities([[10, 1], [5.5, 2]], [[4, 1], [6, 2]])
        assert d.dtype == np.float32 and d.tolist() == [6.0, -0.5]

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


# --------------------------------------------------------------------------------------
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


class TestRectifiedReprojection:
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

    def test_rectify_points_then_reproject(self, scene):
        # with lens distortion: rectify the original projections, not the images
        D1 = np.array([-0.08, 0.02, 0.001, -0.0005, 0.0])
        D2 = np.array([0.05, -0.01, 0.0, 0.0007, 0.0])
        cal = StereoCalibration(K1, D1, K2, D2, R, T, image_size=SIZE).with_rectification()
        left = rectify_points(project(scene, K1, D=D1), cal, "left")
        right = rectify_points(project(scene, K2, R, T, D=D2), cal, "right")
        assert left.dtype == np.float32
        assert np.abs(left[:, 1] - right[:, 1]).max() < 1e-2
        xyz = reproject_points(left, match_disparities(left, right), cal.Q)
        assert relative_error(xyz @ cal.R1, scene).max() < 1e-3
        xyz2 = triangulate_matches(left, right, cal.P1, cal.P2)
        assert relative_error(xyz2 @ cal.R1, scene).max() < 1e-3

    def test_nan_and_infinity_rows(self):
        Q = np.array([[1, 0, 0, -320], [0, 1, 0, -240], [0, 0, 0, 500], [0, 0, 10, 0.0]])
        xyz = reproject_points([[320, 240], [1, 1], [2, 2]], [10, np.nan, 0], Q)
        assert xyz[0].tolist() == [0, 0, 5] and np.isnan(xyz[1:]).all()
        assert reproject_points(np.zeros((0, 2)), [], Q).shape == (0, 3)

    def test_rectify_points_errors(self, calibration):
        with pytest.raises(InvalidArgumentError, match="no rectification.*with_rectification"):
            rectify_points([[1, 1]], calibration)
        with pytest.raises(InvalidArgumentError, match="'left', 'right'; got 'middle'"):
            rectify_points([[1, 1]], calibration.with_rectification(), "middle")
        with pytest.raises(InvalidTypeError, match="StereoCalibration"):
            rectify_points([[1, 1]], {"K1": K1})


# --------------------------------------------------------------------------------------
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


# --------------------------------------------------------------------------------------
def render_blobs(points, shape, sigma=1.6, channels=0):
    """Gaussian blobs at sub-pixel (x, y), as uint8."""
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    img = np.zeros((h, w), np.float32)
    for x, y in points:
        x0, y0 = int(round(x)), int(round(y))
        sl = np.s_[max(y0 - 8, 0):y0 + 9, max(x0 - 8, 0):x0 + 9]
        img[sl] += 250 * np.exp(-((xx[sl] - x) ** 2 + (yy[sl] - y) ** 2) / (2 * sigma**2))
    img = np.clip(img, 0, 255).astype(np.uint8)
    return np.dstack([img] * channels) if channels else img


def centroids(img, points, r=4):
    out = []
    g = img.astype(np.float64) if img.ndim == 2 else img[..., 0].astype(np.float64)
    for x, y in points:
        x0, y0 = int(round(x)), int(round(y))
        win = g[y0 - r:y0 + r + 1, x0 - r:x0 + r + 1]
        yy, xx = np.mgrid[y0 - r:y0 + r + 1, x0 - r:x0 + r + 1]
        out.append([(win * xx).sum() / win.sum(), (win * yy).sum() / win.sum()])
    return np.array(out)


@pytest.fixture
def blob_scene():
    gx, gy = np.meshgrid(np.linspace(-0.5, 0.5, 5), np.linspace(-0.35, 0.35, 4))
    z = 3.0 + 0.5 * gx  # a slanted plane of dots
    return np.column_stack([gx.ravel() * z.ravel() / 3, gy.ravel() * z.ravel() / 3, z.ravel()])


class TestRectify:
    @pytest.mark.parametrize("channels", [0, 3])
    def test_synthetic_pair(self, blob_scene, channels):
        D1 = np.array([-0.05, 0.01, 0.0, 0.0, 0.0])
        D2 = np.array([0.03, 0.0, 0.0, 0.0, 0.0])
        cal = StereoCalibration(K1, D1, K2, D2, R, T, image_size=SIZE)
        pl = project(blob_scene, K1, D=D1)
        pr = project(blob_scene, K2, R, T, D=D2)
        left = render_blobs(pl, (SIZE[1], SIZE[0]), channels=channels)
        right = render_blobs(pr, (SIZE[1], SIZE[0]), channels=channels)
        lr, rr, rcal = rectify(left, right, cal, alpha=0)
        assert lr.shape == left.shape and lr.dtype == np.uint8 and rr.shape == right.shape
        assert rcal.rectified and rcal.image_size == SIZE and cal.R1 is None
        want_l = rectify_points(pl, rcal, "left")
        want_r = rectify_points(pr, rcal, "right")
        got_l, got_r = centroids(lr, want_l), centroids(rr, want_r)
        assert np.abs(got_l - want_l).max() < 0.3
        assert np.abs(got_r - want_r).max() < 0.3
        assert np.abs(got_l[:, 1] - got_r[:, 1]).max() < 0.3  # same rows after rectification
        xyz = reproject_points(got_l, match_disparities(got_l, got_r), rcal.Q) @ rcal.R1
        assert relative_error(xyz, blob_scene).max() < 0.02

    def test_errors(self, calibration):
        img = np.zeros((480, 640), np.uint8)
        with pytest.raises(InvalidArgumentError, match=r"320x240.*made for 640x480"):
            rectify(img[:240, :320], img[:240, :320], calibration)
        with pytest.raises(InvalidArgumentError, match="same height and width"):
            rectify(img, img[:, :600], calibration)
        with pytest.raises(InvalidTypeError, match="`calibration` must be a StereoCalibration"):
            rectify(img, img, (K1, K2))
        with pytest.raises(InvalidArgumentError, match=r"`alpha` must be -1 or in \[0, 1\]"):
            rectify(img, img, calibration, alpha=2)
        with pytest.raises(InvalidArgumentError, match="interpolation.*cv2.INTER_LINEAR"):
            rectify(img, img, calibration, interpolation=99)
        with pytest.raises(InvalidTypeError, match="`left` must have dtype"):
            rectify(img.astype(bool), img, calibration)

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


# --------------------------------------------------------------------------------------
class TestCalibrationObject:
    def test_coercion_and_repr(self):
        cal = StereoCalibration(K1.tolist(), [0, 0, 0, 0], K2, NO_DIST, [0.01, -0.02, 0.005],
                                T.tolist())
        np.testing.assert_allclose(cal.R, R)
        assert cal.T.shape == (3, 1) and cal.D1.shape == (1, 4) and cal.K1.dtype == np.float64
        assert cal.image_size is None and not cal.rectified
        assert repr(cal) == "StereoCalibration(image_size=None, baseline=0.100065, rectified=False)"
        with pytest.raises(InvalidArgumentError, match="no image_size"):
            cal.with_rectification()
        assert cal.with_rectification(image_size=SIZE).image_size == SIZE

    def test_fundamental_matrix(self, calibration, scene):
        F = calibration.fundamental_matrix()
        xl = np.column_stack([project(scene, K1), np.ones(len(scene))])
        xr = np.column_stack([project(scene, K2, R, T), np.ones(len(scene))])
        assert np.abs(np.einsum("ij,jk,ik->i", xr, F, xl)).max() < 1e-6

    @pytest.mark.parametrize(
        "kwargs, pattern",
        [
            ({"K1": np.eye(4)}, r"`K1` must be a 3x3 matrix, got shape \(4, 4\)"),
            ({"K2": -np.eye(3)}, "`K2` must be a camera matrix .*positive focal"),
            ({"D1": np.zeros(6)}, r"`D1` must hold 4, 5, 8, 12 or 14 .*got shape \(6,\)"),
            ({"R": np.ones((3, 3))}, "`R` must be a rotation matrix"),
            ({"T": np.zeros(3)}, "`T` must not be zero"),
            ({"T": [1, 2]}, r"`T` must hold 3 values"),
            ({"Q": np.eye(3)}, r"`Q` must be a 4x4 matrix"),
            ({"image_size": (640, 0)}, r"`image_size` must be positive"),
        ],
    )
    def test_bad_fields(self, kwargs, pattern):
        args = dict(K1=K1, D1=NO_DIST, K2=K2, D2=NO_DIST, R=R, T=T, image_size=SIZE)
        args.update(kwargs)
        with pytest.raises(InvalidArgumentError, match=pattern):
            StereoCalibration(**args)

    def test_bad_types(self):
        with pytest.raises(InvalidTypeError, match="`K1` must be a numeric array"):
            StereoCalibration(None, NO_DIST, K2, NO_DIST, R, T)
        with pytest.raises(InvalidTypeError, match="`image_size` must be \\(width, height\\)"):
            StereoCalibration(K1, NO_DIST, K2, NO_DIST, R, T, image_size=(640.0, 480.0))


class TestCalibrationFiles:
    @pytest.mark.parametrize("ext", [".yml", ".xml", ".json", ".yaml"])
    @pytest.mark.parametrize("rectified", [False, True])
    def test_round_trip(self, tmp_path, calibration, ext, rectified):
        cal = calibration.with_rectification() if rectified else calibration
        path = tmp_path / f"stereo{ext}"
        cal.to_file(path)
        assert os.listdir(tmp_path) == [path.name]  # no temporary file left
        back = StereoCalibration.from_file(path)
        for key in ("K1", "D1", "K2", "D2", "R", "T", "R1", "R2", "P1", "P2", "Q"):
            a, b = getattr(cal, key), getattr(back, key)
            if a is None:
                assert b is None
            else:
                np.testing.assert_array_equal(a, b)
        assert back.image_size == SIZE and back.rectified == rectified
        # overwriting works and keeps one file
        back.to_file(str(path))
        assert os.listdir(tmp_path) == [path.name]

    def test_other_key_spellings(self, tmp_path):
        path = tmp_path / "calib.yml"
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
        for key, value in (("cameraMatrix1", K1), ("distCoeffs1", NO_DIST.reshape(5, 1)),
                           ("cameraMatrix2", K2), ("distCoeffs2", NO_DIST), ("R", R),
                           ("T", T.reshape(3, 1))):
            fs.write(key, value)
        fs.startWriteStruct("imageSize", cv2.FileNode_SEQ)
        fs.write("", 640)
        fs.write("", 480)
        fs.endWriteStruct()
        fs.release()
        cal = StereoCalibration.from_file(path)
        np.testing.assert_array_equal(cal.K2, K2)
        assert cal.image_size == SIZE

    def test_opencv_sample_pair_of_files(self, tmp_path, calibration):
        fs = cv2.FileStorage(str(tmp_path / "intrinsics.yml"), cv2.FILE_STORAGE_WRITE)
        for key, value in (("M1", K1), ("D1", NO_DIST), ("M2", K2), ("D2", NO_DIST)):
            fs.write(key, value)
        fs.release()
        rc = calibration.with_rectification()
        fs = cv2.FileStorage(str(tmp_path / "extrinsics.yml"), cv2.FILE_STORAGE_WRITE)
        for key in ("R", "T", "R1", "R2", "P1", "P2", "Q"):
            fs.write(key, getattr(rc, key))
        fs.release()
        cal = StereoCalibration.from_file(tmp_path / "intrinsics.yml")  # finds extrinsics.yml
        np.testing.assert_array_equal(cal.Q, rc.Q)
        np.testing.assert_array_equal(cal.K1, K1)
        assert cal.rectified and cal.image_size is None

    def test_unreadable_files(self, tmp_path):
        with pytest.raises(InvalidArgumentError, match="no such file.*nope.yml"):
            StereoCalibration.from_file(tmp_path / "nope.yml")
        empty = tmp_path / "empty.yml"
        empty.write_text("")
        with pytest.raises(InvalidArgumentError, match="empty.yml.*is empty"):
            StereoCalibration.from_file(empty)
        binary = tmp_path / "image.png"
        binary.write_bytes(b"\x89PNG\r\n\x1a\n....")
        with pytest.raises(InvalidArgumentError, match="image.png"):
            StereoCalibration.from_file(binary)
        garbage = tmp_path / "garbage.yml"
        garbage.write_text("%YAML:1.0\nK1: [1, 2\n")
        with pytest.raises(InvalidArgumentError, match="garbage.yml"):
            StereoCalibration.from_file(garbage)
        with pytest.raises(InvalidTypeError, match="`path` must be a str or os.PathLike"):
            StereoCalibration.from_file(3)

    def test_malformed_matrix_names_the_key_and_file(self, tmp_path, calibration):
        path = tmp_path / "c.yml"
        calibration.to_file(path)
        text = path.read_text().replace("K2:", "K2old:")
        text += ("M2: !!opencv-matrix\n   rows: 2\n   cols: 2\n   dt: d\n"
                 "   data: [ 1., 0., 0., 1. ]\n")
        path.write_text(text)
        pattern = (r"c.yml: key 'M2' \(read as K2\) is malformed: "
                   r"`K2` must be a 3x3 matrix, got shape \(2, 2\)")
        with pytest.raises(InvalidArgumentError, match=pattern):
            StereoCalibration.from_file(path)
        bad = tmp_path / "bad.yml"
        bad.write_text(path.read_text().replace("rows: 2\n   cols: 2", "rows: 3\n   cols: 3"))
        with pytest.raises(InvalidArgumentError, match=r"key 'M2' of .*bad.yml is malformed"):
            StereoCalibration.from_file(bad)

    def test_to_file_errors(self, tmp_path, calibration):
        with pytest.raises(InvalidArgumentError, match=r"\.yml, \.yaml, \.xml or \.json"):
            calibration.to_file(tmp_path / "calib.txt")
        with pytest.raises(InvalidArgumentError, match="folder .* does not exist"):
            calibration.to_file(tmp_path / "missing" / "calib.yml")
        assert os.listdir(tmp_path) == []

    @pytest.mark.shared_data
    def test_opencv_sample_stereo_calib_xml_is_an_image_list(self, shared_data):
        path = shared_data / "opencv_stereo_calib" / "stereo_calib.xml"
        with pytest.raises(InvalidArgumentError) as info:
            StereoCalibration.from_file(path)
        msg = str(info.value)
        assert "stereo_calib.xml" in msg and "imagelist" in msg and "image list" in msg
        for key in ("K1", "D1", "K2", "D2", "R", "T"):
            assert key in msg
        assert "M1" in msg  # the accepted spellings are listed

    @pytest.mark.shared_data
    def test_opencv_sample_intrinsics_needs_extrinsics(self, shared_data, tmp_path):
        path = shared_data / "opencv_stereo_calib" / "intrinsics.yml"
        with pytest.raises(InvalidArgumentError, match=r"intrinsics.yml .*missing R, T.*extrins"):
            StereoCalibration.from_file(path)
        ext = tmp_path / "extrinsics.yml"
        fs = cv2.FileStorage(str(ext), cv2.FILE_STORAGE_WRITE)
        fs.write("R", R)
        fs.write("T", T)
        fs.release()
        cal = StereoCalibration.from_file(path, extrinsics=ext)
        assert cal.K1[0, 0] == pytest.approx(534.80326845051309)
        assert cal.D2.shape == (1, 5)


@pytest.mark.shared_data
def test_real_chessboard_pair(shared_data, tmp_path):
    """A plain cv2.stereoCalibrate on OpenCV's sample, saved, read back and rectified."""
    folder = shared_data / "opencv_stereo_calib"
    board = np.zeros((54, 3), np.float32)
    board[:, :2] = np.mgrid[0:9, 0:6].T.reshape(-1, 2) * 0.025
    obj, img_l, img_r = [], [], []
    for i in [1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14]:
        gl = cv2.imread(str(folder / f"left{i:02d}.jpg"), cv2.IMREAD_GRAYSCALE)
        gr = cv2.imread(str(folder / f"right{i:02d}.jpg"), cv2.IMREAD_GRAYSCALE)
        ok_l, cl = cv2.findChessboardCorners(gl, (9, 6))
        ok_r, cr = cv2.findChessboardCorners(gr, (9, 6))
        if ok_l and ok_r:
            crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.01)
            obj.append(board)
            img_l.append(cv2.cornerSubPix(gl, cl, (11, 11), (-1, -1), crit))
            img_r.append(cv2.cornerSubPix(gr, cr, (11, 11), (-1, -1), crit))
    assert len(obj) >= 8
    size = gl.shape[::-1]
    rms, k1, d1, k2, d2, r, t, _, _ = cv2.stereoCalibrate(
        obj, img_l, img_r, None, None, None, None, size, flags=0)
    assert rms < 1.0
    StereoCalibration(k1, d1, k2, d2, r, t, image_size=size).to_file(tmp_path / "pair.xml")
    cal = StereoCalibration.from_file(tmp_path / "pair.xml")
    left = cv2.imread(str(folder / "left01.jpg"))
    right = cv2.imread(str(folder / "right01.jpg"))
    lr, rr, rcal = rectify(left, right, cal)
    assert lr.shape == left.shape
    ok_l, cl = cv2.findChessboardCorners(cv2.cvtColor(lr, cv2.COLOR_BGR2GRAY), (9, 6))
    ok_r, cr = cv2.findChessboardCorners(cv2.cvtColor(rr, cv2.COLOR_BGR2GRAY), (9, 6))
    assert ok_l and ok_r
    cl, cr = cl.reshape(-1, 2), cr.reshape(-1, 2)
    assert np.median(np.abs(cl[:, 1] - cr[:, 1])) < 1.0  # epipolar lines are rows
    # the same from the corners alone, without rectifying images
    pl = rectify_points(img_l[0], rcal, "left")
    pr = rectify_points(img_r[0], rcal, "right")
    assert np.median(np.abs(pl[:, 1] - pr[:, 1])) < 1.0
    xyz = reproject_points(pl, match_disparities(pl, pr), rcal.Q)
    # neighbouring corners are 25 mm apart on the board
    steps = np.linalg.norm(np.diff(xyz.reshape(6, 9, 3), axis=1), axis=2)
    assert np.median(steps) == pytest.approx(0.025, rel=0.05)


# --------------------------------------------------------------------------------------
class TestWritePly:
    def test_content(self, tmp_path):
        xyz = np.array([[0, 0, 1], [0.5, -0.25, 2], [np.nan, 0, 0], [1, 2, 3]], np.float32)
        colors = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [1, 2, 3]], np.uint8)
        path = tmp_path / "cloud.ply"
        assert write_ply(path, xyz, colors) == 3
        lines = path.read_text().splitlines()
        end = lines.index("end_header")
        assert lines[0] == "ply" and lines[1] == "format ascii 1.0"
        assert "element vertex 3" in lines
        assert "property uchar red" in lines and "property float z" in lines
        rows = lines[end + 1:]
        assert rows == ["0 0 1 255 0 0", "0.5 -0.25 2 0 255 0", "1 2 3 1 2 3"]
        assert os.listdir(tmp_path) == ["cloud.ply"]

    def test_no_colours_and_empty(self, tmp_path):
        xyz = np.random.default_rng(0).normal(size=(50, 3)).astype(np.float32)
        path = tmp_path / "a.ply"
        assert write_ply(str(path), xyz) == 50
        lines = path.read_text().splitlines()
        rows = lines[lines.index("end_header") + 1:]
        assert len(rows) == 50 and "property uchar red" not in lines
        np.testing.assert_array_equal(np.array([r.split() for r in rows], np.float32), xyz)
        assert write_ply(tmp_path / "e.ply", np.zeros((0, 3))) == 0
        assert "element vertex 0" in (tmp_path / "e.ply").read_text()

    def test_bad_colours_leave_no_file(self, tmp_path):
        xyz = np.zeros((4, 3))
        with pytest.raises(InvalidArgumentError, match=r"`colors` must have shape \(4, 3\)"):
            write_ply(tmp_path / "c.ply", xyz, np.zeros((3, 3), np.uint8))
        with pytest.raises(InvalidTypeError, match="`colors` must have dtype uint8.*astype"):
            write_ply(tmp_path / "c.ply", xyz, np.zeros((4, 3)))
        with pytest.raises(InvalidArgumentError, match=r"`xyz` must have shape \(N, 3\)"):
            write_ply(tmp_path / "c.ply", np.zeros((4, 2)))
        assert os.listdir(tmp_path) == []

    def test_failure_while_writing_keeps_the_old_file(self, tmp_path, monkeypatch):
        path = tmp_path / "c.ply"
        path.write_text("old")

        def broken(fh, pts, cols):
            fh.write("ply\nformat ascii 1.0\nelement vertex")
            raise OSError("disk full")

        monkeypatch.setattr(stereo, "_write_ply_body", broken)
        with pytest.raises(OSError, match="disk full"):
            write_ply(path, np.zeros((4, 3)))
        assert os.listdir(tmp_path) == ["c.ply"] and path.read_text() == "old"

    def test_missing_folder(self, tmp_path):
        with pytest.raises(InvalidArgumentError, match="does not exist"):
            write_ply(tmp_path / "no" / "c.ply", np.zeros((1, 3)))
