"""Kernels of SPEC section 1: Moravec directional variance (eq. 1) and selection (eq. 2).

Both are compiled with ``exact=True`` (no fastmath): the tests compare them bit for bit with
the loop-based references in ``tests/naive.py``.
"""

from __future__ import annotations

import numpy as np

from .._config import jit

#: The four unit steps u_theta of eq. 1 as (dx, dy): 0, 45, 90 and 135 degrees.
DIRECTIONS = np.array([[1, 0], [1, 1], [0, 1], [-1, 1]], dtype=np.int64)


@jit(exact=True)
def moravec_response(g, radius):
    """Eq. 1: ``V(p) = min_theta sum_{q in W(p)} (G(q) - G(q + u_theta))**2``.

    ``g`` is a float32 (H, W) image, the window is (2 radius + 1) squared. The sum over the
    window is taken row by row (each row summed left to right, then the row sums top to
    bottom) in float64. Pixels closer than ``radius + 1`` to the border, whose window or
    shifted window would leave the image, get V = 0. Returns float32 (H, W).
    """
    h, w = g.shape
    out = np.zeros((h, w), dtype=np.float32)
    m = radius + 1
    if h < 2 * m + 1 or w < 2 * m + 1:
        return out
    best = np.full((h, w), np.inf)
    diff = np.zeros((h, w))
    rows = np.zeros((h, w))
    for t in range(4):
        ux = DIRECTIONS[t, 0]
        uy = DIRECTIONS[t, 1]
        # squared differences for every q that some window uses: rows/cols 1 .. n-2
        for y in range(1, h - 1):
            for x in range(1, w - 1):
                d = np.float64(g[y, x]) - np.float64(g[y + uy, x + ux])
                diff[y, x] = d * d
        # horizontal sums over the window's columns
        for y in range(1, h - 1):
            for x in range(m, w - m):
                s = 0.0
                for dx in range(-radius, radius + 1):
                    s += diff[y, x + dx]
                rows[y, x] = s
        # vertical sums of the row sums, and the minimum over directions
        for y in range(m, h - m):
            for x in range(m, w - m):
                s = 0.0
                for dy in range(-radius, radius + 1):
                    s += rows[y + dy, x]
                if s < best[y, x]:
                    best[y, x] = s
    for y in range(m, h - m):
        for x in range(m, w - m):
            out[y, x] = best[y, x]
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
                    ys2[:n] = ys[:n]
                    xs2[:n] = xs[:n]
                    ys = ys2
                    xs = xs2
                ys[n] = y
                xs[n] = x
                n += 1
    out = np.empty((n, 2), dtype=np.int64)
    out[:, 0] = ys[:n]
    out[:, 1] = xs[:n]
    return out
