"""Kernels of SPEC section 4's search window: the candidate pairs (i, k), the neurons of the
network of sections 2-3.

:func:`band_index` orders the right points row by row (rows by :func:`row_order`), x
increasing within a row, and :func:`row_buckets` adds an x-bucket table per row;
:func:`band_candidates` then finds the pairs of a rectified band, and
:func:`epipolar_candidates` those of a band around epipolar lines. Both return the pairs
grouped by left point; :func:`group_by_left` and :func:`sort_groups` put them in (i, k)
order. Every array is of the size of the points or of the candidates, never ``Nl x Nr``.
"""

from __future__ import annotations

import numpy as np

from .._config import jit
from .arrays import grown, lower_bound, upper_bound
from .similarity import contrast_admits, similarity_norm

#: Runs longer than this are sorted with NumPy's O(n log n) sorts, shorter ones by insertion
#: (faster on the short runs that are the rule; crowded inputs make long ones).
SHORT_RUN = 32


@jit(inline=True)
def point_rows(points):
    """``floor(y)`` of every (x, y) point as int64, and the smallest and largest of them."""
    n = points.shape[0]
    rows = np.empty(n, dtype=np.int64)
    rmin = np.int64(0)
    rmax = np.int64(0)
    for i in range(n):
        r = np.int64(np.floor(np.float64(points[i, 1])))
        rows[i] = r
        if i == 0 or r < rmin:
            rmin = r
        if i == 0 or r > rmax:
            rmax = r
    return rows, rmin, rmax


@jit
def row_order(points, max_span):
    """The points ordered by row ``floor(y)``, index order within a row: ``(order, rows)``,
    ``rows`` each point's row. A counting sort when the rows span at most ``max_span``
    values (O(N) counts), else one sort of unique int64 keys, the row above the 31-bit index
    (coordinates are validated to ``|v| <= 2**20``, indices are below 2**31)."""
    n = points.shape[0]
    rows, rmin, rmax = point_rows(points)
    order = np.empty(n, dtype=np.int64)
    if n == 0:
        return order, rows
    span = rmax - rmin + 1
    if span > max_span:
        key = np.empty(n, dtype=np.int64)
        for i in range(n):
            key[i] = ((rows[i] - rmin) << 31) | i
        key.sort()
        for t in range(n):
            order[t] = key[t] & (2**31 - 1)
        return order, rows
    fill = np.zeros(span + 1, dtype=np.int64)
    for i in range(n):
        fill[rows[i] - rmin + 1] += 1
    for r in range(span):
        fill[r + 1] += fill[r]
    for i in range(n):
        order[fill[rows[i] - rmin]] = i
        fill[rows[i] - rmin] += 1
    return order, rows


@jit
def band_index(points, max_span):
    """What :func:`band_candidates` needs of the right points: ``(row_values, row_start,
    order, rx, ry)`` -- the distinct rows ``floor(y)`` (increasing), each row's offsets
    in ``order``, the points row by row with x increasing (ties: index increasing), and
    their coordinates in that order.

    Rows by :func:`row_order`; within a row, one unique int64 key per point, the float32 x
    made monotonic as an unsigned 32-bit number above the 31-bit index (indices < 2**31),
    sorted by insertion (short rows) or NumPy's sort.
    """
    n = points.shape[0]
    order, point_row = row_order(points, max_span)
    key = np.empty(n, dtype=np.int64)
    rows = np.empty(n, dtype=np.int64)
    for t in range(n):
        i = order[t]
        rows[t] = point_row[i]
        bits = np.int64(np.float32(points[i, 0]).view(np.int32))
        if bits < 0:
            bits = -bits - 2**31 - 1
        key[t] = ((bits + 2**31) << 31) | i
    row_values = np.empty(n, dtype=np.int64)
    row_start = np.empty(n + 1, dtype=np.int64)
    nrows = 0
    lo = 0
    while lo < n:
        hi = lo + 1
        while hi < n and rows[hi] == rows[lo]:
            hi += 1
        row_values[nrows] = rows[lo]
        row_start[nrows] = lo
        nrows += 1
        if hi - lo > SHORT_RUN:  # distinct keys: any sort will do
            ordered = key[lo:hi].copy()
            ordered.sort()  # the one sort of the kernels (int64, in place): compiled once
            for t in range(hi - lo):
                key[lo + t] = ordered[t]
        else:
            for t in range(lo + 1, hi):
                kt = key[t]
                u = t - 1
                while u >= lo and key[u] > kt:
                    key[u + 1] = key[u]
                    u -= 1
                key[u + 1] = kt
        lo = hi
    row_start[nrows] = n
    rx = np.empty(n, dtype=np.float32)
    ry = np.empty(n, dtype=np.float32)
    for t in range(n):
        i = key[t] & (2**31 - 1)
        order[t] = i
        rx[t] = points[i, 0]
        ry[t] = points[i, 1]
    return row_values[:nrows].copy(), row_start[:nrows + 1].copy(), order, rx, ry


#: Entries the x-bucket table of :func:`row_buckets` may have per right point (plus
#: ``BUCKET_SLACK``): memory stays linear in the number of points.
BUCKETS_PER_POINT = 4
BUCKET_SLACK = 1024
#: Longest bucket range :func:`band_candidates` scans as it is; longer ones (crowded
#: buckets: most points in a few of them) are narrowed by binary search first.
BUCKET_SCAN_MAX = 64


@jit(exact=True)
def _bucket(x, x0, inv, nb):
    """``floor((x - x0) * inv)`` clamped to ``[0, nb - 1]``, clamped in float64 before the
    conversion (so any x, however far out, is safe); monotonic in x. Compiled without
    fastmath, so the table and the searches round it the same way."""
    f = (x - x0) * inv
    if f >= nb:
        return nb - 1
    if f > 0.0:
        return np.int64(f)
    return np.int64(0)


@jit
def row_buckets(row_start, rx, max_entries):
    """An x-bucket table over rows of points sorted by x within each row, so that a search
    for an x range needs no binary search: ``(table, x0, inv, nb)``, ``table[r * (nb + 1) +
    b]`` the first offset t of row r (``row_start[r] <= t <= row_start[r + 1]``) whose
    bucket ``_bucket(rx[t], x0, inv, nb)`` is at least b (the row's end if none).

    Every point of row r with ``x_lo <= rx <= x_hi`` then lies in ``[table[r, bucket(x_lo)],
    table[r, bucket(x_hi) + 1])`` (buckets are monotonic in x), a superset by at most the
    points sharing the two end buckets. The ``nb`` buckets split the x span of all points
    evenly; ``nb`` is as large as ``max_entries`` allows (at least 1).
    """
    nrows = row_start.shape[0] - 1
    n = rx.shape[0]
    x0 = 0.0
    x1 = 0.0
    for t in range(n):
        x = np.float64(rx[t])
        if t == 0 or x < x0:
            x0 = x
        if t == 0 or x > x1:
            x1 = x
    nb = np.int64(max(1, min(max_entries // max(nrows, 1) - 1, 1 << 24)))
    inv = nb / (x1 - x0) if x1 > x0 else 0.0
    stride = nb + 1
    table = np.empty(nrows * stride, dtype=np.int64)
    for r in range(nrows):
        base = r * stride
        b = 0
        for t in range(row_start[r], row_start[r + 1]):
            bt = _bucket(np.float64(rx[t]), x0, inv, nb)
            while b <= bt:
                table[base + b] = t
                b += 1
        while b < stride:
            table[base + b] = row_start[r + 1]
            b += 1
    return table, x0, inv, nb


@jit
def band_candidates(left, visit, row_values, row_start, order, rx, ry, dmin, dmax, vmax,
                    max_neurons, scale_l, scale_r_sorted, gate, eps, gain_tol,
                    count_only=False):
    """The pairs (i, k) with ``dmin <= xl - xr <= dmax`` and ``yl - vmax <= yr <= yl + vmax``
    (float32 arithmetic, as the points are stored), as ``(ni, nk, n)``: grouped by left point
    in the order ``visit`` lists them, each group in row order (:func:`group_by_left` and
    :func:`sort_groups` sort them by (i, k)). Visiting the left points row by row
    (:func:`row_order`) reads the right points' rows while they are still in cache.

    ``row_values`` are the distinct rows ``floor(y)`` of the right points (increasing),
    ``order`` the right points row by row with x increasing, ``row_start`` each row's
    offsets in it, and ``rx, ry`` the right points' coordinates in that order. Only the
    rows ``floor(yl - vmax) .. floor(yl + vmax)`` are visited, and in each row only the x
    range of the disparity band (one pixel of slack for rounding), found in the x-bucket
    table of :func:`row_buckets` without a search and scanned without branches (the exact
    test keeps the pairs inside); a range longer than ``BUCKET_SCAN_MAX`` points (crowded
    buckets) is narrowed by binary search first. The cost grows with the number of
    candidates, not with ``Nl x Nr``, however the points are spread.

    Pairs whose window contrasts alone put them past the similarity ``gate``
    (:func:`contrast_admits`, the bound :func:`normalised_difference` skips by) are not
    written; ``scale_r_sorted`` is ``scale_r[order]``, ``gain_tol`` the relative gain the
    similarity allows for. Pass zero scales and ``gate = inf`` to keep every pair. ``n``
    counts every pair of the band all the same (the ``max_neurons`` budget is on the
    band).

    The search itself is :func:`_band_scan`; here the output grows by doubling up to
    ``max_neurons`` entries whenever a left point's pairs would not fit. Past that the
    pairs are only counted, and the count stops at the first row of the band that takes it
    past ``max_neurons`` (a refusal costs about ``max_neurons`` steps, not the band's
    size): ``n > max_neurons`` then says so (``n`` a lower bound of the band's pairs), and
    ``ni``/``nk`` are empty.

    ``count_only``: write no pair, only count (``ni``/``nk`` empty, ``n`` as above): the
    count of a refusal without the writes that lead up to it.
    """
    table, x0, inv, nb = row_buckets(row_start, rx,
                                     BUCKETS_PER_POINT * rx.shape[0] + BUCKET_SLACK)
    cap = 0 if count_only else min(max_neurons, 8 * left.shape[0] + 1024)
    ni = np.empty(cap, dtype=np.int32)
    nk = np.empty(cap, dtype=np.int32)
    # int64, not the literal 0: Numba would compile _band_scan for both types
    q = np.int64(0)  # left points searched (in visit order)
    p = np.int64(0)  # pairs written
    n = np.int64(0)  # pairs in the band
    while q < visit.shape[0]:
        q, p, n = _band_scan(left, visit, q, row_values, table, x0, inv, nb, order, rx, ry,
                             dmin, dmax, vmax, scale_l, scale_r_sorted, gate, eps, gain_tol,
                             ni, nk, p, n, cap < max_neurons and not count_only,
                             max_neurons)
        if q < visit.shape[0]:  # left point q did not fit: grow, then resume at it
            cap = min(2 * cap, max_neurons)
            ni = grown(ni, p, cap)
            nk = grown(nk, p, cap)
    if n > max_neurons or count_only:
        return np.empty(0, dtype=np.int32), np.empty(0, dtype=np.int32), n
    return ni[:p].copy(), nk[:p].copy(), n


@jit
def _band_scan(left, visit, q0, row_values, table, x0, inv, nb, order, rx, ry, dmin, dmax,
               vmax, scale_l, scale_r_sorted, gate, eps, gain_tol, ni, nk, p, n, may_grow,
               limit):
    """The search of :func:`band_candidates` from ``visit[q0]`` on, into ``ni``/``nk``
    (``p`` pairs written and ``n`` counted so far): returns ``(q, p, n)``; once ``n``
    exceeds ``limit`` it returns at once (``q = len(visit)``).

    With ``may_grow``, it stops at the first left point q whose bucket ranges would not fit
    in the room left, before writing any of its pairs (``p``, ``n`` as they were before it),
    so that the caller can grow the arrays and resume at q. Without, it writes while there
    is room and then only counts, to the end (``q = len(visit)``).

    The arrays are arguments and never rebound here (growing them is the caller's): a loop
    that rebinds its arrays compiles to a slower search.
    """
    stride = nb + 1
    cap = ni.shape[0]
    last_lo = np.int64(0)
    last_hi = np.int64(-1)
    r_lo = 0
    r_hi = 0
    for q in range(q0, visit.shape[0]):
        i = visit[q]
        xl = left[i, 0]
        yl = left[i, 1]
        sl = scale_l[i]
        y_lo = yl - vmax
        y_hi = yl + vmax
        row_lo = np.int64(np.floor(np.float64(y_lo)))
        row_hi = np.int64(np.floor(np.float64(y_hi)))
        if row_lo != last_lo or row_hi != last_hi:  # a new row range (visits go row by row)
            r_lo = lower_bound(row_values, 0, row_values.shape[0], row_lo)
            r_hi = upper_bound(row_values, r_lo, row_values.shape[0], row_hi)
            last_lo = row_lo
            last_hi = row_hi
        x_lo = np.float64(xl) - np.float64(dmax) - 1.0
        x_hi = np.float64(xl) - np.float64(dmin) + 1.0
        b_lo = _bucket(x_lo, x0, inv, nb)
        b_hi = _bucket(x_hi, x0, inv, nb) + 1
        p_before = p
        n_before = n
        for r in range(r_lo, r_hi):
            t0 = table[r * stride + b_lo]
            t1 = max(table[r * stride + b_hi], t0)
            if t1 - t0 > BUCKET_SCAN_MAX:
                t0 = lower_bound(rx, t0, t1, x_lo)
                t1 = upper_bound(rx, t0, t1, x_hi)
            if p + (t1 - t0) <= cap:  # room for every pair of the segment: no branches
                for t in range(t0, t1):
                    d = xl - rx[t]
                    inside = (d >= dmin) & (d <= dmax) & (ry[t] >= y_lo) & (ry[t] <= y_hi)
                    sr = scale_r_sorted[t]
                    ni[p] = i
                    nk[p] = order[t]
                    n += inside
                    p += inside & contrast_admits(sl, sr, similarity_norm(sl, sr, eps), gate,
                                                  gain_tol)
                if n > limit:  # past the budget: the caller refuses, counting on is moot
                    return visit.shape[0], p, n
            elif may_grow:
                return q, p_before, n_before
            else:  # at the budget: write while there is room, then only count
                for t in range(t0, t1):
                    d = xl - rx[t]
                    if d >= dmin and d <= dmax and ry[t] >= y_lo and ry[t] <= y_hi:
                        n += 1
                        sr = scale_r_sorted[t]
                        if contrast_admits(sl, sr, similarity_norm(sl, sr, eps), gate,
                                           gain_tol):
                            if p < cap:
                                ni[p] = i
                                nk[p] = order[t]
                            p += 1
                if n > limit:
                    return visit.shape[0], p, n
    return visit.shape[0], p, n


@jit(inline=True)
def _window_query(ys_sorted, y_lo, y_hi):
    """[a, b) range of a sorted array with y_lo <= y <= y_hi (``np.searchsorted`` left and
    right, by the binary searches the band search compiles anyway)."""
    a = lower_bound(ys_sorted, 0, ys_sorted.shape[0], y_lo)
    b = upper_bound(ys_sorted, a, ys_sorted.shape[0], y_hi)
    return a, b


@jit
def epipolar_offset(f, xl, yl, xr, yr):
    """Signed distance of the right point (xr, yr) to the epipolar line ``F (xl, yl, 1)``."""
    a = f[0, 0] * xl + f[0, 1] * yl + f[0, 2]
    b = f[1, 0] * xl + f[1, 1] * yl + f[1, 2]
    c = f[2, 0] * xl + f[2, 1] * yl + f[2, 2]
    norm = np.sqrt(a * a + b * b)
    if norm == 0.0:
        return np.inf
    return (a * xr + b * yr + c) / norm


#: :func:`epipolar_candidates` buckets the right points in horizontal strips of this many
#: pixels (or ``2 vmax``, whichever is more), so that a left point scans only the strips
#: its band crosses, each over the columns where it crosses them.
EPIPOLAR_STRIP = 8.0
#: ... and at most this many strips (taller ones over a taller range of y).
EPIPOLAR_MAX_STRIPS = 4096


@jit
def epipolar_strips(right, order_x, min_height):
    """The right points in horizontal strips from the smallest y, ``min_height`` px tall or
    taller so that there are at most :data:`EPIPOLAR_MAX_STRIPS`: ``(ymin, height,
    n_strips, start, members, xs, rank)``, ``start`` the CSR starts of the strips in
    ``members`` (right point indices in ``order_x`` order within a strip, so x increasing),
    ``xs`` their x (float32) and ``rank[k]`` the position of point k in ``order_x``."""
    n = right.shape[0]
    ymin = np.float64(right[0, 1])
    ymax = ymin
    for k in range(1, n):
        y = np.float64(right[k, 1])
        ymin = min(ymin, y)
        ymax = max(ymax, y)
    height = max(min_height, (ymax - ymin) / EPIPOLAR_MAX_STRIPS)
    ns = min(int((ymax - ymin) // height) + 1, EPIPOLAR_MAX_STRIPS + 1)
    strip = np.empty(n, dtype=np.int64)
    start = np.zeros(ns + 1, dtype=np.int64)
    for k in range(n):
        s = min(int((np.float64(right[k, 1]) - ymin) // height), ns - 1)
        strip[k] = s
        start[s + 1] += 1
    for s in range(ns):
        start[s + 1] += start[s]
    fill = start[:ns].copy()
    members = np.empty(n, dtype=np.int32)
    xs = np.empty(n, dtype=np.float32)
    rank = np.empty(n, dtype=np.int32)
    for t in range(n):
        k = order_x[t]
        rank[k] = t
        q = fill[strip[k]]
        members[q] = k
        xs[q] = right[k, 0]
        fill[strip[k]] = q + 1
    return ymin, height, ns, start, members, xs, rank


@jit
def epipolar_candidates(left, right, order_x, f, dmin, dmax, vmax, max_neurons):
    """The pairs with ``dmin <= xl - xr <= dmax`` and the right point within ``vmax`` of the
    left point's epipolar line (fundamental matrix ``f``, float64 3 x 3), as ``(ni, nk, n)``
    grouped by left point i increasing, within a group in x order (``order_x`` sorts the
    right points by x).

    Each left point scans only the strips of :func:`epipolar_strips` that its band crosses
    over the disparity range, each over the columns where the band crosses it (widened by
    1 px for rounding), then tests every point there exactly (eq. 12's window with the
    epipolar offset for the rows): the work grows with the band's pairs, not with
    ``Nl x Nr``. A near-vertical epipolar line (``|b| <= 1e-9 |(a, b)|``) scans every strip.

    As :func:`band_candidates`: the output grows up to ``max_neurons`` entries; past that
    the count stops at the first pair beyond the budget, ``n > max_neurons`` says so and
    ``ni``/``nk`` are empty.
    """
    cap = min(max_neurons, 8 * left.shape[0] + 1024)
    ni = np.empty(cap, dtype=np.int32)
    nk = np.empty(cap, dtype=np.int32)
    rk = np.empty(cap, dtype=np.int32)  # int32 as ni, nk: grown() compiles once
    p = np.int64(0)  # not the literal 0: grown() would compile twice
    if right.shape[0] == 0 or left.shape[0] == 0:
        return ni[:0].copy(), nk[:0].copy(), p
    ymin, height, ns, start, members, xs, rank = epipolar_strips(
        right, order_x, max(EPIPOLAR_STRIP, 2.0 * np.float64(vmax)))
    pad = 1.0
    for i in range(left.shape[0]):
        xl = np.float64(left[i, 0])
        yl = np.float64(left[i, 1])
        a = f[0, 0] * xl + f[0, 1] * yl + f[0, 2]
        b = f[1, 0] * xl + f[1, 1] * yl + f[1, 2]
        c = f[2, 0] * xl + f[2, 1] * yl + f[2, 2]
        norm = np.sqrt(a * a + b * b)
        if not norm > 0.0:
            continue  # no line: no right point is within vmax of it
        wx_lo = np.float32(xl - dmax)
        wx_hi = np.float32(xl - dmin)
        s_lo = 0
        s_hi = ns - 1
        steep = not abs(b) > 1e-9 * norm
        half = np.float64(vmax) * norm / abs(b) if not steep else 0.0
        if not steep:  # the strips the band crosses between the window's ends
            y1 = (-a * np.float64(wx_lo) - c) / b
            y2 = (-a * np.float64(wx_hi) - c) / b
            y_lo = min(y1, y2) - half - pad
            y_hi = max(y1, y2) + half + pad
            if y_lo == y_lo and y_hi == y_hi:  # finite bounds narrow the strips
                s_lo = int(max(-1.0, min(np.float64(ns), (y_lo - ymin) // height)))
                s_hi = int(max(-1.0, min(np.float64(ns), (y_hi - ymin) // height)))
                s_lo = max(s_lo, 0)
                s_hi = min(s_hi, ns - 1)
        for s in range(s_lo, s_hi + 1):
            x_lo = wx_lo
            x_hi = wx_hi
            if not steep and abs(a) > 1e-12 * norm:  # the columns where it crosses strip s
                y0 = ymin + s * height - half - pad
                y3 = ymin + (s + 1) * height + half + pad
                xa = (-b * y0 - c) / a
                xb = (-b * y3 - c) / a
                if xa == xa and xb == xb:
                    x_lo = max(x_lo, np.float32(min(xa, xb) - pad))
                    x_hi = min(x_hi, np.float32(max(xa, xb) + pad))
            if not x_lo <= x_hi:
                continue
            t0 = start[s]
            ta, tb = _window_query(xs[t0:start[s + 1]], x_lo, x_hi)
            for t in range(t0 + ta, t0 + tb):
                k = members[t]
                d = left[i, 0] - right[k, 0]
                if d >= dmin and d <= dmax:
                    if abs(epipolar_offset(f, xl, yl, np.float64(right[k, 0]),
                                           np.float64(right[k, 1]))) <= vmax:
                        if p == cap and cap < max_neurons:
                            cap = min(2 * cap, max_neurons)
                            ni = grown(ni, p, cap)
                            nk = grown(nk, p, cap)
                            rk = grown(rk, p, cap)
                        if p < cap:
                            ni[p] = i
                            nk[p] = k
                            rk[p] = rank[k]
                        p += 1
                        if p > max_neurons:
                            return (np.empty(0, dtype=np.int32), np.empty(0, dtype=np.int32),
                                    p)
    if p > max_neurons:
        return np.empty(0, dtype=np.int32), np.empty(0, dtype=np.int32), p
    # each group in x order (order_x), as one scan of the sorted x gives: the strips found
    # them strip by strip (sort_groups of the ranks, in its one compiled form)
    out_i = ni[:p].copy()
    ranks = rk[:p].copy()
    out_k = np.empty(p, dtype=np.float64)
    for j in range(p):
        out_k[j] = nk[j]
    sort_groups(out_i, ranks, out_k)
    out = np.empty(p, dtype=np.int32)
    for j in range(p):
        out[j] = np.int32(out_k[j])
    return out_i, out, p


@jit
def group_by_left(ni, nk, values, n_left, gated, limit):
    """Pairs grouped by left point in any order, regrouped by i increasing (a stable
    counting sort: each group keeps its order). With ``gated``, only the pairs with
    ``values <= limit`` are kept (NaN is not). Returns new ``(ni, nk, values)``."""
    n = ni.shape[0]
    fill = np.zeros(n_left + 1, dtype=np.int64)
    kept = 0
    for t in range(n):
        if not gated or values[t] <= limit:
            fill[ni[t] + 1] += 1
            kept += 1
    for i in range(n_left):
        fill[i + 1] += fill[i]
    oi = np.empty(kept, dtype=ni.dtype)
    ok = np.empty(kept, dtype=nk.dtype)
    ov = np.empty(kept, dtype=values.dtype)
    for t in range(n):
        if gated and not values[t] <= limit:
            continue
        w = fill[ni[t]]
        oi[w] = ni[t]
        ok[w] = nk[t]
        ov[w] = values[t]
        fill[ni[t]] += 1
    return oi, ok, ov


@jit
def sort_groups(ni, nk, values):
    """Sort, in place, each run of equal ``ni`` by ``nk`` (by insertion when the run is
    short, else by sorting int64 keys, ``nk`` above the offset in the run), permuting
    ``values`` alike: candidate pairs grouped by left point become sorted by (i, k)."""
    n = ni.shape[0]
    lo = 0
    while lo < n:
        hi = lo + 1
        while hi < n and ni[hi] == ni[lo]:
            hi += 1
        if hi - lo > SHORT_RUN:  # the keys of a run are distinct: any sort will do
            m = hi - lo
            order = np.empty(m, dtype=np.int64)  # k above the 31-bit offset in the run
            for t in range(m):
                order[t] = (np.int64(nk[lo + t]) << 31) | t
            order.sort()  # the sort of row_order and band_index: compiled once
            keys = np.empty(m, dtype=nk.dtype)
            vals = np.empty(m, dtype=values.dtype)
            for t in range(m):
                u = lo + (order[t] & (2**31 - 1))
                keys[t] = nk[u]
                vals[t] = values[u]
            for t in range(m):
                nk[lo + t] = keys[t]
                values[lo + t] = vals[t]
            lo = hi
            continue
        for t in range(lo + 1, hi):
            key = nk[t]
            val = values[t]
            u = t - 1
            while u >= lo and nk[u] > key:
                nk[u + 1] = nk[u]
                values[u + 1] = values[u]
                u -= 1
            nk[u + 1] = key
            values[u + 1] = val
        lo = hi


@jit(inline=True)
def _ranks_before(s_a, k_a, s_b, k_b):
    """Whether pair a comes before pair b in the order (similarity distance, right index),
    NaN distances last (NumPy's sort order)."""
    if s_a < s_b:
        return True
    if s_a > s_b:
        return False
    if s_a == s_b or (s_a != s_a and s_b != s_b):  # equal, or both NaN
        return k_a < k_b
    return s_b != s_b  # exactly one is NaN: the other comes first


@jit
def best_two_per_group(ni, nk, sim):
    """The two best pairs of each left point: pairs grouped by left point (each left
    point's pairs contiguous, the groups in any order), ranked by (``sim``, ``nk``), NaN
    last. Returns ``(left, best, second)`` per group in input order: the group's ``ni``,
    the index of its first pair in that ranking and of its second (-1 for a group of one
    pair). In O(pairs), where sorting the pairs by (i, sim) costs O(pairs log pairs)."""
    n = ni.shape[0]
    groups = 0
    for t in range(n):
        if t == 0 or ni[t] != ni[t - 1]:
            groups += 1
    left = np.empty(groups, dtype=np.int64)
    best = np.empty(groups, dtype=np.int64)
    second = np.empty(groups, dtype=np.int64)
    g = -1
    for t in range(n):
        if t == 0 or ni[t] != ni[t - 1]:
            g += 1
            left[g] = ni[t]
            best[g] = t
            second[g] = -1
            continue
        b = best[g]
        if _ranks_before(sim[t], nk[t], sim[b], nk[b]):
            second[g] = b
            best[g] = t
        else:
            s = second[g]
            if s < 0 or _ranks_before(sim[t], nk[t], sim[s], nk[s]):
                second[g] = t
    return left, best, second
