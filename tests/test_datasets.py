"""Tests of hopmatch.datasets: every reader on tiny files written here, malformed and
missing files, the scene catalogue, and the real scenes of ../shared/data."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from hopmatch import datasets as ds
from hopmatch.datasets import (
    StereoScene,
    list_scenes,
    load,
    load_motorcycle,
    load_scene,
    read_kitti_calib,
    read_kitti_disparity,
    read_middlebury_calib,
    read_middlebury_disparity,
    read_pfm,
    shared_data_dir,
)
from hopmatch.errors import InvalidArgumentError, InvalidTypeError

KITTI_CALIB = """\
P0: 7.188560e+02 0.000000e+00 6.071928e+02 0.000000e+00 0.000000e+00 7.188560e+02 1.852157e+02 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00
P1: 7.188560e+02 0.000000e+00 6.071928e+02 -3.861448e+02 0.000000e+00 7.188560e+02 1.852157e+02 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00
P2: 7.188560e+02 0.000000e+00 6.071928e+02 4.538225e+01 0.000000e+00 7.188560e+02 1.852157e+02 -1.130887e-01 0.000000e+00 0.000000e+00 1.000000e+00 3.779761e-03
P3: 7.188560e+02 0.000000e+00 6.071928e+02 -3.372877e+02 0.000000e+00 7.188560e+02 1.852157e+02 2.369057e+00 0.000000e+00 0.000000e+00 1.000000e+00 4.915215e-03
"""

MIDDLEBURY_CALIB = """\
cam0=[3997.684 0 1176.728; 0 3997.684 1011.728; 0 0 1]
cam1=[3997.684 0 1307.839; 0 3997.684 1011.728; 0 0 1]
doffs=131.111
baseline=193.001
width=2964
height=1988
ndisp=280
isint=0
vmin=31
vmax=257
dyavg=0.918
dymax=1.516
"""


def write_pfm(path: Path, top_to_bottom: np.ndarray, byteorder: str, scale: float = 1.0):
    """Write a PFM the way Middlebury does: rows bottom to top, sign of scale = endianness."""
    arr = np.asarray(top_to_bottom, dtype=np.float32)
    magic = b"PF" if arr.ndim == 3 else b"Pf"
    h, w = arr.shape[:2]
    signed = -abs(scale) if byteorder == "<" else abs(scale)
    data = arr[::-1].astype(byteorder + "f4").tobytes()
    path.write_bytes(magic + b"\n" + f"{w} {h}\n{signed}\n".encode() + data)
    return path


def grey(img):
    return cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if img.ndim == 3 else img


def photometric_error(scene: StereoScene, sign: int) -> float:
    """Mean |left - right warped with xr = xl + sign * d| over pixels with ground truth."""
    left = grey(scene.left).astype(np.float32)
    right = grey(scene.right).astype(np.float32)
    h, w = scene.shape
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    d = np.nan_to_num(scene.disparity, nan=0.0)
    map_x = xs + sign * d
    warped = cv2.remap(right, map_x, ys, cv2.INTER_LINEAR)
    ok = scene.valid & (map_x >= 0) & (map_x <= w - 1)
    return float(np.abs(warped - left)[ok].mean())


# --------------------------------------------------------------------------------------
# Middlebury 2001-2006 disparity
# --------------------------------------------------------------------------------------


class TestReadMiddleburyDisparity:
    @pytest.mark.parametrize("ext", ["png", "pgm"])
    def test_values_scale_and_unknown(self, tmp_path, ext):
        raw = np.array([[0, 8, 16], [20, 255, 0]], np.uint8)
        path = tmp_path / f"disp.{ext}"
        assert cv2.imwrite(str(path), raw)
        d = read_middlebury_disparity(path, scale=8)
        assert d.dtype == np.float32 and d.shape == (2, 3)
        np.testing.assert_array_equal(np.isnan(d), raw == 0)
        np.testing.assert_allclose(d[raw != 0], raw[raw != 0] / 8.0)

    def test_unknown_value_none_keeps_zero(self, tmp_path):
        path = tmp_path / "d.png"
        cv2.imwrite(str(path), np.array([[0, 4]], np.uint8))
        d = read_middlebury_disparity(path, scale=2, unknown_value=None)
        np.testing.assert_array_equal(d, [[0.0, 2.0]])

    def test_other_unknown_value(self, tmp_path):
        path = tmp_path / "d.png"
        cv2.imwrite(str(path), np.array([[0, 255, 4]], np.uint8))
        d = read_middlebury_disparity(path, scale=1, unknown_value=255)
        assert d[0, 0] == 0 and np.isnan(d[0, 1]) and d[0, 2] == 4

    def test_16_bit(self, tmp_path):
        path = tmp_path / "d.png"
        cv2.imwrite(str(path), np.array([[0, 1000]], np.uint16))
        d = read_middlebury_disparity(path, scale=4)
        assert np.isnan(d[0, 0]) and d[0, 1] == 250

    def test_grey_saved_as_three_equal_channels(self, tmp_path):
        path = tmp_path / "d.png"
        cv2.imwrite(str(path), np.dstack([np.array([[8, 16]], np.uint8)] * 3))
        np.testing.assert_array_equal(read_middlebury_disparity(path, scale=8), [[1, 2]])

    def test_colour_refused(self, tmp_path):
        path = tmp_path / "d.png"
        img = np.zeros((2, 2, 3), np.uint8)
        img[..., 2] = 9
        cv2.imwrite(str(path), img)
        with pytest.raises(InvalidArgumentError, match="single-channel") as exc:
            read_middlebury_disparity(path, scale=8)
        assert "d.png" in str(exc.value)

    def test_missing_file(self, tmp_path):
        path = tmp_path / "nope.pgm"
        with pytest.raises(InvalidArgumentError, match="does not exist") as exc:
            read_middlebury_disparity(path, scale=8)
        assert "nope.pgm" in str(exc.value)
        assert isinstance(exc.value, ValueError)

    def test_not_an_image(self, tmp_path):
        path = tmp_path / "junk.png"
        path.write_text("this is not a PNG")
        with pytest.raises(InvalidArgumentError, match="could not be decoded") as exc:
            read_middlebury_disparity(path, scale=8)
        assert "junk.png" in str(exc.value)

    def test_empty_file(self, tmp_path):
        path = tmp_path / "empty.pgm"
        path.write_bytes(b"")
        with pytest.raises(InvalidArgumentError, match="could not be decoded"):
            read_middlebury_disparity(path, scale=8)

    @pytest.mark.parametrize("scale", [0, -8, float("nan")])
    def test_bad_scale(self, tmp_path, scale):
        with pytest.raises(InvalidArgumentError, match="scale"):
            read_middlebury_disparity(tmp_path / "x.png", scale=scale)

    def test_scale_type(self, tmp_path):
        with pytest.raises(InvalidTypeError, match="scale"):
            read_middlebury_disparity(tmp_path / "x.png", scale="8")

    def test_path_type(self):
        with pytest.raises(InvalidTypeError, match="path"):
            read_middlebury_disparity(42, scale=8)


# --------------------------------------------------------------------------------------
# PFM
# --------------------------------------------------------------------------------------


class TestReadPfm:
    @pytest.mark.parametrize("byteorder", ["<", ">"])
    def test_grey_both_endiannesses(self, tmp_path, byteorder):
        img = np.array([[1.5, 2.0, np.inf], [4.0, 5.25, 6.0]], np.float32)
        path = write_pfm(tmp_path / "d.pfm", img, byteorder)
        d = read_pfm(path)
        assert d.dtype == np.float32 and d.dtype.isnative and d.shape == (2, 3)
        # Row 0 is the top row: the file's bottom-to-top order was undone.
        np.testing.assert_array_equal(d[0, :2], [1.5, 2.0])
        np.testing.assert_array_equal(d[1], [4.0, 5.25, 6.0])
        assert np.isnan(d[0, 2])  # inf -> NaN

    def test_endianness_matters(self, tmp_path):
        # The same bytes read with the other byte order would give other numbers.
        img = np.array([[1.0, 2.0]], np.float32)
        path = write_pfm(tmp_path / "d.pfm", img, ">")
        np.testing.assert_array_equal(read_pfm(path), img)
        blob = path.read_bytes().replace(b"\n1.0\n", b"\n-1.0\n")
        path.write_bytes(blob)
        assert not np.array_equal(read_pfm(path), img)

    def test_rows_are_stored_bottom_to_top(self, tmp_path):
        path = tmp_path / "d.pfm"
        path.write_bytes(b"Pf\n1 2\n-1.0\n" + np.array([10.0, 20.0], "<f4").tobytes())
        np.testing.assert_array_equal(read_pfm(path), [[20.0], [10.0]])

    @pytest.mark.parametrize("byteorder", ["<", ">"])
    def test_colour(self, tmp_path, byteorder):
        img = np.arange(2 * 3 * 3, dtype=np.float32).reshape(2, 3, 3)
        path = write_pfm(tmp_path / "c.pfm", img, byteorder)
        out = read_pfm(path)
        assert out.shape == (2, 3, 3)
        np.testing.assert_array_equal(out, img)

    def test_scale_magnitude_not_applied(self, tmp_path):
        img = np.array([[3.0]], np.float32)
        path = write_pfm(tmp_path / "d.pfm", img, "<", scale=4.0)
        np.testing.assert_array_equal(read_pfm(path), img)

    def test_bad_magic(self, tmp_path):
        path = tmp_path / "d.pfm"
        path.write_bytes(b"P5\n1 1\n255\n\x00")
        with pytest.raises(InvalidArgumentError, match="header") as exc:
            read_pfm(path)
        assert "d.pfm" in str(exc.value) and "'PF' or 'Pf'" in str(exc.value)

    def test_missing_size(self, tmp_path):
        path = tmp_path / "d.pfm"
        path.write_bytes(b"Pf\nabc\n-1.0\n")
        with pytest.raises(InvalidArgumentError, match="header"):
            read_pfm(path)

    def test_zero_scale(self, tmp_path):
        path = tmp_path / "d.pfm"
        path.write_bytes(b"Pf\n1 1\n0\n" + b"\x00" * 4)
        with pytest.raises(InvalidArgumentError, match="byte order"):
            read_pfm(path)

    def test_truncated(self, tmp_path):
        path = tmp_path / "d.pfm"
        path.write_bytes(b"Pf\n4 4\n-1.0\n" + b"\x00" * 20)
        with pytest.raises(InvalidArgumentError, match="truncated") as exc:
            read_pfm(path)
        assert "64 bytes" in str(exc.value) and "20" in str(exc.value)

    def test_missing(self, tmp_path):
        with pytest.raises(InvalidArgumentError, match="does not exist"):
            read_pfm(tmp_path / "disp0.pfm")


# --------------------------------------------------------------------------------------
# Middlebury calib.txt
# --------------------------------------------------------------------------------------


class TestReadMiddleburyCalib:
    def test_full_file(self, tmp_path):
        path = tmp_path / "calib.txt"
        path.write_text(MIDDLEBURY_CALIB)
        c = read_middlebury_calib(path)
        assert c["cam0"].shape == (3, 3) and c["cam1"].shape == (3, 3)
        np.testing.assert_allclose(
            c["cam0"], [[3997.684, 0, 1176.728], [0, 3997.684, 1011.728], [0, 0, 1]]
        )
        assert c["cam1"][0, 2] == pytest.approx(1307.839)
        # doffs is the difference of the principal points, as Middlebury defines it.
        assert c["doffs"] == pytest.approx(c["cam1"][0, 2] - c["cam0"][0, 2])
        assert c["baseline"] == 193.001 and c["width"] == 2964.0 and c["height"] == 1988.0
        assert c["ndisp"] == 280.0 and c["vmax"] == 257.0 and c["dymax"] == 1.516
        assert c["focal_length"] == 3997.684 and c["cx"] == 1176.728 and c["cy"] == 1011.728
        assert all(isinstance(c[k], float) for k in ("doffs", "baseline", "width", "isint"))

    def test_missing_cam1(self, tmp_path):
        path = tmp_path / "calib.txt"
        path.write_text("cam0=[1 0 0; 0 1 0; 0 0 1]\ndoffs=0\n")
        with pytest.raises(InvalidArgumentError, match="`cam1`") as exc:
            read_middlebury_calib(path)
        assert "calib.txt" in str(exc.value)

    def test_matrix_wrong_shape(self, tmp_path):
        path = tmp_path / "calib.txt"
        path.write_text("cam0=[1 0; 0 1]\ncam1=[1 0 0; 0 1 0; 0 0 1]\n")
        with pytest.raises(InvalidArgumentError, match=r"`cam0` as a 3x3.*\(2, 2\)"):
            read_middlebury_calib(path)

    def test_ragged_matrix(self, tmp_path):
        path = tmp_path / "calib.txt"
        path.write_text("cam0=[1 0 0; 0 1; 0 0 1]\n")
        with pytest.raises(InvalidArgumentError, match="different lengths"):
            read_middlebury_calib(path)

    def test_line_without_equals(self, tmp_path):
        path = tmp_path / "calib.txt"
        path.write_text(MIDDLEBURY_CALIB + "garbage line\n")
        with pytest.raises(InvalidArgumentError, match=r"line 13.*key=value"):
            read_middlebury_calib(path)

    def test_bad_number(self, tmp_path):
        path = tmp_path / "calib.txt"
        path.write_text(MIDDLEBURY_CALIB.replace("doffs=131.111", "doffs=abc"))
        with pytest.raises(InvalidArgumentError, match="`doffs`.*'abc'"):
            read_middlebury_calib(path)

    def test_bad_matrix_entry(self, tmp_path):
        path = tmp_path / "calib.txt"
        path.write_text(MIDDLEBURY_CALIB.replace("0 0 1]", "0 0 x]", 1))
        with pytest.raises(InvalidArgumentError, match="`cam0` must be a matrix"):
            read_middlebury_calib(path)

    def test_unclosed_matrix(self, tmp_path):
        path = tmp_path / "calib.txt"
        path.write_text("cam0=[1 0 0; 0 1 0; 0 0 1\n")
        with pytest.raises(InvalidArgumentError, match="not closed"):
            read_middlebury_calib(path)

    def test_missing(self, tmp_path):
        with pytest.raises(InvalidArgumentError, match="calib.txt.*does not exist"):
            read_middlebury_calib(tmp_path / "calib.txt")

    def test_binary_file(self, tmp_path):
        path = tmp_path / "calib.txt"
        path.write_bytes(b"\xff\xfe\x00\x81")
        with pytest.raises(InvalidArgumentError, match="not a text file"):
            read_middlebury_calib(path)


# --------------------------------------------------------------------------------------
# KITTI
# --------------------------------------------------------------------------------------


class TestReadKittiDisparity:
    def test_values(self, tmp_path):
        raw = np.array([[0, 256, 640], [65535, 1, 0]], np.uint16)
        path = tmp_path / "000000_10.png"
        cv2.imwrite(str(path), raw)
        d = read_kitti_disparity(path)
        assert d.dtype == np.float32 and d.shape == (2, 3)
        np.testing.assert_array_equal(np.isnan(d), raw == 0)
        np.testing.assert_allclose(d[raw != 0], raw[raw != 0] / 256.0)

    def test_8_bit_refused(self, tmp_path):
        path = tmp_path / "d.png"
        cv2.imwrite(str(path), np.array([[0, 5]], np.uint8))
        with pytest.raises(InvalidArgumentError, match="16-bit") as exc:
            read_kitti_disparity(path)
        assert "uint8" in str(exc.value) and "d.png" in str(exc.value)

    def test_missing(self, tmp_path):
        with pytest.raises(InvalidArgumentError, match="KITTI disparity.*does not exist"):
            read_kitti_disparity(tmp_path / "disp.png")

    def test_directory_is_not_a_file(self, tmp_path):
        with pytest.raises(InvalidArgumentError, match="not a file"):
            read_kitti_disparity(tmp_path)


class TestReadKittiCalib:
    def test_real_values(self, tmp_path):
        path = tmp_path / "calib.txt"
        path.write_text(KITTI_CALIB)
        c = read_kitti_calib(path)
        for k in ("P0", "P1", "P2", "P3"):
            assert c[k].shape == (3, 4) and c[k].dtype == np.float64
        assert c["P1"][0, 3] == pytest.approx(-386.1448)
        assert c["focal_length"] == pytest.approx(718.856)
        assert c["baseline"] == pytest.approx(0.537, abs=5e-4)  # metres
        assert c["cx"] == pytest.approx(607.1928) and c["cy"] == pytest.approx(185.2157)

    def test_extra_lines_kept(self, tmp_path):
        path = tmp_path / "calib.txt"
        path.write_text(KITTI_CALIB + "R0_rect: 1 0 0 0 1 0 0 0 1\nfoo: 1 2\n")
        c = read_kitti_calib(path)
        assert c["R0_rect"].shape == (3, 3) and c["foo"].tolist() == [1.0, 2.0]

    def test_missing_p3(self, tmp_path):
        path = tmp_path / "calib.txt"
        path.write_text("".join(KITTI_CALIB.splitlines(True)[:3]))
        with pytest.raises(InvalidArgumentError, match="`P3`.*got nothing"):
            read_kitti_calib(path)

    def test_short_matrix(self, tmp_path):
        path = tmp_path / "calib.txt"
        path.write_text(KITTI_CALIB.replace("P2: 7.188560e+02 ", "P2: "))
        with pytest.raises(InvalidArgumentError, match="`P2`.*11 numbers"):
            read_kitti_calib(path)

    def test_not_numbers(self, tmp_path):
        path = tmp_path / "calib.txt"
        path.write_text(KITTI_CALIB + "P4: a b c\n")
        with pytest.raises(InvalidArgumentError, match="line 5"):
            read_kitti_calib(path)

    def test_no_colon(self, tmp_path):
        path = tmp_path / "calib.txt"
        path.write_text("cam0=[1 0 0; 0 1 0; 0 0 1]\n")
        with pytest.raises(InvalidArgumentError, match="P0: 12 numbers"):
            read_kitti_calib(path)

    def test_missing(self, tmp_path):
        with pytest.raises(InvalidArgumentError, match="does not exist"):
            read_kitti_calib(tmp_path / "calib.txt")


# --------------------------------------------------------------------------------------
# meta.json scenes
# --------------------------------------------------------------------------------------


def make_scene(folder: Path, **meta_overrides) -> Path:
    """A 6x10 scene: right = left shifted by 2 px, disparity 2 (stored 4 at scale 2)."""
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    left = rng.integers(0, 255, (6, 10, 3), dtype=np.uint8)
    right = np.roll(left, -2, axis=1)
    disp = np.full((6, 10), 4, np.uint8)
    disp[:, :2] = 0
    cv2.imwrite(str(folder / "left.png"), left)
    cv2.imwrite(str(folder / "right.png"), right)
    cv2.imwrite(str(folder / "disp_left.pgm"), disp)
    cv2.imwrite(str(folder / "disp_right.pgm"), disp)
    cv2.imwrite(str(folder / "mask.png"), np.where(disp > 0, 255, 0).astype(np.uint8))
    meta = {
        "left": "left.png",
        "right": "right.png",
        "disp": "disp_left.pgm",
        "scale": 2,
        "unknown_value": 0,
        "dataset": "tiny",
        "cite": "nobody, 2024",
    }
    meta.update(meta_overrides)
    meta = {k: v for k, v in meta.items() if v is not None}
    (folder / "meta.json").write_text(json.dumps(meta))
    return folder


class TestLoadScene:
    def test_minimal(self, tmp_path):
        folder = make_scene(tmp_path / "tiny")
        s = load_scene(folder)
        assert isinstance(s, StereoScene)
        assert s.name == "tiny" and s.folder == folder
        assert s.left.shape == (6, 10, 3) and s.left.dtype == np.uint8
        np.testing.assert_array_equal(s.left, cv2.imread(str(folder / "left.png")))
        assert s.disparity.dtype == np.float32 and s.shape == (6, 10) and s.image_size == (10, 6)
        assert np.isnan(s.disparity[:, :2]).all() and (s.disparity[:, 2:] == 2).all()
        np.testing.assert_array_equal(s.valid, ~np.isnan(s.disparity))
        assert s.source == "nobody, 2024" and s.dataset == "tiny" and s.calibration is None
        assert s.disparity_right is None and s.nonoccluded_mask is None
        assert "tiny" in repr(s) and "2..2 px" in repr(s)
        # The ground truth is right: left (x, y) shows what right (x - d, y) shows.
        ys, xs = np.nonzero(s.valid)
        xr = (xs - s.disparity[ys, xs]).astype(int)
        np.testing.assert_array_equal(s.left[ys, xs], s.right[ys, xr])

    def test_optional_files(self, tmp_path):
        folder = make_scene(
            tmp_path / "full",
            disp_right="disp_right.pgm",
            nonoccluded_mask="mask.png",
            disp_all="disp_left.pgm",
        )
        (folder / "dmin.txt").write_text("200\n")
        s = load_scene(folder, name="custom")
        assert s.name == "custom"
        np.testing.assert_array_equal(s.disparity_right, s.disparity)
        np.testing.assert_array_equal(s.disparity_all, s.disparity)
        assert s.nonoccluded_mask.dtype == np.bool_
        np.testing.assert_array_equal(s.nonoccluded_mask, s.valid)
        assert s.meta["dmin"] == 200.0

    def test_grey_images_stay_grey(self, tmp_path):
        folder = make_scene(tmp_path / "g")
        cv2.imwrite(str(folder / "left.png"), np.zeros((6, 10), np.uint8))
        cv2.imwrite(str(folder / "right.png"), np.zeros((6, 10), np.uint8))
        assert load_scene(folder).left.shape == (6, 10)

    def test_kitti_calibration_with_description(self, tmp_path):
        folder = make_scene(tmp_path / "k", calibration="calib.txt (KITTI P0..P3; blah)")
        (folder / "calib.txt").write_text(KITTI_CALIB)
        c = load_scene(folder).calibration
        assert c["focal_length"] == pytest.approx(718.856) and c["P3"].shape == (3, 4)

    def test_middlebury_calibration(self, tmp_path):
        folder = make_scene(tmp_path / "m", calibration="calib.txt")
        (folder / "calib.txt").write_text(MIDDLEBURY_CALIB)
        assert load_scene(folder).calibration["doffs"] == pytest.approx(131.111)

    def test_calibration_dict(self, tmp_path):
        folder = make_scene(tmp_path / "d", calibration={"f": 100.0, "K": [[1, 0], [0, 1]]})
        c = load_scene(folder).calibration
        assert c["f"] == 100.0 and c["K"].shape == (2, 2)

    def test_unknown_calibration_format(self, tmp_path):
        folder = make_scene(tmp_path / "u", calibration="calib.txt")
        (folder / "calib.txt").write_text("focal 100\n")
        with pytest.raises(InvalidArgumentError, match="neither KITTI"):
            load_scene(folder)

    def test_pfm_disparity(self, tmp_path):
        folder = make_scene(tmp_path / "p", disp="disp0.pfm", scale=1, unknown_value=None)
        d = np.full((6, 10), 2.0, np.float32)
        d[:, :2] = np.inf
        d[0, 5] = 0.0  # a real zero: PFM scenes have no unknown_value by default
        write_pfm(folder / "disp0.pfm", d, "<")
        s = load_scene(folder)
        assert np.isnan(s.disparity[:, :2]).all() and s.disparity[0, 5] == 0.0

    def test_missing_meta(self, tmp_path):
        (tmp_path / "empty").mkdir()
        with pytest.raises(InvalidArgumentError, match="meta.json.*does not exist"):
            load_scene(tmp_path / "empty")

    def test_missing_folder(self, tmp_path):
        with pytest.raises(InvalidArgumentError, match="does not exist"):
            load_scene(tmp_path / "nowhere")

    def test_invalid_json(self, tmp_path):
        folder = make_scene(tmp_path / "j")
        (folder / "meta.json").write_text("{left: nope")
        with pytest.raises(InvalidArgumentError, match="not valid JSON") as exc:
            load_scene(folder)
        assert "meta.json" in str(exc.value)

    def test_not_an_object(self, tmp_path):
        folder = make_scene(tmp_path / "j")
        (folder / "meta.json").write_text("[1, 2]")
        with pytest.raises(InvalidArgumentError, match="JSON object"):
            load_scene(folder)

    def test_missing_key(self, tmp_path):
        folder = make_scene(tmp_path / "k", scale=None)
        with pytest.raises(InvalidArgumentError, match=r"lacks the key\(s\) \['scale'\]"):
            load_scene(folder)

    def test_bad_scale(self, tmp_path):
        folder = make_scene(tmp_path / "k", scale=0)
        with pytest.raises(InvalidArgumentError, match="meta.json.*scale"):
            load_scene(folder)

    def test_bad_file_name(self, tmp_path):
        folder = make_scene(tmp_path / "k", left=3)
        with pytest.raises(InvalidArgumentError, match="`left` must be a file name"):
            load_scene(folder)

    def test_missing_image(self, tmp_path):
        folder = make_scene(tmp_path / "k")
        (folder / "right.png").unlink()
        with pytest.raises(InvalidArgumentError, match="right image file.*right.png.*does not exist"):
            load_scene(folder)

    def test_size_mismatch(self, tmp_path):
        folder = make_scene(tmp_path / "k")
        cv2.imwrite(str(folder / "disp_left.pgm"), np.zeros((5, 10), np.uint8))
        with pytest.raises(InvalidArgumentError, match=r"disparity has size \(5, 10\).*\(6, 10\)"):
            load_scene(folder)

    def test_bad_dmin(self, tmp_path):
        folder = make_scene(tmp_path / "k")
        (folder / "dmin.txt").write_text("many\n")
        with pytest.raises(InvalidArgumentError, match="dmin.txt"):
            load_scene(folder)


class TestCatalogue:
    def test_shared_data_dir_env(self, tmp_path, monkeypatch):
        monkeypatch.setenv(ds.SHARED_DATA_ENV, str(tmp_path))
        assert shared_data_dir() == tmp_path

    def test_shared_data_dir_absent(self, tmp_path, monkeypatch):
        monkeypatch.setenv(ds.SHARED_DATA_ENV, str(tmp_path / "absent"))
        assert shared_data_dir(must_exist=False) is None
        with pytest.raises(InvalidArgumentError, match="HOPMATCH_SHARED_DATA") as exc:
            shared_data_dir()
        assert "absent" in str(exc.value)
        # Without shared data only the built-in scene is listed, and loading says why.
        assert list_scenes() == ["motorcycle"]
        with pytest.raises(InvalidArgumentError, match="shared stereo data folder is absent"):
            load("middlebury/tsukuba")

    def test_list_and_load_from_root(self, tmp_path):
        make_scene(tmp_path / "set" / "a")
        make_scene(tmp_path / "b")
        (tmp_path / "no_meta").mkdir()
        assert list_scenes(tmp_path) == ["motorcycle", "b", "set/a"]
        s = load("set/a", root=tmp_path)
        assert s.name == "set/a" and s.shape == (6, 10)

    def test_name_relative_to_shared_data(self, tmp_path, monkeypatch):
        make_scene(tmp_path / "set" / "a")
        monkeypatch.setenv(ds.SHARED_DATA_ENV, str(tmp_path))
        assert load_scene(tmp_path / "set" / "a").name == "set/a"
        assert load("set/a").name == "set/a"

    def test_unknown_name_lists_available(self, tmp_path):
        make_scene(tmp_path / "b")
        with pytest.raises(InvalidArgumentError, match="unknown scene 'zzz'.*motorcycle, b"):
            load("zzz", root=tmp_path)
        with pytest.raises(InvalidArgumentError, match="unknown scene"):
            load("../b", root=tmp_path / "b")

    def test_bad_root(self, tmp_path):
        with pytest.raises(InvalidArgumentError, match="not a folder"):
            list_scenes(tmp_path / "absent")

    def test_name_type(self):
        with pytest.raises(InvalidTypeError, match="`name`"):
            load(3)


# --------------------------------------------------------------------------------------
# The built-in motorcycle scene
# --------------------------------------------------------------------------------------


class TestMotorcycle:
    def test_arrays(self, motorcycle):
        left_rgb, right_rgb, disp = motorcycle
        s = load_motorcycle()
        assert s.name == "motorcycle" and load("motorcycle").name == "motorcycle"
        # BGR, like cv2.imread; scikit-image gives RGB.
        np.testing.assert_array_equal(s.left, left_rgb[..., ::-1])
        np.testing.assert_array_equal(s.right, right_rgb[..., ::-1])
        assert s.disparity.dtype == np.float32 and s.shape == (500, 741)
        np.testing.assert_array_equal(np.isnan(s.disparity), ~np.isfinite(disp))
        assert np.isinf(disp).any()  # the source uses inf, which became NaN
        known = s.disparity[s.valid]
        assert 5 < known.min() and known.max() < 70

    def test_calibration(self):
        c = load_motorcycle().calibration
        assert c["focal_length"] == 994.978 and c["baseline"] == 193.001
        assert c["doffs"] == 31.086 and c["cx"] == 311.193 and c["cy"] == 254.877
        assert c["cam1"][0, 2] - c["cam0"][0, 2] == pytest.approx(c["doffs"])
        assert (c["width"], c["height"]) == (741.0, 500.0)

    def test_sign_convention(self):
        """Warping right to left with xr = xl - d beats xr = xl + d by far."""
        s = load_motorcycle()
        minus, plus = photometric_error(s, -1), photometric_error(s, +1)
        assert minus < 12 and minus < plus / 3


# --------------------------------------------------------------------------------------
# The real scenes of ../shared/data
# --------------------------------------------------------------------------------------

EXPECTED = {
    "aloe",
    "kitti2012/000070",
    "middlebury/tsukuba",
    "middlebury/venus",
    "middlebury/sawtooth",
    "middlebury/bull",
    "middlebury/poster",
    "middlebury/barn1",
    "middlebury/barn2",
    "middlebury/art",
    "middlebury/books",
    "middlebury/dolls",
}


@pytest.mark.shared_data
class TestSharedData:
    def test_list(self, shared_data):
        names = list_scenes(shared_data)
        assert names[0] == "motorcycle" and EXPECTED <= set(names)

    def test_tsukuba_end_to_end(self, shared_data):
        s = load("middlebury/tsukuba", root=shared_data)
        assert s.shape == (288, 384) and s.left.shape == (288, 384, 3)
        assert "Scharstein" in s.source
        known = s.disparity[s.valid]
        assert 0.5 < s.valid.mean() < 1
        assert 0 <= known.min() and known.max() <= 16.5  # Tsukuba: 5..14 px
        assert s.nonoccluded_mask is not None and s.nonoccluded_mask.shape == s.shape
        # Shifting left pixels by the ground truth lands on similar intensities.
        lg, rg = grey(s.left).astype(np.float32), grey(s.right).astype(np.float32)
        ys, xs = np.nonzero(s.valid & s.nonoccluded_mask)
        xr = np.rint(xs - s.disparity[ys, xs]).astype(int)
        inside = (xr >= 0) & (xr < s.shape[1])
        ys, xs, xr = ys[inside], xs[inside], xr[inside]
        diff_gt = np.abs(lg[ys, xs] - rg[ys, xr]).mean()
        diff_none = np.abs(lg[ys, xs] - rg[ys, xs]).mean()
        assert diff_gt < 8 and diff_gt < diff_none / 3

    def test_kitti(self, shared_data):
        s = load("kitti2012/000070", root=shared_data)
        assert s.left.ndim == 2 and s.shape == (376, 1241)
        assert s.calibration["focal_length"] == pytest.approx(718.856)
        assert s.calibration["baseline"] == pytest.approx(0.537, abs=1e-3)
        # Sparse LiDAR ground truth; disp_occ knows at least what disp_noc knows.
        assert 0.1 < s.valid.mean() < 0.6
        assert s.disparity_all is not None
        assert (np.isfinite(s.disparity_all) >= s.valid).all()
        # Where both know, they agree, but not bit for bit: about 0.2 % of the pixels
        # differ by up to 0.4 px in the files as shipped.
        diff = np.abs(s.disparity_all[s.valid] - s.disparity[s.valid])
        assert (diff == 0).mean() > 0.99 and diff.max() < 0.5
        np.testing.assert_array_equal(s.disparity, read_kitti_disparity(s.folder / "disp_noc.png"))

    def test_middlebury_2005_dmin_and_right_disparity(self, shared_data):
        s = load("middlebury/art", root=shared_data)
        assert s.meta["dmin"] == 200.0 and s.disparity_right is not None
        assert np.nanmax(s.disparity) <= 255 / 2

    @pytest.mark.parametrize("name", sorted(EXPECTED))
    def test_every_scene_sign_and_scale(self, shared_data, name):
        """xr = xl - d / scale matches; the opposite sign, or a doubled scale, does not."""
        s = load(name, root=shared_data)
        good = photometric_error(s, -1)
        assert good < photometric_error(s, +1) / 2
        half = StereoScene(s.name, s.left, s.right, s.disparity / 2, None, "")
        assert good < photometric_error(half, -1)
