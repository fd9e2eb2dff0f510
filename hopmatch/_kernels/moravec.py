"""Kernels of SPEC section 1: Moravec directional variance (eq. 1) and selection (eq. 2).

Both are compiled with ``exact=True`` (no fastmath) and work on exact integer sums: the tests
compare them bit for bit with the loop-based references in ``tests/naive.py``.
"""

from __future__ import annotations

import numpy as np

from .._config import jit

#: The four unit steps u_theta of eq. 1 as (dx, dy): 0, 45, 90 and 135 degrees.
DIRECTIONS = np.array([[1, 0], [1, 1], [0, 1], [-1, 1]], dtype=np.int64)


@jit(exact=True)
def moravec_response(gq, radius, scale):
    """Eq. 1: ``V(p) = min_theta sum_{q in W(p)} (G(q) - G(q + u_theta))**2``.

    ``gq`` is G quantised to integers (int64, ``|gq| <= 2**19``, see
    ``hopmatch.feature.moravec.quantise``), so every window sum is an exact integer whatever
    the order of the additions: the sums slide along rows and columns in O(1) per pixel and
    still equal the plain double loop bit for bit. ``V = scale * min_theta S_theta`` is
    returned as float32 (H, W); pixels closer than ``radius + 1`` to the border, whose window
    or shifted window would leave the image, get V = 0.
    """
    h, w = gq.shape
    out = np.zeros((h, w), dtype=np.float32)
    m = radius + 1
    if h < 2 * m + 1 or w < 2 * m + 1:
        return out
    k = 2 * radius + 1
    # squared differences of the last k rows, per direction (a ring), and their column sums
    ring = np.zeros((k, 4, w), dtype=np.int64)
    col = np.zeros((4, w), dtype=np.int64)
    for yy in range(1, h - 1):
        here = gq[yy]
        below = gq[yy + 1]
        old = ring[yy % k]  # the row leaving the window
        for x in range(1, w - 1):  # the steps u_theta of DIRECTIONS, in that order
            c = here[x]
            d0 = c - here[x + 1]
            d1 = c - below[x + 1]
            d2 = c - below[x]
            d3 = c - below[x - 1]
            e0 = d0 * d0
            e1 = d1 * d1
            e2 = d2 * d2
            e3 = d3 * d3
            col[0, x] += e0 - old[0, x]
            col[1, x] += e1 - old[1, x]
            col[2, x] += e2 - old[2, x]
            col[3, x] += e3 - old[3, x]
            old[0, x] = e0
            old[1, x] = e1
            old[2, x] = e2
            old[3, x] = e3
        y = yy - radius  # the output row whose window's last row is yy
        if y < m or y >= h - m:
            continue
        # slide the window sums along the row: add the entering column, drop the leaving one
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


@jit(exact=True)
def strict_maxima(v, vmax, radius, margin, threshold):
    """Eq. 2: pixels p with ``V(p) > threshold`` and ``V(p) > V(q)`` for every other q with
    ``max(|qx - px|, |qy - py|) <= radius`` (neighbours outside the image do not exist).

    ``vmax`` is ``v`` dilated over the same neighbourhood (``cv2.dilate``): only pixels equal
    to it are checked for strictness. Pixels closer than ``margin`` to the border are never
    selected. Returns the (y, x) int64 coordinates in raster order.
    """
    h, w = v.shape
    n = 0
    cap = 64
    ys = np.empty(cap, dtype=np.int64)
    xs = np.empty(cap, dtype=np.int64)
    for y in range(margin, h - margin):
        for x in range(margin, w - margin):
            c = v[y, x]
            if c <= threshold or c < vmax[y, x]:
                continue
            strict = True
            for qy in range(max(0, y - radius), min(h, y + radius + 1)):
                for qx in range(max(0, x - radius), min(w, x + radius + 1)):
                    if (qy != y or qx != x) and v[qy, qx] >= c:
                        strict = False
                        break
                if not strict:
                    break
            if strict:
                if n == cap:
                    cap *= 2
                    ys2 = np.empty(cap, dtype=np.int64)
                    xs2 = np.empty(cap, dtype=np.int64)
                    for t in range(n):
                        ys2[t] = ys[t]
                        xs2[t] = xs[t]
                    ys = ys2
                    xs = xs2
                ys[n] = y
                xs[n] = x
                n += 1
    out = np.empty((n, 2), dtype=np.int64)
    for t in range(n):
        out[t, 0] = ys[t]
        out[t, 1] = xs[t]
    return out
