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


def _fields(kps):
    return [(k.pt, k.size, k.angle, k.response, k.octave, k.class_id) for k in kps]


def test_keypoints_built_in_bulk_equal_keypoints_built_one_by_one():
    from hopmatch.feature.detector import keypoints_from_arrays

    pts = (RNG.random((500, 2)) * 1000).astype(np.float32)
    resp = RNG.random(500).astype(np.float32)
    bulk = keypoints_from_arrays(pts, resp, 3.0)
    naive = tuple(cv2.KeyPoint(float(x), float(y), 3.0, -1.0, float(r), 0, -1)
                  for (x, y), r in zip(pts, resp))
    assert type(bulk) is tuple and _fields(bulk) == _fields(naive)
    assert keypoints_from_arrays(np.zeros((0, 2), np.float32), np.zeros(0, np.float32), 3) == ()


def test_compute_of_the_detectors_own_keypoints_equals_compute_of_copies():
    det = hopmatch.DericheMoravecDetector()
    kps = det.detect(IMG)
    copies = [cv2.KeyPoint(*k.pt, k.size, k.angle, k.response, k.octave, k.class_id)
              for k in kps]
    own_k, own_d = det.compute(IMG, kps)
    copy_k, copy_d = det.compute(IMG, copies)
    assert _fields(own_k) == _fields(copy_k)
    np.testing.assert_array_equal(own_d, copy_d)


def test_compute_reads_a_keypoint_moved_after_detection():
    """``KeyPoint.pt`` is writable: compute must describe where a keypoint is now, not
    where the detector put it (nothing is cached between calls)."""
    det = hopmatch.DericheMoravecDetector()
    kps, desc = det.detectAndCompute(IMG, None)
    moved = kps[0].pt
    kps[0].pt = (kps[1].pt[0], kps[1].pt[1])
    _, again = det.compute(IMG, kps)
    np.testing.assert_array_equal(again[0], desc[1])
    kps[0].pt = (-50.0, -50.0)  # outside the image: dropped, as cv2 does
    kept, again = det.compute(IMG, kps)
    assert len(kept) == len(kps) - 1 and kept[0] is kps[1]
    kps[0].pt = moved
