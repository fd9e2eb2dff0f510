"""Kernels of SPEC eqs. 5, 6 and 10: the interactions ``C_ik,jl`` between neurons (i, k) and
(j, l), j a left neighbour of i, stored as CSR arrays of the size of the interactions.
"""

from __future__ import annotations

import numpy as np

from .._config import jit


@jit
def compatibility(x, theta, slope):
    """Eq. 5: ``C = 2 / (1 + exp(slope * (X - theta))) - 1``, in (-1, 1)."""
    z = slope * (x - theta)
    if z > 50.0:
        return -1.0
    return 2.0 / (1.0 + np.exp(z)) - 1.0


@jit
def count_interactions(ni, nk, start, nb_off, nb_idx, limit=-1):
    """Number of ordered pairs of neurons ((i, k), (j, l)) with j a neighbour of i, l != k.

    With ``limit >= 0`` the count stops as soon as it exceeds ``limit`` and returns what
    it has counted then (a number above ``limit``): the loop then takes at most about
    ``limit`` steps, however many interactions there are (a budget check needs no more).
    """
    total = 0
    for p in range(ni.shape[0]):
        i = ni[p]
        k = nk[p]
        for t in range(nb_off[i], nb_off[i + 1]):
            j = nb_idx[t]
            for q in range(start[j], start[j + 1]):
                if nk[q] != k:
                    total += 1
            if limit >= 0 and total > limit:
                return total
    return total


@jit
def interaction_bounds(start, nb_off, nb_idx):
    """Bounds ``(lower, upper)`` of :func:`count_interactions` in O(Nl + neighbour
    entries). ``upper``: every neuron of i times every neuron of i's neighbours, ``l != k``
    not excluded; ``lower``: the same with one neuron fewer per neighbour (``l != k``
    removes at most one neuron of a neighbour j for each neuron (i, k))."""
    lower = 0
    upper = 0
    for i in range(start.shape[0] - 1):
        c = start[i + 1] - start[i]
        if c == 0:
            continue
        s = 0
        s_less = 0
        for t in range(nb_off[i], nb_off[i + 1]):
            j = nb_idx[t]
            cj = start[j + 1] - start[j]
            s += cj
            if cj > 1:
                s_less += cj - 1
        upper += c * s
        lower += c * s_less
    return lower, upper


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
    at least that (:func:`count_interactions`, or :func:`interaction_bounds`).

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
