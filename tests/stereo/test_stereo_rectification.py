"""Tests of hopmatch.stereo.rectification: rectify (images) and rectify_points, on the
synthetic rig and on OpenCV's chessboard sample."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from stereo_rig import K1, K2, SIZE, R, T, centroids, project, relative_error, render_blobs

from hopmatch.errors import InvalidArgumentError, InvalidTypeError
from hopmatch.stereo import (
    StereoCalibration,
    match_disparities,
    rectify,
    rectify_points,
    reproject_points,
    triangulate_matches,
)


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


class TestRectifyPoints:
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

    def test_rectify_points_errors(self, calibration):
        with pytest.raises(InvalidArgumentError, match="no rectification.*with_rectification"):
            rectify_points([[1, 1]], calibration)
        with pytest.raises(InvalidArgumentError, match="'left', 'right'; got 'middle'"):
            rectify_points([[1, 1]], calibration.with_rectification(), "middle")
        with pytest.raises(InvalidTypeError, match="StereoCalibration"):
            rectify_points([[1, 1]], {"K1": K1})


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
