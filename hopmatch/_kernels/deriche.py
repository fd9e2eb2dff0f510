"""Kernel of SPEC section 1, item 1: the Canny-Deriche gradient in float32, the recursive
filters of OpenCV's ``cv2.ximgproc.GradientDericheX/Y`` (opencv_contrib,
``modules/ximgproc/src/deriche_filter.cpp``).

OpenCV filters each direction apart, in double precision: ``GradientDericheX`` is the
derivative filter along each row, then the smoothing filter down each column;
``GradientDericheY`` the derivative down each column, then the smoothing along each row.
The filters are linear and act on one axis each, so they commute: one pass along the rows
gives the row derivative and the row smoothing of the image, one pass down the columns
smooths the first (X) and differentiates the second (Y) and ends with ``G**2 = X**2 +
Y**2``. Both passes are :func:`deriche_pass`, which runs along axis 0 on every lane of
axis 1 at once (contiguous, so the inner loops vectorise); the caller hands it the image
transposed for the row pass, and transposes the row pass's outputs back
(``hopmatch.feature.gradient``).

Each pass runs OpenCV's causal and anti-causal recursions with its coefficients
(:func:`coefficients`) and its start-up values, which differ between its row and column
filters. float32 rounding: the first pass filters ``image - offset`` (the caller passes the
middle of the grey levels) so that the recursions' states stay small, and the second adds
back the exact (float64) response to the constant ``offset``: a rank-one term, non-zero
only near the ends of the mirrored image, where OpenCV's start-up values make a constant
look like an edge.
"""

from __future__ import annotations

import math

import numpy as np

from .._config import jit


def coefficients(alpha: float, omega: float) -> np.ndarray:
    """OpenCV's coefficients ``(a, b1, b2, a0, a1, a2, a3)`` (float64) for ``alpha`` and
    ``omega``: the derivative filter is ``a * (causal - anticausal)`` with unit numerators
    and denominators ``1 + b1 z + b2 z**2``; the smoothing filter has the numerators
    ``a0 + a1 z`` (causal) and ``a2 z + a3 z**2`` (anti-causal) over the same
    denominators."""
    ea = math.exp(-alpha)
    e2a = math.exp(-2.0 * alpha)
    co = math.cos(omega)
    so = math.sin(omega)
    with np.errstate(all="ignore"):
        # OpenCV's formulas as written (inf or nan for extreme parameters, as OpenCV gives)
        c = np.float64(1.0 - 2.0 * ea * co + e2a) / np.float64(ea * so)
        a = -c * ea * so
        a2po2 = alpha * alpha + omega * omega
        k = np.float64((1.0 - 2.0 * ea * co + e2a) * a2po2) / np.float64(
            2.0 * alpha * ea * so + omega - omega * e2a)
        c1 = k * alpha / a2po2
        c2 = k * omega / a2po2
        b1 = -2.0 * ea * co
        b2 = e2a
        a0 = c2
        a1 = (-c2 * co + c1 * so) * ea
        a2 = a1 - c2 * b1
        a3 = -c2 * b2
    return np.array([a, b1, b2, a0, a1, a2, a3], dtype=np.float64)


@jit("int64(int64, int64)")
def _reflect(p, n):
    """``cv2.borderInterpolate(p, n, cv2.BORDER_REFLECT)``: ``...cba|abc...|...cba``."""
    if n == 1:
        return 0
    while p < 0 or p >= n:
        if p < 0:
            p = -p - 1
        else:
            p = 2 * n - 1 - p
    return p


@jit("void(int64, float64[::1], boolean, float64[::1], float64[::1])")
def _constant_response(n, c, vertical, deriv, smooth):
    """The derivative and smoothing filters of one axis applied to ``n`` ones, in float64,
    into ``deriv`` and ``smooth``; ``vertical`` chooses the column filters' start-up values
    (``c`` holds :func:`coefficients`)."""
    a, b1, b2, a0, a1, a2, a3 = c[0], c[1], c[2], c[3], c[4], c[5], c[6]
    d1m1 = 1.0
    d1m2 = 0.0
    s1m1 = a0 + a1
    s1m2 = 0.0
    deriv[0] = d1m1
    smooth[0] = s1m1
    for i in range(1, n):
        if i == 1:
            dn = 1.0 - b1 * d1m1
            sn = a0 + a1 - b1 * s1m1
        else:
            dn = 1.0 - b1 * d1m1 - b2 * d1m2
            sn = a0 + a1 - b1 * s1m1 - b2 * s1m2
        d1m2 = d1m1
        d1m1 = dn
        s1m2 = s1m1
        s1m1 = sn
        deriv[i] = dn
        smooth[i] = sn
    d2p1 = 1.0
    d2p2 = 0.0
    s2p1 = a2 + a3
    s2p2 = 0.0
    deriv[n - 1] = a * (deriv[n - 1] - d2p1)
    smooth[n - 1] += s2p1
    for i in range(n - 2, -1, -1):
        if i == n - 2:
            dn = 1.0 + (b1 if vertical else -b1) * d2p1
            sn = a2 + a3 - b2 * s2p1
        else:
            dn = 1.0 - b1 * d2p1 - b2 * d2p2
            sn = a2 + a3 - b1 * s2p1 - b2 * s2p2
        d2p2 = d2p1
        d2p1 = dn
        s2p2 = s2p1
        s2p1 = sn
        deriv[i] = a * (deriv[i] - dn)
        smooth[i] += sn



#: States smaller than this are flushed to 0 (:func:`_step`); the filters' values are
#: about the grey levels, 1e30 times larger.
TINY = np.float32(1e-30)


@jit("void(float32[:, ::1], int64, float32[:, ::1], int64, int64, int64, int64, float32, "
     "float32, float32, float32, float32, int64)")
def _step(o, io, x, ia, ib, i1, i2, ca, cb, c1, c2, sub, n):
    """One step of a recursion on ``n`` lanes: row ``io`` of ``o`` becomes ``ca (x[ia] - sub)
    + cb (x[ib] - sub) + c1 o[i1] + c2 o[i2]`` (inputs in rows of ``x``, the two previous
    states in rows of ``o``), values under :data:`TINY` in magnitude flushed to 0: a
    recursion fed zeros would otherwise decay into subnormal numbers, whose arithmetic is
    many times slower. NaN stays NaN."""
    for k in range(n):
        v = ca * (x[ia, k] - sub) + cb * (x[ib, k] - sub) + c1 * o[i1, k] + c2 * o[i2, k]
        o[io, k] = np.float32(0.0) if abs(v) < TINY else v


@jit("void(float32[:, ::1], float32[:, ::1], int64, float64[::1], boolean, float32, "
     "float32[:, ::1], float32[:, ::1], float64[:, ::1], float32[:, ::1], float32, "
     "float32[:, ::1])")
def deriche_pass(src_d, src_s, border, coeffs, along_rows, sub, out_d, out_s, resp,
                 lane_resp, corr, g):
    """One pass of SPEC section 1, item 1's Canny-Deriche filters along axis 0, on all
    lanes (axis 1, contiguous) at once: ``out_d`` the derivative filter of ``src_d - sub``
    and ``out_s`` the smoothing filter of ``src_s - sub`` (float32, ``src``'s shape), the
    sequence mirrored by ``border`` samples at both ends (``cv2.BORDER_REFLECT``, read
    through the index: nothing is copied). ``coeffs``: :func:`coefficients`;
    ``along_rows``: OpenCV's start-up values of a row filter, else of a column filter.
    ``resp`` (float64, ``(2, n)``) receives the two filters' exact responses to a constant
    1 (the same mirrored length).

    When ``g`` has ``src``'s shape the pass also ends the gradient: ``g = X**2 + Y**2``, the
    squared magnitude (the caller takes the square root, a vectorised library call), with
    ``X = out_s + corr resp[1, i] lane_resp[0, k]`` and ``Y = out_d + corr resp[0, i]
    lane_resp[1, k]``: the response to the constant ``corr`` that the first pass took off
    (``lane_resp``: that pass's ``resp``) added back. ``out_s`` and ``out_d`` keep the
    filters' outputs without it.

    The recursions (OpenCV's, with its coefficients and start-up values), for a sequence
    ``x`` of length ``n``: causal derivative ``d1[j] = x[q] - b1 d1[j-1] - b2 d1[j-2]``,
    causal smoothing ``s1[j] = a0 x[j] + a1 x[q] - b1 s1[j-1] - b2 s1[j-2]``, from zero
    states, ``q = j - 1`` but ``q(0) = 0`` and ``q(1) = 1`` for a row filter, 0 for a
    column filter; anti-causal derivative ``d2[j] = x[u] + c d2[j+1] - b2 d2[j+2]`` and
    smoothing ``s2[j] = a2 x[u] + a3 x[v] + e s2[j+1] - b2 s2[j+2]`` with ``u = min(j+1,
    n-1)``, ``v = min(j+2, n-1)``, ``c = -b1`` (``+b1`` at ``j = n-2`` for a column
    filter) and ``e = -b1`` (``-b2`` at ``j = n-2``). The derivative is ``a (d1 - d2)``,
    the smoothing ``s1 + s2``.
    """
    n0, m = src_d.shape
    b = border
    n = n0 + 2 * b
    a = np.float32(coeffs[0])
    b1 = np.float32(coeffs[1])
    b2 = np.float32(coeffs[2])
    a0 = np.float32(coeffs[3])
    a1 = np.float32(coeffs[4])
    a2 = np.float32(coeffs[5])
    a3 = np.float32(coeffs[6])
    one = np.float32(1.0)
    zero = np.float32(0.0)
    dr = np.zeros((3, m), dtype=np.float32)  # states in rings of three rows
    sr = np.zeros((3, m), dtype=np.float32)
    for t in range(2, n + 2):  # causal state j = t - 2 in row t % 3 (loops from 2 vectorise)
        j = t - 2
        q = t - 3 if t >= 4 else (j if along_rows else 0)
        xj = _reflect(j - b, n0)
        xq = _reflect(q - b, n0)
        r = t % 3
        r1 = (t - 1) % 3
        r2 = (t - 2) % 3
        _step(dr, r, src_d, xq, xq, r1, r2, one, zero, -b1, -b2, sub, m)
        _step(sr, r, src_s, xj, xq, r1, r2, a0, a1, -b1, -b2, sub, m)
        i = j - b
        if 0 <= i < n0:
            for k in range(m):
                out_d[i, k] = dr[r, k]
            for k in range(m):
                out_s[i, k] = sr[r, k]
    for r in range(3):
        for k in range(m):
            dr[r, k] = zero
            sr[r, k] = zero
    d64 = np.empty(n, dtype=np.float64)
    s64 = np.empty(n, dtype=np.float64)
    _constant_response(n, coeffs, not along_rows, d64, s64)
    for i in range(n0):
        resp[0, i] = d64[i + b]
        resp[1, i] = s64[i + b]
    finish = g.shape[0] == n0 and g.shape[1] == m
    for j in range(n - 1, b - 1, -1):  # anti-causal state j in row j % 3
        u = _reflect(min(j + 1, n - 1) - b, n0)
        v = _reflect(min(j + 2, n - 1) - b, n0)
        c = b1 if (j == n - 2 and not along_rows) else -b1
        e = -b2 if j == n - 2 else -b1
        r = j % 3
        r1 = (j + 1) % 3
        r2 = (j + 2) % 3
        _step(dr, r, src_d, u, u, r1, r2, one, zero, c, -b2, sub, m)
        _step(sr, r, src_s, u, v, r1, r2, a2, a3, e, -b2, sub, m)
        i = j - b
        if i < n0:
            for k in range(m):
                out_d[i, k] = a * (out_d[i, k] - dr[r, k])
            for k in range(m):
                out_s[i, k] += sr[r, k]
            if finish:
                cs = corr * np.float32(resp[1, i])
                cd = corr * np.float32(resp[0, i])
                for k in range(m):
                    xv = out_s[i, k] + cs * lane_resp[0, k]
                    yv = out_d[i, k] + cd * lane_resp[1, k]
                    g[i, k] = xv * xv + yv * yv
