"""hopmatch.matching.geometry: F from the pair itself, and refusing an F it does not support."""

from __future__ import annotations

import warnings

import cv2
import numpy as np
import pytest
from unrect_scene import SIZE, fundamental, plane_correspondences, render_pair

import hopmatch
from hopmatch.errors import HopmatchWarning, PairInfoError
from hopmatch.matching.geometry import (
    GeometryWarning,
    chance_inliers,
    epipolar_band,
    estimate_geometry,
    quasi_euclidean_homographies,
    ratio_pairs,
    rectifying_homographies,
    robust_fundamental,
    row_alignment,
    symmetric_epipolar_error,
    transform_points,
)

RECTIFIED_F = np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0.0]])


@pytest.fixture(scope="module")
def pair():
    return render_pair()


def test_the_synthetic_rig_is_consistent():
    left, right = plane_correspondences()
    assert len(left) > 200
    from unrect_scene import fundamental
    assert symmetric_epipolar_error(fundamental(), left, right).max() < 1e-6


def test_geometry_recovered_on_a_synthetic_pair_from_a_known_f(pair):
    left, right, F = pair
    g = estimate_geometry(left, right)
    assert g.fundamental is not None and g.reason is None
    assert g.n_inliers >= 100 and g.inlier_ratio > 0.5
    true_l, true_r = plane_correspondences()
    err = symmetric_epipolar_error(g.fundamental, true_l, true_r)
    assert err.mean() < 0.5 and np.percentile(err, 95) < 0.5


def test_epipolar_band_matches_a_point_by_point_reference():
    rng = np.random.default_rng(5)
    F = fundamental()
    left = rng.uniform(0, 400, (60, 2))
    right = np.concatenate([rng.uniform(0, 400, (40, 2)), plane_correspondences()[1][:30]])
    band = 6.0
    got = epipolar_band(F, left, right, band)
    assert got.shape == (60, 70) and got.dtype == np.uint8
    want = np.zeros((60, 70), np.uint8)
    for n, (xl, yl) in enumerate(left):
        for m, (xr, yr) in enumerate(right):
            a, b, c = F @ [xl, yl, 1.0]  # the right image's line of the left point
            d_right = abs(a * xr + b * yr + c) / np.hypot(a, b)
            a, b, c = F.T @ [xr, yr, 1.0]  # the left image's line of the right point
            d_left = abs(a * xl + b * yl + c) / np.hypot(a, b)
            want[n, m] = d_right <= band and d_left <= band
    assert (got == want).all() and 0 < want.sum() < want.size


@pytest.mark.parametrize("masked", [False, True])
def test_ratio_pairs_are_mutual_clear_nearest_neighbours_within_the_mask(masked):
    rng = np.random.default_rng(6)
    da = rng.normal(size=(80, 16)).astype(np.float32)
    db = np.concatenate([da[:50] + 0.05 * rng.normal(size=(50, 16)),
                         rng.normal(size=(40, 16))]).astype(np.float32)
    mask = (rng.uniform(size=(80, 90)) < 0.5).astype(np.uint8) if masked else None
    qi, ti = ratio_pairs(da, db, 0.8, mask)
    dist = np.linalg.norm(da[:, None, :].astype(np.float64) - db[None], axis=2)
    if mask is not None:
        dist[mask == 0] = np.inf
    want = []
    for n in range(80):
        order = np.argsort(dist[n])
        best, second = dist[n, order[0]], dist[n, order[1]]
        if np.isfinite(best) and best < 0.8 * second and np.argmin(dist[:, order[0]]) == n:
            want.append((n, int(order[0])))
    assert sorted(zip(qi.tolist(), ti.tolist())) == want
    assert len(want) >= 10


def box_pair(rng):
    """A rectified pair of a plane at disparity 6 and a nearer box at 14: the right image
    is ``right(x, y) = left(x + d(x, y), y)``, ``d`` given on the right image's grid."""
    from unrect_scene import texture
    left = texture(rng, 420)[:300, :400]
    d = np.full(left.shape, 6.0, np.float32)
    d[80:220, 120:280] = 14.0
    ys, xs = np.mgrid[0:300, 0:400].astype(np.float32)
    return left, cv2.remap(left, xs + d, ys, cv2.INTER_LINEAR), d


@pytest.mark.parametrize("angle, dy, scale", [(5.0, 30.0, 1.03), (-3.0, -12.0, 0.97)])
def test_geometry_recovered_on_a_perturbed_rectified_pair(angle, dy, scale):
    from unrect_scene import perturbation
    rng = np.random.default_rng(3)
    left, right, d = box_pair(rng)
    A = perturbation((400, 300), angle, dy, scale)
    g = estimate_geometry(left, cv2.warpAffine(right, A, (400, 300), flags=cv2.INTER_LINEAR))
    assert g.fundamental is not None
    x, y = rng.uniform(40, 360, 500), rng.uniform(40, 260, 500)
    disp = d[y.astype(int), x.astype(int)]
    true_l = np.c_[x + disp, y]
    true_r = np.c_[x, y, np.ones(len(x))] @ A.T
    err = symmetric_epipolar_error(g.fundamental, true_l, true_r)
    assert np.median(err) < 0.5 and err.mean() < 0.5


def test_row_alignment_recovers_a_similarity():
    rng = np.random.default_rng(0)
    left = rng.uniform(0, 400, (300, 2))
    d = rng.uniform(5, 40, 300)
    A = cv2.getRotationMatrix2D((200, 150), 4.0, 1.02)
    A[1, 2] += 17
    right = np.c_[left[:, 0] - d, left[:, 1], np.ones(300)] @ A.T
    from hopmatch.matching.geometry import EpipolarGeometry
    g = EpipolarGeometry(np.eye(3), left.astype(np.float32), right.astype(np.float32),
                         np.ones(300, bool), 0.0, "test")
    S = row_alignment(g)
    aligned = transform_points(right, np.linalg.inv(S))
    np.testing.assert_allclose(aligned[:, 1], left[:, 1], atol=1e-3)


def test_rectifying_homographies_stay_near_the_identity_on_a_rectified_pair():
    rng = np.random.default_rng(1)
    left = rng.uniform(0, 400, (200, 2))
    right = left - np.c_[rng.uniform(5, 30, 200), np.zeros(200)]
    H1, H2 = rectifying_homographies(RECTIFIED_F, left, right, (400, 300))
    for H, pts in ((H1, left), (H2, right)):
        moved = np.hypot(*(transform_points(pts, H) - pts).T)
        assert moved.max() < 1.0


@pytest.mark.parametrize("flip", [(1, 1), (-1, 1), (1, -1), (-1, -1)])
def test_rectifying_homographies_are_scaled_to_a_positive_w(monkeypatch, flip):
    """OpenCV may give a rectifying homography with a negative scale (w < 0 at every point
    of the image: the same map). rectifying_homographies returns each map scaled so that
    w > 0 at the image's centre, the same map whatever the sign OpenCV chose, so that
    near_identity judges the map and not its scale (the verged chessboard photos of
    OpenCV's samples came with w < 0 and were searched in the slower epipolar band)."""
    left, right = plane_correspondences()
    F = fundamental()
    reference = rectifying_homographies(F, left, right, SIZE)
    original = cv2.stereoRectifyUncalibrated

    def flipped(*args, **kwargs):
        ok, H1, H2 = original(*args, **kwargs)
        return ok, flip[0] * H1, flip[1] * H2

    monkeypatch.setattr(cv2, "stereoRectifyUncalibrated", flipped)
    H1, H2 = rectifying_homographies(F, left, right, SIZE)
    centre = np.array([(SIZE[0] - 1) / 2, (SIZE[1] - 1) / 2, 1.0])
    for H, ref in zip((H1, H2), reference):
        assert (H @ centre)[2] > 0
        np.testing.assert_allclose(H, ref, rtol=1e-12, atol=1e-12)


def rotated_rig(angles_left, angles_right, focal=500.0, size=(480, 360), n=300, seed=3):
    """``(left, right)`` projections of ``n`` random points 2-8 m away seen by two cameras
    with one intrinsic matrix (focal length ``focal``, principal point at the image's
    centre) 0.1 m apart along x and turned by the Rodrigues vectors ``angles_left``,
    ``angles_right`` (radians): the model of quasi-Euclidean rectification, exactly."""
    rng = np.random.default_rng(seed)
    w, h = size
    K = np.array([[focal, 0.0, (w - 1) / 2], [0.0, focal, (h - 1) / 2], [0.0, 0.0, 1.0]])
    z = rng.uniform(2.0, 8.0, n)
    xyz = np.c_[rng.uniform(-0.3, 0.3, (n, 2)) * z[:, None], z]
    out = []
    for angles, centre in ((angles_left, np.zeros(3)), (angles_right, np.array([0.1, 0, 0]))):
        R = cv2.Rodrigues(np.asarray(angles, np.float64))[0]
        p = (xyz - centre) @ R.T @ K.T
        out.append(p[:, :2] / p[:, 2:])
    return out[0], out[1]


@pytest.mark.parametrize("angles_left, angles_right", [
    ((0.0, 0.0, 0.0), (0.0, np.radians(3.0), 0.0)),          # verged right camera
    ((0.0, np.radians(-2.0), np.radians(1.0)),
     (np.radians(0.5), np.radians(2.0), np.radians(-2.0))),  # both turned and rolled
])
def test_quasi_euclidean_homographies_rectify_a_rig_of_turned_cameras(angles_left,
                                                                      angles_right):
    """Two cameras with one centred intrinsic matrix, turned about any axes: the maps
    K R K^-1 put every correspondence on one row (to 1e-3 px) and move the image by
    little more than the turn itself (a 3 degree verge at f = 500 px is 26 px)."""
    left, right = rotated_rig(angles_left, angles_right)
    H1, H2 = quasi_euclidean_homographies(left, right, (480, 360))
    rl, rr = transform_points(left, H1), transform_points(right, H2)
    assert np.abs(rl[:, 1].astype(np.float64) - rr[:, 1]).max() < 1e-3
    corners = np.array([[0, 0], [479, 0], [0, 359], [479, 359]], np.float64)
    for H in (H1, H2):
        assert np.hypot(*(transform_points(corners, H) - corners).T).max() < 60.0


def test_quasi_euclidean_homographies_keep_a_rectified_pair_as_it_is():
    """Correspondences already on their rows: maps that move no point by more than a
    hundredth of a pixel."""
    left, right = rotated_rig((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    H1, H2 = quasi_euclidean_homographies(left, right, (480, 360))
    for H, pts in ((H1, left), (H2, right)):
        assert np.hypot(*(transform_points(pts, H) - pts).T).max() < 1e-2


def test_quasi_euclidean_homographies_need_eight_correspondences():
    left, right = rotated_rig((0.0, 0.0, 0.0), (0.0, 0.05, 0.0), n=7)
    assert quasi_euclidean_homographies(left, right, (480, 360)) is None


def test_shuffled_correspondences_are_refused():
    left, right = plane_correspondences()
    perm = np.random.default_rng(0).permutation(len(right))
    g = robust_fundamental(left, right[perm])
    assert g.fundamental is None
    assert "agree on a fundamental matrix" in g.reason
    assert chance_inliers(left, right, 1.0) < 0.5 * len(left)


def test_too_few_correspondences_are_refused():
    g = robust_fundamental(np.zeros((5, 2)), np.zeros((5, 2)))
    assert g.fundamental is None and "only 5 bootstrap correspondences" in g.reason


def _warned_empty(left, right):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = hopmatch.match_stereo(left, right, rectified=False)
    kinds = [w.category for w in caught]
    assert GeometryWarning in kinds and issubclass(GeometryWarning, HopmatchWarning)
    assert len(res.query_idx) == 0 and len(res.matches) == 0
    assert res.fundamental_matrix is None and res.geometry.reason
    return res, next(w for w in caught if w.category is GeometryWarning)


def test_a_pair_without_texture_gives_an_empty_result_and_says_why():
    flat = np.full((240, 320), 128, np.uint8)
    _, w = _warned_empty(flat, flat)
    assert "no epipolar geometry" in str(w.message) and w.filename == __file__


def test_two_unrelated_images_give_an_empty_result_and_say_why():
    from unrect_scene import texture
    rng = np.random.default_rng(7)
    a, b = texture(rng, 360)[:240, :320], texture(rng, 360)[:240, :320]
    _, w = _warned_empty(a, b)
    assert "show the same scene" in str(w.message)


def test_the_matcher_refuses_the_f_of_two_unrelated_images():
    """The descriptor bootstrap finds many correspondences there (the best look-alike of
    each point), which a fundamental matrix fits no better than shuffled ones."""
    from unrect_scene import texture
    rng = np.random.default_rng(8)
    det = hopmatch.DericheMoravecDetector.create()
    kl, dl = det.detectAndCompute(texture(rng, 360)[:240, :320], None)
    kr, dr = det.detectAndCompute(texture(rng, 360)[:240, :320], None)
    m = hopmatch.HopfieldMatcher.create()
    m.setPairInfo(kl, kr, (320, 240), (320, 240))
    with pytest.warns(GeometryWarning, match="show the same scene"):
        g = m.estimateFundamentalMatrix(dl, dr)
    assert g.fundamental is None and g.n_correspondences >= 30
    assert m.getFundamentalMatrix() is None


def test_matcher_estimates_and_sets_f(pair):
    left, right, F = pair
    det = hopmatch.DericheMoravecDetector.create()
    kl, dl = det.detectAndCompute(left, None)
    kr, dr = det.detectAndCompute(right, None)
    m = hopmatch.HopfieldMatcher.create()
    with pytest.raises(PairInfoError, match="setPairInfo"):
        m.estimateFundamentalMatrix(dl, dr)
    m.setPairInfo(kl, kr, SIZE, SIZE)
    g = m.estimateFundamentalMatrix(dl, dr)
    assert g.fundamental is not None and g.source == "descriptors"
    np.testing.assert_array_equal(m.getFundamentalMatrix(), g.fundamental)
    true_l, true_r = plane_correspondences()
    assert np.median(symmetric_epipolar_error(g.fundamental, true_l, true_r)) < 0.5
    matches = m.match(dl, dr)
    pl = cv2.KeyPoint_convert(kl)[[x.queryIdx for x in matches]]
    pr = cv2.KeyPoint_convert(kr)[[x.trainIdx for x in matches]]
    assert len(matches) > 200
    assert np.mean(symmetric_epipolar_error(F, pl, pr) <= 1.0) > 0.95


def test_matcher_without_geometry_warns_and_keeps_its_f():
    flat = np.full((120, 160), 90, np.float32)
    m = hopmatch.HopfieldMatcher.create()
    pts = np.array([[20.0, 20.0], [60, 40]], np.float32)
    m.setPairInfo(pts, pts, (160, 120), (160, 120))
    m.setFundamentalMatrix(RECTIFIED_F)
    desc = np.zeros((2, 81), np.float32)
    with pytest.warns(GeometryWarning, match="unchanged"):
        g = m.estimateFundamentalMatrix(desc, desc)
    assert g.fundamental is None
    np.testing.assert_array_equal(m.getFundamentalMatrix(), RECTIFIED_F / 1.0)
    assert flat.size  # the image itself is never needed
