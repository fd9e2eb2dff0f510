"""Tests of hopmatch.stereo.checks: the boundary checks the stereo modules share."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from hopmatch.errors import InvalidArgumentError, InvalidTypeError
from hopmatch.stereo import checks


def test_real_array_keeps_nan_and_infinities():
    arr = checks.as_real_array([1, np.nan, np.inf], "xyz")
    assert arr.dtype == np.float64 and np.isnan(arr[1]) and np.isinf(arr[2])
    src = np.zeros(3, np.float32)
    assert checks.as_real_array(src, "xyz") is not src  # a new array
    with pytest.raises(InvalidTypeError, match="`xyz` must hold real numbers, got dtype bool"):
        checks.as_real_array(np.ones(2, bool), "xyz")
    with pytest.raises(InvalidTypeError, match="`d` must be a number or an array, got bool"):
        checks.as_real_array(True, "d", "a number or an array", refuse_bool=True)
    with pytest.raises(InvalidTypeError, match="`xyz` must be a numeric array, got NoneType"):
        checks.as_real_array(None, "xyz")


def test_values_one_per_point():
    assert checks.as_values([1, np.nan], "v", 2).shape == (2,)
    assert checks.as_values([], "v", 0).shape == (0,)
    with pytest.raises(InvalidArgumentError, match=r"`v` must have shape \(3,\)"):
        checks.as_values([1, 2], "v", 3)
    with pytest.raises(InvalidArgumentError, match="infinite values"):
        checks.as_values([np.inf], "v", 1)


def test_camera_model():
    r = cv2.Rodrigues(np.array([0.1, 0.0, 0.0]))[0]
    np.testing.assert_allclose(checks.as_rotation([0.1, 0.0, 0.0], "R"), r)
    assert checks.as_distortion(np.zeros((5, 1)), "D").shape == (1, 5)
    assert checks.as_translation([1, 0, 0], "T").shape == (3, 1)
    with pytest.raises(InvalidArgumentError, match="det"):
        checks.as_rotation(-np.eye(3), "R")
    with pytest.raises(InvalidArgumentError, match=r"`alpha` must be -1 or in \[0, 1\]"):
        checks.as_alpha(-0.5)
    assert checks.as_alpha(-1) == -1.0


def test_options_images_and_paths():
    assert checks.check_option(cv2.INTER_CUBIC, "interpolation", checks.INTERPOLATIONS) == 2
    with pytest.raises(InvalidArgumentError, match="one of cv2.INTER_NEAREST"):
        checks.check_option(True, "interpolation", checks.INTERPOLATIONS)
    img = np.zeros((4, 5, 3), np.uint16)[:, ::-1]
    out = checks.as_image(img, "left")
    assert out.flags.c_contiguous and out.dtype == np.uint16 and out.shape == (4, 5, 3)
    with pytest.raises(InvalidArgumentError, match="same height and width"):
        checks.as_image_pair(np.zeros((4, 5)), np.zeros((5, 4)))
    assert checks.as_path("a/b.ply") == Path("a/b.ply")
    with pytest.raises(InvalidTypeError, match="`out` must be a str or os.PathLike"):
        checks.as_path(3, "out")
