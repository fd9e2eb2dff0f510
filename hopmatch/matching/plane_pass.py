"""The plane pass: the left points still unmatched among the matches of a receding plane,
searched at the plane's disparity (beyond the paper; docs/method.md section 4.2, "The
plane pass").

The seeds find the receding planes (a road, a floor) that hundreds of their peaks lie on
(:func:`~hopmatch.matching.planes.receding_planes`). Such a plane predicts the disparity at
every point of its surface, and its gradient the shear of the right window there, better
than a point's few matched neighbours do, and the fine texture of a road gives broad,
repeated ZNCC peaks that the guided rounds' uniqueness margin refuses. A left point whose
matched neighbours lie on such a plane (enough of them, and most) is searched there
without that margin and with a lower ZNCC floor, and kept as every guided match is: the
best peak near the plane's disparity, confirmed by searching back, and a positive field
with its neighbours carried along the plane (eq. 12's bracket, the network's own test).
"""

from __future__ import annotations

import numpy as np

from .._kernels import guided as _k
from .guided_kernels import continuity_fields, row_searches
from .guided_results import GuidedMatches, accepted_matches, empty_guided
from .neighbourhood import half_sides, query_neighbours
from .planes import plane_residuals
from .similarity import EPS

#: Largest distance (px of disparity) of a matched neighbour from the plane for it to
#: count as lying on it.
PLANE_PASS_TOLERANCE = 1.0
#: Fewest matched neighbours (in the network's window) on the plane for a left point to
#: be searched there...
PLANE_PASS_SUPPORT = 4
#: ...and the smallest share of its matched neighbours they make.
PLANE_PASS_SHARE = 0.5
#: Largest distance (px) between the peak and the plane's disparity.
PLANE_PASS_RADIUS = 1.0
#: Smallest ZNCC of an accepted peak (the guided rounds': 0.8).
PLANE_PASS_ZNCC = 0.6
#: Smallest lead of the peak over the best ZNCC ``shoulder`` or more columns away (the
#: guided rounds': 0.1, then 0.2).
PLANE_PASS_MARGIN = 0.0
#: Smallest field of an accepted match (0: the network's own test).
PLANE_PASS_FIELD = 0.0


def plane_support(offsets, idx, m_left, m_disp, planes,
                  tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """``(plane, count)`` per query: the plane (row of ``planes``, ``(a, b, c)`` of ``d = a
    + b x + c y``) that most of its neighbours ``idx[offsets[q]:offsets[q + 1]]`` (indices
    into ``m_left``, whose disparities are ``m_disp``) lie within ``tolerance`` of (the
    first of equal counts; -1 with count 0 when none does), and how many do."""
    n = len(offsets) - 1
    owner = np.repeat(np.arange(n), np.diff(offsets))
    p = np.asarray(m_left, dtype=np.float64)[idx]
    d = np.asarray(m_disp, dtype=np.float64)[idx]
    best = np.full(n, -1, dtype=np.int64)
    count = np.zeros(n, dtype=np.int64)
    for k, coef in enumerate(np.asarray(planes, dtype=np.float64).reshape(-1, 3)):
        on = plane_residuals(p, d, coef) <= tolerance
        cnt = np.bincount(owner[on], minlength=n)
        better = cnt > count
        best[better] = k
        count[better] = cnt[better]
    return best, count


def plane_pass(pts_l, desc_l, g_l, g_r, m_left, m_right, m_sim, unmatched, y_offset,
               config, planes, *, search: int, back: int, shoulder: int,
               gradient_limit: float, threads: int | None = None) -> GuidedMatches:
    """Matches of the left points ``unmatched`` (indices into ``pts_l``) on the receding
    ``planes`` ((K, 3) rows ``(a, b, c)``, ``d = a + b x + c y``).

    A point is searched when at least :data:`PLANE_PASS_SUPPORT` of its matched neighbours
    (``m_left``/``m_right``, the pairs matched so far, in the network's window of
    ``config``), and :data:`PLANE_PASS_SHARE` of them, lie within
    :data:`PLANE_PASS_TOLERANCE` of one plane: along its row (``yl - y_offset``) around the
    plane's disparity, right windows sheared by the plane's gradient along y
    (:func:`~hopmatch._kernels.guided.row_search`: the best ZNCC within ``search`` px, at
    most :data:`PLANE_PASS_RADIUS` from the plane, a local maximum of ZNCC at least
    :data:`PLANE_PASS_ZNCC` and ahead by :data:`PLANE_PASS_MARGIN` of the best one
    ``shoulder`` or more columns away, and searching back ``back`` px finds no better left
    window). It is kept when its field (:func:`~hopmatch._kernels.guided.continuity_field`,
    neighbours carried along the plane's gradient, each component clipped to
    ``gradient_limit``; ``m_sim`` the matched pairs' eq. 7 distances) exceeds
    :data:`PLANE_PASS_FIELD`. Each point's search and field come from its own inputs: the
    result is the same for any ``threads``.
    """
    unmatched = np.asarray(unmatched, dtype=np.int64)
    planes = np.asarray(planes, dtype=np.float64).reshape(-1, 3)
    if len(planes) == 0 or len(unmatched) == 0 or len(m_left) == 0:
        return empty_guided()
    m_left = np.ascontiguousarray(m_left, dtype=np.float32)
    m_right = np.ascontiguousarray(m_right, dtype=np.float32)
    m_disp = m_left[:, 0].astype(np.float64) - m_right[:, 0]
    qpts = np.ascontiguousarray(pts_l[unmatched])
    off, idx = query_neighbours(qpts, m_left,
                                *half_sides(config.neighbour_width, config.neighbour_height),
                                threads=threads)
    plane, support = plane_support(off, idx, m_left, m_disp, planes, PLANE_PASS_TOLERANCE)
    rows = np.flatnonzero((support >= PLANE_PASS_SUPPORT)
                          & (support >= PLANE_PASS_SHARE * np.diff(off)))
    if len(rows) == 0:
        return empty_guided()
    q = unmatched[rows]
    coef = planes[plane[rows]]
    x = pts_l[q, 0].astype(np.float64)
    y = pts_l[q, 1].astype(np.float64)
    centre = np.ascontiguousarray(x - (coef[:, 0] + coef[:, 1] * x + coef[:, 2] * y))
    gx = np.ascontiguousarray(np.clip(coef[:, 1], -gradient_limit, gradient_limit))
    gy = np.ascontiguousarray(np.clip(coef[:, 2], -gradient_limit, gradient_limit))
    yoff = np.ascontiguousarray(np.asarray(y_offset, dtype=np.float64)[q])
    status, best, second, xr, sim = row_searches(
        g_l, g_r, pts_l, desc_l, q, centre, yoff, PLANE_PASS_RADIUS, search, back,
        PLANE_PASS_ZNCC, PLANE_PASS_MARGIN, EPS, config.gain_tolerance, False, False,
        shoulder, gy, threads=threads)
    ok = status == _k.FOUND
    yr = y - yoff
    u = continuity_fields(np.ascontiguousarray(pts_l[q]), np.where(ok, xr, np.nan), yr, sim,
                          off, idx, rows, m_left, m_right, np.asarray(m_sim, dtype=np.float64),
                          config.theta, config.slope, config.similarity_weight,
                          config.input_bias, gx, gy, threads=threads)
    keep = ok & (np.nan_to_num(u, nan=-np.inf) > PLANE_PASS_FIELD)
    return accepted_matches(keep, q, xr, yr, u, best, second, sim)
