"""Kernels of the guided second pass: neighbours among matched points, a row search of
zero-mean normalised cross-correlation (ZNCC) on the gradient windows, and the network's
continuity field of a guided match (eqs. 5, 6, 10, 12)."""

from __future__ import annotations

import numpy as np

from .._config import jit
from .interactions import compatibility
from .neighbours import cell_buckets
from .similarity import gain_within

#: Status codes of :func:`row_search` (0 = a peak was found and passed the back search).
FOUND = 0
OUTSIDE = 1  # a window of the search leaves the image
FLAT = 2  # the left window has no contrast
OFF_PREDICTION = 3  # the best correlation of the range lies too far from the prediction
NOT_PEAK = 4  # the best correlation lies at the end of the searched range
BACK_FAILED = 5  # searching back from the right position finds another left position
WEAK = 6  # the peak's ZNCC is below the minimum, or not ahead of the runner-up by the margin


@jit
def query_neighbours(queries, matched, half_w, half_h):
    """CSR lists, for each query point, of the matched points j with
    ``|xj - xq| <= half_w`` and ``|yj - yq| <= half_h`` (SPEC section 4's neighbourhood,
    differences in float32 as in the network's lists).

    ``queries`` (Q, 2) and ``matched`` (M, 2) are float32 (x, y). Returns ``(offsets,
    indices)``: query q's neighbours are ``indices[offsets[q]:offsets[q + 1]]`` (indices
    into ``matched``, in no particular order). The matched points are bucketed by
    :func:`~hopmatch._kernels.neighbours.cell_buckets` (the network's grid), and each query
    scans the cells of the box around it.
    """
    nq = queries.shape[0]
    nm = matched.shape[0]
    offsets = np.zeros(nq + 1, dtype=np.int64)
    if nm == 0 or nq == 0:
        return offsets, np.empty(0, dtype=np.int32)
    xmin, ymin, cw, ch, ncx, ncy, _, cell_start, members, sx, sy = cell_buckets(
        matched, half_w, half_h)
    cap = 16 * nq + 1024
    idx = np.empty(cap, dtype=np.int32)
    p = 0
    for q in range(nq):
        xq = queries[q, 0]
        yq = queries[q, 1]
        # the cells of the box around q (a query may lie outside the matched points' box)
        cx_lo = max(int(np.floor((np.float64(xq) - half_w - xmin) / cw)), 0)
        cx_hi = min(int(np.floor((np.float64(xq) + half_w - xmin) / cw)), ncx - 1)
        cy_lo = max(int(np.floor((np.float64(yq) - half_h - ymin) / ch)), 0)
        cy_hi = min(int(np.floor((np.float64(yq) + half_h - ymin) / ch)), ncy - 1)
        for cy in range(cy_lo, cy_hi + 1):
            if cx_lo > cx_hi:
                break
            a = cell_start[cy * ncx + cx_lo]
            b = cell_start[cy * ncx + cx_hi + 1]
            if p + (b - a) > cap:
                cap = max(2 * cap, p + (b - a))
                grown = np.empty(cap, dtype=np.int32)
                for u in range(p):  # an element loop: a slice assignment compiles a shape
                    grown[u] = idx[u]  # check whose error message costs seconds to compile
                idx = grown
            for t in range(a, b):
                idx[p] = members[t]
                p += (abs(sx[t] - xq) <= half_w) & (abs(sy[t] - yq) <= half_h)
        offsets[q + 1] = p
    return offsets, idx[:p]


#: Longest neighbour list whose median :func:`neighbour_medians` finds by counting ranks
#: (branch-free, n**2 compares that vectorise); longer lists are sorted by insertion.
RANK_MEDIAN_MAX = 64


@jit
def _select(buf, c, k):
    """The ``k``-th smallest of ``buf[:c]`` (0-based), the values reordered in place so that
    ``buf[:k]`` hold ``k`` values no larger than it and ``buf[k]`` is it (Hoare's
    quickselect, the middle of three as pivot)."""
    lo = 0
    hi = c - 1
    while lo < hi:
        mid = (lo + hi) // 2
        a, b, d = buf[lo], buf[mid], buf[hi]
        pivot = max(min(a, b), min(max(a, b), d))
        i = lo
        j = hi
        while i <= j:
            while buf[i] < pivot:
                i += 1
            while buf[j] > pivot:
                j -= 1
            if i <= j:
                buf[i], buf[j] = buf[j], buf[i]
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            break
    return buf[k]


@jit
def neighbour_medians(offsets, idx, values):
    """Median of ``values[idx[offsets[q]:offsets[q + 1]]]`` for each q (NaN when empty;
    the mean of the two middle values for an even count, as ``np.median``). The values are
    finite (disparities of matches).

    A list of at most :data:`RANK_MEDIAN_MAX` values has its middle ones found by their
    ranks (value i's rank: the values below it, and the equal ones before it), which
    costs no mispredicted branches; in a longer one they are selected (:func:`_select`).
    The middle values, and so the result, are the same either way."""
    nq = offsets.shape[0] - 1
    out = np.full(nq, np.nan)
    longest = 0
    for q in range(nq):
        longest = max(longest, offsets[q + 1] - offsets[q])
    buf = np.empty(longest, dtype=np.float64)
    for q in range(nq):
        a = offsets[q]
        c = offsets[q + 1] - a
        if c == 0:
            continue
        h = c // 2
        if c <= RANK_MEDIAN_MAX:
            for t in range(c):
                buf[t] = np.float64(values[idx[a + t]])
            below = 0.0  # the values of ranks h - 1 and h
            middle = 0.0
            for i in range(c):
                v = buf[i]
                rank = 0
                for j in range(c):
                    rank += (buf[j] < v) | ((buf[j] == v) & (j < i))
                if rank == h:
                    middle = v
                elif rank == h - 1:
                    below = v
            out[q] = middle if c % 2 else 0.5 * (below + middle)
            continue
        for t in range(c):
            buf[t] = np.float64(values[idx[a + t]])
        # O(c) on average (an insertion sort until 2026-12-05: O(c**2))
        middle = _select(buf, c, h)
        if c % 2:
            out[q] = middle
            continue
        below = buf[0]  # buf[:h] now holds the h values below the middle one
        for t in range(1, h):
            below = max(below, buf[t])
        out[q] = 0.5 * (below + middle)
    return out


@jit
def _strip(g, x_lo, n_cols, y_top, ay, rows, out, shear=0.0):
    """``out[r, c]``: g at row ``y_top + r + ay`` (lerped between rows) and column
    ``x_lo + c - shear (r - rows // 2)`` (lerped between columns when ``shear`` is not 0)
    for ``r < rows``, ``c < n_cols``: with ``shear`` the disparity gradient along y of a
    surface, the rows of a window on it in the right image slide as the surface does."""
    by = 1.0 - ay
    half = rows // 2
    for r in range(rows):
        # row views and a loop from 0: no checks for negative indices, so the loop
        # vectorises (the same arithmetic as g[y, x] per element: 2-4x faster)
        o = out[r]
        if shear == 0.0:
            a = g[y_top + r, x_lo:x_lo + n_cols]
            b = g[y_top + r + 1, x_lo:x_lo + n_cols]
            for c in range(n_cols):
                o[c] = by * np.float64(a[c]) + ay * np.float64(b[c])
        else:
            sh = -shear * (r - half)
            fs = np.floor(sh)
            ax = sh - fs
            x0 = x_lo + int(fs)
            a = g[y_top + r, x0:x0 + n_cols + 1]
            b = g[y_top + r + 1, x0:x0 + n_cols + 1]
            for c in range(n_cols):
                v0 = by * np.float64(a[c]) + ay * np.float64(b[c])
                v1 = by * np.float64(a[c + 1]) + ay * np.float64(b[c + 1])
                o[c] = (1.0 - ax) * v0 + ax * v1


@jit
def _correlate(a, sa2, strip, s, span, acc, colsum, colsq, z):
    """``z[m]``: ZNCC of the zero-mean ``s x s`` window ``a`` (float64, raster order,
    ``sa2 = sum a**2``) with the window of ``strip`` whose first column is ``m``, for
    ``m < span``; -1 where that window is flat.

    The cross sums run along the strip's rows (one multiply-add per window and pixel, in
    loops over ``m`` that vectorise, three columns of ``a`` per loop so that ``acc`` is
    read and written a third as often; each ``acc[m]`` still adds its terms in column
    order); the windows' sums and sums of squares slide over column sums.
    """
    n = s * s
    ncols = span + s - 1
    for m in range(span):
        acc[m] = 0.0
    for x in range(ncols):
        colsum[x] = 0.0
        colsq[x] = 0.0
    for r in range(s):
        row = strip[r]
        for x in range(ncols):
            v = row[x]
            colsum[x] += v
            colsq[x] += v * v
        c = 0
        while c + 3 <= s:
            c0 = a[r * s + c]
            c1 = a[r * s + c + 1]
            c2 = a[r * s + c + 2]
            for m in range(span):
                v = acc[m]
                v += c0 * row[m + c]
                v += c1 * row[m + c + 1]
                v += c2 * row[m + c + 2]
                acc[m] = v
            c += 3
        while c < s:
            coef = a[r * s + c]
            for m in range(span):
                acc[m] += coef * row[m + c]
            c += 1
    sb = 0.0
    sbb = 0.0
    for c in range(s - 1):
        sb += colsum[c]
        sbb += colsq[c]
    for m in range(span):
        sb += colsum[m + s - 1]
        sbb += colsq[m + s - 1]
        var = sbb - sb * sb / n
        if var <= 1e-12 * max(sbb, 1e-300):
            z[m] = -1.0
        else:
            z[m] = acc[m] / np.sqrt(sa2 * var)
        sb -= colsum[m]
        sbb -= colsq[m]


@jit
def _zncc_bilinear(a, sa2, g, x, y, s):
    """ZNCC of the zero-mean float64 ``s x s`` window ``a`` (``sa2 = sum a**2``) with the
    window of ``g`` centred on (x, y), sampled bilinearly; -1 when that window is flat.
    The caller keeps the window's pixels inside ``g``."""
    rad = s // 2
    fx = np.floor(x)
    fy = np.floor(y)
    ax = x - fx
    ay = y - fy
    x0 = int(fx) - rad
    y0 = int(fy) - rad
    sb = 0.0
    sbb = 0.0
    sab = 0.0
    for r in range(s):
        g0 = g[y0 + r, x0:x0 + s + 1]  # row views, as in _strip
        g1 = g[y0 + r + 1, x0:x0 + s + 1]
        for c in range(s):
            v = ((1.0 - ay) * ((1.0 - ax) * np.float64(g0[c]) + ax * np.float64(g0[c + 1]))
                 + ay * ((1.0 - ax) * np.float64(g1[c]) + ax * np.float64(g1[c + 1])))
            sb += v
            sbb += v * v
            sab += a[r * s + c] * v
    var = sbb - sb * sb / (s * s)
    if var <= 1e-12 * max(sbb, 1e-300):
        return -1.0
    return sab / np.sqrt(sa2 * var)


@jit(exact=True)  # its loops sum while they write (hopmatch._config)
def row_search(g_l, g_r, pts_l, desc_l, queries, centre, y_offset, inner, outer, back,
               min_zncc, margin, eps, gain_tol=1.0, clip=False, peaks=False, shoulder=2,
               shear=None):
    """The guided search of each query (left point) along its row of the right image.

    For query q (left point ``i = queries[q]`` at (xl, yl)), the right row is
    ``yr = yl - y_offset[q]`` and the search is centred on column ``centre[q]`` (the
    predicted ``xl - d``). The left window is ``desc_l[i]`` (eqs. 8-9, zero mean,
    ``s x s``); right windows are centred on the integer columns ``c`` with
    ``|c - round(centre)| <= outer`` (rows lerped at yr, columns exact), scored by ZNCC.
    Let ``c*`` be the best of them: the match is *found* when ``|c* - centre| <= inner``,
    ``c*`` is a local maximum (one more column is scored at each end for that), its ZNCC
    is at least ``min_zncc`` and exceeds by ``margin`` the best one at least ``shoulder``
    columns from it (uniqueness), and searching back (the right window at the refined position
    against the left windows at ``xl + t``, ``0 < |t| <= back``) finds none better than
    the left window itself. The refined position is ``c* + delta``, delta the vertex of
    the parabola through the ZNCC at ``c* - 1, c*, c* + 1`` (clamped to +-0.5).

    Returns ``(status, best, second, xr, similarity)`` per query: the status code
    (:data:`FOUND`...), the best ZNCC, the best ZNCC at least ``shoulder`` columns from ``c*``,
    the refined right x, and eq. 7's normalised distance (``mean |a - g b| / (0.5 (mean
    |a| + mean |b|) + eps)``) between the left window a and the zero-mean right window b
    at (xr, yr), g the relative gain ``mean |a| / mean |b|`` clipped to ``[1 / gain_tol,
    gain_tol]`` (:func:`~hopmatch._kernels.similarity.gain_within`, as the network's
    similarity; 1 when ``gain_tol`` is 1).

    ``clip``: the columns ``c`` are first clipped to those whose windows (and the refined
    window's one more column) lie inside the right image, ``rad <= c <= W - rad - 2``
    (``rad`` = ``s // 2``; with ``shear``, ``rad + ceil(|shear| rad) <= c <= W - rad - 2 -
    floor(|shear| rad) - 1``: the slid rows too), and the search goes on over the rest when
    it keeps at least three columns (the seeds' search of the whole range: a right point
    beyond the image is no candidate); otherwise a search leaving the image is
    :data:`OUTSIDE`.

    ``peaks``: the runner-up is the best ZNCC beyond the valleys on either side of ``c*``
    (the columns past the first one, walking away from ``c*``, where the ZNCC rises again),
    not the best at least ``shoulder`` columns away: the shoulders of a broad peak are not
    another match (the margin then separates the peak from the best other peak).
    ``shoulder``: without ``peaks``, the runner-up is the best ZNCC at least ``shoulder``
    columns from ``c*`` (the columns nearer are the peak's own flanks).

    ``shear`` (per query, or None for 0): the disparity gradient along y of the surface
    the query lies on; row ``r`` of each right window (``r = -rad..rad`` from its centre)
    is then read ``shear[q] r`` px further left (lerped between columns), as a window on a
    receding surface (a road, a floor) is sheared in the right image. The window at the
    refined position is then lerped between the two sheared windows at the columns around
    it. A search whose slid rows leave the image (the columns ``x_lo - ceil(|shear| rad)``
    to ``x_hi + floor(|shear| rad) + 1``, ``x_lo``, ``x_hi`` those of the strip without
    shear) is :data:`OUTSIDE`.
    """
    h, w = g_r.shape
    hl, wl = g_l.shape
    nq = queries.shape[0]
    s = int(np.sqrt(desc_l.shape[1]) + 0.5)
    rad = s // 2
    n = s * s
    status = np.full(nq, OUTSIDE, dtype=np.int8)
    best = np.full(nq, np.nan)
    second = np.full(nq, np.nan)
    xr_out = np.full(nq, np.nan)
    sim = np.full(nq, np.nan)
    span = 2 * outer + 3  # centres c0 - outer - 1 .. c0 + outer + 1
    strip = np.empty((s, span + 2 * rad + 1), dtype=np.float64)
    rbw = np.empty((s, s), dtype=np.float64)
    nbig = span + s
    z = np.empty(nbig, dtype=np.float64)
    acc = np.empty(nbig, dtype=np.float64)
    colsum = np.empty(nbig, dtype=np.float64)
    colsq = np.empty(nbig, dtype=np.float64)
    af = np.empty(n, dtype=np.float64)
    flat = np.empty(n, dtype=np.float64)
    for q in range(nq):
        i = queries[q]
        xl = np.float64(pts_l[i, 0])
        yl = np.float64(pts_l[i, 1])
        yr = yl - y_offset[q]
        if not (np.isfinite(yr) and np.isfinite(centre[q])):
            continue
        g_y = 0.0 if shear is None else shear[q]
        # how far the rows slide (:func:`_strip`): left, and right with the lerp's column
        left_reach = int(np.ceil(abs(g_y) * rad))
        right_reach = int(np.floor(abs(g_y) * rad)) + (g_y != 0.0)
        c0 = int(np.floor(centre[q] + 0.5))
        first = c0 - outer - 1
        last = c0 + outer + 1
        if clip:  # the columns whose (slid) windows lie inside the image
            first = max(first, rad + left_reach)
            last = min(last, w - rad - 2 - right_reach)
        n_span = last - first + 1
        x_lo = first - rad
        x_hi = last + rad + 1  # one more column for the refined window
        fy = np.floor(yr)
        y_top = int(fy) - rad
        if (n_span < 3 or x_lo - left_reach < 0 or x_hi + right_reach > w - 1
                or y_top < 0 or y_top + s > h - 1):
            continue
        sa2 = 0.0
        for t in range(n):
            af[t] = np.float64(desc_l[i, t])
            sa2 += af[t] * af[t]
        if sa2 <= 1e-12:
            status[q] = FLAT
            continue
        _strip(g_r, x_lo, x_hi - x_lo + 1, y_top, yr - fy, s, strip, g_y)
        _correlate(af, sa2, strip, s, n_span, acc, colsum, colsq, z)
        mb = 1
        for m in range(1, n_span - 1):
            if z[m] > z[mb]:
                mb = m
        z2 = -1.0
        if peaks:  # beyond the valleys on either side of the peak
            j = mb - 1
            while j >= 1 and z[j] <= z[j + 1]:
                j -= 1
            for m in range(1, j + 1):
                if z[m] > z2:
                    z2 = z[m]
            j = mb + 1
            while j <= n_span - 2 and z[j] <= z[j - 1]:
                j += 1
            for m in range(j, n_span - 1):
                if z[m] > z2:
                    z2 = z[m]
        else:
            for m in range(1, n_span - 1):
                if abs(m - mb) >= shoulder and z[m] > z2:
                    z2 = z[m]
        best[q] = z[mb]
        second[q] = z2
        cbest = first + mb
        if abs(cbest - centre[q]) > inner:
            status[q] = OFF_PREDICTION
            continue
        zm, z0, zp = z[mb - 1], z[mb], z[mb + 1]
        if zm > z0 or zp > z0:
            status[q] = NOT_PEAK
            continue
        if not (z0 >= min_zncc and z0 - z2 >= margin):
            status[q] = WEAK
            continue
        den = zm - 2.0 * z0 + zp
        delta = 0.0
        if den < 0.0:
            delta = min(max(0.5 * (zm - zp) / den, -0.5), 0.5)
        xr = cbest + delta
        xr_out[q] = xr
        # the right window at (xr, yr), zero mean
        fx = np.floor(xr)
        ax = xr - fx
        col = int(fx) - rad - x_lo
        sb = 0.0
        for r in range(s):
            for c in range(s):
                v = (1.0 - ax) * strip[r, col + c] + ax * strip[r, col + c + 1]
                rbw[r, c] = v
                sb += v
        mean_b = sb / n
        sbb = 0.0
        m_a = 0.0
        m_b = 0.0
        for r in range(s):
            for c in range(s):
                v = rbw[r, c] - mean_b
                rbw[r, c] = v
                sbb += v * v
                m_a += abs(af[r * s + c])
                m_b += abs(v)
        g = gain_within(m_a / n, m_b / n, gain_tol)
        m_ab = 0.0
        for r in range(s):
            for c in range(s):
                m_ab += abs(af[r * s + c] - g * rbw[r, c])
        sim[q] = (m_ab / n) / (0.5 * (m_a / n + m_b / n) + eps)
        # back search: the right window against the left windows at xl + t, |t| <= back
        # (t = 0 is the left window itself, whose ZNCC is symmetric)
        if not (np.floor(xl) - back - rad >= 0 and np.floor(xl) + back + rad + 1 <= wl - 1
                and np.floor(yl) - rad >= 0 and np.floor(yl) + rad + 1 <= hl - 1):
            status[q] = BACK_FAILED
            continue
        for r in range(s):
            for c in range(s):
                flat[r * s + c] = rbw[r, c]
        z_here = 0.0
        for t in range(n):
            z_here += flat[t] * af[t]
        z_here /= np.sqrt(sbb * sa2)
        found = True
        for t in range(1, back + 1):
            if (_zncc_bilinear(flat, sbb, g_l, xl - t, yl, s) > z_here
                    or _zncc_bilinear(flat, sbb, g_l, xl + t, yl, s) > z_here):
                found = False
                break
        status[q] = FOUND if found else BACK_FAILED
    return status, best, second, xr_out, sim


@jit
def continuity_field(pts_q, xr, yr, sim_q, offsets, idx, rows, m_left, m_right, m_sim,
                     theta, slope, weight, bias, gx, gy):
    """Eq. 12's bracket for a guided match alone in its row and column: ``u = bias +
    sum_j C`` over the matched neighbours j (eq. 5 of eq. 10's ``X = |d_q - d_j| + |D_qj -
    D'_qj| + weight (s_q + s_j)``, d the Euclidean disparity of eq. 6, D and D' the left
    and right lengths), with ``(pts_q[q], (xr[q], yr[q]))`` the guided pair, ``sim_q`` its
    normalised similarity, its neighbours ``idx[offsets[rows[q]]:offsets[rows[q] + 1]]``
    (indices into the matched pairs ``m_left``, ``m_right``, ``m_sim``).

    ``gx[q]``, ``gy[q]``: a local disparity gradient (px per px) the neighbours are
    carried along before the comparison (support from a local plane): neighbour j's right
    x becomes ``xk - e``, ``e = gx (xq - xj) + gy (yq - yj)``, so that a neighbour on the
    same slanted plane counts as continuous. With zero gradients this is eq. 10 as is."""
    nq = pts_q.shape[0]
    u = np.full(nq, np.nan)
    for q in range(nq):
        if not np.isfinite(xr[q]):
            continue
        x0 = np.float64(pts_q[q, 0])
        y0 = np.float64(pts_q[q, 1])
        d_q = np.sqrt((x0 - xr[q]) ** 2 + (y0 - yr[q]) ** 2)
        total = bias
        for t in range(offsets[rows[q]], offsets[rows[q] + 1]):
            j = idx[t]
            xj = np.float64(m_left[j, 0])
            yj = np.float64(m_left[j, 1])
            # neighbour j carried along the gradient to the query (e = 0 without one)
            xk = np.float64(m_right[j, 0]) - (gx[q] * (x0 - xj) + gy[q] * (y0 - yj))
            yk = np.float64(m_right[j, 1])
            d_j = np.sqrt((xj - xk) ** 2 + (yj - yk) ** 2)
            len_l = np.sqrt((x0 - xj) ** 2 + (y0 - yj) ** 2)
            len_r = np.sqrt((xr[q] - xk) ** 2 + (yr[q] - yk) ** 2)
            x = abs(d_q - d_j) + abs(len_l - len_r) + weight * (sim_q[q] + m_sim[j])
            total += compatibility(x, theta, slope)
        u[q] = total
    return u


@jit
def _band_plane(lo, hi, idx, m_left, values, xq, yq, pa, pb, pc, band, min_count):
    """Least-squares plane ``d = a + b (x - xq) + c (y - yq)`` through the neighbours
    ``idx[lo:hi]`` whose disparity lies within ``band`` px of the plane ``(pa, pb, pc)``:
    ``(fitted, a, b, c)``, ``fitted`` False when fewer than ``min_count`` of them do or
    their positions span no plane (the normal matrix's determinant below 1e-9 of the
    product of its diagonal)."""
    n = 0.0
    sx = sy = sxx = sxy = syy = 0.0
    sd = sxd = syd = 0.0
    for t in range(lo, hi):
        j = idx[t]
        d = np.float64(values[j])
        x = np.float64(m_left[j, 0]) - xq
        y = np.float64(m_left[j, 1]) - yq
        if abs(d - (pa + pb * x + pc * y)) > band:
            continue
        n += 1.0
        sx += x
        sy += y
        sxx += x * x
        sxy += x * y
        syy += y * y
        sd += d
        sxd += x * d
        syd += y * d
    if n < min_count:
        return False, 0.0, 0.0, 0.0
    # normal equations [[n, sx, sy], [sx, sxx, sxy], [sy, sxy, syy]] (a, b, c) = rhs
    c00 = sxx * syy - sxy * sxy
    c01 = sy * sxy - sx * syy
    c02 = sx * sxy - sy * sxx
    det = n * c00 + sx * c01 + sy * c02
    if not det > 1e-9 * n * sxx * syy:
        return False, 0.0, 0.0, 0.0
    a = (sd * c00 + sxd * c01 + syd * c02) / det
    # b and c by Cramer's rule on the other two columns
    b = (n * (sxd * syy - sxy * syd) - sd * (sx * syy - sxy * sy)
         + sy * (sx * syd - sxd * sy)) / det
    c = (n * (sxx * syd - sxd * sxy) - sx * (sx * syd - sxd * sy)
         + sd * (sx * sxy - sxx * sy)) / det
    return True, a, b, c


@jit
def neighbour_planes(queries, offsets, idx, m_left, values, inlier, min_count, reach=-1.0,
                     refits=0):
    """Disparity predicted at each query point by a local plane of its matched neighbours.

    For query q (point ``queries[q]``, neighbours ``idx[offsets[q]:offsets[q + 1]]`` into
    ``m_left`` with disparities ``values``): m is the median of the neighbours'
    disparities (as :func:`neighbour_medians`); the neighbours within ``inlier`` px of m
    are fitted by least squares with ``d = a + b (x - xq) + c (y - yq)``, then ``refits``
    times the neighbours within ``inlier`` px of the plane fitted last (a refit that has
    fewer than ``min_count`` inliers, or is degenerate, keeps the plane before it); the
    prediction is a, the plane at the query. The median is returned instead when the
    first fit has fewer than ``min_count`` inliers or is degenerate (the inliers'
    positions span no plane: the normal matrix's determinant is below 1e-9 of the product
    of its diagonal), or when a lies more than ``reach`` px from m (``reach`` < 0:
    ``inlier``). NaN for a query without neighbours.

    Returns ``(prediction, gx, gy)``: the plane's gradient (b, c) in px of disparity per
    px, 0 where the median is returned.
    """
    nq = offsets.shape[0] - 1
    reach = inlier if reach < 0.0 else reach
    med = neighbour_medians(offsets, idx, values)
    out = med.copy()
    gx = np.zeros(nq)
    gy = np.zeros(nq)
    for q in range(nq):
        m = med[q]
        if not np.isfinite(m):
            continue
        xq = np.float64(queries[q, 0])
        yq = np.float64(queries[q, 1])
        # the band around the median first (the plane m + 0 x + 0 y), then around the
        # plane fitted last
        pa = m
        pb = 0.0
        pc = 0.0
        fitted = False
        for _ in range(refits + 1):
            ok, a, b, c = _band_plane(offsets[q], offsets[q + 1], idx, m_left, values, xq, yq,
                                      pa, pb, pc, inlier, min_count)
            if not ok:
                break
            pa, pb, pc = a, b, c
            fitted = True
        if fitted and abs(pa - m) <= reach:
            out[q] = pa
            gx[q] = pb
            gy[q] = pc
    return out, gx, gy
