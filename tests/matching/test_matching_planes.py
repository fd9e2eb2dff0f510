"""Receding planes among the seeds' peaks (hopmatch.matching.planes): against a slow,
plain reference, and what they find on synthetic peaks."""

from __future__ import annotations

import numpy as np
import pytest

from hopmatch.matching import planes
from hopmatch.matching.planes import receding_plane_inliers

RNG = np.random.default_rng(11)


def plane_points(n, coef, noise, rng, box=(0.0, 600.0, 0.0, 400.0)):
    """``n`` points uniform in ``box`` whose disparity lies on ``coef`` = (a, b, c) within
    +-``noise``, with the plane's own gradient as their local one (slightly off)."""
    p = np.c_[rng.uniform(box[0], box[1], n), rng.uniform(box[2], box[3], n)]
    d = coef[0] + coef[1] * p[:, 0] + coef[2] * p[:, 1] + rng.uniform(-noise, noise, n)
    gx = coef[1] + rng.normal(0, 0.01, n)
    gy = coef[2] + rng.normal(0, 0.01, n)
    return p, d, gx, gy


def scattered(n, rng):
    """``n`` wrong peaks: anywhere, any disparity in 0..100, local gradients anyhow."""
    p = np.c_[rng.uniform(0, 600, n), rng.uniform(0, 400, n)]
    return p, rng.uniform(0, 100, n), rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)


def stack(*parts):
    return tuple(np.concatenate([part[k] for part in parts]) for k in range(4))


def reference(p, d, gx, gy, tol, min_in, min_slant, max_planes, hypotheses, sample_max):
    """The same search written plainly: loops over candidates and points."""
    n = len(d)
    out = [False] * n
    slant = [float(np.hypot(gx[i], gy[i])) for i in range(n)]
    cand = [i for i in range(n) if np.isfinite(d[i]) and np.isfinite(slant[i])
            and slant[i] >= min_slant]
    if n < max(min_in, 3) or not cand:
        return np.array(out)
    stride = np.linspace(0, len(cand) - 1, min(hypotheses, len(cand))).astype(np.int64)
    hyp = [(d[i] - gx[i] * p[i, 0] - gy[i] * p[i, 1], gx[i], gy[i])
           for i in (cand[s] for s in stride)]
    free = [bool(np.isfinite(d[i])) for i in range(n)]

    def res(j, c):
        return abs(d[j] - (c[0] + c[1] * p[j, 0] + c[2] * p[j, 1]))

    for _ in range(max_planes):
        idx = [i for i in range(n) if free[i]]
        if len(idx) < min_in or not hyp:
            break
        pick = np.linspace(0, len(idx) - 1, min(sample_max, len(idx))).astype(np.int64)
        sample = [idx[s] for s in pick]
        counts = [sum(res(j, h) <= tol for j in sample) for h in hyp]
        k = counts.index(max(counts))
        coef = hyp[k]
        for _ in range(planes.PLANE_REFITS):
            near = [j for j in idx if res(j, coef) <= tol]
            if len(near) < 3:
                break
            coef = np.linalg.lstsq(np.array([[1.0, p[j, 0], p[j, 1]] for j in near]),
                                   np.array([d[j] for j in near]), rcond=None)[0]
        inl = [j for j in idx if res(j, coef) <= tol]
        if len(inl) < min_in or np.hypot(coef[1], coef[2]) < min_slant:
            break
        for j in inl:
            out[j] = True
            free[j] = False
        del hyp[k]
    return np.array(out)


@pytest.mark.parametrize("case", ["one", "two", "none", "flat", "sample"])
def test_receding_planes_match_the_reference(monkeypatch, case):
    rng = np.random.default_rng(len(case))
    parts = [scattered(600, rng)]
    if case in ("one", "two", "sample"):
        parts.append(plane_points(500, (-20.0, 0.01, 0.2), 0.3, rng))
    if case == "two":
        parts.append(plane_points(400, (5.0, 0.12, 0.0), 0.3, rng, (300, 600, 0, 200)))
    if case == "flat":
        parts.append(plane_points(700, (40.0, 0.0, 0.0), 0.3, rng))
    if case == "sample":  # more points than PLANE_SAMPLE, fewer candidates than points
        monkeypatch.setattr(planes, "PLANE_SAMPLE", 300)
    p, d, gx, gy = stack(*parts)
    d[::97] = np.nan  # unknown disparities and gradients are nobody's inliers
    gx[5::89] = np.nan
    kw = dict(tolerance=0.5, min_inliers=200, min_slant=0.1, max_planes=3, hypotheses=64)
    got = receding_plane_inliers(p, d, gx, gy, **kw)
    want = reference(p, d, gx, gy, 0.5, 200, 0.1, 3, 64, planes.PLANE_SAMPLE)
    np.testing.assert_array_equal(got, want)
    assert got.any() == (case in ("one", "two", "sample"))


def test_a_road_among_scattered_peaks_is_found_and_only_it():
    """Nearly every point of a receding plane, and of the scattered peaks only those that
    happen to lie within the tolerance of it."""
    rng = np.random.default_rng(3)
    coef = (-30.0, 0.0, 0.25)  # a road: disparity grows downwards
    road = plane_points(800, coef, 0.35, rng, (0, 600, 120, 400))
    p, d, gx, gy = stack(road, scattered(2000, rng))
    got = receding_plane_inliers(p, d, gx, gy)
    assert got[:800].mean() > 0.99
    off = np.abs(d[800:] - (coef[0] + coef[1] * p[800:, 0] + coef[2] * p[800:, 1]))
    assert (off[got[800:]] <= 0.6).all()  # chance inliers only, within a refit's tolerance
    assert got[800:].sum() < 0.05 * 2000


def test_receding_planes_give_each_inlier_its_plane():
    """receding_planes: the planes' coefficients (least squares on their inliers, near the
    truth), each inlier labelled with the plane it was counted on, in the order found (the
    larger first), and the labels' inliers exactly receding_plane_inliers'."""
    rng = np.random.default_rng(4)
    road, wall = (-30.0, 0.0, 0.25), (10.0, 0.15, 0.0)
    args = stack(plane_points(900, road, 0.3, rng, (0, 600, 150, 400)),
                 plane_points(600, wall, 0.3, rng, (300, 600, 0, 150)), scattered(800, rng))
    coef, label = planes.receding_planes(*args)
    assert coef.shape == (2, 3) and label.dtype == np.int64
    np.testing.assert_allclose(coef[0], road, atol=0.05)
    np.testing.assert_allclose(coef[1], wall, atol=0.05)
    assert (label[:900] == 0).mean() > 0.99 and (label[900:1500] == 1).mean() > 0.99
    np.testing.assert_array_equal(label >= 0, receding_plane_inliers(*args))
    p, d = args[0], args[1]
    for k in range(2):  # each plane is the least-squares fit to its own inliers
        on = label == k
        np.testing.assert_array_less(planes.plane_residuals(p[on], d[on], coef[k]), 0.5 + 1e-9)
        lsq = np.linalg.lstsq(np.c_[np.ones(on.sum()), p[on]], d[on], rcond=None)[0]
        np.testing.assert_allclose(coef[k], lsq, atol=0.02)
    none, lab = planes.receding_planes(*scattered(300, rng))
    assert none.shape == (0, 3) and (lab == -1).all()


def test_planes_need_enough_points_and_a_slant():
    rng = np.random.default_rng(5)
    few = stack(plane_points(planes.PLANE_MIN_INLIERS - 20, (0, 0.0, 0.3), 0.2, rng),
                scattered(200, rng))
    assert not receding_plane_inliers(*few).any()  # below PLANE_MIN_INLIERS
    # enough points, but below PLANE_MIN_SHARE of all the peaks
    n = planes.PLANE_MIN_INLIERS + 20
    p, d, _, _ = scattered(int(1.5 * n / planes.PLANE_MIN_SHARE), rng)
    flat = np.zeros(len(d))  # fronto-parallel local planes: the candidates are the plane's
    diluted = stack(plane_points(n, (0, 0.0, 0.3), 0.2, rng), (p, d, flat, flat))
    assert not receding_plane_inliers(*diluted).any()
    assert receding_plane_inliers(*diluted, min_inliers=n - 10).any()
    # a fronto-parallel wall of many points: not a receding plane
    wall = stack(plane_points(2000, (50, 0.0, 0.0), 0.2, rng), scattered(200, rng))
    assert not receding_plane_inliers(*wall).any()
    assert receding_plane_inliers(*wall, min_slant=0.0)[:2000].mean() > 0.99
    # nothing at all, and no candidate with a gradient
    empty = np.zeros((0, 2)), np.zeros(0), np.zeros(0), np.zeros(0)
    assert receding_plane_inliers(*empty).shape == (0,)
    p, d, _, _ = stack(plane_points(1000, (0, 0.0, 0.3), 0.2, rng))
    nan = np.full(len(d), np.nan)
    assert not receding_plane_inliers(p, d, nan, nan).any()


def test_planes_are_deterministic_and_bounded(monkeypatch):
    rng = np.random.default_rng(9)
    args = stack(plane_points(700, (-10, 0.05, 0.2), 0.3, rng), scattered(3000, rng))
    first = receding_plane_inliers(*args)
    assert first.any()
    np.testing.assert_array_equal(receding_plane_inliers(*args), first)
    # the candidates are ranked on at most PLANE_SAMPLE points x PLANE_HYPOTHESES planes
    seen = []
    best = planes.best_hypothesis

    def recording(p, d, hyp, tol):
        seen.append((len(d), len(hyp)))
        return best(p, d, hyp, tol)

    monkeypatch.setattr(planes, "best_hypothesis", recording)
    receding_plane_inliers(*args)
    assert seen and all(n <= planes.PLANE_SAMPLE and h <= planes.PLANE_HYPOTHESES
                        for n, h in seen)
