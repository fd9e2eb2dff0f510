"""Kernels of SPEC section 1: Moravec directional variance (eq. 1) and selection (eq. 2).

Both are compiled with ``exact=True`` (no fastmath) and work on exact integer sums: the tests
compare them bit for bit with the loop-based references in ``tests/naive.py``. Indices that
Numba cannot prove non-negative get its negative-index wrap-around, which keeps a loop from
vectorising (or vectorises it with gathers): the hot loops index with unsigned integers.
"""

from __future__ import annotations

import numpy as np

from .._config import jit

#: The four unit steps u_theta of eq. 1 as (dx, dy): 0, 45, 90 and 135 degrees.
DIRECTIONS = np.array([[1, 0], [1, 1], [0, 1], [-1, 1]], dtype=np.int64)


@jit(exact=True)
def moravec_response(g, factor, radius, scale):
    """Eq. 1: ``V(p) = min_theta sum_{q in W(p)} (G(q) - G(q + u_theta))**2``.

    ``g`` is G (float32 (H, W)); each pixel is put on the power-of-two grid of
    ``hopmatch.feature.moravec.quantise`` here, once, as ``rint(float64(G) * factor)``
    (int32, ``|gq| <= 2**19``; ``factor`` and ``scale`` from ``quantisation_step``, the
    rule's one home). Every window sum is then an exact integer (int64) whatever the order
    of the additions: the column sums slide down the image in O(1) per pixel (the squared
    differences of the row entering the window added, those of the row leaving it
    recomputed from the quantised rows and subtracted), then along each row (for the
    default 3 x 3 window, a vectorised sum of three columns), and still equal the plain
    double loop bit for bit. ``V = scale * min_theta S_theta`` is returned as float32
    (H, W); pixels closer than ``radius + 1`` to the border, whose window or shifted window
    would leave the image, get V = 0.
    """
    h, w = g.shape
    out = np.zeros((h, w), dtype=np.float32)
    m = radius + 1
    if h < 2 * m + 1 or w < 2 * m + 1:
        return out
    k = 2 * radius + 1
    nq = k + 2
    # the last k + 2 rows of G quantised (a ring indexed by row % nq), enough to add the
    # squared differences of the row entering the windows and drop those of the row
    # leaving them; row nq stays 0: the rows "leaving" before the first k have entered
    q = np.zeros((nq + 1, w), dtype=np.int32)
    # per direction u_theta (DIRECTIONS, in that order), the column sums over the last k rows
    col = np.zeros((4, w), dtype=np.int64)
    # column indices are unsigned (np.uint64): Numba then skips its negative-index
    # wrap-around and the loops over a row vectorise
    one = np.uint64(1)
    two = np.uint64(2)
    for yy in range(1, h):  # row 0 is never a row q of a window: it is not needed
        rb = yy % nq
        for x in range(w):
            q[rb, x] = np.int32(np.rint(np.float64(g[yy, x]) * factor))
        if yy < 2:
            continue
        ra = (yy - 1) % nq  # row yy - 1 enters (with its lower neighbour yy, row rb) ...
        rao = nq
        rbo = nq
        if yy - 1 - k >= 1:  # ... and row yy - 1 - k leaves
            rao = (yy - 1 - k) % nq
            rbo = (yy - k) % nq
        # the differences fit in int32 (|gq| <= 2**19); squares and sums are int64
        for i in range(w - 2):
            u = np.uint64(i) + one  # x = 1 ... w - 2
            c = q[ra, u]
            d0 = np.int32(c - q[ra, u + one])
            d1 = np.int32(c - q[rb, u + one])
            d2 = np.int32(c - q[rb, u])
            d3 = np.int32(c - q[rb, u - one])
            co = q[rao, u]
            f0 = np.int32(co - q[rao, u + one])
            f1 = np.int32(co - q[rbo, u + one])
            f2 = np.int32(co - q[rbo, u])
            f3 = np.int32(co - q[rbo, u - one])
            col[0, u] += np.int64(d0) * np.int64(d0) - np.int64(f0) * np.int64(f0)
            col[1, u] += np.int64(d1) * np.int64(d1) - np.int64(f1) * np.int64(f1)
            col[2, u] += np.int64(d2) * np.int64(d2) - np.int64(f2) * np.int64(f2)
            col[3, u] += np.int64(d3) * np.int64(d3) - np.int64(f3) * np.int64(f3)
        y = yy - 1 - radius  # the output row whose window's last row is yy - 1
        if y < m or y >= h - m:
            continue
        if k == 3:  # the default window: columns x - 1, x, x + 1 summed in one pass
            for i in range(w - 4):
                u = np.uint64(i) + one  # x - 1 = 1 ... w - 4
                s0 = col[0, u] + col[0, u + one] + col[0, u + two]
                s1 = col[1, u] + col[1, u + one] + col[1, u + two]
                s2 = col[2, u] + col[2, u + one] + col[2, u + two]
                s3 = col[3, u] + col[3, u + one] + col[3, u + two]
                v = min(min(s0, s1), min(s2, s3))
                out[y, u + one] = np.float32(np.float64(v) * scale)
            continue
        # other windows: slide the sums along the row (add the entering column, drop the
        # leaving one)
        s0 = np.int64(0)
        s1 = np.int64(0)
        s2 = np.int64(0)
        s3 = np.int64(0)
        for x in range(m - radius, m + radius):
            s0 += col[0, x]
            s1 += col[1, x]
            s2 += col[2, x]
            s3 += col[3, x]
        for x in range(m, w - m):
            s0 += col[0, x + radius]
            s1 += col[1, x + radius]
            s2 += col[2, x + radius]
            s3 += col[3, x + radius]
            v = min(min(s0, s1), min(s2, s3))
            out[y, x] = np.float32(np.float64(v) * scale)
            s0 -= col[0, x - radius]
            s1 -= col[1, x - radius]
            s2 -= col[2, x - radius]
            s3 -= col[3, x - radius]
    return out


@jit(exact=True, inline=True)
def parabola_offset(lo, c, hi):
    """Sub-pixel offset of a maximum (eq. 2's points refined): the vertex of the parabola
    through (-1, lo), (0, c), (1, hi), in float64; 0 unless the parabola opens downwards,
    clipped to half a pixel."""
    lo = np.float64(lo)
    hi = np.float64(hi)
    den = lo - 2.0 * c + hi
    off = 0.0
    if den < 0:
        off = 0.5 * (lo - hi) / den
    if off < -0.5:
        off = -0.5
    elif off > 0.5:
        off = 0.5
    return off


@jit(exact=True)
def strict_maxima(v, vmax, radius, margin, threshold, subpixel):
    """Eq. 2: pixels p with ``V(p) > threshold`` and ``V(p) > V(q)`` for every other q with
    ``max(|qx - px|, |qy - py|) <= radius`` (neighbours outside the image do not exist).

    ``vmax`` is ``v`` dilated over the same neighbourhood (``cv2.dilate``): only pixels equal
    to it are checked for strictness. Pixels closer than ``margin`` to the border are never
    selected. Returns, in raster order: the (y, x) int64 coordinates, the (x, y) float32
    points, and V there (float32).

    With ``subpixel``, each point moves along each axis by the vertex of the parabola through
    V at p - 1, p, p + 1 (neighbours clamped to the image):
    ``0.5 (V- - V+) / (V- - 2 V + V+)`` in float64 when that denominator is negative, else 0,
    clipped to [-0.5, 0.5], rounded to float32 and added in float32 (the NumPy formula of
    ``tests/naive.py: quadratic_offsets``, bit for bit).

    Each row is screened at once (a vectorised test into byte flags, compacted without
    branches into the row's candidates); the points found are appended per row, so that the
    growing output is rebound (a reference-count update) once per row, not once per point.
    (Scanning the flags 8 bytes at a time, through a uint64 view, saves about 40 us on
    motorcycle but costs about 0.3 s of first compilation.)
    """
    h, w = v.shape
    nx = max(w - 2 * margin, 0)
    flag = np.empty(nx, dtype=np.uint8)
    cand = np.empty(nx, dtype=np.int64)  # x of the row's candidates, then of its maxima
    found = np.empty(1024, dtype=np.int64)  # y * w + x of the maxima, grown by rows
    n = 0
    for y in range(margin, h - margin):
        vr = v[y, margin:]
        mr = vmax[y, margin:]
        for i in range(nx):
            c = vr[i]
            flag[i] = not (c <= threshold or c < mr[i])
        nc = 0
        for i in range(nx):
            cand[nc] = i  # branch-free compaction of the flagged columns
            nc += flag[i]
        ylo = max(0, y - radius)
        yhi = min(h, y + radius + 1)
        nr = 0
        for t in range(nc):
            x = margin + cand[t]
            c = v[y, x]
            xlo = max(0, x - radius)
            xhi = min(w, x + radius + 1)
            strict = True
            for qy in range(ylo, yhi):
                for qx in range(xlo, xhi):
                    if (qy != y or qx != x) and v[qy, qx] >= c:
                        strict = False
                        break
                if not strict:
                    break
            if strict:
                cand[nr] = x  # nr <= t: overwrites only candidates already checked
                nr += 1
        if n + nr > found.shape[0]:
            grown = np.empty(max(2 * found.shape[0], n + nr), dtype=np.int64)
            for t in range(n):
                grown[t] = found[t]
            found = grown
        for t in range(nr):
            found[n + t] = y * w + cand[t]
        n += nr
    yx = np.empty((n, 2), dtype=np.int64)
    pts = np.empty((n, 2), dtype=np.float32)
    resp = np.empty(n, dtype=np.float32)
    for t in range(n):
        y = found[t] // w
        x = found[t] - y * w
        yx[t, 0] = y
        yx[t, 1] = x
        c32 = v[y, x]
        resp[t] = c32
        px = np.float32(x)
        py = np.float32(y)
        if subpixel:  # the vertex of the parabola along x, then along y
            c = np.float64(c32)
            px = px + np.float32(parabola_offset(v[y, max(x - 1, 0)], c, v[y, min(x + 1, w - 1)]))
            py = py + np.float32(parabola_offset(v[max(y - 1, 0), x], c, v[min(y + 1, h - 1), x]))
        pts[t, 0] = px
        pts[t, 1] = py
    return yx, pts, resp
