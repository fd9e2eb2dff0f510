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

    Every value is computed by the same float64 operations in the same order whatever the
    path:

    - a window whose (k + 1) x (k + 1) footprint lies inside the image reads contiguous rows
      of G without clamping (loops that vectorise); the others clamp each sample;
    - the sum of each mean, a chain of dependent additions in raster order, is run for four
      points at a time, interleaved.

    Points are visited in their given order, so the output rows are written in order.
    """
    h, w = g.shape
    n = points.shape[0]
    k = 2 * radius + 1
    kk = k * k
    out = np.empty((n, kk), dtype=np.float32)
    if n == 0:
        return out
    # Indices known to be >= 0 are unsigned (np.uint64): Numba then skips its negative-index
    # wrap-around, and the row loops vectorise.
    uk = np.uint64(k)
    ukk = np.uint64(kk)
    lanes = 4
    hrows = np.empty((k + 1) * k, dtype=np.float64)  # G lerped along x on the k + 1 rows
    vals = np.empty(lanes * kk, dtype=np.float64)  # the window of each lane
    nan = np.zeros(lanes, dtype=np.bool_)
    for q0 in range(0, n, lanes):
        for lane in range(lanes):
            p = min(q0 + lane, n - 1)  # the last group repeats its last point
            x = np.float64(points[p, 0])
            y = np.float64(points[p, 1])
            fx0 = np.floor(x)
            fy0 = np.floor(y)
            ax = x - fx0
            ay = y - fy0
            nan[lane] = not (ax == ax and ay == ay)
            if nan[lane]:  # NaN centre: the row is NaN; compute any window meanwhile
                fx0 = fy0 = ax = ay = 0.0
            bx = 1.0 - ax
            by = 1.0 - ay
            if (fx0 >= radius and fx0 + radius + 1.0 <= w - 1.0 and fy0 >= radius
                    and fy0 + radius + 1.0 <= h - 1.0):
                ys = np.uint64(fy0 - radius)  # the footprint is inside: no clamping
                xs = np.uint64(fx0 - radius)
                for r in range(k + 1):
                    yr = ys + np.uint64(r)
                    hr = np.uint64(r) * uk
                    for c in range(k):
                        xc = xs + np.uint64(c)
                        hrows[hr + np.uint64(c)] = (bx * np.float64(g[yr, xc])
                                                    + ax * np.float64(g[yr, xc + np.uint64(1)]))
            else:
                fx0 = min(max(fx0, -2.0 * k), w + 2.0 * k)  # keeps the integer conversion defined
                fy0 = min(max(fy0, -2.0 * k), h + 2.0 * k)
                x0 = np.int64(fx0)
                y0 = np.int64(fy0)
                for r in range(k + 1):
                    yr = min(max(y0 - radius + r, 0), h - 1)
                    for c in range(k):
                        xa = min(max(x0 - radius + c, 0), w - 1)
                        xb = min(max(x0 - radius + c + 1, 0), w - 1)
                        hrows[r * k + c] = (bx * np.float64(g[yr, xa])
                                            + ax * np.float64(g[yr, xb]))
            vb = np.uint64(lane) * ukk
            for t in range(kk):  # G lerped along y: the window, in raster order
                ut = np.uint64(t)
                vals[vb + ut] = by * hrows[ut] + ay * hrows[ut + uk]
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        s3 = 0.0
        for t in range(kk):  # four independent chains, each in raster order
            ut = np.uint64(t)
            s0 += vals[ut]
            s1 += vals[ukk + ut]
            s2 += vals[np.uint64(2) * ukk + ut]
            s3 += vals[np.uint64(3) * ukk + ut]
        for lane in range(lanes):
            p = q0 + lane
            if p >= n:
                break
            if nan[lane]:
                for t in range(kk):
                    out[p, t] = np.nan
                continue
            total = s0 if lane == 0 else (s1 if lane == 1 else (s2 if lane == 2 else s3))
            mean = total / kk
            vb = np.uint64(lane) * ukk
            for t in range(kk):
                out[p, t] = np.float32(vals[vb + np.uint64(t)] - mean)
    return out
