"""Tests of hopmatch.stereo.calibration: StereoCalibration, its checks and its FileStorage files."""

from __future__ import annotations

import os
import re

import cv2
import numpy as np
import pytest
from stereo_rig import K1, K2, NO_DIST, SIZE, R, T, project

from hopmatch.errors import InvalidArgumentError, InvalidTypeError
from hopmatch.stereo import StereoCalibration


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


def _chessboard_views(n_views=8, noise=0.0):
    """A 9 x 6 target (unit squares, z = 0) at ``n_views`` poses in front of the rig:
    ``(object_points, left_points, right_points)``, the corners projected by cv2's own
    projectPoints (``noise``: px of Gaussian noise added)."""
    rng = np.random.default_rng(3)
    grid = np.zeros((54, 3), np.float32)
    grid[:, :2] = np.mgrid[0:9, 0:6].T.reshape(-1, 2) * 0.025  # 2.5 cm squares, in m
    obj, left, right = [], [], []
    for v in range(n_views):
        rot = cv2.Rodrigues(np.array([0.3 * np.sin(v), 0.3 * np.cos(1.7 * v), 0.1 * v]))[0]
        shift = np.array([-0.1 + 0.02 * (v % 3), -0.06 + 0.02 * (v % 2), 0.5 + 0.04 * v])
        xyz = grid @ rot.T + shift  # in the left camera's frame
        left.append(project(xyz, K1) + rng.normal(0, noise, (54, 2)))
        right.append(project(xyz, K2, R, T) + rng.normal(0, noise, (54, 2)))
        obj.append(grid)
    return obj, [p.astype(np.float32) for p in left], [p.astype(np.float32) for p in right]


def test_calibrate_from_corners_recovers_the_rig_and_restores_cv2s_threads():
    """Noise-free corners give the rig's K, R and T back, and a near-zero RMS; the same
    corners give the same calibration bit for bit; cv2's thread count is as it was."""
    from hopmatch.stereo import calibrate_from_corners

    obj, left, right = _chessboard_views()
    before = cv2.getNumThreads()
    cal, rms = calibrate_from_corners(obj, left, right, SIZE)
    assert cv2.getNumThreads() == before
    assert isinstance(cal, StereoCalibration) and cal.image_size == SIZE
    assert rms < 0.01
    np.testing.assert_allclose(cal.K1, K1, atol=1.0)
    np.testing.assert_allclose(cal.K2, K2, atol=1.0)
    np.testing.assert_allclose(cal.R, R, atol=2e-3)
    np.testing.assert_allclose(cal.T.ravel(), T, atol=2e-3)
    again, rms_again = calibrate_from_corners(obj, [p.reshape(-1, 1, 2) for p in left],
                                              right, SIZE)
    assert rms_again == rms
    for key in ("K1", "D1", "K2", "D2", "R", "T"):
        np.testing.assert_array_equal(getattr(again, key), getattr(cal, key))


@pytest.mark.parametrize("change, error, words", [
    (lambda o, l, r, s: (o[:-1], l, r, s), InvalidArgumentError, "views"),
    (lambda o, l, r, s: (o, [p[:-1] for p in l], r, s), InvalidArgumentError, "view 0"),
    (lambda o, l, r, s: ([p[:3] for p in o], [p[:3] for p in l], [p[:3] for p in r], s),
     InvalidArgumentError, "at least 4"),
    (lambda o, l, r, s: ([p[:, :2] for p in o], l, r, s), InvalidArgumentError,
     "object_points[0]"),
    (lambda o, l, r, s: (o, l, r, None), InvalidTypeError, "image_size"),
    (lambda o, l, r, s: (np.stack(o), l, r, s), InvalidTypeError, "object_points"),
    (lambda o, l, r, s: (o, ["corners"] * len(l), r, s), InvalidTypeError, "left_points[0]"),
    (lambda o, l, r, s: (o, [np.full((54, 2), np.nan)] * len(l), r, s), InvalidArgumentError,
     "left_points[0]"),
    (lambda o, l, r, s: ([np.zeros((54, 3))] * len(o), l, r, s), InvalidArgumentError,
     "calibrate"),
])
def test_calibrate_from_corners_refuses_bad_corners_by_name(change, error, words):
    from hopmatch.stereo import calibrate_from_corners

    args = change(*_chessboard_views(4), SIZE)
    before = cv2.getNumThreads()
    with pytest.raises(error, match=re.escape(words)):
        calibrate_from_corners(*args)
    assert cv2.getNumThreads() == before


def test_calibrate_from_corners_refuses_too_many_corners_before_calibrating(monkeypatch):
    from hopmatch.stereo import calibrate_from_corners, calibration

    obj, left, right = _chessboard_views(4)  # 4 views of 54 corners: 216 in all
    monkeypatch.setattr(calibration, "MAX_CALIBRATION_CORNERS", 200)
    with pytest.raises(InvalidArgumentError, match="more than 200 corners"):
        calibrate_from_corners(obj, left, right, SIZE)
    monkeypatch.setattr(calibration, "MAX_CALIBRATION_CORNERS", 216)
    assert calibrate_from_corners(obj, left, right, SIZE)[1] < 0.01
