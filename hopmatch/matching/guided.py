"""The guided second pass: support propagation from the network's matches to the left
points it left unmatched (beyond the paper; docs/method.md).

The network stays the judge. A left point that the network left unmatched gets a
disparity only when the network would keep it: its matched neighbours (SPEC section 4's
``neighbour_width x neighbour_height`` window) predict a disparity (a local plane fitted to
those near their median, or the median), a row search of the ZNCC of the gradient windows
(eqs. 8-9; where that peak is too weak, of the grey-level windows:
:class:`~hopmatch.matching.guided_results.GreyFallback`)
finds a clear peak near it that searching back from the right image confirms,
and the pair, alone in its row and column, would have a positive local field (eq. 12's
bracket, with eq. 5's compatibility of eq. 10's ``X`` against every matched neighbour,
each carried along the local plane's disparity gradient so that a slanted surface counts
as continuous, and the network's input bias). :func:`guided_rounds` repeats the pass,
propagating from the guided matches too (later rounds with a larger margin, a field above
3 and, for points with too few matched neighbours, a larger window), then seeds the
points still unmatched (:func:`seed_pass`: a search of the whole disparity range whose
peaks are kept where they agree with one another) and propagates from those, and last
searches the points among the matches of a receding plane the seeds found at the plane's
disparity (:func:`~hopmatch.matching.plane_pass.plane_pass`) and propagates from those.
"""

from __future__ import annotations

from dataclasses import fields

import numpy as np

from .._kernels import guided as _k
from ..feature.descriptor import cut_windows
from .guided_kernels import continuity_fields, row_searches
from .guided_results import (
    STAGE_CONTINUITY,
    STAGE_FEW_NEIGHBOURS,
    GreyFallback,
    GuidedMatches,
    GuidedSearch,
    accepted_matches,
    empty_guided,
    search_stages,
)
from .neighbourhood import half_sides, nearest_of, neighbour_planes, query_neighbours
from .plane_pass import plane_pass
from .planes import receding_planes
from .similarity import EPS, similarity_distance

#: Largest distance (px) between the peak of the row search and the predicted disparity.
GUIDED_RADIUS = 2.0
#: Half-width (px) of the wider range over which the peak must be the best, and unique.
GUIDED_SEARCH = 3
#: Half-width (px) of the search back from the right position along the left row.
GUIDED_BACK = 1
#: The uniqueness margin of the guided rounds is over the best other *peak* of the search
#: (past the valleys on either side of the best column), not over the best ZNCC
#: :data:`GUIDED_SHOULDER` or more columns away (False: the latter; the seeds always use
#: the latter). Off: docs/parameters.md, "Where the recall goes", says why.
GUIDED_PEAK_MARGIN = False
#: Without :data:`GUIDED_PEAK_MARGIN`, the uniqueness margin of the guided rounds and the
#: seeds is over the best ZNCC at least this many columns (px) from the peak: the columns
#: nearer are the peak's own flanks (2 until 2026-12-02; docs/parameters.md, "The
#: uniqueness margin's shoulder", measures 2, 3 and 4).
GUIDED_SHOULDER = 3
#: Smallest ZNCC of an accepted peak.
GUIDED_MIN_ZNCC = 0.8
#: Fewest matched neighbours a left point needs to be searched (the field test needs
#: about three compatible ones with the default input bias).
GUIDED_MIN_SUPPORT = 3
#: Neighbours within this many px of their median disparity make the local plane that
#: predicts the disparity (and its gradient) at an unmatched point.
GUIDED_PLANE_INLIER = 2.0
#: Fewest such neighbours for a plane (fewer: the median predicts, with no gradient).
GUIDED_PLANE_MIN = 4
#: Refits of the local plane: the neighbours within ``GUIDED_PLANE_INLIER`` px of the plane
#: fitted last (first of the median) make the next fit, so that on a slanted surface
#: (a road, a floor) the band follows the slope rather than cutting it across.
GUIDED_PLANE_REFITS = 1
#: Farthest the plane's value at the point may lie from the neighbours' median (px; -1:
#: ``GUIDED_PLANE_INLIER``, as until 2026-12-04): unbounded, since on a slanted surface
#: whose matches lie on one side of the point (the front of the propagation down a road)
#: the median lags the plane by the slope times their distance, and the median was then
#: predicted instead: docs/parameters.md, "Planes that follow a slope".
GUIDED_PLANE_REACH = np.inf
#: The prediction (and the local plane's gradient) comes from this many matched
#: neighbours nearest the point (Euclidean, in the window it takes them from; 0: all of
#: them). The field test still counts every neighbour in that window.
GUIDED_PREDICT_NEAREST = 0
#: Largest disparity gradient (px per px, each axis) the field test carries neighbours
#: along: the disparity-gradient limit of Pollard, Mayhew and Frisby.
GUIDED_GRADIENT_LIMIT = 1.0
#: Compare each query's window with right windows whose rows slide along its neighbours'
#: disparity plane (its gradient along y; :func:`~hopmatch._kernels.guided.row_search`'s
#: ``shear``): on a receding surface (a road, a floor) the right window is sheared.
GUIDED_SHEAR = True
#: The seeds' searches with sheared right windows (:data:`GUIDED_SHEAR`; the seeds have no
#: plane yet), each a disparity gradient along y, after the search with square windows:
#: a seed keeps the peak of the search that finds one with the highest ZNCC. They share
#: :data:`GUIDED_SEED_WORK` with it, the strongest seeds first.
GUIDED_SEED_SHEARS = (0.2,)
#: Rounds of the guided pass (:func:`guided_rounds`): each propagates from every match
#: found before it.
GUIDED_ROUNDS = 3
#: Smallest uniqueness margin of the rounds after the first (they propagate from guided
#: matches, one step further from the network's evidence).
GUIDED_LATER_MARGIN = 0.2
#: Smallest field of the matches of the rounds after the first (the network's test, and
#: the first round's, is > 0).
GUIDED_LATER_FIELD = 3.0
#: Growth of the support window per round: in round r (0-based) a left point with fewer
#: than ``min_support`` matched neighbours in the network's window is searched with the
#: window ``(1 + GUIDED_GROWTH) ** r`` times as wide and high (0: the network's window in
#: every round).
GUIDED_GROWTH = 1.0
#: Seeds (docs/parameters.md, "Seeds wherever the rounds failed"; until 2026-12-04 0.85,
#: 0.25 and 4): after the rounds, the left points still unmatched are searched along
#: their whole row (the disparity range); a peak with at least this ZNCC...
GUIDED_SEED_ZNCC = 0.8
#: ...ahead by this margin of the best one :data:`GUIDED_SHOULDER` or more pixels away...
GUIDED_SEED_MARGIN = 0.05
#: ...is kept when its field, with the matches and the other such peaks as neighbours,
#: exceeds this (eq. 12's bracket; the network's test is > 0).
GUIDED_SEED_FIELD = 12.0
#: The seeds are every left point still unmatched (False: only those with fewer than
#: :data:`GUIDED_MIN_SUPPORT` matched neighbours in the network's window, as until
#: 2026-12-04; a point whose neighbours lie on another surface was then never seeded).
GUIDED_SEED_ALL = True
#: The seeds' search keeps the part of the range whose right windows lie in the image
#: (near the image's left edge a point's whole range does not; False: such a point is not
#: searched).
GUIDED_SEED_CLIP = True
#: Guided rounds after the seeds, propagating from them (0: no seeds; 1, the default, adds
#: about 1 % of correct matches pooled and a quarter on KITTI #70: docs/parameters.md,
#: "Propagation and seeds" and "Seeds on, cheaply").
GUIDED_SEED_ROUNDS = 1
#: The rounds after the seeds search only the unmatched left points with a seed, or a
#: match of the last round before the seeds (then of the round before), among their
#: neighbours: elsewhere nothing changed since the last search (the round after the seeds
#: has round 1's settings, and no larger a window than the last round), so they find the
#: same (False: every unmatched point is searched again).
GUIDED_SEED_NEAR = True
#: A seed whose peak lies on a receding plane that hundreds of the seeds' peaks lie on
#: (:func:`~hopmatch.matching.planes.receding_plane_inliers`: a road, a floor) is kept when
#: its field exceeds :data:`GUIDED_PLANE_SEED_FIELD` rather than
#: :data:`GUIDED_SEED_FIELD` (False: the field test alone, as until 2026-12-06; docs/
#: parameters.md, "Seeds on a receding plane").
GUIDED_SEED_PLANES = True
#: Smallest field of a seed on such a plane (the network's own test, as in round 0).
GUIDED_PLANE_SEED_FIELD = 0.0
#: After the rounds that follow the seeds, the left points still unmatched whose matched
#: neighbours lie on one of the receding planes the seeds found are searched at the plane's
#: disparity (:func:`~hopmatch.matching.plane_pass.plane_pass`; False: not, as until
#: 2026-12-06; docs/parameters.md, "The plane pass")...
GUIDED_PLANE_PASS = True
#: ...and this many guided rounds (round 1's settings) propagate from what it found.
GUIDED_PLANE_ROUNDS = 1
#: Most ZNCC columns the seeds' search scores in all: each seed scores the columns of the
#: whole range (``2 outer + 3``), and beyond this budget only the strongest seeds are
#: searched (the left points come strongest first). Without it the search grows as the
#: cube of the image's width (seeds and range both grow): on motorcycle upsampled to
#: 2964 x 2000, about 1 s of 2.9 s. Of the shared scenes only aloe reaches it (4.14
#: million columns; one match less): docs/parameters.md, "A budget for the seeds".
GUIDED_SEED_WORK = 4_000_000
#: Where the row search on the feature image G finds a peak too weak (low ZNCC, or short of
#: the uniqueness margin) or fails the left-right check, the guided rounds search that
#: left point again on the pair's normalised grey levels (:class:`GreyFallback`; the
#: seeds search G only). False: G only. On since 2026-12-03:
#: 4.3 % more correct matches pooled over 22 scenes at the same precision, 5.7 % with
#: one view vignetted (docs/parameters.md, "Searching the grey levels where G fails").
GUIDED_FALLBACK = True
#: Smallest ZNCC of a peak of the fallback's search (the larger of this and the search's
#: own minimum): windows of grey levels are smoother than G's and correlate higher, so
#: the same ZNCC is weaker evidence there.
GUIDED_FALLBACK_MIN_ZNCC = 0.85


def _choose_csr(off_a, idx_a, off_b, idx_b, use_b):
    """One CSR list per query: query q's list from (off_b, idx_b) where ``use_b[q]``, else
    from (off_a, idx_a)."""
    cnt = np.where(use_b, np.diff(off_b), np.diff(off_a))
    off = np.zeros(len(cnt) + 1, dtype=np.int64)
    np.cumsum(cnt, out=off[1:])
    start = np.where(use_b, off_b[:-1] + len(idx_a), off_a[:-1])
    pos = np.repeat(start - off[:-1], cnt) + np.arange(off[-1])
    return off, np.concatenate((idx_a, idx_b)).astype(np.int32, copy=False)[pos]


def guided_pass(pts_l, pts_r, desc_l, desc_r, g_l, g_r, query_idx, train_idx, y_offset,
                config, *, margin: float = 0.1, radius: float | None = None,
                search: int | None = None, back: int | None = None,
                min_zncc: float | None = None, min_support: int | None = None,
                window: float = 1.0, min_field: float = 0.0,
                matched_similarity=None, new_from: int | None = None,
                fallback: GreyFallback | None = None,
                threads: int | None = None) -> GuidedMatches:
    """Guided matches of the left points the network left unmatched (rectified pairs).

    Parameters
    ----------
    pts_l, pts_r : (Nl, 2), (Nr, 2) float32 ndarray
        Left and right points (x, y), as matched by the network.
    desc_l, desc_r : float32 ndarray
        Their gradient windows (eqs. 8-9: ``descriptor_size ** 2`` columns, zero mean).
    g_l, g_r : (H, W) float32 ndarray
        The feature images (gradient magnitude) the windows were cut from.
    query_idx, train_idx : (M,) int ndarray
        The network's matches.
    y_offset : (Nl,) float ndarray
        The pair's vertical offset ``yl - yr`` at every left point: the right row searched
        is ``yl - y_offset``.
    config : MatcherConfig
        The network's parameters: its neighbourhood (``neighbour_width``,
        ``neighbour_height``), compatibility (``theta``, ``slope``), ``similarity_weight``
        and ``input_bias`` make the field test.
    margin : float
        Smallest lead of the peak's ZNCC over the best one at least two pixels away within
        ``+-search`` px (the uniqueness margin).
    radius, search, back, min_zncc, min_support
        See the module constants (None: ``GUIDED_RADIUS``, ``GUIDED_SEARCH``,
        ``GUIDED_BACK``, ``GUIDED_MIN_ZNCC``, ``GUIDED_MIN_SUPPORT``, read at the call).
    window : float
        A left point with fewer than ``min_support`` matched neighbours in the network's
        window gets them (for the prediction and the field test) from the smallest window
        2, 4... times as wide and high (at most ``window`` times) that has that many, or
        the largest (1: the network's window only).
    min_field : float
        Smallest field u of an accepted match (0: the network's own test, u > 0).
    matched_similarity : (M,) float ndarray, optional
        Eq. 7's normalised distance of each matched pair, when known (the pairs need not
        have descriptors in ``desc_r``: :func:`guided_rounds` passes guided matches).
    new_from : int, optional
        Search only the unmatched left points whose matched neighbours (in the window
        they take them from) include one of the matches ``query_idx[new_from:]``: with
        the same settings, a point whose neighbours are those of an earlier search finds
        what it found then (:func:`guided_rounds` passes the matches no round has
        propagated from yet, after the seeds). None: every unmatched point.
    fallback : GreyFallback, optional
        Where the row search on ``g_l``, ``g_r`` finds too weak a peak (low ZNCC, or short
        of the margin) or fails the left-right check, search again, with the same
        prediction and tests (the smallest ZNCC at least
        :data:`GUIDED_FALLBACK_MIN_ZNCC`), on these images and windows; a peak
        found there has its ZNCC, position and eq. 7 distance measured on them (the
        matched neighbours' similarity stays ``matched_similarity``, or that of
        ``desc_l``, ``desc_r``). None: ``g_l``, ``g_r`` only.
    threads : int, optional
        Search the queries in up to this many threads (None:
        :func:`hopmatch._threads.current_threads`), in contiguous chunks; each query's
        search is independent of the others', so results are bit-identical for any count
        (:func:`hopmatch._threads.map_chunks`).

    Returns
    -------
    GuidedMatches
        Every returned match passed every test: the peak is the best ZNCC within
        ``search`` px of the predicted position, lies within ``radius`` px of it, is a
        local maximum, has ZNCC >= ``min_zncc`` and the margin, searching back finds the
        left point again, and its field is positive (on ``g_l``, ``g_r``, or on the
        ``fallback`` images where the peak on those was too weak).
    """
    found = guided_search(pts_l, pts_r, desc_l, desc_r, g_l, g_r, query_idx, train_idx,
                          y_offset, config, margin=margin, radius=radius, search=search,
                          back=back, min_zncc=min_zncc, min_support=min_support,
                          window=window, min_field=min_field,
                          matched_similarity=matched_similarity, new_from=new_from,
                          fallback=fallback, threads=threads)
    return found.matches


def guided_search(pts_l, pts_r, desc_l, desc_r, g_l, g_r, query_idx, train_idx, y_offset,
                  config, *, margin: float = 0.1, radius: float | None = None,
                  search: int | None = None, back: int | None = None,
                  min_zncc: float | None = None, min_support: int | None = None,
                  window: float = 1.0, min_field: float = 0.0,
                  matched_similarity=None, new_from: int | None = None,
                  fallback: GreyFallback | None = None,
                  threads: int | None = None) -> GuidedSearch:
    """:func:`guided_pass` with the stage at which each left point it considered stopped
    (the arguments are :func:`guided_pass`'s): a :class:`GuidedSearch` whose ``matches``
    are exactly what :func:`guided_pass` returns and whose ``stage`` says, for each left
    point the network left unmatched (those near ``query_idx[new_from:]`` only, with
    ``new_from``), which test it failed first
    (:data:`~hopmatch.matching.guided_results.GUIDED_STAGES`; with ``fallback``, the
    first it failed on ``g_l``, ``g_r``, unless the fallback's search found a peak: then
    accepted, or the field test), or :data:`STAGE_ACCEPTED`."""
    radius = GUIDED_RADIUS if radius is None else radius
    search = GUIDED_SEARCH if search is None else search
    back = GUIDED_BACK if back is None else back
    min_zncc = GUIDED_MIN_ZNCC if min_zncc is None else min_zncc
    min_support = GUIDED_MIN_SUPPORT if min_support is None else min_support
    n_left = len(pts_l)
    if len(query_idx) == 0 or n_left == 0 or desc_l.dtype == np.uint8:
        return GuidedSearch.none()
    # int32, as the network's own candidate pairs: one compiled similarity kernel, not two
    qi = np.ascontiguousarray(query_idx, dtype=np.int32)
    ti = np.ascontiguousarray(train_idx, dtype=np.int32)
    m_left = np.ascontiguousarray(pts_l[qi], dtype=np.float32)
    m_right = np.ascontiguousarray(pts_r[ti], dtype=np.float32)
    m_sim = (similarity_distance(desc_l, desc_r, qi, ti, gain_tolerance=config.gain_tolerance)
             if matched_similarity is None
             else np.asarray(matched_similarity, dtype=np.float64))
    matched = np.zeros(n_left, dtype=bool)
    matched[qi] = True
    queries = np.flatnonzero(~matched)
    if new_from is not None:  # first only where the new matches can reach
        near_off, _ = query_neighbours(
            np.ascontiguousarray(pts_l[queries]), m_left[new_from:],
            *half_sides(config.neighbour_width, config.neighbour_height, max(window, 1.0)),
            threads=threads)
        queries = queries[np.diff(near_off) > 0]
        if len(queries) == 0:
            return GuidedSearch.none()
    qpts = np.ascontiguousarray(pts_l[queries])
    sides = half_sides(config.neighbour_width, config.neighbour_height)
    off, idx = query_neighbours(qpts, m_left, *sides, threads=threads)
    scale = 1.0
    while scale < window:  # the smallest of the windows 2, 4... (at most ``window``)
        scale = min(2.0 * scale, window)
        need = np.flatnonzero(np.diff(off) < min_support)
        if len(need) == 0:
            break
        off_n, idx_n = query_neighbours(np.ascontiguousarray(qpts[need]), m_left,
                                        *half_sides(config.neighbour_width,
                                                    config.neighbour_height, scale),
                                        threads=threads)
        cnt = np.zeros(len(queries), dtype=np.int64)
        cnt[need] = np.diff(off_n)
        off_w = np.zeros(len(queries) + 1, dtype=np.int64)
        np.cumsum(cnt, out=off_w[1:])
        use = np.zeros(len(queries), dtype=bool)
        use[need] = True
        off, idx = _choose_csr(off, idx, off_w, idx_n, use)
    enough = np.diff(off) >= min_support
    if new_from is not None:  # then where they are among the neighbours
        owner = np.repeat(np.arange(len(queries)), np.diff(off))
        enough &= np.bincount(owner[idx >= new_from], minlength=len(queries)) > 0
    rows = np.flatnonzero(enough)
    stage = np.full(len(queries), STAGE_FEW_NEIGHBOURS, dtype=np.int8)
    if len(rows) == 0:
        return GuidedSearch.of(queries, stage)
    disp = m_left[:, 0].astype(np.float64) - m_right[:, 0]
    p_off, p_idx = ((off, idx) if GUIDED_PREDICT_NEAREST <= 0 else
                    nearest_of(qpts, off, idx, m_left, int(GUIDED_PREDICT_NEAREST)))
    pred, gx, gy = neighbour_planes(qpts, p_off, p_idx, m_left, disp, GUIDED_PLANE_INLIER,
                                    GUIDED_PLANE_MIN, GUIDED_PLANE_REACH, GUIDED_PLANE_REFITS,
                                    threads=threads)
    pred = pred[rows]
    gx = np.clip(gx[rows], -GUIDED_GRADIENT_LIMIT, GUIDED_GRADIENT_LIMIT)
    gy = np.clip(gy[rows], -GUIDED_GRADIENT_LIMIT, GUIDED_GRADIENT_LIMIT)
    q = queries[rows].astype(np.int64)
    yoff = np.ascontiguousarray(np.asarray(y_offset, dtype=np.float64)[q])
    centre = np.ascontiguousarray(pts_l[q, 0].astype(np.float64) - pred)

    shear = np.ascontiguousarray(gy if GUIDED_SHEAR else np.zeros_like(gy))

    def search_rows(im_l, im_r, points, windows, which, qs, min_zncc):
        """The row search on ``im_l``, ``im_r`` of the queries ``q[qs]``, the left point
        ``q[k]`` being ``points[which[k]]`` with the window ``windows[which[k]]``."""
        return row_searches(im_l, im_r, points, windows, which, centre[qs], yoff[qs],
                            radius, search, back, min_zncc, margin, EPS,
                            config.gain_tolerance, False, GUIDED_PEAK_MARGIN,
                            GUIDED_SHOULDER, shear[qs], threads=threads)

    status, best, second, xr, sim = search_rows(g_l, g_r, pts_l, desc_l, q, slice(None),
                                                min_zncc)
    if fallback is not None:  # again on the grey levels, where G's peak was too weak
        # (off the prediction, or outside the image, the grey levels almost never help:
        # docs/parameters.md, "Searching the grey levels where G fails")
        again = np.flatnonzero((status == _k.WEAK) | (status == _k.BACK_FAILED))
        if len(again):
            points = np.ascontiguousarray(pts_l[q[again]])
            found_again = search_rows(
                fallback.left, fallback.right, points,
                cut_windows(fallback.left, points, fallback.window_size),
                np.arange(len(again), dtype=np.int64), again,
                max(min_zncc, GUIDED_FALLBACK_MIN_ZNCC))
            took = found_again[0] == _k.FOUND
            for ours, theirs in zip((status, best, second, xr, sim), found_again):
                ours[again[took]] = theirs[took]
    ok = status == _k.FOUND
    yr = pts_l[q, 1].astype(np.float64) - yoff
    u = continuity_fields(np.ascontiguousarray(pts_l[q]), np.where(ok, xr, np.nan), yr, sim,
                          off, idx, rows, m_left, m_right, m_sim, config.theta, config.slope,
                          config.similarity_weight, config.input_bias, gx, gy,
                          threads=threads)
    keep = ok & (np.nan_to_num(u, nan=-np.inf) > min_field)
    stage[rows] = search_stages(status, best, min_zncc)
    stage[rows[ok & ~keep]] = STAGE_CONTINUITY
    predicted = np.full(len(queries), np.nan)
    predicted[rows] = pred
    return GuidedSearch(queries.astype(np.int64), stage,
                        accepted_matches(keep, q, xr, yr, u, best, second, sim), predicted)


def seed_pass(pts_l, pts_r, desc_l, g_l, g_r, query_idx, train_idx, y_offset, config,
              matched_similarity, *, min_zncc: float | None = None,
              margin: float | None = None, min_field: float | None = None,
              max_work: int | None = None, threads: int | None = None) -> GuidedMatches:
    """:func:`seed_search`'s seeds (the same arguments), without the planes."""
    return seed_search(pts_l, pts_r, desc_l, g_l, g_r, query_idx, train_idx, y_offset,
                       config, matched_similarity, min_zncc=min_zncc, margin=margin,
                       min_field=min_field, max_work=max_work, threads=threads)[0]


def seed_search(pts_l, pts_r, desc_l, g_l, g_r, query_idx, train_idx, y_offset, config,
                matched_similarity, *, min_zncc: float | None = None,
                margin: float | None = None, min_field: float | None = None,
                max_work: int | None = None,
                threads: int | None = None) -> tuple[GuidedMatches, np.ndarray]:
    """``(seeds, planes)``. Seeds: the left points not in ``query_idx``
    (:data:`GUIDED_SEED_ALL` False: those with fewer than ``GUIDED_MIN_SUPPORT`` of them in
    the network's window), each searched along its whole row of the right image
    (``config``'s resolved disparity range within ``[1 - W_r, W_l - 1]``; with
    :data:`GUIDED_SEED_CLIP` the part of it whose right windows lie in the image), kept when
    the best ZNCC is at least ``min_zncc``, a local maximum, ahead by ``margin`` of the best
    one at least :data:`GUIDED_SHOULDER` pixels away in the range, searching back finds the
    left point again (:func:`row_search` with the whole range as its search and radius), and
    its field exceeds ``min_field``, its neighbours being the matches *and the other peaks
    found so* (each but itself): a peak far from every match is kept only when enough peaks
    around it agree on one surface (the local plane of those neighbours carries them, as in
    :func:`guided_pass`), or, with :data:`GUIDED_SEED_PLANES`, exceeds
    :data:`GUIDED_PLANE_SEED_FIELD` and the peak lies on a receding plane that hundreds of
    the peaks lie on (:func:`~hopmatch.matching.planes.receding_planes`, with each peak's
    local plane as a candidate).
    Each seed is then searched again with right windows sheared by each of
    :data:`GUIDED_SEED_SHEARS` and keeps the found peak of highest ZNCC.
    ``matched_similarity``: eq. 7's distance of each matched pair. ``max_work``: the most
    ZNCC columns scored in all (each search of a seed scores ``2 outer + 3``, ``outer``
    half the range plus one); beyond it only the first seeds in the order of ``pts_l``
    (the detector's: strongest first) are searched, at least one, and the sheared searches
    take the first seeds again with what the square one left. None for the module's
    ``GUIDED_SEED_*`` values. Returns them as :class:`GuidedMatches` (empty when the range
    is not resolved) and the receding planes found among the peaks ((K, 3) rows ``(a, b,
    c)`` of ``d = a + b x + c y``; none without :data:`GUIDED_SEED_PLANES`)."""
    min_zncc = GUIDED_SEED_ZNCC if min_zncc is None else min_zncc
    margin = GUIDED_SEED_MARGIN if margin is None else margin
    min_field = GUIDED_SEED_FIELD if min_field is None else min_field
    max_work = GUIDED_SEED_WORK if max_work is None else max_work
    none = np.zeros((0, 3))
    if config.max_disparity is None or len(pts_l) == 0 or desc_l.dtype == np.uint8:
        return empty_guided(), none
    # the disparities of right points inside the image: a huge range costs no more
    d_lo = max(float(config.min_disparity or 0.0), 1.0 - g_r.shape[1])
    d_hi = min(float(config.max_disparity), g_l.shape[1] - 1.0)
    sides = half_sides(config.neighbour_width, config.neighbour_height)
    qi = np.ascontiguousarray(query_idx, dtype=np.int32)
    ti = np.ascontiguousarray(train_idx, dtype=np.int32)
    matched = np.zeros(len(pts_l), dtype=bool)
    matched[qi] = True
    q = np.flatnonzero(~matched).astype(np.int64)
    if not GUIDED_SEED_ALL:  # only where no match reaches: fewer than GUIDED_MIN_SUPPORT
        off, _ = query_neighbours(np.ascontiguousarray(pts_l[q]),
                                  np.ascontiguousarray(pts_l[qi], dtype=np.float32),
                                  *sides, threads=threads)
        q = q[np.diff(off) < GUIDED_MIN_SUPPORT]
    if len(q) == 0 or d_lo > d_hi:
        return empty_guided(), none
    outer = int(np.ceil(0.5 * (d_hi - d_lo))) + 1
    columns = 2 * outer + 3  # per seed and search
    q = q[:max(1, int(max_work) // columns)]  # the strongest within the budget
    centre = np.ascontiguousarray(pts_l[q, 0].astype(np.float64) - 0.5 * (d_lo + d_hi))
    yoff = np.ascontiguousarray(np.asarray(y_offset, dtype=np.float64)[q])

    def search(n, shear):
        """The row search of the first ``n`` seeds, right windows sheared by ``shear``."""
        return row_searches(g_l, g_r, pts_l, desc_l, q[:n], centre[:n], yoff[:n], outer,
                            outer, GUIDED_BACK, min_zncc, margin, EPS, config.gain_tolerance,
                            GUIDED_SEED_CLIP, False, GUIDED_SHOULDER,
                            np.full(n, float(shear)), threads=threads)

    status, best, second, xr, sim = search(len(q), 0.0)
    budget_left = int(max_work) - len(q) * columns
    for shear in GUIDED_SEED_SHEARS:  # the strongest seeds again, within what is left
        n = min(len(q), max(0, budget_left) // columns)
        budget_left -= n * columns
        if n == 0:
            break
        run = search(n, shear)
        take = (run[0] == _k.FOUND) & ((status[:n] != _k.FOUND) | (run[1] > best[:n]))
        for ours, theirs in zip((status, best, second, xr, sim), run):
            ours[:n][take] = theirs[take]
    f = np.flatnonzero(status == _k.FOUND)
    if len(f) == 0:
        return empty_guided(), none
    q, xr, best, second, sim = q[f], xr[f], best[f], second[f], sim[f]
    yr = pts_l[q, 1].astype(np.float64) - yoff[f]
    n_m = len(qi)
    m_left = np.ascontiguousarray(np.concatenate((pts_l[qi], pts_l[q])), dtype=np.float32)
    m_right = np.ascontiguousarray(np.concatenate((pts_r[ti], np.stack((xr, yr), axis=1))),
                                   dtype=np.float32)
    m_sim = np.concatenate((np.asarray(matched_similarity, dtype=np.float64), sim))
    qpts = np.ascontiguousarray(pts_l[q])
    off, idx = query_neighbours(qpts, m_left, *sides, threads=threads)
    owner = np.repeat(np.arange(len(q)), np.diff(off))
    others = idx != n_m + owner  # each peak but itself
    off = np.zeros(len(q) + 1, dtype=np.int64)
    np.cumsum(np.bincount(owner[others], minlength=len(q)), out=off[1:])
    idx = np.ascontiguousarray(idx[others], dtype=np.int32)
    disp = m_left[:, 0].astype(np.float64) - m_right[:, 0]
    _, gx, gy = neighbour_planes(qpts, off, idx, m_left, disp, GUIDED_PLANE_INLIER,
                                 GUIDED_PLANE_MIN, GUIDED_PLANE_REACH, GUIDED_PLANE_REFITS,
                                 threads=threads)
    gx = np.clip(gx, -GUIDED_GRADIENT_LIMIT, GUIDED_GRADIENT_LIMIT)
    gy = np.clip(gy, -GUIDED_GRADIENT_LIMIT, GUIDED_GRADIENT_LIMIT)
    u = continuity_fields(qpts, xr, yr, sim, off, idx, np.arange(len(q)), m_left, m_right,
                          m_sim, config.theta, config.slope, config.similarity_weight,
                          config.input_bias, gx, gy, threads=threads)
    field = np.nan_to_num(u, nan=-np.inf)
    keep = field > min_field
    planes = none
    if GUIDED_SEED_PLANES:  # or on a receding plane that hundreds of peaks lie on
        planes, label = receding_planes(qpts, qpts[:, 0].astype(np.float64) - xr, gx, gy)
        keep |= (label >= 0) & (field > GUIDED_PLANE_SEED_FIELD)
    return accepted_matches(keep, q, xr, yr, u, best, second, sim), planes


def guided_rounds(pts_l, pts_r, desc_l, desc_r, g_l, g_r, query_idx, train_idx, y_offset,
                  config, *, margin: float = 0.1, rounds: int | None = None,
                  later_margin: float | None = None, growth: float | None = None,
                  later_field: float | None = None, seed_rounds: int | None = None,
                  fallback: GreyFallback | None = None,
                  threads: int | None = None) -> GuidedMatches:
    """:func:`guided_pass` run ``rounds`` times: round r (0-based) propagates from the
    network's matches and the guided matches of the rounds before it to the left points
    still unmatched. Round 0 is :func:`guided_pass` with the uniqueness margin ``margin``;
    round r > 0 has the margin ``max(margin, later_margin)``, the smallest field
    ``later_field`` (``min_field``) and, for the points with too few matched neighbours
    in the network's window, the window ``(1 + growth) ** r`` times as large
    (``window``). With ``seed_rounds`` > 0, the left points still unmatched then get
    :func:`seed_pass`'s seeds, and ``seed_rounds`` more rounds (numbered 1, 2... again)
    propagate from everything found: with :data:`GUIDED_SEED_NEAR`, the first searches
    only the points with a seed or a match of the last round among their neighbours
    (``new_from``; elsewhere it would find what the last round found), each later one
    only those with a match of the round before. None: :data:`GUIDED_ROUNDS`,
    :data:`GUIDED_LATER_MARGIN`, :data:`GUIDED_GROWTH`, :data:`GUIDED_LATER_FIELD`,
    :data:`GUIDED_SEED_ROUNDS`. Other arguments as :func:`guided_pass` (``fallback`` is
    every round's; the seeds search ``g_l``, ``g_r`` only). Then, with
    :data:`GUIDED_PLANE_PASS` and receding planes among the seeds' peaks
    (:func:`seed_search`), the points still unmatched are searched on them
    (:func:`~hopmatch.matching.plane_pass.plane_pass`, with this module's search, back
    search, shoulder and gradient limit) and :data:`GUIDED_PLANE_ROUNDS` rounds (numbered
    1...) propagate from what it found. Returns the guided matches of all rounds (the
    seeds after the first ``rounds``, the plane pass after the rounds that follow them),
    in round order; the rounds stop early when one finds none."""
    rounds = GUIDED_ROUNDS if rounds is None else rounds
    later_margin = GUIDED_LATER_MARGIN if later_margin is None else later_margin
    growth = GUIDED_GROWTH if growth is None else growth
    seed_rounds = GUIDED_SEED_ROUNDS if seed_rounds is None else seed_rounds
    later_field = GUIDED_LATER_FIELD if later_field is None else later_field
    qi = np.ascontiguousarray(query_idx, dtype=np.int32)
    ti = np.ascontiguousarray(train_idx, dtype=np.int32)
    if len(qi) == 0 or len(pts_l) == 0 or desc_l.dtype == np.uint8:
        return empty_guided()
    sim = similarity_distance(desc_l, desc_r, qi, ti, gain_tolerance=config.gain_tolerance)
    right = pts_r
    found = []

    def add(gm):
        nonlocal qi, ti, right, sim
        found.append(gm)
        qi = np.concatenate((qi, gm.query_idx)).astype(np.int32, copy=False)
        ti = np.concatenate((ti, np.arange(len(right), len(right) + len(gm.query_idx),
                                           dtype=np.int32)))
        right = np.concatenate((right, gm.right_points)).astype(np.float32, copy=False)
        sim = np.concatenate((sim, gm.similarity))

    def run(first, count, new_from=None):
        """Rounds ``first...`` (with ``new_from``: each searching only where the matches
        since ``new_from``, then since the round before, are neighbours); returns ``(the
        last round run, where its matches start in qi)``, the second None when it found
        none (every match before it has been propagated from)."""
        fresh = None
        last = first - 1
        for r in range(first, first + count):
            last = r
            start = len(qi)
            gm = guided_pass(pts_l, right, desc_l, desc_r, g_l, g_r, qi, ti, y_offset,
                             config, margin=margin if r == 0 else max(margin, later_margin),
                             window=(1.0 + growth) ** r,
                             min_field=0.0 if r == 0 else later_field, matched_similarity=sim,
                             new_from=new_from, fallback=fallback, threads=threads)
            if len(gm.query_idx) == 0:
                return r, None
            add(gm)
            fresh = start
            if new_from is not None:
                new_from = start
        return last, fresh

    rounds = max(int(rounds), 1)
    last, fresh = run(0, rounds)
    if seed_rounds > 0:
        start = len(qi)
        gm, planes = seed_search(pts_l, right, desc_l, g_l, g_r, qi, ti, y_offset, config,
                                 sim, threads=threads)
        if len(gm.query_idx):
            add(gm)
            # the round after the seeds has round 1's settings, and the window of the
            # last round (when it is round 1 or later) is at least as large: where none
            # of the seeds, nor of the last round's matches, is a neighbour, it would find
            # what the last round found
            near = GUIDED_SEED_NEAR and last >= 1
            run(1, int(seed_rounds), new_from=(None if not near
                                               else start if fresh is None else fresh))
        if GUIDED_PLANE_PASS and len(planes):
            matched = np.zeros(len(pts_l), dtype=bool)
            matched[qi] = True
            start = len(qi)
            gm = plane_pass(pts_l, desc_l, g_l, g_r, pts_l[qi], right[ti], sim,
                            np.flatnonzero(~matched), y_offset, config, planes,
                            search=GUIDED_SEARCH, back=GUIDED_BACK, shoulder=GUIDED_SHOULDER,
                            gradient_limit=GUIDED_GRADIENT_LIMIT, threads=threads)
            if len(gm.query_idx):
                add(gm)
                run(1, int(GUIDED_PLANE_ROUNDS), new_from=start)

    if not found:
        return empty_guided()
    return GuidedMatches(*(np.concatenate([getattr(g, f.name) for g in found])
                           for f in fields(GuidedMatches)))
