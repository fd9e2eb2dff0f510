"""Kernels of SPEC eqs. 7-9: the similarity of candidate pairs' descriptors.

Float rows (the mean-subtracted windows of eqs. 8-9, or any float descriptor) are compared by
eq. 7's mean absolute difference normalised by the windows' contrasts
(:func:`normalised_difference`); the contrast bound that lets a similarity gate skip pairs
(:func:`contrast_admits`) is the one rule the candidate search and the similarity share.
Binary rows are compared by the fraction of differing bits (:func:`hamming_fraction`).
"""

from __future__ import annotations

import numpy as np

from .._config import jit


@jit(inline=True)
def similarity_norm(s_i, s_k, eps):
    """The normalisation of eq. 7's ``M_ik`` by the window contrasts ``s_i, s_k``
    (``mean |V|``): ``0.5 (s_i + s_k) + eps``."""
    return 0.5 * (s_i + s_k) + eps


@jit(inline=True)
def gain_within(s_i, s_k, gain_tol):
    """The relative gain ``g`` by which eq. 7 scales the right window before comparing it
    with the left one: ``s_i / s_k`` clipped to ``[1 / gain_tol, gain_tol]`` (1 when
    ``gain_tol`` is 1, as in the paper; 1 for a flat right window)."""
    if gain_tol <= 1.0 or not s_k > 0.0:
        return 1.0
    return min(max(s_i / s_k, 1.0 / gain_tol), gain_tol)


@jit(inline=True)
def contrast_admits(s_i, s_k, norm, gate, gain_tol):
    """Whether the window contrasts ``s_i, s_k`` leave the pair within the similarity
    ``gate`` (``norm`` = :func:`similarity_norm`): ``|s_i - g s_k|`` (``g`` =
    :func:`gain_within`) is a lower bound of ``M_ik`` (eq. 7, triangle inequality), so a
    pair with ``|s_i - g s_k| > gate * norm`` (a margin of 1e-6 for rounding) is certainly
    past the gate of the normalised distance. The one rule :func:`band_candidates` and
    :func:`normalised_difference` both apply."""
    g = gain_within(s_i, s_k, gain_tol)
    return abs(s_i - g * s_k) <= gate * norm * (1.0 + 1e-6)


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
def normalised_difference(desc_l, desc_r, ni, nk, scale_l, scale_r, eps, gate, gain_tol):
    """Eq. 7 normalised: ``M_ik / (0.5 (s_i + s_k) + eps)`` for every candidate pair, with
    ``M_ik = (1/n) sum |V_i(x) - g V_k(x')|``, ``s`` the rows' ``mean |V|``
    (:func:`row_mean_abs`) and ``g`` the relative gain of the two windows within
    ``gain_tol`` (:func:`gain_within`; ``gain_tol = 1``: ``g = 1``, eq. 7 as written).

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
        if not contrast_admits(scale_l[i], scale_r[k], norm, gate, gain_tol):
            out[p] = np.inf
            continue
        g = gain_within(scale_l[i], scale_r[k], gain_tol)
        a = desc_l[i]
        b = desc_r[k]
        s = 0.0
        for t in range(dim):
            s += abs(np.float64(a[t]) - g * np.float64(b[t]))
        out[p] = (s / max(dim, 1)) / norm
    return out


@jit(inline=True)
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
