"""match_stereo(left, right, rectified=False): hopmatch.matching.unrectified."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap
import time
import warnings
from pathlib import Path

import cv2
import numpy as np
import pytest
from unrect_scene import SIZE, perturbation, perturbed_truth, render_pair, texture

import hopmatch
from hopmatch.errors import InvalidArgumentError, InvalidTypeError
from hopmatch.feature.descriptor import gradient_windows
from hopmatch.feature.padding import black_padding
from hopmatch.matching import second_try
from hopmatch.matching import unrectified as u
from hopmatch.matching.geometry import symmetric_epipolar_error, transform_points
from hopmatch.matching.stereo_match import PASS_GUIDED
from hopmatch.matching.vertical import row_plane_residual

HERE = Path(__file__).resolve().parent  # unrect_scene.py's folder


@pytest.fixture(scope="module")
def verged():
    left, right, F = render_pair()
    return left, right, F, hopmatch.match_stereo(left, right, rectified=False)


def test_a_verged_pair_is_matched_along_its_true_epipolar_lines(verged):
    left, right, F, res = verged
    assert len(res.query_idx) > 1000
    err = symmetric_epipolar_error(F, res.matched_left, res.matched_right)
    assert np.mean(err <= 1.0) > 0.97
    assert res.geometry.search in ("aligned", "rectified", "epipolar")
    assert res.geometry.n_inliers > 500 and res.geometry.inlier_ratio > 0.8
    np.testing.assert_allclose(res.fundamental_matrix, res.geometry.fundamental)
    assert np.median(symmetric_epipolar_error(res.fundamental_matrix, res.matched_left,
                                              res.matched_right)) < 0.5
    assert set(res.timings) >= {"geometry", "detect_left", "detect_right", "match"}


def test_a_rectified_search_frame_gets_the_guided_pass_and_the_refinement(verged):
    """The verged rig's rows line up only after a projective rectification ('rectified'
    frame): the guided pass and the refinement run on both images warped onto one canvas
    (rectified_canvas) and add matches that lie on the true epipolar lines."""
    _, _, F, res = verged
    assert res.geometry.search == "rectified"
    guided = res.passes == PASS_GUIDED
    assert guided.sum() > 1000 and res.refinement is not None
    assert len(res.refinement.x) == len(res.query_idx)
    err = symmetric_epipolar_error(F, res.matched_left[guided], res.matched_right[guided])
    assert np.mean(err <= 1.0) > 0.97


def test_a_rectified_search_frame_is_bit_identical_in_threads(verged):
    """The guided pass and the refinement on the warped canvas run in threads like the
    rest: the same matches for one thread as for two."""
    left, right, _, _ = verged
    one = hopmatch.match_stereo(left, right, rectified=False, threads=1)
    two = hopmatch.match_stereo(left, right, rectified=False, threads=2)
    assert one.geometry.search == "rectified" and one.passes.max() == 3  # both runs guided
    for name in ("points_left", "points_right", "query_idx", "train_idx", "distances",
                 "passes", "fundamental_matrix"):
        np.testing.assert_array_equal(getattr(two, name), getattr(one, name), name)


def _unrectified_signature(res) -> dict:
    """What must not change between processes, as plain lists (floats round-trip JSON)."""
    return {name: np.asarray(getattr(res, name)).tolist() for name in (
        "points_left", "points_right", "query_idx", "train_idx", "distances", "passes",
        "fundamental_matrix")} | {"search": res.geometry.search}


def test_an_unrectified_pair_is_identical_in_separate_processes(verged):
    """Determinism across processes for the unrectified path too: SIFT, MAGSAC, the
    rectification and the warped canvas give the same matches and F in two fresh
    processes (with different hash seeds) as here."""
    code = textwrap.dedent("""
        import json, sys
        sys.path.insert(0, %r)
        import hopmatch
        from unrect_scene import render_pair
        from test_matching_unrectified import _unrectified_signature
        left, right, _ = render_pair()
        res = hopmatch.match_stereo(left, right, rectified=False)
        print(json.dumps(_unrectified_signature(res)))
    """ % str(HERE))
    here = json.loads(json.dumps(_unrectified_signature(verged[3])))
    for hashseed in ("0", "4242"):
        env = {**os.environ, "PYTHONHASHSEED": hashseed}
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              env=env, cwd=str(HERE), timeout=600)
        assert proc.returncode == 0, proc.stderr[-2000:]
        assert json.loads(proc.stdout.strip().splitlines()[-1]) == here, hashseed


@pytest.fixture(scope="module")
def verged_frame():
    """The verged pair's estimated geometry, the similarity that aligns its rows, and the
    inliers in that frame."""
    from hopmatch.matching.geometry import estimate_geometry

    left, right, _ = render_pair()
    geometry = estimate_geometry(left, right)
    to_aligned = u.aligned_frame(geometry, SIZE, SIZE)
    inliers_l = geometry.left_points[geometry.inliers]
    inliers_a = transform_points(geometry.right_points[geometry.inliers], to_aligned)
    return geometry, to_aligned, inliers_l, inliers_a


def test_aligned_rows_that_a_plane_cannot_follow_are_refused(verged_frame, monkeypatch):
    """A verged rig's aligned rows converge (keystone): the plane vertical model leaves
    the inliers far off where F fits them (rows_fit), and search_frame refuses the
    aligned rows for that alone, even where the median |dy| would let them pass."""
    geometry, to_aligned, il, ia = verged_frame
    dy = il[:, 1].astype(np.float64) - ia[:, 1]
    residual, curve = row_plane_residual(il.astype(np.float64), dy)
    assert residual > 4 * u.ROW_PLANE_PIXELS and curve > 2 * u.ROW_CURVE_PIXELS
    assert not u.rows_fit(geometry, il, dy)
    monkeypatch.setattr(u, "ROW_PIXELS", 100.0)  # the median check lets anything pass
    monkeypatch.setattr(u, "ROW_DRIFT", np.inf)
    assert u.search_frame(geometry, to_aligned, SIZE)[3] == "rectified"
    monkeypatch.setattr(u, "ROW_PLANE_PIXELS", np.inf)
    monkeypatch.setattr(u, "ROW_CURVE_PIXELS", np.inf)
    assert u.search_frame(geometry, to_aligned, SIZE)[3] == "aligned"


def test_aligned_rows_of_a_turned_and_shifted_view_pass_the_plane_check():
    """A rectified pair whose right view is turned, scaled and shifted: the similarity
    lines the rows up, and the plane fits the inliers as well as F does."""
    from hopmatch.matching.geometry import estimate_geometry

    left, _, warped, _, _ = perturbed_box_pair(5.0, 30.0, 1.03)
    geometry = estimate_geometry(left, warped)
    to_aligned = u.aligned_frame(geometry, SIZE, SIZE)
    il = geometry.left_points[geometry.inliers]
    ia = transform_points(geometry.right_points[geometry.inliers], to_aligned)
    dy = il[:, 1].astype(np.float64) - ia[:, 1]
    assert u.rows_fit(geometry, il, dy)
    assert u.search_frame(geometry, to_aligned, SIZE)[3] == "aligned"


def test_a_rectification_opencv_cannot_give_is_quasi_euclidean(verged_frame, monkeypatch):
    """Where OpenCV's rectifying maps are unusable (here: none at all), the rows of the
    quasi-Euclidean maps are searched: within half a pixel of the inliers (the rig's two
    cameras differ in focal length and principal point, which that model leaves out);
    without QUASI_EUCLIDEAN the pair is not searched on rectified rows."""
    geometry, to_aligned, il, ia = verged_frame
    monkeypatch.setattr(u, "rectifying_homographies", lambda *args: None)
    H1, H2, _, mode = u.search_frame(geometry, to_aligned, SIZE)
    assert mode == "rectified"
    rl, ra = transform_points(il, H1), transform_points(ia, H2)
    rows = np.abs(rl[:, 1].astype(np.float64) - ra[:, 1])
    assert np.percentile(rows, 90) <= 0.5
    assert u.near_identity((H1, H2), SIZE)
    monkeypatch.setattr(u, "QUASI_EUCLIDEAN", False)
    assert u.search_frame(geometry, to_aligned, SIZE)[3] != "rectified"


def test_the_rectified_canvas_maps_points_and_images_consistently():
    """rectified_canvas: both images warped by T H1 and T H2 onto one canvas; each point
    lands where its image's content went (the warped image sampled there equals the
    original at the point), the right points map back through ``to_right``, and the
    windows are cut from the warped feature images."""
    rng = np.random.default_rng(5)
    h, w = 120, 160
    gray_l = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32), (0, 0), 2.0) * 200
    gray_a = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32), (0, 0), 2.0) * 200
    grads = (gray_l * 0.5, gray_a * 0.5)
    H1 = np.array([[1.01, 0.02, -3.0], [-0.015, 0.99, 4.0], [1e-5, 2e-5, 1.0]])
    H2 = np.array([[0.98, -0.01, 6.0], [0.01, 1.02, -5.0], [-2e-5, 1e-5, 1.0]])
    to_aligned = np.array([[1.0, 0.0, 2.0], [0.0, 1.0, -1.5], [0.0, 0.0, 1.0]])
    pts_l = rng.uniform(20, [w - 20, h - 20], (50, 2)).astype(np.float32)
    pts_a = rng.uniform(20, [w - 20, h - 20], (50, 2)).astype(np.float32)
    desc = np.zeros((50, 49), np.float32)
    frame = u.SearchFrame(mode="rectified", to_aligned=to_aligned, shift=None,
                          right_points=pts_a, grays=(gray_l, gray_a), gradients=grads,
                          descriptors=(desc, desc), right_shape=(h, w), maps=(H1, H2))
    left, right, grays, canvas_grads, descriptors, to_right = u.rectified_canvas(
        frame, pts_l, pts_a)
    for canvas_pts, image, pts, canvas in ((left, gray_l, pts_l, grays[0]),
                                           (right, gray_a, pts_a, grays[1])):
        assert (canvas_pts >= 0).all()
        assert (canvas_pts[:, 0] <= canvas.shape[1] - 1).all()
        assert (canvas_pts[:, 1] <= canvas.shape[0] - 1).all()
        on_canvas = cv2.remap(canvas, canvas_pts[:, :1], canvas_pts[:, 1:], cv2.INTER_LINEAR)
        original = cv2.remap(image, pts[:, :1], pts[:, 1:], cv2.INTER_LINEAR)
        np.testing.assert_allclose(on_canvas, original, atol=2.0)
    np.testing.assert_allclose(transform_points(right, to_right),
                               transform_points(pts_a, np.linalg.inv(to_aligned)), atol=1e-3)
    np.testing.assert_array_equal(descriptors[0], gradient_windows(canvas_grads[0], left, 7))
    np.testing.assert_array_equal(descriptors[1], gradient_windows(canvas_grads[1], right, 7))


def test_points_are_reported_in_the_given_images(verged):
    left, right, _, res = verged
    w, h = SIZE
    for pts in (res.points_left, res.points_right):
        assert pts.dtype == np.float32 and (pts >= 0).all()
        assert (pts[:, 0] <= w - 1).all() and (pts[:, 1] <= h - 1).all()
    assert len(res.keypoints_right) == len(res.points_right)
    assert all(m.trainIdx < len(res.points_right) for m in res.matches)


def perturbed_box_pair(angle, dy, scale, seed=3):
    rng = np.random.default_rng(seed)
    left = texture(rng, 520)[:360, :480]
    d = np.full(left.shape, 8.0, np.float32)
    d[100:260, 150:330] = 20.0
    # a rectified pair with ground truth on the left image: right(x) = left(x + d(x))
    # holds at x = xl - d, so build the left disparity map by forward warping
    ys, xs = np.mgrid[0:360, 0:480].astype(np.float32)
    right = cv2.remap(left, xs + d, ys, cv2.INTER_LINEAR)
    gt = np.full(left.shape, np.nan, np.float32)
    xl = np.round(xs + d).astype(int)
    ok = xl < 480
    gt[ys[ok].astype(int), xl[ok]] = d[ok]
    A = perturbation((480, 360), angle, dy, scale)
    return left, right, cv2.warpAffine(right, A, (480, 360), flags=cv2.INTER_LINEAR), gt, A


@pytest.mark.parametrize("angle, dy, scale", [(5.0, 30.0, 1.03), (-2.0, -8.0, 0.98)])
def test_a_perturbed_rectified_pair_keeps_most_of_its_matches(angle, dy, scale):
    left, right, warped, gt, A = perturbed_box_pair(angle, dy, scale)
    # the unrectified path runs the guided pass and the refinement on the aligned rows, so
    # it is compared with the defaults on the rectified pair
    ref = hopmatch.match_stereo(left, right, max_disparity=24)
    t, known = perturbed_truth(ref.matched_left, gt, np.eye(3)[:2])
    ref_correct = int((known & (np.hypot(*(ref.matched_right - t).T) <= 1)).sum())
    res = hopmatch.match_stereo(left, warped, rectified=False)
    t, known = perturbed_truth(res.matched_left, gt, A)
    correct = known & (np.hypot(*(res.matched_right - t).T) <= 1)
    assert correct.sum() / known.sum() >= 0.97
    assert correct.sum() >= 0.75 * ref_correct
    assert res.geometry.search == "aligned"
    # both steps after the network ran, and their right points are in the given image
    guided = np.isin(res.passes, (1, 3))  # the guided passes of both_features' two runs
    assert guided.any() and res.refinement is not None and res.refinement.ok.mean() > 0.8
    assert correct[guided].mean() >= 0.95
    # detected right points, then the first run's guided ones, then all of the second's
    second_guided = len(res.second.points_right) - res.second.n_detected_right
    assert len(res.points_right) == res.n_detected_right + (res.passes == 1).sum() \
        + second_guided


def test_the_warp_outside_the_right_image_holds_its_median():
    img = texture(np.random.default_rng(6), 200)[:150, :200]
    to_aligned = np.array([[1.0, 0, 20], [0, 1, 10], [0, 0, 1]])
    warped, valid = u.warp_right(img, None, to_aligned, (200, 150), 4)
    inside = np.median(img[:140, :180])  # what the shift keeps in view
    assert (warped[:10] == inside).all() and (warped[:, :20] == inside).all()
    np.testing.assert_array_equal(warped[10:, 20:], img[:140, :180])
    assert not valid[:14].any() and valid[20:140, 30:190].all()


def test_the_aligned_frame_keeps_the_right_image_whatever_the_inliers_disparities():
    # right = S @ aligned with S a 3-degree rotation, scale 1.02 and a shift: the frame
    # lines up the rows and puts the right image's centre on the left one's column, so
    # false inliers far along their rows (stretched disparities) do not move the image
    rng = np.random.default_rng(7)
    size, right_size = (640, 480), (600, 450)
    A = cv2.getRotationMatrix2D((0.0, 0.0), 3.0, 1.02)
    A[:, 2] = (35.0, -12.0)
    S = np.vstack((A, (0.0, 0.0, 1.0)))
    left = rng.uniform((0, 0), size, (200, 2))
    aligned = left - np.c_[rng.uniform(10, 60, 200), np.zeros(200)]
    right = transform_points(aligned, S)

    def geometry(right_points):
        return u.EpipolarGeometry(fundamental=np.eye(3), left_points=left.astype(np.float32),
                                  right_points=right_points.astype(np.float32),
                                  inliers=np.ones(200, bool), median_error=0.1,
                                  source="sift")

    to_aligned = u.aligned_frame(geometry(right), size, right_size)
    false = right.copy()
    false[:20] = transform_points(aligned[:20] - np.c_[np.full(20, 250.0), np.zeros(20)], S)
    np.testing.assert_allclose(u.aligned_frame(geometry(false), size, right_size),
                               to_aligned, atol=1e-6)
    # rows lined up, and the whole right image kept in x (its centre on the left's)
    got = transform_points(right, to_aligned)
    np.testing.assert_allclose(got[:, 1], left[:, 1], atol=1e-6)
    centre = transform_points(np.array([[299.5, 224.5]]), to_aligned)[0]
    assert abs(centre[0] - 319.5) <= 0.5
    # S^-1's rotation and scale, and a whole-pixel x shift (the alignment fits rows only)
    np.testing.assert_allclose(to_aligned[:, :2], np.linalg.inv(S)[:, :2], atol=1e-9)
    assert to_aligned[0, 2] == np.round(to_aligned[0, 2])


def test_a_perturbed_middlebury_pair(shared_data):
    from hopmatch import datasets
    s = datasets.load("middlebury/art", root=shared_data)
    A = perturbation(s.image_size, 5.0, 30.0, 1.03)
    res = hopmatch.match_stereo(s.left, cv2.warpAffine(s.right, A, s.image_size),
                                rectified=False)
    t, known = perturbed_truth(res.matched_left, s.disparity, A)
    correct = known & (np.hypot(*(res.matched_right - t).T) <= 1)
    assert correct.sum() / known.sum() >= 0.96
    assert correct.sum() >= 1500  # the rectified pair with its range: 1979


@pytest.mark.parametrize("angle, dy, scale", [(5.0, 30.0, 1.03), (-5.0, -30.0, 0.97)])
def test_the_defaults_match_a_far_off_pair_as_unrectified(angle, dy, scale):
    """rectified=None (the default) finds the perturbed pair off its rows, says so, and
    matches it as rectified=False would; rectified=True keeps the rows (few matches, the
    old warning); a rectified pair is searched along its rows, silently."""
    from hopmatch.errors import HopmatchWarning, UnrectifiedPairWarning

    left, right, warped, gt, A = perturbed_box_pair(angle, dy, scale)
    with pytest.warns(UnrectifiedPairWarning, match="matched as an unrectified pair"):
        auto = hopmatch.match_stereo(left, warped)
    explicit = hopmatch.match_stereo(left, warped, rectified=False)
    assert auto.geometry is not None and auto.geometry.search == explicit.geometry.search
    np.testing.assert_array_equal(auto.matched_left, explicit.matched_left)
    np.testing.assert_array_equal(auto.matched_right, explicit.matched_right)
    assert auto.network.config.vertical_threshold == u.UNRECTIFIED_VERTICAL
    t, known = perturbed_truth(auto.matched_left, gt, A)
    correct = known & (np.hypot(*(auto.matched_right - t).T) <= 1)
    assert correct.sum() / known.sum() >= 0.97
    with pytest.warns(UnrectifiedPairWarning, match=r"rectified=False\)$"):
        rows = hopmatch.match_stereo(left, warped, rectified=True)
    assert rows.geometry is None and len(rows.query_idx) < 0.2 * len(auto.query_idx)
    with warnings.catch_warnings():
        warnings.simplefilter("error", HopmatchWarning)
        plain = hopmatch.match_stereo(left, right)
    assert plain.geometry is None and len(plain.query_idx) > 1000


@pytest.mark.parametrize("angle, dy", [(12.0, 60.0), (-12.0, -60.0)])
def test_the_defaults_match_a_pair_with_no_matches_on_its_rows_as_unrectified(angle, dy):
    """12 degrees and 60 px: too far off for the rectification check's window to see the
    pair off its rows, so the rows keep no match; the unrectified path, tried because they
    are so few, finds the geometry and is kept, with one warning that says so (and the
    few-matches warning of the rows is not given)."""
    from hopmatch.errors import UnrectifiedPairWarning

    left, _, warped, gt, A = perturbed_box_pair(angle, dy, 1.0)
    rows = hopmatch.match_stereo(left, warped, rectified=True)
    assert len(rows.query_idx) < 10
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        auto = hopmatch.match_stereo(left, warped)
    assert [w.category for w in caught] == [UnrectifiedPairWarning]
    # the first run's words (both_features: its matches are passes 0 and 1)
    assert str(caught[0].message).startswith(
        f"the pair kept {len(rows.query_idx)} matches along its rows and "
        f"{(auto.passes < 2).sum()} as an unrectified pair")
    explicit = hopmatch.match_stereo(left, warped, rectified=False)
    np.testing.assert_array_equal(auto.matched_right, explicit.matched_right)
    t, known = perturbed_truth(auto.matched_left, gt, A)
    correct = known & (np.hypot(*(auto.matched_right - t).T) <= 1)
    assert correct.sum() / known.sum() >= 0.97 and correct.sum() > 4000


def test_a_16_bit_pair_with_black_corners_is_matched_as_its_8_bit_twin():
    """The black corners of a rotated 16-bit view are found as padding (OpenCV's floodFill
    takes no 16-bit image: this raised cv2.error before) and the pair matched as the 8-bit
    one is."""
    left, _, warped, _, _ = perturbed_box_pair(5.0, 30.0, 1.03)
    assert warped[0, 0] == 0 and black_padding(warped).any()
    eight = hopmatch.match_stereo(left, warped, rectified=False)
    sixteen = hopmatch.match_stereo(left.astype(np.uint16) * 257,
                                    warped.astype(np.uint16) * 257, rectified=False)
    assert len(eight.query_idx) > 1000
    assert abs(len(sixteen.query_idx) - len(eight.query_idx)) < 0.05 * len(eight.query_idx)


def test_a_given_fundamental_matrix_lines_up_the_rows_as_an_estimated_one_does():
    """fundamental_matrix=F with no range: the rows lined up by the given F (kept as
    given, up to the check's power-of-two scale; source 'given'), then the network, the
    guided pass and the refinement on them, as rectified=False does with its own F; with
    a range, or an F the images do not agree with, the epipolar band of F as before
    (network only)."""
    left, _, warped, gt, A = perturbed_box_pair(2.0, 8.0, 1.0)
    F_rect = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    F = np.linalg.inv(np.vstack([A, [0.0, 0.0, 1.0]])).T @ F_rect
    with warnings.catch_warnings():
        warnings.simplefilter("error", hopmatch.errors.HopmatchWarning)
        res = hopmatch.match_stereo(left, warped, fundamental_matrix=F)
    assert res.geometry.source == "given" and res.geometry.search == "aligned"
    ratio = res.fundamental_matrix[1, 2] / F[1, 2]  # as checked: scaled by a power of 2
    assert ratio == 2.0 ** np.round(np.log2(ratio))
    np.testing.assert_array_equal(res.fundamental_matrix, F * ratio)
    assert res.geometry.n_inliers >= 30 and (res.passes == PASS_GUIDED).any()
    t, known = perturbed_truth(res.matched_left, gt, A)
    correct = known & (np.hypot(*(res.matched_right - t).T) <= 1)
    assert correct.sum() / known.sum() >= 0.97
    estimated = hopmatch.match_stereo(left, warped, rectified=False)
    t, known = perturbed_truth(estimated.matched_left, gt, A)
    assert correct.sum() >= 0.95 * (known & (np.hypot(*(estimated.matched_right - t).T)
                                             <= 1)).sum()
    band = hopmatch.match_stereo(left, warped, fundamental_matrix=F, max_disparity=40)
    assert band.geometry is None and set(np.unique(band.passes)) <= {0, 2}  # networks only
    assert len(band.query_idx) < len(res.query_idx)
    # an F of another pair (the right view turned the other way): few SIFT
    # correspondences agree with it, so its band is searched
    other = np.linalg.inv(np.vstack([u_perturbation(-6.0), [0.0, 0.0, 1.0]])).T @ F_rect
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        wrong = hopmatch.match_stereo(left, warped, fundamental_matrix=other)
    assert wrong.geometry is None


def u_perturbation(angle):
    return perturbation((480, 360), angle, 0.0, 1.0)


def test_the_fallback_keeps_only_a_side_by_side_geometry_with_more_matches(verged):
    """second_try.fallback_kept: a geometry, more than UNRECTIFIED_FALLBACK_GAIN times
    the matches along the rows, and a right image turned and scaled little."""
    import dataclasses

    from hopmatch.matching.geometry import alignment_turn

    _, _, _, res = verged
    degrees, scale = alignment_turn(res.geometry)
    assert abs(degrees) <= second_try.UNRECTIFIED_FALLBACK_TURN
    n = len(res.query_idx)
    assert second_try.fallback_kept(0, res) and second_try.fallback_kept(n // 3, res)
    assert not second_try.fallback_kept(math.ceil(n / second_try.UNRECTIFIED_FALLBACK_GAIN), res)
    assert not second_try.fallback_kept(0, dataclasses.replace(res, fundamental_matrix=None,
                                                      geometry=None))
    # the bootstrap's right points turned by 30 degrees about the origin: an object seen
    # turned in another scene, not the right view of a stereo pair
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    turned = (res.geometry.right_points.astype(np.float64) @ [[c, s], [-s, c]])
    geometry = dataclasses.replace(res.geometry, right_points=turned.astype(np.float32))
    assert abs(alignment_turn(geometry)[0]) > 25
    assert not second_try.fallback_kept(0, dataclasses.replace(res, geometry=geometry))


def test_a_second_try_as_unrectified_gives_its_warnings_only_when_kept(verged):
    """second_try.fallback_if_kept: the second try's warnings wait for the verdict and go
    with a try that is not kept; a try that exceeds a budget leaves the rows' match."""
    from hopmatch._warnings import warn
    from hopmatch.errors import BudgetExceededError

    _, _, _, res = verged

    def try_again():
        warn("from the second try", UserWarning)
        return res

    def over_budget():
        raise BudgetExceededError("the network would have too many neurons")

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert second_try.fallback_if_kept(len(res.query_idx), try_again) is None
        kept, pending = second_try.fallback_if_kept(0, try_again)
        assert second_try.fallback_if_kept(0, over_budget) is None
    assert caught == [] and kept is res and len(pending) == 1
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        pending[0]()
    assert [str(w.message) for w in caught] == ["from the second try"]


def test_a_second_try_over_a_budget_leaves_the_rows_match(monkeypatch):
    """The pair of test_the_defaults_match_a_pair_with_no_matches_on_its_rows_as_unrectified,
    its second try as an unrectified pair refused by a budget (a full-size pair): the
    defaults return what the rows kept rather than the budget's error."""
    from hopmatch.errors import BudgetExceededError
    from hopmatch.matching import stereo_match

    left, _, warped, _, _ = perturbed_box_pair(12.0, 60.0, 1.0)

    def over_budget(*args, **kwargs):
        raise BudgetExceededError("the network would have too many neurons")

    monkeypatch.setattr(stereo_match, "_match_unrectified", over_budget)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # few matches on the rows: what this test keeps
        rows = hopmatch.match_stereo(left, warped, rectified=True)
        auto = hopmatch.match_stereo(left, warped)
    assert auto.geometry is None
    np.testing.assert_array_equal(auto.matched_right, rows.matched_right)


def test_a_range_found_beyond_the_budget_is_narrowed_as_a_rectified_pairs_is():
    """rectified=False with no range: the range the coarse pass finds in the search frame
    (unrectified.network_range) holds more candidate pairs than max_neurons, so the network
    searches less of its widening around the coarse matches (disparity_range.run_in_range)
    and says so, where it refused the pair before; the matches are as good."""
    from hopmatch.errors import DisparityRangeWarning

    left, _, warped, gt, A = perturbed_box_pair(-2.0, -8.0, 0.98)
    one = {"rectified": False, "both_features": False}  # (the grey-level run exceeds it)
    plain = hopmatch.match_stereo(left, warped, **one)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        small = hopmatch.match_stereo(left, warped, max_neurons=30_000, **one)
    budget = [str(w.message) for w in caught if w.category is DisparityRangeWarning]
    assert len(budget) == 1 and "in its search frame" in budget[0]
    assert "of its widening around the coarse matches' range" in budget[0]
    wide, narrow = plain.network.config, small.network.config
    assert wide.min_disparity < narrow.min_disparity < narrow.max_disparity < wide.max_disparity
    t, known = perturbed_truth(small.matched_left, gt, A)
    correct = known & (np.hypot(*(small.matched_right - t).T) <= 1)
    assert correct.sum() / known.sum() >= 0.97
    assert len(small.query_idx) >= 0.9 * len(plain.query_idx)


@pytest.mark.parametrize("rectified", [True, False])
def test_a_match_made_again_through_a_tone_map_warns_of_its_range_once(rectified):
    """A right view of another exposure is matched again through the pair's tone map
    (docs/method.md 4.7), and both matches exceed max_neurons: only the match kept warns
    that its range was narrowed (the first one's warning used to be given too)."""
    from hopmatch.errors import DisparityRangeWarning

    left, right, warped, _, _ = perturbed_box_pair(-2.0, -8.0, 0.98)
    view = right if rectified else warped
    darker = np.clip(255 * (view / 255.0) ** 2.2, 0, 255).astype(np.uint8)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = hopmatch.match_stereo(left, darker, rectified=rectified, max_neurons=30_000,
                                    both_features=False)  # (grey levels exceed the budget)
    assert res.tone_map is not None and res.tone_map.used and len(res.query_idx) > 5000
    assert [w.category for w in caught] == [DisparityRangeWarning]


def test_the_defaults_keep_the_rows_when_told_a_range_or_the_paper():
    """A disparity range, a fundamental matrix or preset="paper" mean rows (or F): the
    far-off pair is not re-matched, only warned about."""
    from hopmatch.errors import UnrectifiedPairWarning

    left, _, warped, _, _ = perturbed_box_pair(5.0, 30.0, 1.03)
    for kwargs in ({"max_disparity": 24}, {"min_disparity": 0.0}):
        with pytest.warns(UnrectifiedPairWarning, match=r"rectified=False\)$"):
            res = hopmatch.match_stereo(left, warped, **kwargs)
        assert res.geometry is None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = hopmatch.match_stereo(left, warped, preset="paper")
    assert res.geometry is None
    assert not any("matched as an unrectified" in str(w.message) for w in caught)


def test_the_defaults_keep_the_rows_that_the_row_prior_follows():
    """2 degrees and 8 px: the residual vertical prior follows the rows (docs/method.md),
    the network keeps its matches, and nothing is re-matched."""
    left, _, warped, gt, A = perturbed_box_pair(-2.0, -8.0, 0.98)
    with warnings.catch_warnings():
        warnings.simplefilter("error", hopmatch.errors.UnrectifiedPairWarning)
        res = hopmatch.match_stereo(left, warped)
    assert res.geometry is None and res.network.row_prior is not None
    t, known = perturbed_truth(res.matched_left, gt, A)
    correct = known & (np.hypot(*(res.matched_right - t).T) <= 1)
    assert correct.sum() / known.sum() >= 0.97 and correct.sum() > 5000


def test_argument_errors():
    img = texture(np.random.default_rng(0), 100)
    with pytest.raises(InvalidArgumentError, match="fundamental_matrix"):
        hopmatch.match_stereo(img, img, rectified=False, fundamental_matrix=np.eye(3))
    with pytest.raises(InvalidArgumentError, match="max_disparity"):
        hopmatch.match_stereo(img, img, rectified=False, max_disparity=20)
    with pytest.raises(InvalidTypeError, match="rectified` must be None, True or False"):
        hopmatch.match_stereo(img, img, rectified="no")


def test_vertical_threshold_default_and_given(verged):
    left, right, _, res = verged
    assert res.network.config.vertical_threshold == u.UNRECTIFIED_VERTICAL
    given = hopmatch.match_stereo(left, right, rectified=False, vertical_threshold=1.0)
    assert given.network.config.vertical_threshold == 1.0


def test_mask_right_is_honoured(verged):
    left, right, _, _ = verged
    mask = np.zeros(right.shape, np.uint8)
    mask[:, : SIZE[0] // 2] = 255
    res = hopmatch.match_stereo(left, right, rectified=False, mask_right=mask)
    assert len(res.points_right) and (res.points_right[:, 0] < SIZE[0] // 2 + 1).all()


def test_the_aligned_pair_is_equalised_and_says_so(verged):
    """The right view blurred by 1.5 px: after its warp the left one is blurred towards it
    (hopmatch.feature.sharpness, over the aligned image's valid pixels), and the result
    says so; with sharpness_ratio=None nothing is blurred."""
    left, right, _, _ = verged
    soft = cv2.GaussianBlur(right, (0, 0), 1.5)
    res = hopmatch.match_stereo(left, soft, rectified=False)
    assert res.sharpness.sigma_left > 0.5 and res.sharpness.sigma_right == 0.0
    assert res.sharpness.sharpness_left > res.sharpness.sharpness_right
    off = hopmatch.match_stereo(left, soft, rectified=False, sharpness_ratio=None)
    assert off.sharpness.sigma_left == off.sharpness.sigma_right == 0.0


def test_the_aligned_pair_reads_a_tone_map_and_matches_again_through_it(verged):
    """The right view through a steep response curve: the map read off the aligned pair's
    network matches calls for a second match (recorded); the plain pair's does not, and
    its matches are those with both tolerances None."""
    left, right, F, res = verged
    assert res.tone_map is not None and res.tone_map.nonlinearity < 0.04
    off = hopmatch.match_stereo(left, right, rectified=False, tone_tolerance=None,
                                gain_field_tolerance=None)
    assert off.tone_map is None
    np.testing.assert_array_equal(off.matched_right, res.matched_right)
    curved = np.clip(255.0 * (right / 255.0) ** 2.2, 0, 255).astype(np.uint8)
    again = hopmatch.match_stereo(left, curved, rectified=False)
    assert again.tone_map is not None and again.tone_map.nonlinearity > 0.04
    assert again.tone_map.used  # the second match found more pairs
    err = symmetric_epipolar_error(F, again.matched_left, again.matched_right)
    assert len(again.query_idx) > 1000 and np.mean(err <= 1.0) > 0.97


def test_the_refinement_window_follows_the_given_images_not_the_canvas(monkeypatch):
    # the aligned pair is refined in a canvas wider than the images by the range's shift;
    # the window is that of the left image's size (stereo_match.refine_radius)
    from hopmatch.matching import stereo_match

    shapes = []

    def spy(shape):
        shapes.append(tuple(int(v) for v in shape))
        return 3

    monkeypatch.setattr(stereo_match, "refine_radius", spy)
    left, _, warped, _, _ = perturbed_box_pair(5.0, 30.0, 1.03)
    res = hopmatch.match_stereo(left, warped, rectified=False)
    assert res.geometry.search == "aligned" and res.refinement is not None
    assert shapes == [left.shape[:2]] * 2  # each run of both_features


def test_the_defaults_match_views_of_two_heights_as_an_unrectified_pair():
    """Rows of two heights (the right view less its top 6 rows) are no rectified pair:
    with no range given the pair is matched as rectified=False, with a warning that says
    why, and the matches are right (6 px lower in the left view); with a range, as
    before, an error."""
    from synthetic_pairs import texture

    from hopmatch.errors import UnrectifiedPairWarning

    scene = texture(200, 280, seed=5, sigma=1.3).astype(np.uint8)
    left, right = scene[10:190, 10:260], scene[16:190, 16:266]  # d = 6, yr = yl - 6
    with pytest.warns(UnrectifiedPairWarning, match="180 rows and `right` 174"):
        res = hopmatch.match_stereo(left, right)
    assert res.fundamental_matrix is not None and len(res.query_idx) > 200
    off = res.matched_left - res.matched_right
    assert np.mean(np.hypot(off[:, 0] - 6.0, off[:, 1] - 6.0) <= 1.0) > 0.97
    with pytest.raises(InvalidArgumentError, match="same height"):
        hopmatch.match_stereo(left, right, max_disparity=16)


def test_row_drift_reads_a_disparity_term_and_not_a_plane_or_outliers():
    """unrectified.row_drift: the part of dy that grows with the disparity beyond a plane in
    the position, robust to a few gross outliers; nothing for a slanted surface (the
    disparity itself a plane) or a dy that is a plane."""
    rng = np.random.default_rng(3)
    pts = rng.uniform(0, 400, (500, 2))
    d = 20 + 0.05 * pts[:, 0] + rng.uniform(0, 40, 500)  # depth beyond a plane
    rd = d - np.c_[np.ones(500), pts] @ np.linalg.lstsq(np.c_[np.ones(500), pts], d,
                                                        rcond=None)[0]
    span = np.subtract(*np.percentile(rd, [95, 5]))
    plane = 0.3 + 0.002 * pts[:, 0] - 0.001 * pts[:, 1]
    noise = rng.normal(0, 0.1, 500)
    drift = u.row_drift(pts, d, plane + 0.03 * d + noise)
    assert abs(drift - 0.03 * span) < 0.1 * 0.03 * span
    outliers = plane + noise
    outliers[:6] += 40 * np.sign(rd[:6])  # 1 % of wrong correspondences, all one way
    assert abs(u.row_drift(pts, d, outliers)) < 0.1
    assert abs(u.row_drift(pts, 10 + 0.1 * pts[:, 0], plane + noise)) < 1e-6


def test_a_pair_whose_left_view_is_turned_is_searched_on_rectified_rows(shared_data):
    """The left view turned 3 degrees (not the right one): the right image aligned by a
    similarity leaves rows whose offset grows with the disparity (d sin 3 deg), so the
    pair is searched on the rows of a rectification of both views, and the matches are
    right (before 2026-12-05, on the aligned rows: 4,395 correct at 0.946 on motorcycle)."""
    from hopmatch import datasets

    s = datasets.load("middlebury2006/midd2", root=shared_data)
    A = perturbation(s.image_size, 3.0, 0.0, 1.0)
    turned = cv2.warpAffine(s.left, A, s.image_size, flags=cv2.INTER_LINEAR,
                            borderMode=cv2.BORDER_REFLECT)
    res = hopmatch.match_stereo(turned, s.right, rectified=False)
    assert res.geometry.search == "rectified"
    back = cv2.transform(res.matched_left[None].astype(np.float64),
                         cv2.invertAffineTransform(A))[0]
    xi = np.clip(np.round(back[:, 0]).astype(int), 0, s.image_size[0] - 1)
    yi = np.clip(np.round(back[:, 1]).astype(int), 0, s.image_size[1] - 1)
    gt = s.disparity[yi, xi]
    known = np.isfinite(gt)
    err = np.hypot(back[:, 0] - gt - res.matched_right[:, 0], back[:, 1]
                   - res.matched_right[:, 1])
    assert known.sum() > 800 and np.mean(err[known] <= 1.0) > 0.95


def _wide_pair(width, height=24, shift=5):
    rng = np.random.default_rng(11)
    img = cv2.GaussianBlur(rng.uniform(0, 255, (height, width)).astype(np.float32), (0, 0),
                           1.2).astype(np.uint8)
    return img, np.ascontiguousarray(np.roll(img, -shift, axis=1))


def test_a_pair_too_wide_for_opencvs_warps_is_refused_unrectified_and_searched_on_rows():
    """OpenCV's warps take images of fewer than 32767 px a side (SHRT_MAX): before
    2026-12-06 ``rectified=False`` on a 40 x 40000 pair leaked cv2.error from
    cv2.warpAffine. Now it is refused before any work, naming the image; the defaults
    (``rectified=None``) and a given F search the rows (or F's band) and never warp."""
    left, right = _wide_pair(u.WARP_LIMIT)
    small = left[:, :200].copy()
    for args, name in (((left, right), "left"), ((small, right), "right")):
        t0 = time.perf_counter()
        with pytest.raises(InvalidArgumentError, match=rf"`{name}` is \d+ x 24 px.*OpenCV's "
                                                       r"warps.*at most 32766 px a side"):
            hopmatch.match_stereo(*args, rectified=False)
        assert time.perf_counter() - t0 < 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", hopmatch.errors.HopmatchWarning)
        rows = hopmatch.match_stereo(left, right)
        band = hopmatch.match_stereo(left, right, fundamental_matrix=np.array(
            [[0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]))
    for result in (rows, band):
        assert len(result.matches) > 1000
        assert np.median(result.disparities) == pytest.approx(5.0, abs=0.05)
    assert u.warpable((24, u.WARP_LIMIT - 1), (u.WARP_LIMIT - 1, 3))
    assert not u.warpable((24, 100), (u.WARP_LIMIT, 3))
    assert u.warpable(())  # not an image: left to the image validation


def test_the_canvas_holds_every_mapped_corner():
    """canvas: the box of a frame's corners under each map, moved to (0, 0) by T; its
    size is what search_frame checks against OpenCV's warp limit."""
    H1 = np.array([[1.0, 0.05, -30.0], [0.0, 1.0, 12.0], [0.0, 0.0, 1.0]])
    H2 = np.array([[0.97, 0.0, 40.0], [0.02, 1.0, -7.0], [1e-5, 0.0, 1.0]])
    T, (cw, ch) = u.canvas((H1, H2), (300, 200))
    corners = np.array([[0, 0], [299, 0], [0, 199], [299, 199]], np.float64)
    placed = np.concatenate([transform_points(corners, T @ H) for H in (H1, H2)])
    assert placed.min() >= 0.0 and placed.min(axis=0).max() < 1.0
    assert (placed[:, 0] <= cw - 1).all() and (placed[:, 1] <= ch - 1).all()
    assert placed[:, 0].max() > cw - 2 and placed[:, 1].max() > ch - 2
