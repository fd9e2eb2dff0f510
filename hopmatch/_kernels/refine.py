"""Kernel of the sub-pixel refinement: the peak of the ZNCC of two image windows along the
row, by re-centred parabola fits (beyond the paper; docs/method.md)."""

from __future__ import annotations

import numpy as np

from .._config import jit


@jit
def _row_strip(img, x_lo, n_cols, y, rows, out):
    """``out[r, c]``: ``img`` at column ``x_lo + c`` and row ``y - rows // 2 + r``, lerped
    between the two pixel rows around it, for ``r < rows``, ``c < n_cols``. The caller
    keeps every pixel inside the image."""
    fy = np.floor(y)
    ay = y - fy
    by = 1.0 - ay
    top = int(fy) - rows // 2
    for r in range(rows):
        yy = top + r
        for c in range(n_cols):
            xx = x_lo + c
            out[r, c] = by * np.float64(img[yy, xx]) + ay * np.float64(img[yy + 1, xx])


@jit
def _zncc_on_strip(a, sa2, strip, x, s):
    """ZNCC of the zero-mean ``s x s`` window ``a`` (float64, raster order, ``sa2 = sum
    a**2``) with the window of ``strip`` centred on the fractional column ``x`` (strip
    coordinates, lerped along the row); -2 when that window is flat."""
    rad = s // 2
    fx = np.floor(x)
    ax = x - fx
    bx = 1.0 - ax
    c0 = int(fx) - rad
    sb = 0.0
    sbb = 0.0
    sab = 0.0
    for r in range(s):
        row = strip[r]
        for c in range(s):
            v = bx * row[c0 + c] + ax * row[c0 + c + 1]
            sb += v
            sbb += v * v
            sab += a[r * s + c] * v
    n = s * s
    var = sbb - sb * sb / n
    if var <= 1e-12 * max(sbb, 1e-300):
        return -2.0
    return sab / np.sqrt(sa2 * var)


@jit
def refine_rows(img_l, img_r, left, xr, yr, radius, step, levels, iterations, tol,
                max_shift):
    """Sub-pixel x of each match's right window on its row: the peak of the ZNCC between
    the left window centred on ``left[m]`` of ``img_l`` and the right windows centred on
    (x, ``yr[m]``) of ``img_r`` (both ``(2 radius + 1)**2``, sampled bilinearly).

    From ``x = xr[m]``, each iteration samples the ZNCC at ``x - h``, ``x``, ``x + h``
    and moves x to the vertex of the parabola through them (a move of at most ``h``; ``h``
    towards the larger side when x is not a maximum), until a move is below ``tol``; then
    ``h`` halves and the same repeats, ``levels`` times in all, starting from ``h = step``.
    The fit is re-centred on the peak until its samples are symmetric about it, not one
    parabola through fixed integer shifts, so the bilinear interpolation does not pull the
    result towards whole pixels (pixel locking); the finer steps of the last levels remove
    most of what the peak's own asymmetry leaves. The match is refined only when every
    level converges within ``iterations`` moves in all, ``x`` stays within ``xr[m] +-
    max_shift`` and every window inside the images.

    Returns ``(x, ok, peak, curvature)`` per match: the refined x (``xr[m]`` where not
    ok), whether it converged within its bounds, the ZNCC at the last vertex, and minus
    the last parabola's second derivative, per px**2 (NaN where no parabola was fitted).
    """
    hl, wl = img_l.shape
    h, w = img_r.shape
    nm = left.shape[0]
    s = 2 * radius + 1
    n = s * s
    out = np.empty(nm, dtype=np.float64)
    ok = np.zeros(nm, dtype=np.bool_)
    peak = np.full(nm, np.nan)
    curv = np.full(nm, np.nan)
    reach = int(np.ceil(max_shift + step)) + radius + 2
    span = 2 * reach + 1
    strip = np.empty((s, span + 1), dtype=np.float64)
    lstrip = np.empty((s, s + 2), dtype=np.float64)
    a = np.empty(n, dtype=np.float64)
    for m in range(nm):
        out[m] = xr[m]
        xl = np.float64(left[m, 0])
        yl = np.float64(left[m, 1])
        x0 = np.float64(xr[m])
        y = np.float64(yr[m])
        if not (np.isfinite(xl) and np.isfinite(yl) and np.isfinite(x0) and np.isfinite(y)):
            continue
        # the left window, zero mean
        lx = int(np.floor(xl)) - radius - 1
        if (lx < 0 or lx + s + 1 > wl - 1 or np.floor(yl) - radius < 0
                or np.floor(yl) + radius + 1 > hl - 1):
            continue
        _row_strip(img_l, lx, s + 2, yl, s, lstrip)
        fx = np.floor(xl)
        ax = xl - fx
        sa = 0.0
        for r in range(s):
            for c in range(s):
                v = (1.0 - ax) * lstrip[r, c + 1] + ax * lstrip[r, c + 2]
                a[r * s + c] = v
                sa += v
        mean = sa / n
        sa2 = 0.0
        for t in range(n):
            a[t] -= mean
            sa2 += a[t] * a[t]
        if sa2 <= 1e-12:
            continue
        # the right rows around yr, lerped once; columns x0 - reach .. x0 + reach + 1
        x_lo = int(np.floor(x0)) - reach
        if (x_lo < 0 or x_lo + span > w - 1 or np.floor(y) - radius < 0
                or np.floor(y) + radius + 1 > h - 1):
            continue
        _row_strip(img_r, x_lo, span + 1, y, s, strip)
        x = x0 - x_lo
        start = x
        done = False
        moves = 0
        h_step = step
        for level in range(levels):  # the step halves from one level to the next
            done = False
            while moves < iterations:
                zm = _zncc_on_strip(a, sa2, strip, x - h_step, s)
                z0 = _zncc_on_strip(a, sa2, strip, x, s)
                zp = _zncc_on_strip(a, sa2, strip, x + h_step, s)
                den = zm - 2.0 * z0 + zp
                if zm > z0 or zp > z0 or den >= 0.0:
                    move = h_step if zp > zm else -h_step
                else:
                    move = h_step * min(max(0.5 * (zm - zp) / den, -1.0), 1.0)
                    peak[m] = z0 - 0.125 * (zm - zp) ** 2 / den
                    curv[m] = -den / (h_step * h_step)
                x += move
                moves += 1
                if abs(move) < tol:
                    done = True
                    break
                if abs(x - start) > max_shift:
                    break
            if not done or abs(x - start) > max_shift:
                done = False
                break
            h_step *= 0.5
        if done:
            out[m] = x + x_lo
            ok[m] = True
    return out, ok, peak, curv
