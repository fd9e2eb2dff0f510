"""Tests of hopmatch.datasets.readers: every reader on tiny files written here, and
malformed and missing files."""

from __future__ import annotations

import errno
import os

import cv2
import numpy as np
import pytest
from dataset_files import KITTI_CALIB, MIDDLEBURY_CALIB, write_pfm

import hopmatch.files
from hopmatch.datasets import (
    read_kitti_calib,
    read_kitti_disparity,
    read_middlebury_calib,
    read_middlebury_disparity,
    read_pfm,
)
from hopmatch.datasets.calibration import read_calibration
from hopmatch.datasets.readers import (
    as_path,
    existing_file,
    read_mask,
    read_scene_disparity,
    read_scene_image,
)
from hopmatch.errors import FileReadError, InvalidArgumentError, InvalidTypeError
from hopmatch.imageio import ImageReadError

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
        with pytest.raises(ImageReadError, match="could not be decoded") as exc:
            read_middlebury_disparity(path, scale=8)
        assert "junk.png" in str(exc.value) and exc.value.kind == "undecodable"

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
        with pytest.raises(FileReadError,
                           match="calib.txt: the Middlebury calibration file does not exist"):
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
        with pytest.raises(FileReadError, match="disp.png: the KITTI disparity file does not"):
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
# The files of a scene: images, masks, any disparity format, any calibration format
# --------------------------------------------------------------------------------------


class TestSceneFiles:
    def test_image_as_cv2_imread(self, tmp_path):
        rng = np.random.default_rng(0)
        bgr = rng.integers(0, 256, (4, 5, 3), dtype=np.uint8)
        cv2.imwrite(str(tmp_path / "c.png"), bgr)
        img = read_scene_image(tmp_path / "c.png", "left image")
        assert img.flags.c_contiguous
        np.testing.assert_array_equal(img, cv2.imread(str(tmp_path / "c.png")))

    def test_image_grey_stays_grey_alpha_dropped_16_bit_scaled(self, tmp_path):
        cv2.imwrite(str(tmp_path / "g.png"), np.full((4, 5), 7, np.uint8))
        assert read_scene_image(tmp_path / "g.png").shape == (4, 5)
        bgra = np.dstack([np.full((4, 5), v, np.uint8) for v in (1, 2, 3, 200)])
        cv2.imwrite(str(tmp_path / "a.png"), bgra)
        np.testing.assert_array_equal(read_scene_image(tmp_path / "a.png"), bgra[..., :3])
        cv2.imwrite(str(tmp_path / "d.png"), np.full((4, 5), 256 * 9, np.uint16))
        deep = read_scene_image(tmp_path / "d.png")
        assert deep.dtype == np.uint8 and (deep == 9).all()

    def test_image_errors(self, tmp_path):
        # FileReadError (ImageReadError when decoding fails): path, problem and kind
        with pytest.raises(FileReadError, match="none.png: the left image file does not exist"):
            read_scene_image(tmp_path / "none.png", "left image")
        (tmp_path / "junk.png").write_bytes(b"junk")
        with pytest.raises(ImageReadError,
                           match="junk.png: the right image file could not be decoded") as exc:
            read_scene_image(tmp_path / "junk.png", "right image")
        assert exc.value.path == str(tmp_path / "junk.png")

    def test_unreadable_file(self, tmp_path, monkeypatch):
        path = tmp_path / "d.png"
        cv2.imwrite(str(path), np.array([[0, 8]], np.uint8))

        real_open = os.open

        def refuse(name, flags, *args):  # as for a file of another user (the tests run as root)
            if os.fspath(name) == str(path):
                raise PermissionError(errno.EACCES, "Permission denied", str(name))
            return real_open(name, flags, *args)

        monkeypatch.setattr(hopmatch.files.os, "open", refuse)
        with pytest.raises(FileReadError, match=r"d\.png: cannot read the file: permission "
                                                r"denied \(the Middlebury disparity file\)"):
            read_middlebury_disparity(path, scale=8)

    def test_mask(self, tmp_path):
        cv2.imwrite(str(tmp_path / "m.png"), np.array([[0, 255, 1]], np.uint8))
        np.testing.assert_array_equal(read_mask(tmp_path / "m.png"), [[False, True, True]])
        cv2.imwrite(str(tmp_path / "c.png"), np.dstack([np.array([[0, 9]], np.uint8)] * 3))
        np.testing.assert_array_equal(read_mask(tmp_path / "c.png"), [[False, True]])
        colour = np.zeros((1, 2, 3), np.uint8)
        colour[..., 1] = 5
        cv2.imwrite(str(tmp_path / "x.png"), colour)
        with pytest.raises(InvalidArgumentError, match="non-occluded mask file.*single-channel"):
            read_mask(tmp_path / "x.png")

    def test_disparity_by_format(self, tmp_path):
        cv2.imwrite(str(tmp_path / "d.pgm"), np.array([[0, 8]], np.uint8))
        d = read_scene_disparity(tmp_path / "d.pgm", 4, unknown_value=0)
        assert np.isnan(d[0, 0]) and d[0, 1] == 2
        write_pfm(tmp_path / "d.pfm", np.array([[np.inf, 0.0, 8.0]], np.float32), "<")
        d = read_scene_disparity(tmp_path / "d.pfm", 4, unknown_value=0)  # PFM: not applied
        assert d.dtype == np.float32 and np.isnan(d[0, 0]) and d[0, 1] == 0 and d[0, 2] == 2
        d = read_scene_disparity(tmp_path / "d.pfm", 4, pfm_unknown=0)
        assert np.isnan(d[0, :2]).all() and d[0, 2] == 2
        write_pfm(tmp_path / "c.pfm", np.zeros((1, 2, 3), np.float32), "<")
        with pytest.raises(InvalidArgumentError, match="grey 'Pf' PFM"):
            read_scene_disparity(tmp_path / "c.pfm", 1)
        with pytest.raises(InvalidArgumentError, match="scale"):
            read_scene_disparity(tmp_path / "d.pfm", 0)

    def test_calibration_by_format(self, tmp_path):
        (tmp_path / "k.txt").write_text(KITTI_CALIB)
        (tmp_path / "m.txt").write_text(MIDDLEBURY_CALIB)
        assert read_calibration(tmp_path / "k.txt")["P3"].shape == (3, 4)
        assert read_calibration(tmp_path / "m.txt")["doffs"] == pytest.approx(131.111)
        (tmp_path / "u.txt").write_text("focal 100\n")
        with pytest.raises(FileReadError, match="u.txt: not a valid calibration file: it is "
                                                "neither KITTI"):
            read_calibration(tmp_path / "u.txt")
        (tmp_path / "b.txt").write_bytes(b"\xff\xfe\x00\x81")
        with pytest.raises(FileReadError, match="b.txt: the calibration file is not a text"):
            read_calibration(tmp_path / "b.txt")

    def test_paths(self, tmp_path):
        assert as_path(str(tmp_path)) == tmp_path and as_path(tmp_path) is tmp_path
        with pytest.raises(InvalidTypeError, match="`folder` must be a str or pathlib.Path"):
            as_path(3.5, "folder")
        (tmp_path / "f").touch()
        assert existing_file(str(tmp_path / "f"), "x") == tmp_path / "f"
        with pytest.raises(InvalidArgumentError, match="the thing path is not a file"):
            existing_file(tmp_path, "thing")

    def test_unknown_value_type(self, tmp_path):
        with pytest.raises(InvalidTypeError, match="`unknown_value`"):
            read_middlebury_disparity(tmp_path / "x.png", scale=8, unknown_value="0")
