"""The plane pass (hopmatch.matching.plane_pass): against plain references of its support
count, search and field test, on a synthetic receding surface."""

from __future__ import annotations

import cv2
import naive_guided as ng
import numpy as np
import pytest
from synthetic_pairs import texture

from hopmatch import _threads
from hopmatch.feature.descriptor import gradient_windows
from hopmatch.matching import guided as guided_module
from hopmatch.matching import plane_pass as pp
from hopmatch.matching.guided_results import empty_guided
from hopmatch.matching.neighbourhood import query_neighbours
from hopmatch.matching.params import matcher_config
from hopmatch.matching.plane_pass import plane_pass, plane_support

#: The surface: disparity a + c y (a road, a floor: it grows downwards), no x term.
A, C = 4.0, 0.3
SEARCH, BACK, SHOULDER, LIMIT = 3, 1, 3, 1.0


def receding_pair(n=240, seed=3):
    """``(g_l, g_r, points, windows)``: a textured left image, the right one the same
    surface at disparity ``A + C y``, and ``n`` left points inside both with their 9 x 9
    windows."""
    rng = np.random.default_rng(seed)
    h, w = 120, 200
    g_l = texture(h, w, seed, sigma=1.2).astype(np.float32)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    g_r = cv2.remap(g_l, xx + A + C * yy, yy, cv2.INTER_CUBIC)
    pts = np.c_[rng.uniform(60, 185, n), rng.uniform(10, 105, n)].astype(np.float32)
    return g_l, g_r, pts, gradient_windows(g_l, pts, 9)


def truth(pts):
    return A + C * pts[:, 1].astype(np.float64)


def support_reference(queries, matched, disp, planes, half_w, half_h, tol):
    """Per query: the plane most of its neighbours lie on (first of equal counts; -1 and 0
    when none), and their number; and the number of its neighbours."""
    best, count, total = [], [], []
    for nb in ng.neighbours(queries, matched, half_w, half_h):
        counts = [sum(abs(disp[j] - (a + b * matched[j, 0] + c * matched[j, 1])) <= tol
                      for j in nb) for a, b, c in planes]
        k = max(range(len(planes)), key=lambda i: (counts[i], -i))
        best.append(k if counts[k] > 0 else -1)
        count.append(counts[k])
        total.append(len(nb))
    return np.array(best), np.array(count), np.array(total)


def test_plane_support_matches_the_reference():
    rng = np.random.default_rng(1)
    matched = np.c_[rng.uniform(0, 200, 300), rng.uniform(0, 120, 300)].astype(np.float32)
    planes = np.array([[4.0, 0.0, 0.3], [20.0, -0.05, 0.0], [4.0, 0.0, 0.3]])
    which = rng.integers(0, 3, len(matched))  # on the first, the second, or neither
    disp = np.where(which == 0, 4.0 + 0.3 * matched[:, 1],
                    np.where(which == 1, 20.0 - 0.05 * matched[:, 0], rng.uniform(0, 40, 300)))
    disp = disp + rng.uniform(-0.9, 0.9, len(disp))
    queries = np.c_[rng.uniform(0, 200, 80), rng.uniform(0, 120, 80)].astype(np.float32)
    off, idx = query_neighbours(queries, matched, np.float32(20), np.float32(10))
    got = plane_support(off, idx, matched, disp, planes, 1.0)
    want = support_reference(queries, matched, disp, planes, 20, 10, 1.0)
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])
    assert (got[0] == 2).sum() == 0  # a repeated plane never wins: the first does
    assert (got[0] >= 0).any() and (got[0] == 1).any()


@pytest.mark.parametrize("threads", [1, 2])
def test_plane_pass_keeps_exactly_what_passes_its_tests(threads, monkeypatch):
    """Every left point left unmatched is accepted exactly when the references accept it:
    enough matched neighbours on the plane (and most of them), the row search around the
    plane's disparity with windows sheared by its gradient, and a field above the minimum
    with the neighbours carried along the plane. Most of them are, near the truth."""
    monkeypatch.setattr(_threads, "MIN_CHUNK", 8)  # several chunks with two threads
    g_l, g_r, pts, desc = receding_pair()
    rng = np.random.default_rng(5)
    config = matcher_config({})
    matched_idx = np.arange(0, len(pts), 3)
    unmatched = np.setdiff1d(np.arange(len(pts)), matched_idx)
    m_left = pts[matched_idx]
    m_right = np.c_[m_left[:, 0] - truth(m_left), m_left[:, 1]].astype(np.float32)
    m_sim = rng.uniform(0.0, 0.2, len(matched_idx))
    planes = np.array([[A, 0.0, C], [A + 5.0, 0.0, 0.0]])
    yoff = np.zeros(len(pts))
    gm = plane_pass(pts, desc, g_l, g_r, m_left, m_right, m_sim, unmatched, yoff, config,
                    planes, search=SEARCH, back=BACK, shoulder=SHOULDER,
                    gradient_limit=LIMIT, threads=threads)
    half_w, half_h = config.neighbour_width / 2, config.neighbour_height / 2
    disp = m_left[:, 0].astype(np.float64) - m_right[:, 0]
    best, count, total = support_reference(pts[unmatched], m_left, disp, planes, half_w,
                                           half_h, pp.PLANE_PASS_TOLERANCE)
    nb = ng.neighbours(pts[unmatched], m_left, half_w, half_h)
    want = {}
    for m, i in enumerate(unmatched):
        if not (count[m] >= pp.PLANE_PASS_SUPPORT and count[m] >= pp.PLANE_PASS_SHARE
                * total[m]):
            continue
        a, b, c = planes[best[m]]
        x, y = float(pts[i, 0]), float(pts[i, 1])
        ok, _, _, xr, sim = ng.row_search_one(
            g_l, g_r, x, y, desc[i], x - (a + b * x + c * y), 0.0, pp.PLANE_PASS_RADIUS,
            SEARCH, BACK, pp.PLANE_PASS_ZNCC, pp.PLANE_PASS_MARGIN, config.gain_tolerance,
            shoulder=SHOULDER, shear=c)
        if not ok:
            continue
        j = np.array(sorted(nb[m]))
        u = ng.field((x, y), (xr, y), sim, m_left[j].astype(np.float64),
                     m_right[j].astype(np.float64), m_sim[j], config.theta, config.slope,
                     config.similarity_weight, config.input_bias, gradient=(b, c))
        if u > pp.PLANE_PASS_FIELD:
            want[int(i)] = (xr, u)
    assert sorted(want) == sorted(gm.query_idx.tolist())
    assert len(want) > 0.5 * len(unmatched)
    for m, i in enumerate(gm.query_idx):
        assert gm.right_points[m, 0] == pytest.approx(want[int(i)][0], abs=1e-4)
        assert gm.fields[m] == pytest.approx(want[int(i)][1], abs=1e-6)
    err = pts[gm.query_idx, 0] - gm.right_points[:, 0] - truth(pts[gm.query_idx])
    assert np.abs(err).max() <= 0.35
    np.testing.assert_array_equal(gm.right_points[:, 1], pts[gm.query_idx, 1])


def test_plane_pass_needs_neighbours_on_a_plane():
    """A plane that the matched neighbours do not lie on searches nothing; no plane, no
    left point or no match gives nothing."""
    g_l, g_r, pts, desc = receding_pair(n=120)
    config = matcher_config({})
    matched_idx = np.arange(0, len(pts), 2)
    unmatched = np.setdiff1d(np.arange(len(pts)), matched_idx)
    m_left = pts[matched_idx]
    m_right = np.c_[m_left[:, 0] - truth(m_left), m_left[:, 1]].astype(np.float32)
    m_sim = np.zeros(len(matched_idx))
    kw = dict(search=SEARCH, back=BACK, shoulder=SHOULDER, gradient_limit=LIMIT)
    yoff = np.zeros(len(pts))
    args = (pts, desc, g_l, g_r, m_left, m_right, m_sim)
    right = plane_pass(*args, unmatched, yoff, config, np.array([[A, 0.0, C]]), **kw)
    assert len(right.query_idx) > 0.5 * len(unmatched)
    elsewhere = plane_pass(*args, unmatched, yoff, config, np.array([[A + 3.0, 0.0, C]]), **kw)
    assert len(elsewhere.query_idx) == 0
    for planes, todo, ml in ((np.zeros((0, 3)), unmatched, m_left),
                             (np.array([[A, 0.0, C]]), unmatched[:0], m_left),
                             (np.array([[A, 0.0, C]]), unmatched, m_left[:0])):
        got = plane_pass(pts, desc, g_l, g_r, ml, m_right[:len(ml)], m_sim[:len(ml)], todo,
                         yoff, config, planes, **kw)
        assert len(got.query_idx) == 0 and got.right_points.shape == (0, 2)


@pytest.mark.parametrize("on", [True, False])
def test_guided_rounds_run_the_plane_pass_on_the_seeds_planes(on, monkeypatch):
    """guided_rounds hands the receding planes the seeds found to the plane pass, with the
    left points still unmatched and every match so far, and returns what it found (and
    what the round after it propagated); with ``GUIDED_PLANE_PASS`` off it is not run."""
    monkeypatch.setattr(guided_module, "GUIDED_PLANE_PASS", on)
    g_l, g_r, pts, desc = receding_pair()
    config = matcher_config({"max_disparity": 40})
    qi = np.arange(0, len(pts), 3)
    pts_r = np.c_[pts[qi, 0] - truth(pts[qi]), pts[qi, 1]].astype(np.float32)
    desc_r = gradient_windows(g_r, pts_r, 9)
    ti = np.arange(len(qi))
    planes = np.array([[A, 0.0, C]])
    monkeypatch.setattr(guided_module, "seed_search",
                        lambda *a, **k: (empty_guided(), planes))
    calls = []
    real = guided_module.plane_pass

    def spy(pts_l, desc_l, gl, gr, m_left, m_right, m_sim, unmatched, *args, **kwargs):
        got = real(pts_l, desc_l, gl, gr, m_left, m_right, m_sim, unmatched, *args, **kwargs)
        calls.append((np.array(m_left), np.array(unmatched), args[2], got))
        return got

    monkeypatch.setattr(guided_module, "plane_pass", spy)
    out = guided_module.guided_rounds(pts, pts_r, desc, desc_r, g_l, g_r, qi, ti,
                                      np.zeros(len(pts)), config, rounds=1, seed_rounds=1,
                                      threads=1)
    assert len(calls) == int(on)
    if on:
        m_left, unmatched, given_planes, got = calls[0]
        np.testing.assert_array_equal(given_planes, planes)
        assert len(got.query_idx) > 0
        # the guided matches come in round order: round 0's, the pass's, the round after
        k = int(np.flatnonzero(out.query_idx == got.query_idx[0])[0])
        np.testing.assert_array_equal(out.query_idx[k:k + len(got.query_idx)], got.query_idx)
        before = np.r_[qi, out.query_idx[:k]]
        assert set(unmatched.tolist()) == set(range(len(pts))) - set(before.tolist())
        np.testing.assert_array_equal(m_left, pts[before])
