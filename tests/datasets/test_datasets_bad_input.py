"""Bad input to hopmatch.datasets: numbers in files and meta.json that are not finite, too
long for Python, too deeply nested, or out of the range a reader can use, and numeric
arguments out of range. Each must give hopmatch's own error naming the file (or argument)
and what is wrong, never a RecursionError, a bare ValueError or a RuntimeWarning."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from dataset_files import KITTI_CALIB, MIDDLEBURY_CALIB, make_scene, write_pfm

from hopmatch.datasets import (
    load_scene,
    read_kitti_calib,
    read_middlebury_calib,
    read_middlebury_disparity,
    read_pfm,
)
from hopmatch.datasets.readers import read_scene_disparity
from hopmatch.errors import FileReadError, InvalidArgumentError

# Every overflow, division by zero or invalid value would be a leaked warning: make it fail.
pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")

HUGE_INT = "9" * 5000  # beyond Python's 4300-digit limit of int()


def _png(tmp_path, values, dtype=np.uint8):
    path = tmp_path / "d.png"
    assert cv2.imwrite(str(path), np.array(values, dtype))
    return path


# --------------------------------------------------------------------------------------
# Numeric arguments of the disparity readers
# --------------------------------------------------------------------------------------


class TestDisparityScale:
    @pytest.mark.parametrize("scale", [1e-320, 1e-40, 1e-6, 2.0**16 * 1.01, 1e300])
    def test_out_of_range_refused(self, tmp_path, scale):
        path = _png(tmp_path, [[0, 8]])
        with pytest.raises(InvalidArgumentError, match=r"`scale`.*\[2\*\*-16, 2\*\*16\]"):
            read_middlebury_disparity(path, scale)

    @pytest.mark.parametrize("scale", [2.0**-16, 2.0**16])
    def test_range_ends_give_finite_disparities(self, tmp_path, scale):
        path = _png(tmp_path, [[1, 65535]], np.uint16)
        d = read_middlebury_disparity(path, scale, unknown_value=None)
        assert np.isfinite(d).all() and (d > 0).all()

    @pytest.mark.parametrize("scale", [1e-320, 1e300])
    def test_pfm_scale_out_of_range_refused(self, tmp_path, scale):
        path = write_pfm(tmp_path / "d.pfm", np.ones((1, 2)), "<")
        with pytest.raises(InvalidArgumentError, match="`scale`"):
            read_scene_disparity(path, scale)

    def test_pfm_value_beyond_float32_once_scaled(self, tmp_path):
        path = write_pfm(tmp_path / "d.pfm", np.array([[3e38, 1.0]]), "<")
        with pytest.raises(FileReadError, match="3e\\+38.*float32 range") as exc:
            read_scene_disparity(path, 0.5)
        assert exc.value.path == str(path)


class TestUnknownValue:
    def test_value_an_8_bit_file_cannot_hold(self, tmp_path):
        path = _png(tmp_path, [[0, 8]])
        with pytest.raises(InvalidArgumentError,
                           match=r"`unknown_value` must be an integer in \[0, 255\]") as exc:
            read_middlebury_disparity(path, 8, unknown_value=300)
        assert "8-bit Middlebury disparity file" in str(exc.value) and "d.png" in str(exc.value)

    @pytest.mark.parametrize("value", [0.5, -1])
    def test_value_no_pixel_can_hold(self, tmp_path, value):
        path = _png(tmp_path, [[0, 8]])
        with pytest.raises(InvalidArgumentError, match="`unknown_value` must be an integer"):
            read_middlebury_disparity(path, 8, unknown_value=value)

    @pytest.mark.parametrize("value", [70000, 1e300, 2**70])
    def test_value_no_integer_map_can_hold(self, tmp_path, value):
        path = _png(tmp_path, [[0, 8]], np.uint16)
        with pytest.raises(InvalidArgumentError, match=r"`unknown_value`.*\[0, 65535\]"):
            read_middlebury_disparity(path, 8, unknown_value=value)

    def test_largest_16_bit_value_marks_unknown(self, tmp_path):
        path = _png(tmp_path, [[65535, 8]], np.uint16)
        d = read_middlebury_disparity(path, 8, unknown_value=65535.0)
        assert np.isnan(d[0, 0]) and d[0, 1] == 1.0

    @pytest.mark.parametrize("value", [1e300, -1e39, 1e-50])
    def test_pfm_unknown_beyond_float32(self, tmp_path, value):
        # 1e-50 would round to 0 in float32 and mark every true 0 unknown.
        path = write_pfm(tmp_path / "d.pfm", np.array([[0.0, 1.0]]), "<")
        with pytest.raises(InvalidArgumentError, match="`pfm_unknown`.*float32"):
            read_scene_disparity(path, 1, pfm_unknown=value)

    def test_pfm_unknown_in_float32_marks_unknown(self, tmp_path):
        path = write_pfm(tmp_path / "d.pfm", np.array([[0.1, 1.0]]), "<")
        d = read_scene_disparity(path, 1, pfm_unknown=0.1)
        assert np.isnan(d[0, 0]) and d[0, 1] == 1.0


# --------------------------------------------------------------------------------------
# PFM headers
# --------------------------------------------------------------------------------------


class TestPfmHeader:
    @pytest.mark.parametrize("header, part", [
        (b"Pf\n2 2\n.\n", "scale"),
        (b"Pf\n2 2\n-.\n", "scale"),
        (b"Pf\n2 2\n1.2.3\n", "scale"),
        (b"Pf\n2 2\n1e999\n", "scale"),
        (b"Pf\n2 2\n-1x\n", "scale"),
        (b"Pf\n" + HUGE_INT.encode() + b" 2\n-1\n", "width"),
        (b"Pf\n2 " + HUGE_INT.encode() + b"\n-1\n", "height"),
        (b"Pf\n-2 2\n-1\n", "width"),
        (b"Pf\n2 0\n-1\n", "height"),
        (b"Pf\n2.5 2\n-1\n", "width"),
    ])
    def test_bad_part_named(self, tmp_path, header, part):
        path = tmp_path / "d.pfm"
        path.write_bytes(header + b"\x00" * 16)
        with pytest.raises(FileReadError, match=f"PFM file: the header's {part}") as exc:
            read_pfm(path)
        assert exc.value.path == str(path)
        assert len(str(exc.value)) < 400  # the 5000 digits are not repeated

    def test_leading_zeros_in_size(self, tmp_path):
        path = tmp_path / "d.pfm"
        path.write_bytes(b"Pf\n0002 01\n-1.\n" + np.array([1, 2], "<f4").tobytes())
        np.testing.assert_array_equal(read_pfm(path), [[1.0, 2.0]])

    def test_bad_magic_is_a_file_error(self, tmp_path):
        path = tmp_path / "d.pfm"
        path.write_bytes(b"P5\n1 1\n255\n\x00")
        with pytest.raises(FileReadError, match="header must be 'PF' or 'Pf'") as exc:
            read_pfm(path)
        assert exc.value.path == str(path)


# --------------------------------------------------------------------------------------
# Calibration files
# --------------------------------------------------------------------------------------


def _kitti(tmp_path, old: str, new: str):
    path = tmp_path / "calib.txt"
    assert old in KITTI_CALIB
    path.write_text(KITTI_CALIB.replace(old, new, 1))
    return path


class TestKittiCalibValues:
    P1 = "P1: 7.188560e+02"

    @pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1" + HUGE_INT])
    def test_value_not_finite(self, tmp_path, value):
        path = _kitti(tmp_path, self.P1, f"P1: {value}")
        with pytest.raises(FileReadError, match="line 2: `P1` holds .*not a finite") as exc:
            read_kitti_calib(path)
        assert exc.value.path == str(path)

    def test_not_finite_in_another_key(self, tmp_path):
        path = tmp_path / "calib.txt"
        path.write_text(KITTI_CALIB + "R0_rect: 1 0 0 0 nan 0 0 0 1\n")
        with pytest.raises(FileReadError, match="line 5: `R0_rect` holds nan"):
            read_kitti_calib(path)

    def test_tiny_focal_length_gives_no_infinite_baseline(self, tmp_path):
        path = _kitti(tmp_path, self.P1, "P1: 1e-320")
        with pytest.raises(FileReadError, match="baseline .* is inf; it must be a finite"):
            read_kitti_calib(path)

    @pytest.mark.parametrize("old, new, what", [
        ("P1: 7.188560e+02", "P1: -7.188560e+02", "focal length P1"),
        ("P0: 7.188560e+02", "P0: 0", "focal length P0"),
        ("-3.861448e+02", "0", "baseline"),
        ("-3.861448e+02", "3.861448e+02", "baseline"),
    ])
    def test_not_positive(self, tmp_path, old, new, what):
        path = _kitti(tmp_path, old, new)
        with pytest.raises(FileReadError, match=f"{what}.*must be a finite number > 0"):
            read_kitti_calib(path)


def _middlebury(tmp_path, old: str, new: str):
    path = tmp_path / "calib.txt"
    assert old in MIDDLEBURY_CALIB
    path.write_text(MIDDLEBURY_CALIB.replace(old, new, 1))
    return path


class TestMiddleburyCalibValues:
    @pytest.mark.parametrize("old, new, where", [
        ("cam0=[3997.684", "cam0=[nan", "line 1: `cam0`"),
        ("1307.839", "inf", "line 2: `cam1`"),
        ("doffs=131.111", "doffs=nan", "line 3: `doffs`"),
        ("baseline=193.001", "baseline=1" + HUGE_INT, "line 4: `baseline`"),
        ("vmin=31", "vmin=-infinity", "line 9: `vmin`"),
    ])
    def test_value_not_finite(self, tmp_path, old, new, where):
        path = _middlebury(tmp_path, old, new)
        with pytest.raises(FileReadError, match=f"{where} holds .*not a finite") as exc:
            read_middlebury_calib(path)
        assert exc.value.path == str(path)

    @pytest.mark.parametrize("old, new, what", [
        ("cam0=[3997.684", "cam0=[0", "focal length cam0"),
        ("cam0=[3997.684", "cam0=[-3997.684", "focal length cam0"),
        ("baseline=193.001", "baseline=-193", "`baseline`"),
    ])
    def test_not_positive(self, tmp_path, old, new, what):
        path = _middlebury(tmp_path, old, new)
        with pytest.raises(FileReadError, match=f"{what}.*must be a finite number > 0"):
            read_middlebury_calib(path)


# --------------------------------------------------------------------------------------
# meta.json and dmin.txt of a scene
# --------------------------------------------------------------------------------------


def _scene_with_meta(tmp_path, scale: str = "2", extra: str = ""):
    """A scene of make_scene whose meta.json is written as text (json.dumps could not
    write the numbers and nestings tested here)."""
    folder = make_scene(tmp_path / "s")
    (folder / "meta.json").write_text(
        '{"left": "left.png", "right": "right.png", "disp": "disp_left.pgm", '
        f'"scale": {scale}{extra}}}'
    )
    return folder


def _meta_error(folder, match: str) -> FileReadError:
    with pytest.raises(FileReadError, match=match) as exc:
        load_scene(folder)
    assert exc.value.path == str(folder / "meta.json")
    return exc.value


class TestMetaJson:
    def test_deep_nesting(self, tmp_path):
        deep = "[" * 200000 + "]" * 200000
        folder = _scene_with_meta(tmp_path, "8", f', "x": {deep}')
        err = _meta_error(folder, "`x` nests arrays or objects more than 32 levels deep")
        assert err.kind == "too_deep"

    def test_nesting_the_parser_takes_but_nothing_else_needs(self, tmp_path):
        folder = _scene_with_meta(tmp_path, "2", ', "cite": ' + "[" * 40 + "]" * 40)
        _meta_error(folder, "`cite` nests")

    def test_nesting_of_a_calibration_matrix_accepted(self, tmp_path):
        folder = _scene_with_meta(tmp_path, "2", ', "calibration": {"K": [[1, 0], [0, 1]]}')
        assert load_scene(folder).calibration["K"].shape == (2, 2)

    def test_scale_with_too_many_digits(self, tmp_path):
        folder = _scene_with_meta(tmp_path, HUGE_INT)
        _meta_error(folder, "`scale` must be a finite number")

    def test_unknown_value_with_too_many_digits(self, tmp_path):
        folder = _scene_with_meta(tmp_path, "2", f', "unknown_value": {HUGE_INT}')
        _meta_error(folder, "`unknown_value` must be")

    @pytest.mark.parametrize("scale", ["1e-320", "1e300", "1e999", "NaN"])
    def test_scale_out_of_range(self, tmp_path, scale):
        folder = _scene_with_meta(tmp_path, scale)
        _meta_error(folder, "`scale`")

    @pytest.mark.parametrize("value", ["1e300", "70000", "0.5"])
    def test_unknown_value_no_pixel_can_hold(self, tmp_path, value):
        folder = _scene_with_meta(tmp_path, "2", f', "unknown_value": {value}')
        _meta_error(folder, "`unknown_value` must be an integer")

    def test_unknown_value_the_8_bit_disparity_cannot_hold(self, tmp_path):
        folder = _scene_with_meta(tmp_path, "2", ', "unknown_value": 300')
        with pytest.raises(InvalidArgumentError, match=r"`unknown_value`.*\[0, 255\].*8-bit "
                                                       r"Middlebury disparity file.*disp_left"):
            load_scene(folder)

    def test_unknown_value_of_a_pfm_scene_beyond_float32(self, tmp_path):
        folder = make_scene(tmp_path / "p", disp="disp0.pfm", scale=1, unknown_value=1e300)
        write_pfm(folder / "disp0.pfm", np.ones((6, 10)), "<")
        _meta_error(folder, "`unknown_value` must be a value a PFM file can hold")

    @pytest.mark.parametrize("calibration, key", [
        ('{"cam0": [[1, 2], [3]]}', "calibration.cam0"),
        ('{"cam0": [[1, NaN], [3, 4]]}', "calibration.cam0"),
        ('{"cam0": [["a", "b"]]}', "calibration.cam0"),
        ('{"cam0": [1, null]}', "calibration.cam0"),
        ('{"f": Infinity}', "calibration.f"),
        (f'{{"f": {HUGE_INT}}}', "calibration.f"),
    ])
    def test_calibration_dict_values(self, tmp_path, calibration, key):
        folder = _scene_with_meta(tmp_path, "2", f', "calibration": {calibration}')
        _meta_error(folder, f"`{key}` (must|contains NaN)")

    def test_calibration_dict_keeps_other_values(self, tmp_path):
        folder = _scene_with_meta(
            tmp_path, "2", ', "calibration": {"f": 7, "note": "x", "ok": true}')
        assert load_scene(folder).calibration == {"f": 7, "note": "x", "ok": True}

    @pytest.mark.parametrize("text", ["nan\n", "inf", "-Infinity 3", HUGE_INT])
    def test_dmin_not_finite(self, tmp_path, text):
        folder = make_scene(tmp_path / "s")
        (folder / "dmin.txt").write_text(text)
        with pytest.raises(FileReadError, match="one finite number") as exc:
            load_scene(folder)
        assert exc.value.path == str(folder / "dmin.txt")
