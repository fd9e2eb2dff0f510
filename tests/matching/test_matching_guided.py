"""The guided second pass: its kernels against NumPy references, its acceptance tests,
and what match_stereo returns with it."""

from __future__ import annotations

import cv2
import naive_guided as ng
import numpy as np
import pytest

import hopmatch
from hopmatch._kernels import guided as _k
from hopmatch.feature.descriptor import gradient_windows
from hopmatch.matching.guided import (
    GUIDED_GRADIENT_LIMIT,
    GUIDED_MIN_ZNCC,
    GUIDED_PLANE_INLIER,
    GUIDED_PLANE_MIN,
    GUIDED_RADIUS,
    guided_pass,
    guided_rounds,
)
from hopmatch.matching.params import matcher_config
from hopmatch.matching.similarity import similarity_distance
from hopmatch.matching.stereo_match import PASS_GUIDED, PASS_NETWORK

RNG = np.random.default_rng(7)


def texture(h, w, seed=0, sigma=1.5):
    """A smooth random texture (float32, 20..220)."""
    rng = np.random.default_rng(seed)
    t = cv2.GaussianBlur(rng.normal(size=(h, w)), (0, 0), sigma)
    return ((t - t.min()) / (t.max() - t.min()) * 200 + 20).astype(np.float32)


def test_query_neighbours_match_the_reference():
    queries = RNG.uniform(0, 100, (60, 2)).astype(np.float32)
    matched = RNG.uniform(0, 100, (200, 2)).astype(np.float32)
    off, idx = _k.query_neighbours(queries, matched, np.float32(20), np.float32(10))
    ref = ng.neighbours(queries, matched, 20, 10)
    for q in range(len(queries)):
        got = idx[off[q]:off[q + 1]].tolist()
        assert len(got) == len(set(got)) and set(got) == ref[q]


def test_neighbour_medians_are_np_median():
    off = np.array([0, 0, 1, 3, 7], np.int64)
    idx = np.array([4, 0, 1, 2, 3, 5, 6], np.int32)
    values = RNG.normal(size=7)
    med = _k.neighbour_medians(off, idx, values)
    assert np.isnan(med[0])
    for q in range(1, 4):
        assert med[q] == np.median(values[idx[off[q]:off[q + 1]]])


def _search_case(seed=3, shift=7.3):
    g_l = texture(80, 120, seed)
    x = np.arange(120, dtype=np.float64)
    # right(x) = left(x + shift): disparity `shift` everywhere (bilinear-exact warp of a
    # smooth texture is close enough for the search; the refinement test is exact)
    g_r = cv2.remap(g_l, (x[None, :] + shift).astype(np.float32).repeat(80, 0),
                    np.arange(80, dtype=np.float32)[:, None].repeat(120, 1), cv2.INTER_CUBIC)
    pts = np.c_[RNG.uniform(25, 95, 40), RNG.uniform(15, 65, 40)].astype(np.float32)
    desc = gradient_windows(g_l, pts, 9)
    return g_l, g_r, pts, desc


def test_row_search_matches_the_reference():
    g_l, g_r, pts, desc = _search_case()
    q = np.arange(len(pts), dtype=np.int64)
    centre = pts[:, 0].astype(np.float64) - 7.3 + RNG.uniform(-2.5, 2.5, len(pts))
    yoff = RNG.uniform(-0.4, 0.4, len(pts))
    status, best, second, xr, sim = _k.row_search(g_l, g_r, pts, desc, q, centre, yoff, 2.0,
                                                  4, 1, 0.5, 0.05, 1e-6)
    found = 0
    for m in range(len(pts)):
        ok, b, s2, x, si = ng.row_search_one(g_l, g_r, float(pts[m, 0]), float(pts[m, 1]),
                                             desc[m], centre[m], yoff[m], 2.0, 4, 1, 0.5,
                                             0.05)
        assert (status[m] == _k.FOUND) == ok, m
        assert best[m] == pytest.approx(b, abs=1e-6)
        assert second[m] == pytest.approx(s2, abs=1e-6)
        if ok:
            found += 1
            assert xr[m] == pytest.approx(x, abs=1e-4)
            assert sim[m] == pytest.approx(si, abs=1e-6)
    assert found > len(pts) // 2  # the case exercises the found branch


def test_continuity_field_matches_the_reference():
    ml = RNG.uniform(0, 60, (30, 2)).astype(np.float32)
    mr = (ml - np.float32([8, 0.2]) + RNG.normal(0, 0.5, (30, 2))).astype(np.float32)
    msim = RNG.uniform(0, 0.5, 30)
    pq = RNG.uniform(0, 60, (5, 2)).astype(np.float32)
    xr = pq[:, 0] - 8.0 + RNG.normal(0, 1, 5)
    yr = pq[:, 1] - 0.2
    sim = RNG.uniform(0, 0.5, 5)
    off, idx = _k.query_neighbours(pq, ml, np.float32(20), np.float32(10))
    zero = np.zeros(5)
    u = _k.continuity_field(pq, xr, yr, sim, off, idx, np.arange(5), ml, mr, msim, 2.0, 2.0,
                            1.0, -2.5, zero, zero)
    gx, gy = RNG.uniform(-0.5, 0.5, 5), RNG.uniform(-0.5, 0.5, 5)
    ug = _k.continuity_field(pq, xr, yr, sim, off, idx, np.arange(5), ml, mr, msim, 2.0,
                             2.0, 1.0, -2.5, gx, gy)
    for q in range(5):
        j = idx[off[q]:off[q + 1]]
        args = ((float(pq[q, 0]), float(pq[q, 1])), (xr[q], yr[q]), sim[q],
                ml[j].astype(np.float64), mr[j].astype(np.float64), msim[j], 2.0, 2.0, 1.0,
                -2.5)
        assert u[q] == pytest.approx(ng.field(*args), abs=1e-9)
        assert ug[q] == pytest.approx(ng.field(*args, gradient=(gx[q], gy[q])), abs=1e-9)


def test_neighbour_planes_match_the_reference():
    """Queries on a slanted plane (some neighbours off it, some with too few inliers or
    collinear ones): the kernel's prediction and gradient equal the reference's."""
    matched = RNG.uniform(0, 100, (300, 2)).astype(np.float32)
    disp = 10.0 + 0.3 * matched[:, 0] - 0.2 * matched[:, 1] + RNG.normal(0, 0.2, 300)
    disp[::7] += 15.0  # a second surface: outliers of the plane
    queries = np.r_[RNG.uniform(10, 90, (40, 2)), [[50.0, 50.0]]].astype(np.float32)
    off, idx = _k.query_neighbours(queries, matched, np.float32(20), np.float32(10))
    # the last query: three collinear neighbours only (degenerate: the median)
    line = np.array([[45, 50], [50, 50], [55, 50]], np.float32)
    idx = np.r_[idx[:off[-2]], len(matched) + np.arange(3)].astype(np.int32)
    off = off.copy()
    off[-1] = off[-2] + 3
    matched = np.r_[matched, line]
    disp = np.r_[disp, [20.0, 21.0, 22.0]]
    pred, gx, gy = _k.neighbour_planes(queries, off, idx, matched, disp, 2.0, 3)
    planes = 0
    for q in range(len(queries)):
        j = idx[off[q]:off[q + 1]]
        a, bx, by = ng.local_plane(queries[q], matched[j], disp[j], 2.0, 3)
        assert pred[q] == pytest.approx(a, abs=1e-6), q
        assert gx[q] == pytest.approx(bx, abs=1e-6) and gy[q] == pytest.approx(by, abs=1e-6)
        planes += bx != 0.0
    assert planes > len(queries) // 2 and gx[-1] == 0.0 and pred[-1] == 21.0


def _scene(shift=6, noise=0.0):
    """A textured plane at disparity ``shift``; ``noise``: standard deviation of the noise
    added to the right image (the network then leaves points for the guided pass)."""
    img = texture(160, 220, seed=11, sigma=1.2)
    left = np.clip(img, 0, 255).astype(np.uint8)
    noisy = np.roll(img, -shift, axis=1) + np.random.default_rng(0).normal(0, noise, img.shape)
    return left, np.clip(noisy, 0, 255).astype(np.uint8)


def test_guided_matches_pass_every_acceptance_test():
    """Each guided match passes the tests it is accepted on, recomputed by the references:
    found by the search (peak near the prediction, ZNCC and margin, back search) and a
    positive field against its matched neighbours."""
    left, right = _scene()
    det = hopmatch.DericheMoravecDetector()
    pl, _, dl, gl = det.detect_and_describe(left)
    pr, _, dr, gr = det.detect_and_describe(right)
    res = hopmatch.match_stereo(left, right, max_disparity=12, guided=False, refine=False)
    net = res.network
    config = net.config
    # the network matches almost every point of this clean pair: leave half of its
    # matches out, so that the guided pass has points to propagate to
    qi, ti = net.query_idx[::2], net.train_idx[::2]
    yoff = np.full(len(pl), 0.0)
    gm = guided_pass(pl, pr, dl, dr, gl, gr, qi, ti, yoff, config, margin=0.1)
    assert len(gm.query_idx) > len(qi) // 4
    assert not np.isin(gm.query_idx, qi).any()  # only unmatched left points
    # the search's parabola on the gradient windows is within a third of a pixel; the
    # refinement (test_matching_refine.py) does better
    np.testing.assert_allclose(pl[gm.query_idx, 0] - gm.right_points[:, 0], 6.0, atol=0.3)
    ml, mr = pl[qi], pr[ti]
    msim = similarity_distance(dl, dr, qi.astype(np.int64), ti.astype(np.int64),
                               gain_tolerance=config.gain_tolerance)
    disp = ml[:, 0].astype(np.float64) - mr[:, 0]
    nb = ng.neighbours(pl[gm.query_idx], ml, config.neighbour_width / 2,
                       config.neighbour_height / 2)
    for m, i in enumerate(gm.query_idx):
        j = np.array(sorted(nb[m]))
        assert len(j) >= 3
        pred, gx, gy = ng.local_plane(pl[i], ml[j], disp[j], GUIDED_PLANE_INLIER,
                                      GUIDED_PLANE_MIN)
        grad = tuple(float(np.clip(g, -GUIDED_GRADIENT_LIMIT, GUIDED_GRADIENT_LIMIT))
                     for g in (gx, gy))
        centre = float(pl[i, 0]) - pred
        ok, best, second, xr, sim = ng.row_search_one(
            gl, gr, float(pl[i, 0]), float(pl[i, 1]), dl[i], centre, 0.0, GUIDED_RADIUS, 3,
            1, GUIDED_MIN_ZNCC, 0.1)
        assert ok, m
        assert gm.right_points[m, 0] == pytest.approx(xr, abs=1e-4)
        assert best >= GUIDED_MIN_ZNCC and best - second >= 0.1
        u = ng.field((float(pl[i, 0]), float(pl[i, 1])), (xr, float(pl[i, 1])), sim,
                     ml[j].astype(np.float64), mr[j].astype(np.float64), msim[j],
                     config.theta, config.slope, config.similarity_weight,
                     config.input_bias, gradient=grad)
        assert u > 0 and u == pytest.approx(gm.fields[m], abs=1e-6)


def test_match_stereo_returns_guided_matches_as_extra_right_points():
    left, right = _scene(noise=6.0)
    res = hopmatch.match_stereo(left, right, max_disparity=12)
    n_net = len(res.network.query_idx)
    k = int((res.passes == PASS_GUIDED).sum())
    assert k > 0 and (res.passes[:n_net] == PASS_NETWORK).all()
    assert res.passes.dtype == np.uint8 and len(res.passes) == len(res.query_idx)
    assert len(res.points_right) == res.n_detected_right + k
    assert (res.train_idx[n_net:] >= res.n_detected_right).all()
    assert len(np.unique(res.query_idx)) == len(res.query_idx)
    err = np.abs(res.disparities - 6.0)
    assert np.median(err) < 0.1 and err.max() < 1.0
    # the cv2 objects and drawMatches work unchanged
    assert len(res.keypoints_right) == len(res.points_right)
    pic = cv2.drawMatches(left, res.keypoints_left, right, res.keypoints_right,
                          list(res.matches), None)
    assert pic.shape[:2] == (160, 440)


def test_guided_and_refine_can_be_turned_off_and_are_off_in_the_paper_preset():
    left, right = _scene()
    off = hopmatch.match_stereo(left, right, max_disparity=12, guided=False, refine=False)
    assert (off.passes == PASS_NETWORK).all() and off.guided is None
    np.testing.assert_array_equal(off.query_idx, off.network.query_idx)
    paper = hopmatch.match_stereo(left, right, preset="paper")
    assert paper.guided is None and paper.refinement is None
    assert paper.n_detected_right == len(paper.points_right)
    only_refine = hopmatch.match_stereo(left, right, max_disparity=12, guided=False)
    assert (only_refine.passes == PASS_NETWORK).all() and only_refine.refinement is not None


def test_guided_pass_without_network_matches_finds_nothing():
    left, right = _scene()
    det = hopmatch.DericheMoravecDetector()
    pl, _, dl, gl = det.detect_and_describe(left)
    pr, _, dr, gr = det.detect_and_describe(right)
    gm = guided_pass(pl, pr, dl, dr, gl, gr, np.zeros(0, np.int32), np.zeros(0, np.int32),
                     np.zeros(len(pl)), matcher_config({}))
    assert len(gm.query_idx) == 0 and gm.right_points.shape == (0, 2)


def test_guided_rounds_propagate_from_earlier_rounds():
    """Round 2 starts from the network's matches and round 1's: its matches are left
    points neither matched, each passing the tests of guided_pass run on that union (the
    first round is guided_pass itself)."""
    left, right = _scene(noise=6.0)
    det = hopmatch.DericheMoravecDetector()
    pl, _, dl, gl = det.detect_and_describe(left)
    pr, _, dr, gr = det.detect_and_describe(right)
    net = hopmatch.match_stereo(left, right, max_disparity=12, guided=False,
                                refine=False).network
    qi, ti = net.query_idx[::4], net.train_idx[::4]
    yoff = np.zeros(len(pl))
    one = guided_pass(pl, pr, dl, dr, gl, gr, qi, ti, yoff, net.config, margin=0.1)
    two = guided_rounds(pl, pr, dl, dr, gl, gr, qi, ti, yoff, net.config, margin=0.1,
                        rounds=2, later_margin=0.2)
    k = len(one.query_idx)
    np.testing.assert_array_equal(two.query_idx[:k], one.query_idx)
    assert len(two.query_idx) > k and len(np.unique(two.query_idx)) == len(two.query_idx)
    assert not np.isin(two.query_idx, qi).any()
    # round 2 is guided_pass on the union, with the later margin
    sim = np.r_[similarity_distance(dl, dr, qi.astype(np.int32), ti.astype(np.int32),
                                    gain_tolerance=net.config.gain_tolerance),
                one.similarity]
    again = guided_pass(pl, np.r_[pr, one.right_points].astype(np.float32), dl, dr, gl, gr,
                        np.r_[qi, one.query_idx], np.r_[ti, len(pr) + np.arange(k)], yoff,
                        net.config, margin=0.2, matched_similarity=sim)
    np.testing.assert_array_equal(two.query_idx[k:], again.query_idx)
    np.testing.assert_array_equal(two.fields[k:], again.fields)
