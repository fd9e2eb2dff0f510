"""The guided second pass: its kernels against NumPy references, its acceptance tests,
and what match_stereo returns with it."""

from __future__ import annotations

import math

import cv2
import naive_guided as ng
import numpy as np
import pytest
from synthetic_pairs import texture

import hopmatch
from hopmatch._kernels import guided as _k
from hopmatch.feature.descriptor import gradient_windows
from hopmatch.matching import guided as guided_module
from hopmatch.matching.guided import (
    GUIDED_BACK,
    GUIDED_FALLBACK_MIN_ZNCC,
    GUIDED_GRADIENT_LIMIT,
    GUIDED_MIN_ZNCC,
    GUIDED_PLANE_INLIER,
    GUIDED_PLANE_MIN,
    GUIDED_PLANE_REACH,
    GUIDED_PLANE_REFITS,
    GUIDED_PLANE_SEED_FIELD,
    GUIDED_RADIUS,
    GUIDED_SEED_FIELD,
    GUIDED_SEED_MARGIN,
    GUIDED_SEED_SHEARS,
    GUIDED_SEED_ZNCC,
    GUIDED_SHOULDER,
    guided_pass,
    guided_rounds,
    guided_search,
    seed_pass,
)
from hopmatch.matching.guided_results import (
    GUIDED_STAGES,
    STAGE_ACCEPTED,
    STAGE_CONTINUITY,
    STAGE_FEW_NEIGHBOURS,
    STAGE_LEFT_RIGHT,
    STAGE_LOW_ZNCC,
    STAGE_MARGIN,
    STAGE_OUTSIDE,
)
from hopmatch.matching.neighbourhood import nearest_of
from hopmatch.matching.params import matcher_config
from hopmatch.matching.similarity import similarity_distance
from hopmatch.matching.stereo_match import PASS_GUIDED, PASS_NETWORK, grey_fallback

RNG = np.random.default_rng(7)


def test_query_neighbours_match_the_reference():
    queries = RNG.uniform(0, 100, (60, 2)).astype(np.float32)
    matched = RNG.uniform(0, 100, (200, 2)).astype(np.float32)
    off, idx = _k.query_neighbours(queries, matched, np.float32(20), np.float32(10))
    ref = ng.neighbours(queries, matched, 20, 10)
    for q in range(len(queries)):
        got = idx[off[q]:off[q + 1]].tolist()
        assert len(got) == len(set(got)) and set(got) == ref[q]


@pytest.mark.parametrize("k", [1, 3, 50])
def test_nearest_of_keeps_each_points_k_nearest_neighbours(k):
    queries = RNG.uniform(0, 100, (40, 2)).astype(np.float32)
    matched = np.round(RNG.uniform(0, 100, (150, 2))).astype(np.float32)  # with ties
    off, idx = _k.query_neighbours(queries, matched, np.float32(20), np.float32(10))
    new_off, new_idx = nearest_of(queries, off, idx, matched, k)
    for q in range(len(queries)):
        mine = idx[off[q]:off[q + 1]]
        dist = [float(np.hypot(matched[j, 0] - np.float64(queries[q, 0]),
                               matched[j, 1] - np.float64(queries[q, 1]))) for j in mine]
        want = [j for _, j in sorted(zip(dist, mine.tolist()))][:k]
        assert new_idx[new_off[q]:new_off[q + 1]].tolist() == want


def test_neighbour_medians_are_np_median():
    off = np.array([0, 0, 1, 3, 7], np.int64)
    idx = np.array([4, 0, 1, 2, 3, 5, 6], np.int32)
    values = RNG.normal(size=7)
    med = _k.neighbour_medians(off, idx, values)
    assert np.isnan(med[0])
    for q in range(1, 4):
        assert med[q] == np.median(values[idx[off[q]:off[q + 1]]])
    # lists on both sides of RANK_MEDIAN_MAX (ranks counted, or sorted), with ties
    sizes = np.r_[np.arange(0, 70), _k.RANK_MEDIAN_MAX + np.arange(-2, 3), 150, 257]
    off = np.r_[0, np.cumsum(sizes)].astype(np.int64)
    values = np.r_[RNG.normal(size=300), RNG.integers(0, 4, 300).astype(np.float64)]
    idx = RNG.integers(0, len(values), off[-1]).astype(np.int32)
    med = _k.neighbour_medians(off, idx, values)
    want = [np.median(values[idx[a:b]]) if b > a else np.nan for a, b in zip(off, off[1:])]
    np.testing.assert_array_equal(med, want)


def _search_case(seed=3, shift=7.3):
    g_l = texture(80, 120, seed, sigma=1.5).astype(np.float32)
    x = np.arange(120, dtype=np.float64)
    # right(x) = left(x + shift): disparity `shift` everywhere (bilinear-exact warp of a
    # smooth texture is close enough for the search; the refinement test is exact)
    g_r = cv2.remap(g_l, (x[None, :] + shift).astype(np.float32).repeat(80, 0),
                    np.arange(80, dtype=np.float32)[:, None].repeat(120, 1), cv2.INTER_CUBIC)
    pts = np.c_[RNG.uniform(25, 95, 40), RNG.uniform(15, 65, 40)].astype(np.float32)
    desc = gradient_windows(g_l, pts, 9)
    return g_l, g_r, pts, desc


@pytest.mark.parametrize("gain, gain_tol, peaks, shoulder, shear", [
    (1.0, 1.0, False, 2, None), (0.93, 1.0, False, 2, None), (0.93, 1.1, False, 2, None),
    (1.2, 1.1, False, 2, None), (1.0, 1.0, True, 2, None), (0.93, 1.1, True, 2, None),
    (1.0, 1.0, False, 3, None), (0.93, 1.1, False, 3, None), (1.0, 1.0, False, 3, 0.0),
    (1.0, 1.0, False, 3, 0.3), (0.93, 1.1, False, 3, -0.7)])
def test_row_search_matches_the_reference(gain, gain_tol, peaks, shoulder, shear):
    """Also with a right image of another gain (``gain``): the similarity then allows for
    a gain within ``gain_tol`` (eq. 7 as the network's, 1: as written); ``peaks``: the
    runner-up of the margin is the best other peak (``GUIDED_PEAK_MARGIN``), else the best
    at least ``shoulder`` columns away (``GUIDED_SHOULDER``); ``shear``: each query's
    right windows slide by its own disparity gradient along y (None: not given, 0)."""
    g_l, g_r, pts, desc = _search_case()
    d = np.full(len(pts), 7.3)
    if shear:  # a right image whose disparity grows by `shear` px per row
        yy, xx = np.mgrid[0:80, 0:120].astype(np.float32)
        g_r = cv2.remap(g_l, xx + np.float32(7.3) + np.float32(shear) * (yy - 40), yy,
                        cv2.INTER_CUBIC)
        d = 7.3 + shear * (pts[:, 1].astype(np.float64) - 40)
    g_r = (g_r * gain).astype(g_r.dtype)
    q = np.arange(len(pts), dtype=np.int64)
    centre = pts[:, 0].astype(np.float64) - d + RNG.uniform(-2.5, 2.5, len(pts))
    yoff = RNG.uniform(-0.4, 0.4, len(pts))
    shears = None if shear is None else np.full(len(pts), float(shear))
    status, best, second, xr, sim = _k.row_search(g_l, g_r, pts, desc, q, centre, yoff, 2.0,
                                                  4, 1, 0.5, 0.05, 1e-6, gain_tol, False,
                                                  peaks, shoulder, shears)
    found = 0
    for m in range(len(pts)):
        # the strip's columns (the searched ones, one more at each end, the windows' half
        # sides and the refined window's column), slid by the shear: inside, or OUTSIDE
        g = 0.0 if shears is None else float(shears[m])
        c0 = math.floor(centre[m] + 0.5)
        x_lo, x_hi = c0 - 4 - 1 - 4, c0 + 4 + 1 + 4 + 1
        outside = (x_lo - math.ceil(abs(g) * 4) < 0
                   or x_hi + math.floor(abs(g) * 4) + (g != 0) > g_r.shape[1] - 1)
        assert (status[m] == _k.OUTSIDE) == outside, m
        if outside:
            continue
        ok, b, s2, x, si = ng.row_search_one(g_l, g_r, float(pts[m, 0]), float(pts[m, 1]),
                                             desc[m], centre[m], yoff[m], 2.0, 4, 1, 0.5,
                                             0.05, gain_tol, peaks=peaks,
                                             shoulder=shoulder, shear=g)
        assert (status[m] == _k.FOUND) == ok, m
        assert best[m] == pytest.approx(b, abs=1e-6)
        assert second[m] == pytest.approx(s2, abs=1e-6)
        if ok:
            found += 1
            assert xr[m] == pytest.approx(x, abs=1e-4)
            assert sim[m] == pytest.approx(si, abs=1e-6)
    assert found > len(pts) // 2  # the case exercises the found branch


def test_clipped_row_search_matches_the_reference():
    """``clip=True`` (the seeds' search of the whole range): a search whose columns leave
    the right image keeps those whose windows lie in it, as the reference does; without
    it such a search is OUTSIDE."""
    g_l, g_r, pts, desc = _search_case()
    q = np.arange(len(pts), dtype=np.int64)
    outer = 30  # the whole range of a seed: wider than the margin of most points
    rng = np.random.default_rng(5)
    centre = pts[:, 0].astype(np.float64) - 7.3 + rng.uniform(-6, 6, len(pts))
    yoff = rng.uniform(-0.4, 0.4, len(pts))
    args = (g_l, g_r, pts, desc, q, centre, yoff, float(outer), outer, 1, 0.5, 0.1, 1e-6,
            1.0)
    status, best, second, xr, sim = _k.row_search(*args, True)
    plain = _k.row_search(*args)[0]
    found = clipped = 0
    for m in range(len(pts)):
        ok, b, s2, x, si = ng.row_search_one(g_l, g_r, float(pts[m, 0]), float(pts[m, 1]),
                                             desc[m], centre[m], yoff[m], float(outer),
                                             outer, 1, 0.5, 0.1, clip=True)
        assert (status[m] == _k.FOUND) == ok, m
        assert best[m] == pytest.approx(b, abs=1e-6, nan_ok=True)
        assert second[m] == pytest.approx(s2, abs=1e-6, nan_ok=True)
        if plain[m] == _k.OUTSIDE:
            clipped += 1
        else:  # the whole search fits: clipping changes nothing
            assert status[m] == plain[m]
        if ok:
            found += 1
            assert xr[m] == pytest.approx(x, abs=1e-4)
            assert sim[m] == pytest.approx(si, abs=1e-6)
    assert clipped > 5 and found > len(pts) // 3
    assert (status[plain == _k.OUTSIDE] == _k.FOUND).sum() > 0  # found only when clipped


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


@pytest.mark.parametrize("reach, refits", [(-1.0, 0), (np.inf, 1), (3.0, 2)])
def test_neighbour_planes_match_the_reference(reach, refits):
    """Queries on a slanted plane (some neighbours off it, some with too few inliers or
    collinear ones): the kernel's prediction and gradient equal the reference's, with the
    band around the median only (``refits`` 0) or refitted around the plane, and the
    plane's value bounded to ``reach`` from the median (-1: the band) or not."""
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
    pred, gx, gy = _k.neighbour_planes(queries, off, idx, matched, disp, 2.0, 3, reach, refits)
    planes = 0
    for q in range(len(queries)):
        j = idx[off[q]:off[q + 1]]
        a, bx, by = ng.local_plane(queries[q], matched[j], disp[j], 2.0, 3,
                                   None if reach < 0 else reach, refits)
        assert pred[q] == pytest.approx(a, abs=1e-6), q
        assert gx[q] == pytest.approx(bx, abs=1e-6) and gy[q] == pytest.approx(by, abs=1e-6)
        planes += bx != 0.0
    assert planes > len(queries) // 2 and gx[-1] == 0.0 and pred[-1] == 21.0
    if refits:  # the refitted band takes other neighbours than the median's
        median_band = _k.neighbour_planes(queries, off, idx, matched, disp, 2.0, 3)[0]
        assert np.count_nonzero(pred != median_band) > 5


def _scene(shift=6, noise=0.0):
    """A textured plane at disparity ``shift``; ``noise``: standard deviation of the noise
    added to the right image (the network then leaves points for the guided pass)."""
    img = texture(160, 220, seed=11).astype(np.float32)
    left = np.clip(img, 0, 255).astype(np.uint8)
    noisy = np.roll(img, -shift, axis=1) + np.random.default_rng(0).normal(0, noise, img.shape)
    return left, np.clip(noisy, 0, 255).astype(np.uint8)


def _network_case(rows=None):
    """The noisy plane of ``_scene(noise=6.0)`` (its first ``rows`` rows if given), detected
    and described on both sides, and the network's matches on it (no guided pass, no
    refinement): ``(pl, dl, gl, pr, dr, gr, network)`` as guided_pass takes them."""
    left, right = _scene(noise=6.0)
    if rows is not None:
        left, right = left[:rows], right[:rows]
    det = hopmatch.DericheMoravecDetector()
    pl, _, dl, gl = det.detect_and_describe(left)
    pr, _, dr, gr = det.detect_and_describe(right)
    net = hopmatch.match_stereo(left, right, max_disparity=12, guided=False,
                                refine=False).network
    return pl, dl, gl, pr, dr, gr, net


@pytest.mark.parametrize("step, window, peaks", [(2, 1.0, False), (12, 2.0, False),
                                                 (12, 2.0, True)])
def test_guided_matches_pass_every_acceptance_test(step, window, peaks, monkeypatch):
    """Each guided match passes the tests it is accepted on, recomputed by the references:
    found by the search (peak near the prediction, ZNCC and margin, back search) and a
    positive field against its matched neighbours. With ``window`` > 1 a point with fewer
    than 3 matched neighbours in the network's window takes them from the larger one. With
    ``peaks`` (``GUIDED_PEAK_MARGIN``) the margin is over the best other peak."""
    monkeypatch.setattr(guided_module, "GUIDED_PEAK_MARGIN", peaks)
    left, right = _scene()
    det = hopmatch.DericheMoravecDetector()
    pl, _, dl, gl = det.detect_and_describe(left)
    pr, _, dr, gr = det.detect_and_describe(right)
    res = hopmatch.match_stereo(left, right, max_disparity=12, guided=False, refine=False)
    net = res.network
    config = net.config
    # the network matches almost every point of this clean pair: leave most of its
    # matches out, so that the guided pass has points to propagate to
    qi, ti = net.query_idx[::step], net.train_idx[::step]
    yoff = np.full(len(pl), 0.0)
    gm = guided_pass(pl, pr, dl, dr, gl, gr, qi, ti, yoff, config, margin=0.1,
                     window=window)
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
    wide = ng.neighbours(pl[gm.query_idx], ml, window * config.neighbour_width / 2,
                         window * config.neighbour_height / 2)
    grown = 0
    for m, i in enumerate(gm.query_idx):
        j = np.array(sorted(nb[m] if len(nb[m]) >= 3 else wide[m]))
        grown += len(nb[m]) < 3
        assert len(j) >= 3
        pred, gx, gy = ng.local_plane(pl[i], ml[j], disp[j], GUIDED_PLANE_INLIER,
                                      GUIDED_PLANE_MIN, GUIDED_PLANE_REACH,
                                      GUIDED_PLANE_REFITS)
        grad = tuple(float(np.clip(g, -GUIDED_GRADIENT_LIMIT, GUIDED_GRADIENT_LIMIT))
                     for g in (gx, gy))
        centre = float(pl[i, 0]) - pred
        ok, best, second, xr, sim = ng.row_search_one(
            gl, gr, float(pl[i, 0]), float(pl[i, 1]), dl[i], centre, 0.0, GUIDED_RADIUS, 3,
            1, GUIDED_MIN_ZNCC, 0.1, config.gain_tolerance, peaks=peaks,
            shoulder=GUIDED_SHOULDER, shear=grad[1])  # windows along the plane
        assert ok, m
        assert gm.right_points[m, 0] == pytest.approx(xr, abs=1e-4)
        assert best >= GUIDED_MIN_ZNCC and best - second >= 0.1
        u = ng.field((float(pl[i, 0]), float(pl[i, 1])), (xr, float(pl[i, 1])), sim,
                     ml[j].astype(np.float64), mr[j].astype(np.float64), msim[j],
                     config.theta, config.slope, config.similarity_weight,
                     config.input_bias, gradient=grad)
        assert u > 0 and u == pytest.approx(gm.fields[m], abs=1e-6)
    assert (grown > 0) == (window > 1)  # the larger window served some points


def test_match_stereo_returns_guided_matches_as_extra_right_points():
    left, right = _scene(noise=6.0)
    res = hopmatch.match_stereo(left, right, max_disparity=12, both_features=False)
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
    off = hopmatch.match_stereo(left, right, max_disparity=12, guided=False, refine=False,
                                both_features=False)
    assert (off.passes == PASS_NETWORK).all() and off.guided is None
    np.testing.assert_array_equal(off.query_idx, off.network.query_idx)
    paper = hopmatch.match_stereo(left, right, preset="paper")
    assert paper.guided is None and paper.refinement is None
    assert paper.n_detected_right == len(paper.points_right)
    only_refine = hopmatch.match_stereo(left, right, max_disparity=12, guided=False,
                                        both_features=False)
    assert (only_refine.passes == PASS_NETWORK).all() and only_refine.refinement is not None


@pytest.mark.parametrize("margin, min_field", [(0.1, 0.0), (0.2, 3.0)])
def test_guided_search_says_where_each_point_stopped(margin, min_field):
    """guided_search's matches are guided_pass's; it considers every unmatched left point
    once, its accepted ones are exactly the matches, and each stage agrees with what the
    search measured: too few neighbours in the window, a ZNCC below the minimum or a
    margin below ``margin``, a field not above ``min_field``."""
    pl, dl, gl, pr, dr, gr, net = _network_case()
    config = net.config
    qi, ti = net.query_idx[::3], net.train_idx[::3]
    yoff = np.zeros(len(pl))
    kw = dict(margin=margin, min_field=min_field, window=2.0)
    found = guided_search(pl, pr, dl, dr, gl, gr, qi, ti, yoff, config, **kw)
    gm = guided_pass(pl, pr, dl, dr, gl, gr, qi, ti, yoff, config, **kw)
    for f in ("query_idx", "right_points", "fields", "zncc", "second"):
        np.testing.assert_array_equal(getattr(found.matches, f), getattr(gm, f))
    unmatched = np.setdiff1d(np.arange(len(pl)), qi)
    np.testing.assert_array_equal(np.sort(found.queries), unmatched)
    assert set(found.stage.tolist()) <= set(range(len(GUIDED_STAGES)))
    np.testing.assert_array_equal(found.queries[found.stage == STAGE_ACCEPTED], gm.query_idx)
    assert len(gm.query_idx) > 0
    wide = ng.neighbours(pl[found.queries], pl[qi], 2.0 * config.neighbour_width / 2,
                         2.0 * config.neighbour_height / 2)
    few = found.stage == STAGE_FEW_NEIGHBOURS
    assert all(len(wide[m]) < 3 for m in np.flatnonzero(few))
    assert np.isnan(found.predicted[few]).all() and np.isfinite(found.predicted[~few]).all()
    # the searched ones again, one at a time, by the reference search
    searched = np.flatnonzero(~few)
    size = int(round(np.sqrt(dl.shape[1])))
    rad = size // 2
    for m in searched[:: max(1, len(searched) // 60)]:
        i = found.queries[m]
        x, y = float(pl[i, 0]), float(pl[i, 1])
        c0 = int(np.floor(x - found.predicted[m] + 0.5))
        if (c0 - 4 - rad < 0 or c0 + 4 + rad + 1 > gr.shape[1] - 1 or np.floor(y) - rad < 0
                or np.floor(y) - rad + size > gr.shape[0] - 1):
            assert found.stage[m] == STAGE_OUTSIDE, m  # a window of the search leaves it
            continue
        if not (np.floor(x) - 1 - rad >= 0 and np.floor(x) + 1 + rad + 1 <= gl.shape[1] - 1):
            continue  # the back search's windows would leave the image
        ok, best, second, xr, sim = ng.row_search_one(
            gl, gr, float(pl[i, 0]), float(pl[i, 1]), dl[i],
            float(pl[i, 0]) - found.predicted[m], 0.0, GUIDED_RADIUS, 3, 1,
            GUIDED_MIN_ZNCC, margin, config.gain_tolerance, shoulder=GUIDED_SHOULDER)
        st = found.stage[m]
        assert ok == (st in (STAGE_ACCEPTED, STAGE_CONTINUITY)), (m, st)
        if st == STAGE_LOW_ZNCC:
            assert best < GUIDED_MIN_ZNCC
        if st == STAGE_MARGIN:
            assert best >= GUIDED_MIN_ZNCC and best - second < margin
    assert (gm.fields > min_field).all()


def test_grey_fallback_searches_the_grey_levels_only_where_the_search_on_g_failed():
    """With a GreyFallback, each left point whose search on G stopped at a low ZNCC, the
    uniqueness margin or the left-right check has the outcome of the same search on the
    grey images (with the fallback's smallest ZNCC) where that one found a peak (accepted,
    or refused by the field test); every other point has G's outcome. The matches are the
    two searches' (the same prediction and neighbours' similarity: only the images
    differ)."""
    left, right = _scene(noise=6.0)
    pl, dl, gl, pr, dr, gr, net = _network_case()
    config = net.config
    qi, ti = net.query_idx[::3], net.train_idx[::3]
    yoff = np.zeros(len(pl))
    fb = grey_fallback((left, right), (gl, gr), dl.shape[1])
    assert fb.window_size ** 2 == dl.shape[1]
    grey_windows = gradient_windows(fb.left, pl, fb.window_size)
    msim = similarity_distance(dl, dr, qi, ti, gain_tolerance=config.gain_tolerance)
    kw = dict(margin=0.1, window=2.0, matched_similarity=msim)
    on_g = guided_search(pl, pr, dl, dr, gl, gr, qi, ti, yoff, config, **kw)
    on_grey = guided_search(pl, pr, grey_windows, dr, fb.left, fb.right, qi, ti, yoff,
                            config, min_zncc=max(GUIDED_MIN_ZNCC, GUIDED_FALLBACK_MIN_ZNCC),
                            **kw)
    both = guided_search(pl, pr, dl, dr, gl, gr, qi, ti, yoff, config, fallback=fb, **kw)
    np.testing.assert_array_equal(both.queries, on_g.queries)
    np.testing.assert_array_equal(on_grey.queries, on_g.queries)
    peak = (STAGE_ACCEPTED, STAGE_CONTINUITY)
    weak_on_g = np.isin(on_g.stage, (STAGE_LOW_ZNCC, STAGE_MARGIN, STAGE_LEFT_RIGHT))
    assert weak_on_g.any() and (~weak_on_g & ~np.isin(on_g.stage, peak)).any()
    from_grey = weak_on_g & np.isin(on_grey.stage, peak)
    np.testing.assert_array_equal(both.stage, np.where(from_grey, on_grey.stage, on_g.stage))
    added = from_grey & (on_grey.stage == STAGE_ACCEPTED)
    assert added.sum() > 0 and (on_g.stage == STAGE_ACCEPTED).sum() > 0
    for search, where in ((on_g, ~from_grey), (on_grey, from_grey)):
        mine = np.isin(both.matches.query_idx, both.queries[where])
        theirs = np.isin(search.matches.query_idx, both.queries[where])
        for f in ("query_idx", "right_points", "fields", "zncc", "second", "similarity"):
            np.testing.assert_array_equal(getattr(both.matches, f)[mine],
                                          getattr(search.matches, f)[theirs])


def test_grey_fallback_is_off_on_grey_feature_images_and_without_guided_fallback(
        monkeypatch):
    """No fallback where the feature images are the normalised grey levels (the detector's
    ``on="intensity"``: the same search again), nor with GUIDED_FALLBACK off."""
    left, right = _scene()
    det = hopmatch.DericheMoravecDetector(on="intensity")
    pl, _, dl, gl = det.detect_and_describe(left)
    pr, _, dr, gr = det.detect_and_describe(right)
    assert grey_fallback((left, right), (gl, gr), dl.shape[1]) is None
    g_l = hopmatch.DericheMoravecDetector().feature_image(left)
    g_r = hopmatch.DericheMoravecDetector().feature_image(right)
    assert grey_fallback((left, right), (g_l, g_r), dl.shape[1]) is not None
    monkeypatch.setattr(guided_module, "GUIDED_FALLBACK", False)
    assert grey_fallback((left, right), (g_l, g_r), dl.shape[1]) is None


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
    points neither matched, each passing the tests of guided_pass run on that union with
    the later margin, the later minimum field and the grown window (the first round is
    guided_pass itself)."""
    pl, dl, gl, pr, dr, gr, net = _network_case()
    qi, ti = net.query_idx[::4], net.train_idx[::4]
    yoff = np.zeros(len(pl))
    one = guided_pass(pl, pr, dl, dr, gl, gr, qi, ti, yoff, net.config, margin=0.1)
    two = guided_rounds(pl, pr, dl, dr, gl, gr, qi, ti, yoff, net.config, margin=0.1,
                        rounds=2, later_margin=0.2, growth=1.0, later_field=1.0,
                        seed_rounds=0)
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
                        net.config, margin=0.2, window=2.0, min_field=1.0,
                        matched_similarity=sim)
    np.testing.assert_array_equal(two.query_idx[k:], again.query_idx)
    np.testing.assert_array_equal(two.fields[k:], again.fields)
    assert len(two.fields) > k and (two.fields[k:] > 1.0).all()
    # seeds come after the rounds, then rounds propagate from them: the rounds' matches
    # come first, unchanged
    more = guided_rounds(pl, pr, dl, dr, gl, gr, qi, ti, yoff, net.config, margin=0.1,
                         rounds=2, later_margin=0.2, growth=1.0, later_field=1.0,
                         seed_rounds=1)
    n = len(two.query_idx)
    np.testing.assert_array_equal(more.query_idx[:n], two.query_idx)
    assert len(np.unique(more.query_idx)) == len(more.query_idx)


@pytest.mark.parametrize("window", [1.0, 2.0])
def test_guided_pass_from_new_matches_searches_only_where_they_are_neighbours(window):
    """guided_pass with ``new_from=k`` returns exactly the matches of the full pass whose
    left point has one of the matches ``k...`` among its neighbours (in the window it
    takes them from, by the reference), with the same values: the rest of the search is
    unchanged, and it is what the rounds after the seeds use."""
    pl, dl, gl, pr, dr, gr, net = _network_case()
    config = net.config
    qi, ti = net.query_idx[::3], net.train_idx[::3]
    yoff = np.zeros(len(pl))
    k = len(qi) // 2
    full = guided_pass(pl, pr, dl, dr, gl, gr, qi, ti, yoff, config, margin=0.2,
                       window=window)
    new = guided_pass(pl, pr, dl, dr, gl, gr, qi, ti, yoff, config, margin=0.2,
                      window=window, new_from=k)
    ml = pl[qi]
    nb = ng.neighbours(pl[full.query_idx], ml, config.neighbour_width / 2,
                       config.neighbour_height / 2)
    wide = ng.neighbours(pl[full.query_idx], ml, window * config.neighbour_width / 2,
                         window * config.neighbour_height / 2)
    reached = np.array([max(nb[m] if len(nb[m]) >= 3 else wide[m]) >= k
                        for m in range(len(full.query_idx))])
    assert 0 < reached.sum() < len(reached)  # both kinds of points
    np.testing.assert_array_equal(new.query_idx, full.query_idx[reached])
    for name in ("right_points", "fields", "zncc", "similarity"):
        np.testing.assert_array_equal(getattr(new, name), getattr(full, name)[reached])
    assert len(guided_pass(pl, pr, dl, dr, gl, gr, qi, ti, yoff, config,
                           new_from=len(qi)).query_idx) == 0  # nothing new: no search


@pytest.mark.parametrize("rounds", [1, 2])
def test_rounds_after_the_seeds_search_only_where_something_changed(monkeypatch, rounds):
    """The round after the seeds (round 1's settings, a window no larger than the last
    round's) searches only where a seed or a match of the last round is a neighbour
    (GUIDED_SEED_NEAR): elsewhere it would find what the last round found, so every
    match is that of the round searching every unmatched point (after round 0 alone,
    whose settings differ, it searches every point)."""
    pl, dl, gl, pr, dr, gr, net = _network_case()
    keep = pl[net.query_idx, 0] < 80  # seeds to the right of the matches kept
    qi, ti = net.query_idx[keep][::2], net.train_idx[keep][::2]
    yoff = np.zeros(len(pl))
    got = {}
    for near in (False, True):
        monkeypatch.setattr(guided_module, "GUIDED_SEED_NEAR", near)
        got[near] = guided_rounds(pl, pr, dl, dr, gl, gr, qi, ti, yoff, net.config,
                                  margin=0.1, rounds=rounds, seed_rounds=1)
    before = guided_rounds(pl, pr, dl, dr, gl, gr, qi, ti, yoff, net.config, margin=0.1,
                           rounds=rounds, seed_rounds=0)
    seeds = seed_pass(pl, np.r_[pr, before.right_points].astype(np.float32), dl, gl, gr,
                      np.r_[qi, before.query_idx],
                      np.r_[ti, len(pr) + np.arange(len(before.query_idx))], yoff,
                      net.config, np.r_[similarity_distance(
                          dl, dr, qi.astype(np.int32), ti.astype(np.int32),
                          gain_tolerance=net.config.gain_tolerance), before.similarity])
    n = len(before.query_idx) + len(seeds.query_idx)
    assert len(seeds.query_idx) > 0 and len(got[False].query_idx) > n  # a round after them
    for f in ("query_idx", "right_points", "zncc", "second", "similarity", "fields"):
        np.testing.assert_array_equal(getattr(got[True], f), getattr(got[False], f))


@pytest.mark.parametrize("seed_all, planes", [(True, "default"), (False, "default"),
                                               (True, "off"), (True, "every other")])
def test_seeds_pass_the_whole_range_search_and_the_mutual_field_test(monkeypatch, seed_all,
                                                                     planes):
    """seed_pass: the seeds are the left points without a match (``GUIDED_SEED_ALL``
    False: and with fewer than 3 matches in the network's window) whose row search over
    the whole disparity range (the reference) finds a peak with a field above the seed
    minimum, the matches and the other such peaks (all but itself) as neighbours; far
    from the few matches left, only the peaks' agreement among themselves can carry
    them. Or (``GUIDED_SEED_PLANES``) a peak on a receding plane with a field above
    ``GUIDED_PLANE_SEED_FIELD``: this pair is fronto-parallel, so by default no peak is
    on one ("default" and "off" alike); "every other" stands in a plane finder that puts
    every other peak on one, given the peaks' positions, disparities and local gradients
    in order."""
    monkeypatch.setattr(guided_module, "GUIDED_SEED_ALL", seed_all)
    monkeypatch.setattr(guided_module, "GUIDED_SEED_PLANES", planes != "off")
    plane_calls = []
    if planes == "every other":
        def every_other(points, disparity, gx, gy):
            plane_calls.append((np.array(points), np.array(disparity), np.array(gx),
                                np.array(gy)))
            label = np.where(np.arange(len(disparity)) % 2 == 0, 0, -1)
            return np.array([[0.0, 0.0, 0.2]]), label

        monkeypatch.setattr(guided_module, "receding_planes", every_other)
    pl, dl, gl, pr, dr, gr, net = _network_case(rows=64)  # fewer points for the reference
    config = net.config
    keep = pl[net.query_idx, 0] < 60  # the matches of the left strip only
    qi, ti = net.query_idx[keep], net.train_idx[keep]
    msim = similarity_distance(dl, dr, qi.astype(np.int32), ti.astype(np.int32),
                               gain_tolerance=config.gain_tolerance)
    yoff = np.zeros(len(pl))
    sd = seed_pass(pl, pr, dl, gl, gr, qi, ti, yoff, config, msim)
    assert len(sd.query_idx) > 10 and not np.isin(sd.query_idx, qi).any()
    assert (pl[sd.query_idx, 0] > 100).sum() > 10  # far from every match
    # within a third of a pixel (the search's parabola), but for the odd seed whose
    # sheared search (GUIDED_SEED_SHEARS) peaks higher on this fronto-parallel pair and
    # places it (0.31 px off, one seed of 468 when written; the refinement follows)
    err = np.abs(pl[sd.query_idx, 0] - sd.right_points[:, 0] - 6.0)
    assert err.max() <= 0.4 and np.mean(err <= 0.3) >= 0.99
    lo, hi = float(config.min_disparity or 0.0), float(config.max_disparity)
    outer = int(np.ceil(0.5 * (hi - lo))) + 1
    # the reference search of every unmatched left point over the whole range
    peaks = []  # (left point, xr, similarity)
    size = int(round(np.sqrt(dl.shape[1])))
    rad = size // 2
    h, w = gr.shape
    unmatched = np.setdiff1d(np.arange(len(pl)), qi)
    near = ng.neighbours(pl[unmatched], pl[qi], config.neighbour_width / 2,
                         config.neighbour_height / 2)
    assert min(map(len, near)) < 3 <= max(map(len, near))  # both kinds of points
    searched = unmatched if seed_all else unmatched[[len(nb) < 3 for nb in near]]
    for i in searched:  # every unmatched point, or only where no match reaches
        x, y = float(pl[i, 0]), float(pl[i, 1])
        if np.floor(y) - rad < 0 or np.floor(y) - rad + size > h - 1:
            continue  # the kernel's OUTSIDE: the windows leave the image (the columns
            # are clipped to the image: row_search_one's clip)
        if not (np.floor(x) - GUIDED_BACK - rad >= 0
                and np.floor(x) + GUIDED_BACK + rad + 1 <= w - 1):
            continue  # the back search's windows would leave the image
        # square windows, then each of GUIDED_SEED_SHEARS: the found peak of highest ZNCC
        found = []
        for shear in (0.0,) + tuple(GUIDED_SEED_SHEARS):
            ok, best, _, xr, sim = ng.row_search_one(
                gl, gr, x, y, dl[i], x - 0.5 * (lo + hi), 0.0, float(outer), outer,
                GUIDED_BACK, GUIDED_SEED_ZNCC, GUIDED_SEED_MARGIN, config.gain_tolerance,
                clip=True, shoulder=GUIDED_SHOULDER, shear=shear)
            if ok and (not found or best > found[0]):
                found = [best, xr, sim]
        if found:
            peaks.append((i, found[1], found[2]))
    pk = np.array([p[0] for p in peaks])
    ml = np.r_[pl[qi], pl[pk]].astype(np.float32)
    # the peaks as neighbours: right points in float32, as every matched point
    mr = np.r_[pr[ti], np.c_[[p[1] for p in peaks], pl[pk, 1]]].astype(np.float32)
    mr = mr.astype(np.float64)
    ms = np.r_[msim, [p[2] for p in peaks]]
    disp = ml[:, 0].astype(np.float64) - mr[:, 0]
    nb = ng.neighbours(pl[pk], ml, config.neighbour_width / 2, config.neighbour_height / 2)
    fields_ = {}
    grads = []
    for m, (i, xr, sim) in enumerate(peaks):
        j = np.array(sorted(nb[m] - {len(qi) + m}))  # the matches and the other peaks
        _, gx, gy = ng.local_plane(pl[i], ml[j], disp[j], GUIDED_PLANE_INLIER,
                                   GUIDED_PLANE_MIN, GUIDED_PLANE_REACH, GUIDED_PLANE_REFITS)
        grad = tuple(float(np.clip(g, -GUIDED_GRADIENT_LIMIT, GUIDED_GRADIENT_LIMIT))
                     for g in (gx, gy))
        u = ng.field((float(pl[i, 0]), float(pl[i, 1])), (xr, float(pl[i, 1])), sim, ml[j],
                     mr[j], ms[j], config.theta, config.slope, config.similarity_weight,
                     config.input_bias, gradient=grad)
        fields_[int(i)] = (xr, u)
        grads.append(grad)
    if planes == "every other":  # given every peak in order, with its local plane
        p_pts, p_disp, p_gx, p_gy = plane_calls[0]
        np.testing.assert_array_equal(p_pts, pl[pk])
        np.testing.assert_allclose(p_disp, [pl[i, 0] - xr for i, xr, _ in peaks], atol=1e-4)
        np.testing.assert_allclose(np.c_[p_gx, p_gy], grads, atol=1e-6)
    on_plane = {int(i): planes == "every other" and m % 2 == 0 for m, (i, _, _) in
                enumerate(peaks)}
    # the seeds are the peaks above the minimum field: the default one, and one that
    # refuses about half of them
    us = np.sort([u for _, u in fields_.values()])
    high = float(0.5 * (us[len(us) // 2 - 1] + us[len(us) // 2]))  # between two fields
    for min_field, got in ((GUIDED_SEED_FIELD, sd),
                           (high, seed_pass(pl, pr, dl, gl, gr, qi, ti, yoff, config, msim,
                                            min_field=high))):
        kept = {i: v for i, v in fields_.items()
                if v[1] > min_field or (on_plane[i] and v[1] > GUIDED_PLANE_SEED_FIELD)}
        assert sorted(kept) == sorted(got.query_idx.tolist())
        for m, i in enumerate(got.query_idx):
            assert got.right_points[m, 0] == pytest.approx(kept[int(i)][0], abs=1e-4)
            assert got.fields[m] == pytest.approx(kept[int(i)][1], abs=1e-6)
    assert 0 < len(kept) < len(peaks)
    if planes == "every other":  # some kept for their plane alone
        assert any(on_plane[i] and GUIDED_PLANE_SEED_FIELD < v[1] <= high
                   for i, v in fields_.items())
    # without a resolved range there is nothing to search
    unresolved = matcher_config({"max_disparity": None})
    assert len(seed_pass(pl, pr, dl, gl, gr, qi, ti, yoff, unresolved, msim).query_idx) == 0


def test_seeds_beyond_the_work_budget_are_the_weakest_left_out(monkeypatch):
    """seed_pass with ``max_work``: it searches the first seeds in the order of the left
    points (the detector's, strongest first) whose whole-range searches (``2 outer + 3``
    columns each) fit in the budget, at least one, with square windows; then, with what
    is left, the first seeds again with each of ``GUIDED_SEED_SHEARS``; with a budget
    they all fit in, it searches every seed and finds what it finds without a budget."""
    monkeypatch.setattr(guided_module, "GUIDED_SEED_SHEARS", (0.2, 0.35))
    pl, dl, gl, pr, dr, gr, net = _network_case(rows=64)
    config = net.config
    keep = pl[net.query_idx, 0] < 60  # many seeds: the points right of the strip
    qi, ti = net.query_idx[keep], net.train_idx[keep]
    msim = similarity_distance(dl, dr, qi.astype(np.int32), ti.astype(np.int32),
                               gain_tolerance=config.gain_tolerance)
    yoff = np.zeros(len(pl))
    searched = []  # (queries, shear) of each search
    search = _k.row_search

    def recording(g_l, g_r, pts_l, desc_l, queries, *args):
        shear = args[-1]
        assert len(np.unique(shear)) <= 1
        searched.append((np.array(queries), float(shear[0]) if len(shear) else None))
        return search(g_l, g_r, pts_l, desc_l, queries, *args)

    monkeypatch.setattr(_k, "row_search", recording)

    def seeds(max_work):
        """The seeds, and the sorted queries of each shear searched, in order."""
        searched.clear()
        got = seed_pass(pl, pr, dl, gl, gr, qi, ti, yoff, config, msim, max_work=max_work)
        shears = sorted({s for _, s in searched if s is not None}, key=[
            0.0, 0.2, 0.35].index)
        return got, [(s, np.sort(np.concatenate([q for q, t in searched if t == s])))
                     for s in shears]

    lo, hi = float(config.min_disparity or 0.0), float(config.max_disparity)
    span = 2 * (int(np.ceil(0.5 * (hi - lo))) + 1) + 3
    every, runs = seeds(10**12)
    assert [s for s, _ in runs] == [0.0, 0.2, 0.35]
    all_q = runs[0][1]
    assert all(np.array_equal(q, all_q) for _, q in runs)
    assert len(all_q) > 20 and len(every.query_idx) > 5
    for fits in (3 * len(all_q), 3 * len(all_q) + 7):  # every search fits: the same seeds
        got, runs = seeds(fits * span)
        assert [s for s, _ in runs] == [0.0, 0.2, 0.35]
        for f in ("query_idx", "right_points", "fields"):
            np.testing.assert_array_equal(getattr(got, f), getattr(every, f))
    k, n = len(all_q) // 3, len(all_q)
    for budget, want in (
            (k * span, [(0.0, k)]), (k * span + span - 1, [(0.0, k)]), (span - 1, [(0.0, 1)]),
            (0, [(0.0, 1)]), (n * span, [(0.0, n)]),
            ((n + k) * span + 3, [(0.0, n), (0.2, k)]),
            ((2 * n + k) * span, [(0.0, n), (0.2, n), (0.35, k)])):
        got, runs = seeds(budget)
        assert [(s, len(q)) for s, q in runs] == want, budget
        for _, q in runs:
            np.testing.assert_array_equal(q, all_q[:len(q)])  # the strongest
        assert np.isin(got.query_idx, all_q[:want[0][1]]).all()


def test_a_sheared_search_follows_a_receding_surface():
    """A right image whose disparity grows by 0.5 px per row (a road, a floor): the row
    search with the surface's gradient (``shear``) scores the true column higher than the
    search with square windows, and finds it (within 0.25 px) at least as often."""
    rng = np.random.default_rng(11)
    g_l = texture(90, 140, 5, sigma=1.2).astype(np.float32)
    yy, xx = np.mgrid[0:90, 0:140].astype(np.float32)
    g_r = cv2.remap(g_l, xx + 10.0 + 0.5 * (yy - 45.0), yy, cv2.INTER_CUBIC)
    pts = np.c_[rng.uniform(35, 105, 60), rng.uniform(25, 65, 60)].astype(np.float32)
    desc = gradient_windows(g_l, pts, 9)
    q = np.arange(len(pts), dtype=np.int64)
    d = 10.0 + 0.5 * (pts[:, 1].astype(np.float64) - 45.0)
    centre = pts[:, 0] - d
    yoff = np.zeros(len(pts))
    runs = [_k.row_search(g_l, g_r, pts, desc, q, centre, yoff, 2.0, 3, 1, 0.5, 0.05, 1e-6,
                          1.0, False, False, 3, shear)
            for shear in (np.zeros(len(pts)), np.full(len(pts), 0.5))]
    (st0, best0, _, xr0, _), (st1, best1, _, xr1, _) = runs
    assert np.mean(best1 > best0) > 0.9 and np.median(best1) > np.median(best0) + 0.05
    hit0 = (st0 == _k.FOUND) & (np.abs(xr0 - centre) <= 0.25)
    hit1 = (st1 == _k.FOUND) & (np.abs(xr1 - centre) <= 0.25)
    assert hit1.sum() >= hit0.sum() and hit1.sum() >= 0.8 * len(pts)
