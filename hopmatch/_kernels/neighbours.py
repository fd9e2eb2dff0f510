"""Kernels of SPEC section 4's neighbourhood: for each left point i, the left points j within
its ``width x height`` window (a neuron (i, k) interacts only with the neurons (j, l) of
these j), as CSR lists found on a grid of cells (:func:`cell_size`, the cell rule's one
home).
"""

from __future__ import annotations

import numpy as np

from .._config import jit
from .arrays import grown


@jit(exact=True)
def cell_size(half_w, half_h):
    """The grid cell ``(cw, ch)`` (float64) for neighbours within ``half_w x half_h``: a hair
    larger than the half-window, ``max(half * (1 + 1e-6), 1e-3)`` on each axis, so that a
    neighbour (``|dx| <= half_w`` in float32, as the points are stored) is never beyond the
    3 x 3 cells around a point whatever the rounding; at least 1e-3 px, so a zero window
    still gives a finite grid.

    The one rule of :func:`neighbour_lists` and of the neighbour-pair bound counted on it
    (:func:`grid_neighbour_bound`); callable from Python with the same result for the same
    float64 half-window (compiled without fastmath).
    """
    return (max(np.float64(half_w) * (1.0 + 1e-6), 1e-3),
            max(np.float64(half_h) * (1.0 + 1e-6), 1e-3))


@jit
def cell_buckets(points, half_w, half_h):
    """The points of ``points`` (N >= 1, float32 (x, y)) sorted by grid cell (a counting
    sort): cells of :func:`cell_size` for ``half_w x half_h``, enlarged by doubling until
    there are at most ``4 N + 64`` cells, so every point within the half-window of a point
    lies in the 3 x 3 cells around the cell of that point.

    Returns ``(xmin, ymin, cw, ch, ncx, ncy, cell, cell_start, members, sx, sy)``: the grid
    origin (float64), cell size (float64) and counts, ``cell[i]`` the cell
    (``cy * ncx + cx``) of point i, ``cell_start`` (``ncx * ncy + 1``) the CSR starts of the
    cells in ``members`` (point indices, int32, increasing within a cell), and ``sx``, ``sy``
    the points' coordinates in that order (float32, stored contiguously for the scans).
    The one grid of :func:`neighbour_lists` and of the guided pass's query lists.
    """
    n = points.shape[0]
    # the extremes by a loop, NaN propagating as in NumPy's min and max (whose compiled
    # implementations cost more than this kernel)
    x_lo = x_hi = points[0, 0]
    y_lo = y_hi = points[0, 1]
    for i in range(1, n):
        x = points[i, 0]
        y = points[i, 1]
        if x < x_lo or x != x:
            x_lo = x
        if x > x_hi or x != x:
            x_hi = x
        if y < y_lo or y != y:
            y_lo = y
        if y > y_hi or y != y:
            y_hi = y
    xmin = np.float64(x_lo)
    ymin = np.float64(y_lo)
    span_x = np.float64(x_hi) - xmin
    span_y = np.float64(y_hi) - ymin
    cw, ch = cell_size(np.float64(half_w), np.float64(half_h))  # one specialisation
    ncx = int(span_x / cw) + 1
    ncy = int(span_y / ch) + 1
    while ncx * ncy > 4 * n + 64:
        cw *= 2.0
        ch *= 2.0
        ncx = int(span_x / cw) + 1
        ncy = int(span_y / ch) + 1
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
    return xmin, ymin, cw, ch, ncx, ncy, cell, cell_start, members, sx, sy


@jit
def neighbour_lists(points, half_w, half_h):
    """CSR lists of the other points j with ``|xj - xi| <= half_w`` and ``|yj - yi| <= half_h``
    (differences in float32, as the points are stored).

    Points are bucketed in a grid of cells of :func:`cell_size` (enlarged by doubling until
    there are at most ``4 N + 64`` cells), so every neighbour lies in the 3 x 3 cells
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
    xmin, ymin, cw, ch, ncx, ncy, cell, cell_start, members, sx, sy = cell_buckets(
        points, half_w, half_h)
    cap = 16 * n + 1024
    indices = np.empty(cap, dtype=np.int32)
    p = np.int64(0)  # not the literal 0: grown() would compile twice
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
                indices = grown(indices, p, cap)
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
def neighbour_counts(points, queries, half_w, half_h, cap):
    """For each index i of ``queries`` (into ``points``), how many other points j have
    ``|xj - xi| <= half_w`` and ``|yj - yi| <= half_h`` (differences in float32, as in
    :func:`neighbour_lists`), counted up to ``cap``: ``min(count, cap)`` (int64).

    On the grid of :func:`cell_buckets`; a query stops scanning once it reaches ``cap``,
    so the cost is at most about ``cap`` steps per query beyond its 3 x 3 cells, however
    crowded the points are."""
    nq = queries.shape[0]
    counts = np.zeros(nq, dtype=np.int64)
    if nq == 0 or points.shape[0] < 2 or cap <= 0:
        return counts
    _, _, _, _, ncx, ncy, cell, cell_start, members, sx, sy = cell_buckets(
        points, half_w, half_h)
    for q in range(nq):
        i = queries[q]
        cx0 = cell[i] % ncx
        cy0 = cell[i] // ncx
        xi = points[i, 0]
        yi = points[i, 1]
        c = 0
        for cy in range(max(cy0 - 1, 0), min(cy0 + 2, ncy)):
            a = cell_start[cy * ncx + max(cx0 - 1, 0)]
            b = cell_start[cy * ncx + min(cx0 + 2, ncx)]
            for t in range(a, b):
                c += ((members[t] != i) & (abs(sx[t] - xi) <= half_w)
                      & (abs(sy[t] - yi) <= half_h))
                if c >= cap:
                    break
            if c >= cap:
                break
        counts[q] = c
    return counts


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
    """An upper bound on the ordered neighbour pairs of ``points``: with cells ``cw x ch`` of
    :func:`cell_size`, every neighbour of a point lies in the 3 x 3 cells around its own,
    so the bound is
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
