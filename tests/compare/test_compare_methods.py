"""The methods of hopmatch.compare (hopmatch.compare.methods), on synthetic pairs."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from compare_helpers import synthetic_scene

from hopmatch import compare
from hopmatch.compare import METHODS, MethodResult, methods


@pytest.mark.parametrize("name", list(METHODS))
def test_every_method_on_a_constant_disparity(name):
    scene = synthetic_scene()
    res = compare.run_method(name, scene)
    assert isinstance(res, MethodResult) and res.seconds > 0
    for arr in res[:2] + res[3:]:
        assert arr.dtype == np.float32 and arr.ndim == 2 and arr.shape[1] == 2
    assert res.left_pts.shape == res.right_pts.shape
    assert len(res.keypoints_left) >= len(np.unique(res.left_pts, axis=0))


@pytest.mark.parametrize("name", ["hopmatch", "ncc-wta", "sgbm", "sift-ratio-band"])
def test_methods_find_the_disparity(name):
    res = compare.run_method(name, synthetic_scene())
    d = res.left_pts[:, 0] - res.right_pts[:, 0]
    assert len(d) > 10 and np.median(np.abs(d - 5)) < 0.5


def test_ncc_matches_cv2_match_template():
    """The vectorised NCC equals cv2.matchTemplate(TM_CCOEFF_NORMED) point by point."""
    rng = np.random.default_rng(0)
    left = (rng.random((40, 60)) * 255).astype(np.uint8)
    right = (rng.random((40, 60)) * 255).astype(np.uint8)
    pts = np.array([[30, 10], [20, 25], [8, 30], [50, 5]], np.intp)
    dmax, h = 12, compare.NCC_HALF
    keep, disp = methods._ncc_wta(left, right, pts, dmax)
    for (x, y), k, d in zip(pts, keep, disp):
        tpl = left[y - h:y + h + 1, x - h:x + h + 1]
        lo = max(x - dmax, h)
        band = right[y - h:y + h + 1, lo - h:x + h + 1]
        score = cv2.matchTemplate(band, tpl, cv2.TM_CCOEFF_NORMED)[0][::-1]  # d = 0, 1, ...
        assert k and abs(float(d) - int(np.argmax(score))) <= 0.5  # winner + parabola shift


def test_band_mask_equals_the_dense_test():
    rng = np.random.default_rng(1)
    kl = (rng.random((300, 2)) * [100, 20]).astype(np.float32)
    kr = (rng.random((250, 2)) * [100, 20]).astype(np.float32)
    dy = np.abs(kl[:, None, 1] - kr[None, :, 1])
    d = kl[:, None, 0] - kr[None, :, 0]
    want = ((dy <= 1) & (d >= 0) & (d <= 30)).astype(np.uint8)
    np.testing.assert_array_equal(methods._band_mask(kl, kr, 30), want)


def test_disparity_range():
    scene = synthetic_scene(disparity=9)
    assert compare.disparity_range(scene) == 10  # ceil(9 * 1.1)


def test_dmatches_become_point_pairs():
    kl = np.float32([[0, 0], [1, 1], [2, 2]])
    kr = np.float32([[5, 5], [6, 6]])
    left, right = methods._from_dmatches(kl, kr, (cv2.DMatch(2, 0, 0.1), cv2.DMatch(0, 1, 0.2)))
    np.testing.assert_array_equal(left, kl[[2, 0]])
    np.testing.assert_array_equal(right, kr[[0, 1]])
    empty = methods._from_dmatches(kl, kr, ())
    assert all(a.shape == (0, 2) and a.dtype == np.float32 for a in empty)
    with pytest.raises(ValueError, match="do not exist"):
        methods._from_dmatches(kl, kr, [cv2.DMatch(0, 2, 0.0)])


def test_sgbm_samples_at_the_points_given():
    """``sgbm_uniqueness(..., left_points)``: the disparity map read at those points (rounded
    to pixels; points outside the image dropped), the same reading as at hopmatch's own."""
    scene = synthetic_scene()
    own = methods.sgbm_uniqueness(scene, 10)
    h, w = scene.left.shape[:2]
    extra = np.array([[-3.0, 5.0], [w + 2.0, 5.0]], np.float32)  # outside: dropped
    given = methods.sgbm_uniqueness(scene, 10, np.vstack([own.keypoints_left, extra]))
    np.testing.assert_array_equal(given.keypoints_left, own.keypoints_left)
    np.testing.assert_array_equal(given.left_pts, own.left_pts)
    np.testing.assert_array_equal(given.right_pts, own.right_pts)
    some = own.keypoints_left[::3]
    fewer = methods.sgbm_uniqueness(scene, 10, some)
    assert len(fewer.keypoints_left) == len(some)
    assert set(map(tuple, fewer.left_pts.tolist())) <= set(map(tuple, some.tolist()))
