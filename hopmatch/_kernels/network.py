"""Kernels of SPEC sections 2-3: the sparse Hopfield network (eqs. 5-13).

Neurons exist only for candidate pairs (i, k); interactions only between a neuron (i, k) and
the neurons (j, l) of i's left neighbours j. Everything is stored as CSR arrays whose size is
the number of candidates and interactions; nothing is of size Nl x Nr x Nl x Nr.
"""

from __future__ import annotations

import numpy as np

from .._config import jit

#: Runs longer than this are sorted with NumPy's O(n log n) sorts, shorter ones by insertion
#: (faster on the short runs that are the rule; crowded inputs make long ones).
SHORT_RUN = 32

# --------------------------------------------------------------------------------------
# candidate pairs and neighbourhoods
# --------------------------------------------------------------------------------------


@jit
def _window_query(ys_sorted, y_lo, y_hi):
    """[a, b) range of a sorted array with y_lo <= y <= y_hi."""
    a = np.searchsorted(ys_sorted, y_lo, side="left")
    b = np.searchsorted(ys_sorted, y_hi, side="right")
    return a, b


@jit
def _lower_bound(a, lo, hi, value):
    """First index t in [lo, hi) with ``a[t] >= value`` (``hi`` if none); ``a`` sorted."""
    while lo < hi:
        mid = (lo + hi) >> 1
        if a[mid] < value:
            lo = mid + 1
        else:
            hi = mid
    return lo


@jit
def _upper_bound(a, lo, hi, value):
    """First index t in [lo, hi) with ``a[t] > value`` (``hi`` if none); ``a`` sorted."""
    while lo < hi:
        mid = (lo + hi) >> 1
        if a[mid] <= value:
            lo = mid + 1
        else:
            hi = mid
    return lo


@jit
def _grown(a, n, cap):
    """A copy of ``a[:n]`` with room for ``cap`` entries."""
    out = np.empty(cap, dtype=a.dtype)
    for t in range(n):  # an element loop: a slice assignment compiles a shape check
        out[t] = a[t]
    return out


@jit
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
    sorted by insertion (short rows) or ``np.sort``.
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
            ordered = np.sort(key[lo:hi])
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
def similarity_norm(s_i, s_k, eps):
    """The normalisation of eq. 7's ``M_ik`` by the window contrasts ``s_i, s_k``
    (``mean |V|``): ``0.5 (s_i + s_k) + eps``."""
    return 0.5 * (s_i + s_k) + eps


@jit
def contrast_admits(s_i, s_k, norm, gate):
    """Whether the window contrasts ``s_i, s_k`` leave the pair within the similarity
    ``gate`` (``norm`` = :func:`similarity_norm`): ``|s_i - s_k|`` is a lower bound of
    ``M_ik`` (eq. 7, triangle inequality), so a pair with ``|s_i - s_k| > gate * norm`` (a
    margin of 1e-6 for rounding) is certainly past the gate of the normalised distance. The
    one rule :func:`band_candidates` and :func:`normalised_difference` both apply."""
    return abs(s_i - s_k) <= gate * norm * (1.0 + 1e-6)


@jit
def band_candidates(left, visit, row_values, row_start, order, rx, ry, dmin, dmax, vmax,
                    max_neurons, scale_l, scale_r_sorted, gate, eps):
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
    written; ``scale_r_sorted`` is ``scale_r[order]``. Pass zero scales and ``gate = inf``
    to keep every pair. ``n`` counts every pair of the band all the same (the
    ``max_neurons`` budget is on the band).

    The search itself is :func:`_band_scan`; here the output grows by doubling up to
    ``max_neurons`` entries whenever a left point's pairs would not fit. Past that the
    pairs are only counted: ``n > max_neurons`` then says so, and ``ni``/``nk`` are empty.
    """
    table, x0, inv, nb = row_buckets(row_start, rx,
                                     BUCKETS_PER_POINT * rx.shape[0] + BUCKET_SLACK)
    cap = min(max_neurons, 8 * left.shape[0] + 1024)
    ni = np.empty(cap, dtype=np.int32)
    nk = np.empty(cap, dtype=np.int32)
    q = 0  # left points searched (in visit order)
    p = 0  # pairs written
    n = 0  # pairs in the band
    while q < visit.shape[0]:
        q, p, n = _band_scan(left, visit, q, row_values, table, x0, inv, nb, order, rx, ry,
                             dmin, dmax, vmax, scale_l, scale_r_sorted, gate, eps, ni, nk,
                             p, n, cap < max_neurons)
        if q < visit.shape[0]:  # left point q did not fit: grow, then resume at it
            cap = min(2 * cap, max_neurons)
            ni = _grown(ni, p, cap)
            nk = _grown(nk, p, cap)
    if n > max_neurons:
        return np.empty(0, dtype=np.int32), np.empty(0, dtype=np.int32), n
    return ni[:p].copy(), nk[:p].copy(), n


@jit
def _band_scan(left, visit, q0, row_values, table, x0, inv, nb, order, rx, ry, dmin, dmax,
               vmax, scale_l, scale_r_sorted, gate, eps, ni, nk, p, n, may_grow):
    """The search of :func:`band_candidates` from ``visit[q0]`` on, into ``ni``/``nk``
    (``p`` pairs written and ``n`` counted so far): returns ``(q, p, n)``.

    With ``may_grow``, it stops at the first left point q whose bucket ranges would not fit
    in the room left, before writing any of its pairs (``p``, ``n`` as they were before it),
    so that the caller can grow the arrays and resume at q. Without, it writes while there
    is room and then only counts, to the end (``q = len(visit)``).

    The arrays are arguments, never rebound here: rebinding them in the loop (as growing
    them in place would) made the whole search about a fifth slower (``band_candidates``
    in ``python benchmarks/end_to_end.py --profile``: 1.78 ms per pair before, 1.46 after,
    in the runs that wrote docs/performance.md).
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
            r_lo = _lower_bound(row_values, 0, row_values.shape[0], row_lo)
            r_hi = _upper_bound(row_values, r_lo, row_values.shape[0], row_hi)
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
                t0 = _lower_bound(rx, t0, t1, x_lo)
                t1 = _upper_bound(rx, t0, t1, x_hi)
            if p + (t1 - t0) <= cap:  # room for every pair of the segment: no branches
                for t in range(t0, t1):
                    d = xl - rx[t]
                    inside = (d >= dmin) & (d <= dmax) & (ry[t] >= y_lo) & (ry[t] <= y_hi)
                    sr = scale_r_sorted[t]
                    ni[p] = i
                    nk[p] = order[t]
                    n += inside
                    p += inside & contrast_admits(sl, sr, similarity_norm(sl, sr, eps), gate)
            elif may_grow:
                return q, p_before, n_before
            else:  # at the budget: write while there is room, then only count
                for t in range(t0, t1):
                    d = xl - rx[t]
                    if d >= dmin and d <= dmax and ry[t] >= y_lo and ry[t] <= y_hi:
                        n += 1
                        sr = scale_r_sorted[t]
                        if contrast_admits(sl, sr, similarity_norm(sl, sr, eps), gate):
                            if p < cap:
                                ni[p] = i
                                nk[p] = order[t]
                            p += 1
    return visit.shape[0], p, n


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


@jit
def epipolar_candidates(left, right, order_x, rx_sorted, f, dmin, dmax, vmax, max_neurons):
    """The pairs with ``dmin <= xl - xr <= dmax`` and the right point within ``vmax`` of the
    left point's epipolar line (fundamental matrix ``f``, float64 3 x 3), as ``(ni, nk, n)``
    grouped by left point i increasing (within a group in x order: :func:`sort_groups` sorts
    them). ``order_x`` sorts the right points by x, ``rx_sorted`` is their x in that order.

    As :func:`band_candidates`: the output grows up to ``max_neurons`` entries; past that the
    pairs are only counted, ``n > max_neurons`` says so and ``ni``/``nk`` are empty.
    """
    cap = min(max_neurons, 8 * left.shape[0] + 1024)
    ni = np.empty(cap, dtype=np.int32)
    nk = np.empty(cap, dtype=np.int32)
    p = 0
    for i in range(left.shape[0]):
        xl = np.float64(left[i, 0])
        yl = np.float64(left[i, 1])
        a, b = _window_query(rx_sorted, np.float32(xl - dmax), np.float32(xl - dmin))
        for t in range(a, b):
            k = order_x[t]
            d = left[i, 0] - right[k, 0]
            if d >= dmin and d <= dmax:
                if abs(epipolar_offset(f, xl, yl, np.float64(right[k, 0]),
                                       np.float64(right[k, 1]))) <= vmax:
                    if p == cap and cap < max_neurons:
                        cap = min(2 * cap, max_neurons)
                        ni = _grown(ni, p, cap)
                        nk = _grown(nk, p, cap)
                    if p < cap:
                        ni[p] = i
                        nk[p] = k
                    p += 1
    if p > max_neurons:
        return np.empty(0, dtype=np.int32), np.empty(0, dtype=np.int32), p
    return ni[:p].copy(), nk[:p].copy(), p


@jit
def sort_groups(ni, nk, values):
    """Sort, in place, each run of equal ``ni`` by ``nk`` (by insertion when the run is
    short, else ``np.argsort``), permuting ``values`` alike: candidate pairs grouped by left
    point become sorted by (i, k)."""
    n = ni.shape[0]
    lo = 0
    while lo < n:
        hi = lo + 1
        while hi < n and ni[hi] == ni[lo]:
            hi += 1
        if hi - lo > SHORT_RUN:  # the keys of a run are distinct: any sort will do
            perm = np.argsort(nk[lo:hi]) + lo
            keys = nk[perm]
            vals = values[perm]
            for t in range(hi - lo):
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


@jit
def neighbour_lists(points, half_w, half_h):
    """CSR lists of the other points j with ``|xj - xi| <= half_w`` and ``|yj - yi| <= half_h``
    (differences in float32, as the points are stored).

    Points are bucketed in a grid of cells a hair larger than ``half_w x half_h`` (enlarged
    until there are at most ~4 cells per point), so every neighbour lies in the 3 x 3 cells
    around a point and the cost grows with the number of neighbours, not with N squared.
    Returns ``(offsets, indices)``; each list is sorted by index.

    The lists are gathered cell by cell, so each comes out as a few sorted runs; rather than
    sorting every list, they are transposed (:func:`transposed_lists`): the relation is
    symmetric (``|a - b| == |b - a|`` exactly in float32), so the transpose holds the same
    lists, each in increasing order.
    """
    n = points.shape[0]
    offsets = np.zeros(n + 1, dtype=np.int64)
    if n == 0:
        return offsets, np.empty(0, dtype=np.int32)
    xmin = np.float64(points[:, 0].min())
    ymin = np.float64(points[:, 1].min())
    span_x = np.float64(points[:, 0].max()) - xmin
    span_y = np.float64(points[:, 1].max()) - ymin
    cw = max(np.float64(half_w) * (1.0 + 1e-6), 1e-3)
    ch = max(np.float64(half_h) * (1.0 + 1e-6), 1e-3)
    ncx = int(span_x / cw) + 1
    ncy = int(span_y / ch) + 1
    while ncx * ncy > 4 * n + 64:
        cw *= 2.0
        ch *= 2.0
        ncx = int(span_x / cw) + 1
        ncy = int(span_y / ch) + 1
    # counting sort of the points by cell, with their coordinates stored contiguously
    cell = np.empty(n, dtype=np.int64)
    cell_start = np.zeros(ncx * ncy + 1, dtype=np.int64)
    for i in range(n):
        cx = min(int((np.float64(points[i, 0]) - xmin) / cw), ncx - 1)
        cy = min(int((np.float64(points[i, 1]) - ymin) / ch), ncy - 1)
        cell[i] = cy * ncx + cx
        cell_start[cell[i] + 1] += 1
    for c in range(ncx * ncy):
        cell_start[c + 1] += cell_start[c]
    members = np.empty(n, dtype=np.int32)
    sx = np.empty(n, dtype=np.float32)
    sy = np.empty(n, dtype=np.float32)
    fill = cell_start[:-1].copy()
    for i in range(n):
        q = fill[cell[i]]
        members[q] = i
        sx[q] = points[i, 0]
        sy[q] = points[i, 1]
        fill[cell[i]] += 1
    cap = 16 * n + 1024
    indices = np.empty(cap, dtype=np.int32)
    p = 0
    for i in range(n):  # one pass; the output grows by doubling
        cx0 = cell[i] % ncx
        cy0 = cell[i] // ncx
        xi = points[i, 0]
        yi = points[i, 1]
        for cy in range(max(cy0 - 1, 0), min(cy0 + 2, ncy)):
            a = cell_start[cy * ncx + max(cx0 - 1, 0)]
            b = cell_start[cy * ncx + min(cx0 + 2, ncx)]
            if p + (b - a) > cap:
                cap = max(2 * cap, p + (b - a))
                indices = _grown(indices, p, cap)
            for t in range(a, b):  # room for all: write, keep the ones that qualify
                indices[p] = members[t]
                p += ((members[t] != i) & (abs(sx[t] - xi) <= half_w)
                      & (abs(sy[t] - yi) <= half_h))
        offsets[i + 1] = p
    return offsets, transposed_lists(offsets, indices, n)[1]  # symmetric: same offsets


@jit
def neighbour_lists_among(points, start, half_w, half_h):
    """:func:`neighbour_lists` among the points with neurons (``start[i + 1] > start[i]``),
    as CSR lists over all the points: the others have empty lists and are in none."""
    n = points.shape[0]
    m = 0
    for i in range(n):
        if start[i + 1] > start[i]:
            m += 1
    has = np.empty(m, dtype=np.int64)
    sub = np.empty((m, 2), dtype=points.dtype)
    a = 0
    for i in range(n):
        if start[i + 1] > start[i]:
            has[a] = i
            sub[a, 0] = points[i, 0]
            sub[a, 1] = points[i, 1]
            a += 1
    off_s, idx_s = neighbour_lists(sub, half_w, half_h)
    offsets = np.zeros(n + 1, dtype=np.int64)
    for a in range(m):
        offsets[has[a] + 1] = off_s[a + 1] - off_s[a]
    for i in range(n):
        offsets[i + 1] += offsets[i]
    idx = np.empty(idx_s.shape[0], dtype=np.int32)
    for t in range(idx_s.shape[0]):
        idx[t] = has[idx_s[t]]
    return offsets, idx


@jit
def transposed_lists(offsets, indices, n_out):
    """The transpose of CSR lists whose entries are in ``[0, n_out)`` (``indices`` may be
    longer than ``offsets[-1]``): ``(offsets_t, out)``, list i of the result holding every j
    whose list holds i, in increasing j. For a symmetric relation the lists are the same,
    each sorted."""
    n = offsets.shape[0] - 1
    offsets_t = np.zeros(n_out + 1, dtype=np.int64)
    for t in range(offsets[n]):
        offsets_t[indices[t] + 1] += 1
    for i in range(n_out):
        offsets_t[i + 1] += offsets_t[i]
    fill = offsets_t[:-1].copy()
    out = np.empty(offsets[n], dtype=np.int32)
    for j in range(n):
        for t in range(offsets[j], offsets[j + 1]):
            i = indices[t]
            out[fill[i]] = j
            fill[i] += 1
    return offsets_t, out


@jit
def grid_neighbour_bound(points, cw, ch, max_cells):
    """An upper bound on the ordered neighbour pairs of ``points``: every neighbour of a
    point lies in the 3 x 3 cells of ``cw x ch`` around its own, so the bound is
    ``sum_points (points in those cells) - N``. Counted on a dense grid of cells; returns -1
    when that grid would have more than ``max_cells`` cells (the caller counts sparsely)."""
    n = points.shape[0]
    if n < 2:
        return 0
    xmin = np.inf
    ymin = np.inf
    xmax = -np.inf
    ymax = -np.inf
    for i in range(n):
        x = np.float64(points[i, 0])
        y = np.float64(points[i, 1])
        xmin = min(xmin, x)
        xmax = max(xmax, x)
        ymin = min(ymin, y)
        ymax = max(ymax, y)
    ncx = np.floor((xmax - xmin) / cw) + 3.0  # a ring of empty cells around the points
    ncy = np.floor((ymax - ymin) / ch) + 3.0
    if ncx * ncy > max_cells:
        return -1
    nx = np.int64(ncx)
    counts = np.zeros((np.int64(ncy), nx), dtype=np.int64)
    for i in range(n):
        cx = np.int64(np.floor((np.float64(points[i, 0]) - xmin) / cw)) + 1
        cy = np.int64(np.floor((np.float64(points[i, 1]) - ymin) / ch)) + 1
        counts[cy, cx] += 1
    total = 0
    for cy in range(1, counts.shape[0] - 1):
        for cx in range(1, nx - 1):
            c = counts[cy, cx]
            if c:
                around = 0
                for dy in range(-1, 2):
                    for dx in range(-1, 2):
                        around += counts[cy + dy, cx + dx]
                total += c * around
    return total - n


# --------------------------------------------------------------------------------------
# similarity (eqs. 7-9)
# --------------------------------------------------------------------------------------


@jit
def row_mean_abs(desc):
    """``mean |row|`` of every float descriptor row, in float64 (the contrast of a window)."""
    n, dim = desc.shape
    out = np.zeros(n, dtype=np.float64)
    if dim == 0:
        return out
    for p in range(n):
        s = 0.0
        for t in range(dim):
            s += abs(np.float64(desc[p, t]))
        out[p] = s / dim
    return out


@jit
def normalised_difference(desc_l, desc_r, ni, nk, scale_l, scale_r, eps, gate):
    """Eq. 7 normalised: ``M_ik / (0.5 (s_i + s_k) + eps)`` for every candidate pair, with
    ``M_ik = (1/n) sum |V_i(x) - V_k(x')|`` and ``s`` the rows' ``mean |V|``
    (:func:`row_mean_abs`).

    Pairs whose value certainly exceeds ``gate`` (pass ``inf`` for none) get ``inf``
    without the sum: their contrasts alone put them past it (:func:`contrast_admits`, a
    lower bound of ``M_ik`` with a margin for rounding). Every other value is computed in
    full, so the gate keeps exactly the pairs it would keep otherwise.
    """
    n = ni.shape[0]
    dim = desc_l.shape[1]
    out = np.empty(n, dtype=np.float64)
    for p in range(n):
        i = ni[p]
        k = nk[p]
        norm = similarity_norm(scale_l[i], scale_r[k], eps)
        if not contrast_admits(scale_l[i], scale_r[k], norm, gate):
            out[p] = np.inf
            continue
        a = desc_l[i]
        b = desc_r[k]
        s = 0.0
        for t in range(dim):
            s += abs(np.float64(a[t]) - np.float64(b[t]))
        out[p] = (s / max(dim, 1)) / norm
    return out


@jit
def zero_mean(a, rel_tol, abs_tol):
    """Whether the row ``a`` has ``|mean| <= rel_tol * mean |x| + abs_tol`` (float64 sums):
    the zero-mean test of windows (eqs. 8-9)."""
    dim = a.shape[0]
    s = 0.0
    m = 0.0
    for u in range(dim):
        x = np.float64(a[u])
        s += x
        m += abs(x)
    return abs(s / dim) <= rel_tol * (m / dim) + abs_tol


@jit
def shift_minimal_windows(desc_l, desc_r, qi, ti, size, rel_tol, abs_tol):
    """For each pair (qi, ti) of ``size x size`` windows stored as rows: whether the mean
    absolute difference of the overlapping columns is no larger at the matched position
    than with the right window shifted by one column either way.

    Returns ``(keep, windows)``; ``windows`` is False, and ``keep`` meaningless, as soon as
    a row fails :func:`zero_mean` (the rows are not windows of eqs. 8-9: SIFT, KAZE...).
    """
    n = qi.shape[0]
    keep = np.empty(n, dtype=np.bool_)
    for p in range(n):
        a = desc_l[qi[p]]
        b = desc_r[ti[p]]
        if not (zero_mean(a, rel_tol, abs_tol) and zero_mean(b, rel_tol, abs_tol)):
            return keep, False
        c_minus = 0.0
        c_zero = 0.0
        c_plus = 0.0
        for y in range(size):
            r = y * size
            for x in range(size - 1):
                c_minus += abs(np.float64(a[r + x + 1]) - np.float64(b[r + x]))
                c_plus += abs(np.float64(a[r + x]) - np.float64(b[r + x + 1]))
            for x in range(1, size - 1):
                c_zero += abs(np.float64(a[r + x]) - np.float64(b[r + x]))
        c_minus /= size * (size - 1)
        c_plus /= size * (size - 1)
        c_zero /= size * (size - 2)
        keep[p] = c_zero <= c_minus and c_zero <= c_plus
    return keep, True


@jit
def hamming_fraction(desc_l, desc_r, ni, nk):
    """Fraction of differing bits between binary (uint8-packed) descriptors of each pair."""
    n = ni.shape[0]
    nbytes = desc_l.shape[1]
    out = np.empty(n, dtype=np.float64)
    for p in range(n):
        a = desc_l[ni[p]]
        b = desc_r[nk[p]]
        c = 0
        for t in range(nbytes):
            x = np.int64(a[t] ^ b[t])
            while x != 0:
                x = x & (x - 1)
                c += 1
        out[p] = c / max(8 * nbytes, 1)
    return out


# --------------------------------------------------------------------------------------
# compatibility and interactions (eqs. 5, 6, 10)
# --------------------------------------------------------------------------------------


@jit
def compatibility(x, theta, slope):
    """Eq. 5: ``C = 2 / (1 + exp(slope * (X - theta))) - 1``, in (-1, 1)."""
    z = slope * (x - theta)
    if z > 50.0:
        return -1.0
    return 2.0 / (1.0 + np.exp(z)) - 1.0


@jit
def count_interactions(ni, nk, start, nb_off, nb_idx):
    """Number of ordered pairs of neurons ((i, k), (j, l)) with j a neighbour of i, l != k."""
    total = 0
    for p in range(ni.shape[0]):
        i = ni[p]
        k = nk[p]
        for t in range(nb_off[i], nb_off[i + 1]):
            j = nb_idx[t]
            for q in range(start[j], start[j + 1]):
                if nk[q] != k:
                    total += 1
    return total


@jit
def interaction_bound(start, nb_off, nb_idx):
    """An upper bound of :func:`count_interactions` in O(Nl + neighbour entries): every
    neuron of i times every neuron of i's neighbours, ``l != k`` not excluded (it removes at
    most one pair per neuron and neighbour)."""
    total = 0
    for i in range(start.shape[0] - 1):
        c = start[i + 1] - start[i]
        if c == 0:
            continue
        s = 0
        for t in range(nb_off[i], nb_off[i + 1]):
            j = nb_idx[t]
            s += start[j + 1] - start[j]
        total += c * s
    return total


@jit
def _pair_weight(right, k, l, d_ik, d_jl, len_l, s_p, s_q, theta, slope):
    """``C_ik,jl`` (eq. 5) of ``X = |d_ik - d_jl| + |D_ij - D_kl| + s_ik + s_jl`` (eq. 10),
    given the left length ``D_ij``."""
    xk = np.float64(right[k, 0])
    yk = np.float64(right[k, 1])
    xl = np.float64(right[l, 0])
    yl = np.float64(right[l, 1])
    len_r = np.sqrt((xk - xl) ** 2 + (yk - yl) ** 2)
    return compatibility(abs(d_ik - d_jl) + abs(len_l - len_r) + s_p + s_q, theta, slope)


@jit
def fill_interactions(left, right, ni, nk, start, nb_off, nb_idx, sim, theta, slope,
                      capacity):
    """CSR interactions: for neuron (i, k), every (j, l) of i's neighbours j with l != k and
    weight ``C_ik,jl`` (eq. 5) of ``X = |d_ik - d_jl| + |D_ij - D_kl| + s_ik + s_jl``
    (eq. 10), with d the Euclidean disparity of eq. 6 and s the weighted similarity term.

    Returns ``(off, idx, w)``, ``off[-1]`` the number of interactions; ``capacity`` must be
    at least that (:func:`count_interactions`, or :func:`interaction_bound`).

    The weights are symmetric (``C_ik,jl = C_jl,ik``) and the neighbour relation is too, so
    each weight is computed once: neurons are sorted by (i, k) and each row of the CSR by
    partner, hence row p meets its partners q < p in the order row q stored (q, p) among
    its partners above q. A cursor per row walks them; an entry is copied only if it is the
    mirror (``idx[cursor[q]] == p``), else it is computed, so any neighbour lists give the
    weights eq. 5 defines, and the stored T is exactly symmetric.
    """
    n = ni.shape[0]
    off = np.zeros(n + 1, dtype=np.int64)
    idx = np.empty(capacity, dtype=np.int32)
    w = np.empty(capacity, dtype=np.float32)
    cursor = np.empty(n, dtype=np.int64)  # row q's next entry to mirror
    disparity = np.empty(n, dtype=np.float64)  # eq. 6, once per neuron
    for p in range(n):
        dx = np.float64(left[ni[p], 0]) - np.float64(right[nk[p], 0])
        dy = np.float64(left[ni[p], 1]) - np.float64(right[nk[p], 1])
        disparity[p] = np.sqrt(dx ** 2 + dy ** 2)
    e = 0
    for p in range(n):
        i = ni[p]
        k = nk[p]
        xi = np.float64(left[i, 0])
        yi = np.float64(left[i, 1])
        d_ik = disparity[p]
        cursor[p] = -1
        for t in range(nb_off[i], nb_off[i + 1]):
            j = nb_idx[t]
            if j > i and cursor[p] < 0:
                cursor[p] = e  # this row's partners above p start here
            xj = np.float64(left[j, 0])
            yj = np.float64(left[j, 1])
            len_l = np.sqrt((xi - xj) ** 2 + (yi - yj) ** 2)
            for q in range(start[j], start[j + 1]):
                l = nk[q]
                if l == k:
                    continue
                idx[e] = q
                c = cursor[q] if q < p else -1
                if c >= 0 and c < off[q + 1] and idx[c] == p:
                    w[e] = w[c]
                    cursor[q] = c + 1
                else:
                    w[e] = _pair_weight(right, k, l, d_ik, disparity[q], len_l, sim[p],
                                        sim[q], theta, slope)
                e += 1
        off[p + 1] = e
    return off, idx[:e], w[:e]


# --------------------------------------------------------------------------------------
# dynamics (eqs. 12-13)
# --------------------------------------------------------------------------------------


@jit
def splitmix64(state):
    """One step of SplitMix64: returns (new state, random 64-bit value)."""
    state = state + np.uint64(0x9E3779B97F4A7C15)
    z = state
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return state, z ^ (z >> np.uint64(31))


@jit
def shuffle(perm, state):
    """Fisher-Yates shuffle of ``perm`` in place with SplitMix64; returns the new state."""
    for a in range(perm.shape[0] - 1, 0, -1):
        state, r = splitmix64(state)
        b = np.int64(r % np.uint64(a + 1))
        tmp = perm[a]
        perm[a] = perm[b]
        perm[b] = tmp
    return state


@jit
def local_fields(v, ni, nk, off, idx, w, row, col, unique_w, bias):
    """Eq. 12's bracket for every neuron: ``u = sum_(j,l) T_ik,jl V_jl + I`` with
    ``T = C - w (delta_ij + delta_kl)`` and ``T_ik,ik = 0``."""
    n = ni.shape[0]
    u = np.empty(n, dtype=np.float64)
    for p in range(n):
        s = 0.0
        for e in range(off[p], off[p + 1]):
            if v[idx[e]]:
                s += np.float64(w[e])
        u[p] = s - unique_w * (row[ni[p]] - v[p] + col[nk[p]] - v[p]) + bias
    return u


@jit
def network_energy(v, ni, nk, off, idx, w, row, col, unique_w, bias):
    """Eq. 11: ``E = -1/2 sum T V V - sum I V`` (with the uniqueness weight ``unique_w``)."""
    pair = 0.0
    active = 0
    for p in range(ni.shape[0]):
        if v[p]:
            active += 1
            for e in range(off[p], off[p + 1]):
                if v[idx[e]]:
                    pair += np.float64(w[e])
    unique = 0.0
    for i in range(row.shape[0]):
        unique += row[i] * (row[i] - 1)
    for k in range(col.shape[0]):
        unique += col[k] * (col[k] - 1)
    return -0.5 * pair + 0.5 * unique_w * unique - bias * active


@jit
def run_network(v0, ni, nk, start, off, idx, w, n_left, n_right, unique_w, bias, seed,
                stable_iterations, max_iterations, record_energy):
    """Asynchronous binary dynamics (eq. 13) from the state ``v0`` (the paper: all zero).

    One *iteration* visits one left point i, drawn from a random permutation of the left
    points that have neurons (a new permutation each sweep, SplitMix64 seeded by ``seed``),
    and updates its neurons (i, k) in increasing k with eq. 13:
    ``V <- 1 if u > 0, V <- 0 if u < 0, unchanged if u = 0``. Local fields are kept up to
    date incrementally, so an update costs O(1) and a flip O(its interactions).

    Stops when a whole sweep changed nothing (a fixed point), when ``stable_iterations``
    consecutive iterations changed nothing (if > 0), or after ``max_iterations``.

    A visit reads only its neurons' fields, states and column counts and its row count; a
    left point whose last visit changed nothing and none of whose inputs changed since is
    *clean*, and its visit is counted without recomputing it (it would change nothing
    again). A flip marks dirty the left points of its interaction partners (their fields)
    and of the neurons in its column (their column count). States, iteration and sweep
    counts and the energy trace are those of visiting every point in full.

    Returns ``(v, iterations, sweeps, converged, energy_trace)``; ``energy_trace[t]`` is the
    energy after iteration t (index 0: the start), empty unless ``record_energy``.
    """
    n = ni.shape[0]
    v = v0.copy()
    field = np.zeros(n, dtype=np.float64)
    row = np.zeros(n_left, dtype=np.int64)
    col = np.zeros(n_right, dtype=np.int64)
    for p in range(n):
        if v[p]:
            row[ni[p]] += 1
            col[nk[p]] += 1
            for e in range(off[p], off[p + 1]):
                field[idx[e]] += w[e]
    col_start, col_left = transposed_lists(start, nk, n_right)  # the left points of each column
    clean = np.zeros(n_left, dtype=np.uint8)
    n_active_left = 0
    for i in range(n_left):
        if start[i + 1] > start[i]:
            n_active_left += 1
    perm = np.empty(n_active_left, dtype=np.int64)
    c = 0
    for i in range(n_left):
        if start[i + 1] > start[i]:
            perm[c] = i
            c += 1
    trace = np.empty(max_iterations + 1 if record_energy else 0, dtype=np.float64)
    energy = 0.0  # tracked only for the trace (the starting value costs a pass over the state)
    if record_energy:
        energy = network_energy(v, ni, nk, off, idx, w, row, col, unique_w, bias)
        trace[0] = energy
    state = np.uint64(seed)
    iterations = 0
    sweeps = 0
    unchanged_run = 0
    converged = False
    while iterations < max_iterations and n_active_left > 0:
        state = shuffle(perm, state)
        sweeps += 1
        sweep_changed = False
        for t in range(n_active_left):
            if iterations >= max_iterations:
                break
            i = perm[t]
            changed = False
            if not clean[i]:
                for p in range(start[i], start[i + 1]):
                    k = nk[p]
                    u = field[p] - unique_w * (row[i] - v[p] + col[k] - v[p]) + bias
                    new = v[p]
                    if u > 0.0:
                        new = 1
                    elif u < 0.0:
                        new = 0
                    if new != v[p]:
                        dv = 1.0 if new == 1 else -1.0
                        energy -= u * dv
                        v[p] = new
                        row[i] += 1 if new == 1 else -1
                        col[k] += 1 if new == 1 else -1
                        for e in range(off[p], off[p + 1]):
                            q = idx[e]
                            field[q] += dv * w[e]
                            clean[ni[q]] = 0
                        for m in range(col_start[k], col_start[k + 1]):
                            clean[col_left[m]] = 0
                        changed = True
                clean[i] = 0 if changed else 1
            iterations += 1
            if record_energy:
                trace[iterations] = energy
            if changed:
                sweep_changed = True
                unchanged_run = 0
            else:
                unchanged_run += 1
                if stable_iterations > 0 and unchanged_run >= stable_iterations:
                    converged = True
                    break
        if converged:
            break
        if not sweep_changed:
            converged = True
            break
    return v, iterations, sweeps, converged, trace[: iterations + 1 if record_energy else 0]
