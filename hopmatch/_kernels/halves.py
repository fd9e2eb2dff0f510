"""Kernel of the half-window test: the ZNCC of the left and the right half of a match's
grey windows at its (refined) position (beyond the paper; docs/method.md, "Windows that
straddle a depth edge")."""

from __future__ import annotations

import numpy as np

from .._config import jit


@jit(inline=True)
def _at(img, i, j, tx, ty):
    """``img`` at (i + tx, j + ty), linear in both axes (i, j whole, tx, ty in [0, 1));
    the caller keeps the four pixels inside the image."""
    top = (1.0 - tx) * np.float64(img[j, i]) + tx * np.float64(img[j, i + 1])
    bottom = (1.0 - tx) * np.float64(img[j + 1, i]) + tx * np.float64(img[j + 1, i + 1])
    return (1.0 - ty) * top + ty * bottom


@jit(inline=True)
def _inside(x, y, radius, h, w):
    """Whether the ``(2 radius + 1)**2`` window centred on (x, y) and the pixels its
    linear interpolation reads lie inside an ``h x w`` image."""
    return (np.floor(x) - radius >= 0 and np.floor(x) + radius + 1 <= w - 1
            and np.floor(y) - radius >= 0 and np.floor(y) + radius + 1 <= h - 1)


@jit
def half_windows(img_l, img_r, left, right, radius):
    """ZNCC of the two side halves of each match's windows, and their left contrast.

    For match m the left window is centred on ``left[m]`` of ``img_l`` and the right one
    on ``right[m]`` of ``img_r``, both ``(2 radius + 1)**2`` samples at whole-pixel offsets
    (c, r), ``|c|, |r| <= radius``, taken by linear interpolation. The left half is the
    samples with ``c < 0``, the right half those with ``c > 0`` (the centre column in
    neither), ``radius (2 radius + 1)`` samples each.

    Returns ``(z_left, z_right, s_left, s_right)``, (M,) float64: the ZNCC of each half
    between the two images (0 where either half is flat), and the standard deviation of
    each half of the left window; all NaN where a window does not fit in its image.
    """
    m = len(left)
    z_l = np.empty(m)
    z_r = np.empty(m)
    s_l = np.empty(m)
    s_r = np.empty(m)
    hl, wl = img_l.shape
    hr, wr = img_r.shape
    n = radius * (2 * radius + 1)
    buf_a = np.empty(n)
    buf_b = np.empty(n)
    for k in range(m):
        xl = np.float64(left[k, 0])
        yl = np.float64(left[k, 1])
        xr = np.float64(right[k, 0])
        yr = np.float64(right[k, 1])
        z_l[k] = np.nan
        z_r[k] = np.nan
        s_l[k] = np.nan
        s_r[k] = np.nan
        if not (_inside(xl, yl, radius, hl, wl) and _inside(xr, yr, radius, hr, wr)):
            continue
        # whole-pixel offsets: every sample of a window has the same fractional part
        il = int(np.floor(xl))
        jl = int(np.floor(yl))
        ir = int(np.floor(xr))
        jr = int(np.floor(yr))
        txl = xl - il
        tyl = yl - jl
        txr = xr - ir
        tyr = yr - jr
        for side in range(2):
            sa = 0.0
            sb = 0.0
            i = 0
            for r in range(-radius, radius + 1):
                for c0 in range(1, radius + 1):
                    c = -c0 if side == 0 else c0
                    buf_a[i] = _at(img_l, il + c, jl + r, txl, tyl)
                    buf_b[i] = _at(img_r, ir + c, jr + r, txr, tyr)
                    sa += buf_a[i]
                    sb += buf_b[i]
                    i += 1
            ma = sa / n
            mb = sb / n
            va = 0.0
            vb = 0.0
            cov = 0.0
            for i in range(n):  # centred sums: no cancellation on flat windows
                da = buf_a[i] - ma
                db = buf_b[i] - mb
                va += da * da
                vb += db * db
                cov += da * db
            den = np.sqrt(va * vb)
            z = cov / den if den > 1e-12 else 0.0
            s = np.sqrt(va / n)
            if side == 0:
                z_l[k] = z
                s_l[k] = s
            else:
                z_r[k] = z
                s_r[k] = s
    return z_l, z_r, s_l, s_r
