"""Kernels of SPEC sections 2-3: the sparse Hopfield network (eqs. 5-13).

Neurons exist only for candidate pairs (i, k); interactions only between a neuron (i, k) and
the neurons (j, l) of i's left neighbours j. Everything is stored as CSR arrays whose size is
the number of candidates and interactions; nothing is of size Nl x Nr x Nl x Nr.
"""

from __future__ import annotations

import numpy as np

from .._config import jit

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
def count_candidates(left, right, order_r, ry_sorted, dmin, dmax, vmax):
    """Number of pairs (i, k) with ``dmin <= xl - xr <= dmax`` and ``|yl - yr| <= vmax``."""
    n = 0
    for i in range(left.shape[0]):
        xl = left[i, 0]
        yl = left[i, 1]
        a, b = _window_query(ry_sorted, yl - vmax, yl + vmax)
        for t in range(a, b):
            d = xl - right[order_r[t], 0]
            if d >= dmin and d <= dmax:
                n += 1
    return n


@jit
def fill_candidates(left, right, order_r, ry_sorted, dmin, dmax, vmax, n):
    """The pairs counted by :func:`count_candidates`, sorted by i then k.

    Returns ``(ni, nk, start)`` with ``start`` the CSR offsets of each left point's neurons.
    """
    ni = np.empty(n, dtype=np.int32)
    nk = np.empty(n, dtype=np.int32)
    nl = left.shape[0]
    start = np.zeros(nl + 1, dtype=np.int64)
    p = 0
    for i in range(nl):
        xl = left[i, 0]
        yl = left[i, 1]
        a, b = _window_query(ry_sorted, yl - vmax, yl + vmax)
        q = p
        for t in range(a, b):
            k = order_r[t]
            d = xl - right[k, 0]
            if d >= dmin and d <= dmax:
                nk[p] = k
                ni[p] = i
                p += 1
        insertion_sort(nk, q, p)
        start[i + 1] = p
    return ni, nk, start


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
def count_candidates_epipolar(left, right, order_x, rx_sorted, f, dmin, dmax, vmax):
    """Number of pairs with ``dmin <= xl - xr <= dmax`` and the right point within ``vmax``
    of the left point's epipolar line (fundamental matrix ``f``, float64 3 x 3)."""
    n = 0
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
                    n += 1
    return n


@jit
def fill_candidates_epipolar(left, right, order_x, rx_sorted, f, dmin, dmax, vmax, n):
    """The pairs counted by :func:`count_candidates_epipolar`, sorted by i then k."""
    ni = np.empty(n, dtype=np.int32)
    nk = np.empty(n, dtype=np.int32)
    p = 0
    for i in range(left.shape[0]):
        xl = np.float64(left[i, 0])
        yl = np.float64(left[i, 1])
        a, b = _window_query(rx_sorted, np.float32(xl - dmax), np.float32(xl - dmin))
        q = p
        for t in range(a, b):
            k = order_x[t]
            d = left[i, 0] - right[k, 0]
            if d >= dmin and d <= dmax:
                if abs(epipolar_offset(f, xl, yl, np.float64(right[k, 0]),
                                       np.float64(right[k, 1]))) <= vmax:
                    nk[p] = k
                    ni[p] = i
                    p += 1
        insertion_sort(nk, q, p)
    return ni, nk


@jit
def insertion_sort(a, lo, hi):
    """Sort ``a[lo:hi]`` in place (the lists sorted here are short)."""
    for t in range(lo + 1, hi):
        key = a[t]
        u = t - 1
        while u >= lo and a[u] > key:
            a[u + 1] = a[u]
            u -= 1
        a[u + 1] = key


@jit
def neighbour_lists(points, half_w, half_h):
    """CSR lists of the other points j with ``|xj - xi| <= half_w`` and ``|yj - yi| <= half_h``
    (differences in float32, as the points are stored).

    Points are bucketed in a grid of cells a hair larger than ``half_w x half_h`` (enlarged
    until there are at most ~4 cells per point), so every neighbour lies in the 3 x 3 cells
    around a point and the cost grows with the number of neighbours, not with N squared.
    Returns ``(offsets, indices)``; each list is sorted by index.
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
    for i in range(n):  # count (each point finds itself once)
        cx0 = cell[i] % ncx
        cy0 = cell[i] // ncx
        c = 0
        for cy in range(max(cy0 - 1, 0), min(cy0 + 2, ncy)):
            a = cell_start[cy * ncx + max(cx0 - 1, 0)]
            b = cell_start[cy * ncx + min(cx0 + 2, ncx)]
            for t in range(a, b):
                if abs(sx[t] - points[i, 0]) <= half_w and abs(sy[t] - points[i, 1]) <= half_h:
                    c += 1
        offsets[i + 1] = offsets[i] + c - 1
    indices = np.empty(offsets[n], dtype=np.int32)
    for i in range(n):  # fill
        cx0 = cell[i] % ncx
        cy0 = cell[i] // ncx
        p = offsets[i]
        for cy in range(max(cy0 - 1, 0), min(cy0 + 2, ncy)):
            a = cell_start[cy * ncx + max(cx0 - 1, 0)]
            b = cell_start[cy * ncx + min(cx0 + 2, ncx)]
            for t in range(a, b):
                if (members[t] != i and abs(sx[t] - points[i, 0]) <= half_w
                        and abs(sy[t] - points[i, 1]) <= half_h):
                    indices[p] = members[t]
                    p += 1
        insertion_sort(indices, offsets[i], p)
    return offsets, indices


# --------------------------------------------------------------------------------------
# similarity (eqs. 7-9)
# --------------------------------------------------------------------------------------


@jit
def mean_abs_difference(desc_l, desc_r, ni, nk):
    """Eq. 7: ``M_ik = (1/n) sum |V_i(x) - V_k(x')|`` for every candidate pair (float rows)."""
    n = ni.shape[0]
    dim = desc_l.shape[1]
    out = np.empty(n, dtype=np.float64)
    for p in range(n):
        a = desc_l[ni[p]]
        b = desc_r[nk[p]]
        s = 0.0
        for t in range(dim):
            s += abs(np.float64(a[t]) - np.float64(b[t]))
        out[p] = s / max(dim, 1)
    return out


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
def fill_interactions(left, right, ni, nk, start, nb_off, nb_idx, sim, theta, slope, n_inter):
    """CSR interactions: for neuron (i, k), every (j, l) of i's neighbours j with l != k and
    weight ``C_ik,jl`` (eq. 5) of ``X = |d_ik - d_jl| + |D_ij - D_kl| + s_ik + s_jl``
    (eq. 10), with d the Euclidean disparity of eq. 6 and s the weighted similarity term.
    """
    n = ni.shape[0]
    off = np.zeros(n + 1, dtype=np.int64)
    idx = np.empty(n_inter, dtype=np.int32)
    w = np.empty(n_inter, dtype=np.float32)
    e = 0
    for p in range(n):
        i = ni[p]
        k = nk[p]
        xi = np.float64(left[i, 0])
        yi = np.float64(left[i, 1])
        xk = np.float64(right[k, 0])
        yk = np.float64(right[k, 1])
        d_ik = np.sqrt((xi - xk) ** 2 + (yi - yk) ** 2)
        for t in range(nb_off[i], nb_off[i + 1]):
            j = nb_idx[t]
            xj = np.float64(left[j, 0])
            yj = np.float64(left[j, 1])
            len_l = np.sqrt((xi - xj) ** 2 + (yi - yj) ** 2)
            for q in range(start[j], start[j + 1]):
                l = nk[q]
                if l == k:
                    continue
                xl = np.float64(right[l, 0])
                yl = np.float64(right[l, 1])
                d_jl = np.sqrt((xj - xl) ** 2 + (yj - yl) ** 2)
                len_r = np.sqrt((xk - xl) ** 2 + (yk - yl) ** 2)
                x = abs(d_ik - d_jl) + abs(len_l - len_r) + sim[p] + sim[q]
                idx[e] = q
                w[e] = compatibility(x, theta, slope)
                e += 1
        off[p + 1] = e
    return off, idx, w


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
    energy = network_energy(v, ni, nk, off, idx, w, row, col, unique_w, bias)
    if record_energy:
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
                        field[idx[e]] += dv * w[e]
                    changed = True
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
