"""Receding planes that many seeds agree on (beyond the paper; docs/method.md section 4.2,
"Seeds on a receding plane").

A plane in the scene is an affine function of the image position in a rectified pair's
disparity, ``d = a + b x + c y``. A road, a floor or a wall seen at an angle is such a plane
over a large part of the image, with a steady disparity gradient, and there the seeds'
field test (:func:`~hopmatch.matching.guided.seed_pass`) keeps few of the peaks its
whole-row search finds: its sheared windows correlate less well than a fronto-parallel
surface's, eq. 10's similarity term then lowers every neighbour's compatibility, and a
field above 12 is rarely reached. Hundreds of peaks that lie on one slanted plane within
half a pixel are evidence of another kind: wrong peaks scatter in disparity and do not
line up over an image. :func:`receding_plane_inliers` finds such planes among the peaks.
"""

from __future__ import annotations

import numpy as np

#: Largest distance (px of disparity) of a peak from a plane it lies on.
PLANE_TOLERANCE = 0.5
#: Fewest peaks on one plane for it to count (the slanted chance planes of the 22 shared
#: scenes hold at most about 320, with noise in both views: docs/parameters.md, "Seeds on a
#: receding plane").
PLANE_MIN_INLIERS = 400
#: ...and at least this share of all the peaks (the more peaks an image has, the more
#: line up by chance).
PLANE_MIN_SHARE = 0.06
#: Smallest disparity gradient ``hypot(b, c)`` (px per px) of a plane that counts: a
#: receding surface. Fronto-parallel planes are left to the field test, which keeps their
#: seeds well, while chance planes through several objects at one depth are nearly
#: fronto-parallel.
PLANE_MIN_SLANT = 0.1
#: Most planes found in one pair.
PLANE_MAX = 3
#: Most candidate planes tried per plane found: the local planes of that many peaks, taken
#: at an even stride through the peaks.
PLANE_HYPOTHESES = 128
#: Least-squares refits of the best candidate to the points within the tolerance of it
#: (each to those of the refit before).
PLANE_REFITS = 3
#: Most peaks the candidates are ranked on (taken at an even stride; the best candidate's
#: inliers are then those among all the peaks).
PLANE_SAMPLE = 1024


def plane_residuals(points, disparity, coef) -> np.ndarray:
    """``|disparity - (a + b x + c y)|`` of each point ``(x, y)`` for ``coef = (a, b,
    c)``."""
    p = np.asarray(points, dtype=np.float64)
    return np.abs(np.asarray(disparity, dtype=np.float64)
                  - (coef[0] + coef[1] * p[:, 0] + coef[2] * p[:, 1]))


def best_hypothesis(points, disparity, hyp, tolerance) -> tuple[int, int]:
    """``(index, count)`` of the plane of ``hyp`` ((H, 3) ``(a, b, c)`` rows) with the most
    points within ``tolerance`` of it (the first of equal counts)."""
    p = np.asarray(points, dtype=np.float64)
    d = np.asarray(disparity, dtype=np.float64)
    r = np.abs(d[None, :] - (hyp[:, :1] + hyp[:, 1:2] * p[None, :, 0]
                             + hyp[:, 2:3] * p[None, :, 1]))
    counts = (r <= tolerance).sum(axis=1)
    k = int(np.argmax(counts))
    return k, int(counts[k])


def receding_plane_inliers(points, disparity, gx, gy, *, tolerance: float | None = None,
                           min_inliers: int | None = None, min_slant: float | None = None,
                           max_planes: int | None = None,
                           hypotheses: int | None = None) -> np.ndarray:
    """(N,) bool: which points lie within ``tolerance`` of a slanted plane that at least
    ``min_inliers`` of them lie on (:func:`receding_planes`' labels, same arguments)."""
    return receding_planes(points, disparity, gx, gy, tolerance=tolerance,
                           min_inliers=min_inliers, min_slant=min_slant,
                           max_planes=max_planes, hypotheses=hypotheses)[1] >= 0


def receding_planes(points, disparity, gx, gy, *, tolerance: float | None = None,
                    min_inliers: int | None = None, min_slant: float | None = None,
                    max_planes: int | None = None,
                    hypotheses: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(planes, label)``: the slanted planes that at least ``min_inliers`` of the points
    lie on within ``tolerance``, (K, 3) float64 rows ``(a, b, c)`` of ``d = a + b x + c
    y`` in the order found, and (N,) int64 ``label``, the plane each point was counted on
    (-1: none).

    ``points`` (N, 2) are left positions ``(x, y)``, ``disparity`` (N,) their disparities,
    ``gx``, ``gy`` (N,) the local disparity gradient at each (NaN where unknown). The
    candidate planes are the points' own local planes, ``d_i + gx_i (x - x_i) + gy_i (y -
    y_i)``, of the points whose gradient is at least ``min_slant`` (``hypot(gx, gy)``), at
    most ``hypotheses`` of them taken at an even stride. Up to ``max_planes`` times: the
    candidate with the most points within ``tolerance`` among at most
    :data:`PLANE_SAMPLE` of the points on no plane yet (at an even stride) is refitted by
    least squares to the points on no plane within ``tolerance`` of it, :data:`PLANE_REFITS`
    times (each refit to the points near the one before), and the points within
    ``tolerance`` of the last fit are its inliers when they number at least ``min_inliers``
    and its gradient is at least ``min_slant``; otherwise the search stops. Deterministic:
    no random sampling. None for the module's ``PLANE_*`` values (``min_inliers``: the
    larger of :data:`PLANE_MIN_INLIERS` and :data:`PLANE_MIN_SHARE` of the points).
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    d = np.asarray(disparity, dtype=np.float64).reshape(-1)
    tolerance = PLANE_TOLERANCE if tolerance is None else tolerance
    min_inliers = (max(PLANE_MIN_INLIERS, PLANE_MIN_SHARE * len(d)) if min_inliers is None
                   else min_inliers)
    min_slant = PLANE_MIN_SLANT if min_slant is None else min_slant
    max_planes = PLANE_MAX if max_planes is None else max_planes
    hypotheses = PLANE_HYPOTHESES if hypotheses is None else hypotheses
    gx = np.asarray(gx, dtype=np.float64).reshape(-1)
    gy = np.asarray(gy, dtype=np.float64).reshape(-1)
    label = np.full(len(d), -1, dtype=np.int64)
    planes = []
    slant = np.hypot(gx, gy)
    cand = np.flatnonzero(np.isfinite(d) & np.isfinite(slant) & (slant >= min_slant))
    if len(d) < max(min_inliers, 3) or len(cand) == 0:
        return np.zeros((0, 3)), label
    cand = cand[np.linspace(0, len(cand) - 1, min(hypotheses, len(cand))).astype(np.int64)]
    hyp = np.stack((d[cand] - gx[cand] * p[cand, 0] - gy[cand] * p[cand, 1], gx[cand],
                    gy[cand]), axis=1)
    free = np.isfinite(d)
    for _ in range(max_planes):
        idx = np.flatnonzero(free)
        if len(idx) < min_inliers or len(hyp) == 0:
            break
        sample = idx[np.linspace(0, len(idx) - 1, min(PLANE_SAMPLE, len(idx))).astype(np.int64)]
        k, _ = best_hypothesis(p[sample], d[sample], hyp, tolerance)
        coef = hyp[k]
        for _ in range(PLANE_REFITS):  # a candidate's gradient is a local estimate
            near = idx[plane_residuals(p[idx], d[idx], coef) <= tolerance]
            if len(near) < 3:
                break
            coef = np.linalg.lstsq(np.c_[np.ones(len(near)), p[near]], d[near], rcond=None)[0]
        inliers = idx[plane_residuals(p[idx], d[idx], coef) <= tolerance]
        if len(inliers) < min_inliers or np.hypot(coef[1], coef[2]) < min_slant:
            break
        label[inliers] = len(planes)
        planes.append(coef)
        free[inliers] = False
        hyp = np.delete(hyp, k, axis=0)
    return np.reshape(planes, (-1, 3)).astype(np.float64), label
