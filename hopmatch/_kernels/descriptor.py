"""Kernel of eqs. 8-9: the mean-subtracted windows of G that the similarity term compares."""

from __future__ import annotations

import numpy as np

from .._config import jit


@jit(exact=True)
def bilinear_windows(g, points, radius):
    """Eqs. 8-9: ``V_i(x) = G(x) - mean_{W_i}(G)`` on the ``(2 radius + 1)**2`` window
    centred on each (x, y) of ``points``, in raster order, as float32 rows.

    G is sampled bilinearly at the window's pixels ``(x + dx, y + dy)`` (exactly, in float64:
    integer centres read the pixels themselves); samples outside the image take the nearest
    border pixel, as ``cv2.BORDER_REPLICATE`` does. The mean is taken in float64.
    """
    h, w = g.shape
    n = points.shape[0]
    k = 2 * radius + 1
    out = np.empty((n, k * k), dtype=np.float32)
    rows = np.empty((k + 1, k), dtype=np.float64)  # G lerped along x on the k + 1 rows
    vals = np.empty(k * k, dtype=np.float64)
    for p in range(n):
        x = np.float64(points[p, 0])
        y = np.float64(points[p, 1])
        fx0 = np.floor(x)
        fy0 = np.floor(y)
        ax = x - fx0
        ay = y - fy0
        if not (ax == ax and ay == ay):  # NaN centre: every sample is NaN
            for t in range(k * k):
                out[p, t] = np.nan
            continue
        fx0 = min(max(fx0, -2.0 * k), w + 2.0 * k)  # keeps the integer conversion defined
        fy0 = min(max(fy0, -2.0 * k), h + 2.0 * k)
        x0 = np.int64(fx0)
        y0 = np.int64(fy0)
        for r in range(k + 1):
            yr = min(max(y0 - radius + r, 0), h - 1)
            for c in range(k):
                xa = min(max(x0 - radius + c, 0), w - 1)
                xb = min(max(x0 - radius + c + 1, 0), w - 1)
                rows[r, c] = (1.0 - ax) * np.float64(g[yr, xa]) + ax * np.float64(g[yr, xb])
        total = 0.0
        for r in range(k):
            for c in range(k):
                v = (1.0 - ay) * rows[r, c] + ay * rows[r + 1, c]
                vals[r * k + c] = v
                total += v
        mean = total / (k * k)
        for t in range(k * k):
            out[p, t] = np.float32(vals[t] - mean)
    return out
