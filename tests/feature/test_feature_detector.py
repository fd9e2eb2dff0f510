"""DericheMoravecDetector's array-level API agrees with its cv2 API."""

from __future__ import annotations

import cv2
import numpy as np

import hopmatch

RNG = np.random.default_rng(5)
IMG = cv2.GaussianBlur((RNG.random((90, 120)) * 255).astype(np.uint8), (3, 3), 0)


def test_detect_and_describe_is_detect_and_compute_without_objects():
    det = hopmatch.DericheMoravecDetector()
    pts, resp, desc, g = det.detect_and_describe(IMG)
    kps, desc_cv = det.detectAndCompute(IMG, None)
    np.testing.assert_array_equal(pts, cv2.KeyPoint_convert(kps))
    np.testing.assert_array_equal(resp, np.float32([k.response for k in kps]))
    np.testing.assert_array_equal(desc, desc_cv)
    np.testing.assert_array_equal(g, det.feature_image(IMG))
    assert len(pts) > 20 and desc.shape == (len(pts), det.descriptorSize())


def test_detect_and_describe_names_its_arguments():
    det = hopmatch.DericheMoravecDetector()
    try:
        det.detect_and_describe(IMG, np.ones((3, 3), np.uint8), mask_name="mask_left")
    except hopmatch.errors.InvalidArgumentError as exc:
        assert "mask_left" in str(exc)
    else:  # pragma: no cover
        raise AssertionError("a mask of the wrong shape was accepted")


def test_detect_and_describe_can_keep_the_grey_image():
    det = hopmatch.DericheMoravecDetector()
    colour = cv2.cvtColor(IMG, cv2.COLOR_GRAY2BGR)
    *same, gray = det.detect_and_describe(colour, keep_gray=True)
    for a, b in zip(same, det.detect_and_describe(colour)):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(gray, IMG)
