"""Kernel of the sub-pixel refinement: the peak of the ZNCC of two image windows along the
row, by re-centred parabola fits (beyond the paper; docs/method.md)."""

from __future__ import annotations

import numpy as np

from .._config import jit

#: Keys' cubic convolution parameter (a = -0.5: the interpolating cubic that reproduces
#: quadratics, the usual "bicubic").
_KEYS_A = -0.5


@jit(inline=True)
def _taps(t, cubic):
    """The four weights of the samples at -1, 0, 1, 2 for the fractional offset ``t`` in
    [0, 1): linear (``cubic`` False: 0, 1 - t, t, 0) or Keys' cubic convolution."""
    if not cubic:
        return 0.0, 1.0 - t, t, 0.0
    a = _KEYS_A
    t2 = t * t
    t3 = t2 * t
    return (a * (t3 - 2.0 * t2 + t), (a + 2.0) * t3 - (a + 3.0) * t2 + 1.0,
            -(a + 2.0) * t3 + (2.0 * a + 3.0) * t2 - a * t, -a * (t3 - t2))


@jit
def _row_strip(img, x_lo, n_cols, y, rows, cubic, out):
    """``out[r, c]``: ``img`` at column ``x_lo + c`` and row ``y - rows // 2 + r``,
    interpolated between the pixel rows around it (linear, or cubic: two more rows), for
    ``r < rows``, ``c < n_cols``. The caller keeps every pixel inside the image."""
    fy = np.floor(y)
    w0, w1, w2, w3 = _taps(y - fy, cubic)
    top = int(fy) - rows // 2
    for r in range(rows):
        yy = top + r
        dst = out[r]
        src1 = img[yy, x_lo:x_lo + n_cols]
        src2 = img[yy + 1, x_lo:x_lo + n_cols]
        if cubic:
            src0 = img[yy - 1, x_lo:x_lo + n_cols]
            src3 = img[yy + 2, x_lo:x_lo + n_cols]
            for c in range(n_cols):
                v = w1 * np.float64(src1[c]) + w2 * np.float64(src2[c])
                v += w0 * np.float64(src0[c]) + w3 * np.float64(src3[c])
                dst[c] = v
        else:  # the same sums, in a loop without the branch (it vectorises)
            for c in range(n_cols):
                dst[c] = w1 * np.float64(src1[c]) + w2 * np.float64(src2[c])


@jit(inline=True)
def _sample(row, x, cubic):
    """``row`` at the fractional column ``x`` (linear or cubic)."""
    fx = np.floor(x)
    i = int(fx)
    w0, w1, w2, w3 = _taps(x - fx, cubic)
    v = w1 * row[i] + w2 * row[i + 1]
    if cubic:
        v += w0 * row[i - 1] + w3 * row[i + 2]
    return v


@jit
def _zncc_on_strip(a, sa2, wts, strip, x, s, gx, gy, cubic):
    """Weighted ZNCC of the ``s x s`` window ``a`` (float64, raster order, zero weighted
    mean, ``sa2 = sum wts a**2``) with the window of ``strip`` centred on the fractional
    column ``x`` (strip coordinates), its sample of offset (c, r) from the centre taken at
    column ``x + c (1 - gx) - r gy`` (the window of a plane of disparity gradient (gx, gy));
    -2 when that window is flat."""
    rad = s // 2
    sw = 0.0
    sb = 0.0
    sbb = 0.0
    sab = 0.0
    for r in range(s):
        row = strip[r]
        x_r = x - (r - rad) * gy
        for c in range(s):
            v = _sample(row, x_r + (c - rad) * (1.0 - gx), cubic)
            w = wts[r * s + c]
            wv = w * v
            sw += w
            sb += wv
            sbb += wv * v
            sab += a[r * s + c] * wv
    var = sbb - sb * sb / sw
    if var <= 1e-12 * max(sbb, 1e-300):
        return -2.0
    return sab / np.sqrt(sa2 * var)


@jit(inline=True)
def _zncc_of_sums(sa2, sw, sb, sbb, sab):
    """The weighted ZNCC of :func:`_zncc_on_strip` from its sums (-2: a flat window)."""
    var = sbb - sb * sb / sw
    if var <= 1e-12 * max(sbb, 1e-300):
        return -2.0
    return sab / np.sqrt(sa2 * var)


@jit
def _base_sums(a, wts, strip, b_lo, nb, s, sa_, sab_, sbb_, sbn_):
    """The sums of the windows of ``strip`` at whole columns whose first column is ``b =
    b_lo + m``, ``m < nb``: ``sa_[m]`` = sum w v, ``sab_[m]`` = sum w a v, ``sbb_[m]`` =
    sum w v**2 and ``sbn_[m]`` = sum w v v', v' the strip's value one column right of v
    (``a``, ``wts``: the left window and the weights, raster order). The loop over m is
    innermost (it vectorises); each sum adds its terms in raster order."""
    for m in range(nb):
        sa_[m] = 0.0
        sab_[m] = 0.0
        sbb_[m] = 0.0
        sbn_[m] = 0.0
    for r in range(s):
        row = strip[r]
        for c in range(s):
            w = wts[r * s + c]
            av = a[r * s + c]
            for m in range(nb):
                v = row[b_lo + m + c]
                wv = w * v
                sa_[m] += wv
                sab_[m] += av * wv
                sbb_[m] += wv * v
                sbn_[m] += wv * row[b_lo + m + c + 1]


@jit
def _zncc_square(sa2, sw, x, s, b_lo, sa_, sab_, sbb_, sbn_):
    """:func:`_zncc_on_strip` of a square window (gradient 0, 0) with linear interpolation,
    from :func:`_base_sums` (``b_lo`` their first window's first column): every sample
    lies the same fraction t between two columns, so the window's sums are those of the
    two windows at whole columns around it mixed by 1 - t and t (equal to
    :func:`_zncc_on_strip`'s up to rounding)."""
    rad = s // 2
    fx = np.floor(x)
    k = int(fx) - rad - b_lo
    t = x - fx
    u = 1.0 - t
    sb = u * sa_[k] + t * sa_[k + 1]
    sab = u * sab_[k] + t * sab_[k + 1]
    sbb = u * u * sbb_[k] + 2.0 * u * t * sbn_[k] + t * t * sbb_[k + 1]
    return _zncc_of_sums(sa2, sw, sb, sbb, sab)


@jit
def _fits(xl, yl, x0, y, rm, reach, pad, hl, wl, h, w):
    """Whether the left window of half-side ``rm`` at (xl, yl) and the right strip of
    ``reach`` columns either side of x0 on row y (``pad`` more pixels for the
    interpolation) lie inside the images."""
    lx = int(np.floor(xl)) - rm - pad
    x_lo = int(np.floor(x0)) - reach
    return not (lx < 0 or lx + 2 * rm + 2 * pad > wl - 1
                or np.floor(yl) - rm - pad + 1 < 0 or np.floor(yl) + rm + pad > hl - 1
                or x_lo - pad + 1 < 0 or x_lo + 2 * reach + pad > w - 1
                or np.floor(y) - rm - pad + 1 < 0 or np.floor(y) + rm + pad > h - 1)


@jit(exact=True)  # its loops sum while they write (hopmatch._config)
def refine_rows(img_l, img_r, left, xr, yr, gx, gy, radius, min_radius, sigma, cubic, step,
                levels, iterations, tol, max_shift):
    """Sub-pixel x of each match's right window on its row: the peak of the ZNCC between
    the left window centred on ``left[m]`` of ``img_l`` and the right windows centred on
    (x, ``yr[m]``) of ``img_r`` (both ``(2 r + 1)**2``, sampled by linear interpolation,
    or Keys' cubic convolution with ``cubic``).

    The window's half-side r is ``radius``, or near the image borders the largest r down
    to ``min_radius`` whose windows fit. With ``sigma > 0`` every sample of the ZNCC is
    weighted by ``exp(-(c**2 + r**2) / (2 sigma**2))`` of its offset (c, r) from the
    centre (uniform weights with 0). The right window follows a plane of disparity
    gradient (``gx[m]``, ``gy[m]``): the sample of the left pixel at offset (c, r) is taken
    at column ``x + c (1 - gx) - r gy`` (0, 0: the same square window); a match with
    ``|gx| + |gy| > 1`` is not refined.

    From ``x = xr[m]``, each iteration samples the ZNCC at ``x - h``, ``x``, ``x + h``
    and moves x to the vertex of the parabola through them (a move of at most ``h``; ``h``
    towards the larger side when x is not a maximum), until a move is below ``tol``; then
    ``h`` halves and the same repeats, ``levels`` times in all, starting from ``h = step``.
    The fit is re-centred on the peak until its samples are symmetric about it, not one
    parabola through fixed integer shifts, so the interpolation does not pull the
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
    pad = 2 if cubic else 1
    s_max = 2 * radius + 1
    out = np.empty(nm, dtype=np.float64)
    ok = np.zeros(nm, dtype=np.bool_)
    peak = np.full(nm, np.nan)
    curv = np.full(nm, np.nan)
    reach_max = int(np.ceil(max_shift + step + 2.0 * radius)) + pad + 1
    strip = np.empty((s_max, 2 * reach_max + 2), dtype=np.float64)
    lstrip = np.empty((s_max, s_max + 2 * pad), dtype=np.float64)
    a = np.empty(s_max * s_max, dtype=np.float64)
    # the weights of each window half-side (computed at its first match), and their sums
    w_tab = np.empty((radius + 1, s_max * s_max), dtype=np.float64)
    w_done = np.zeros(radius + 1, dtype=np.bool_)
    sw_tab = np.zeros(radius + 1, dtype=np.float64)
    # the sums of the square windows at whole columns (_base_sums, _zncc_square)
    n_strip = strip.shape[1]
    sa_ = np.empty(n_strip, dtype=np.float64)
    sab_ = np.empty(n_strip, dtype=np.float64)
    sbb_ = np.empty(n_strip, dtype=np.float64)
    sbn_ = np.empty(n_strip, dtype=np.float64)
    for m in range(nm):
        out[m] = xr[m]
        xl = np.float64(left[m, 0])
        yl = np.float64(left[m, 1])
        x0 = np.float64(xr[m])
        y = np.float64(yr[m])
        g_x = np.float64(gx[m])
        g_y = np.float64(gy[m])
        if not (np.isfinite(xl) and np.isfinite(yl) and np.isfinite(x0) and np.isfinite(y)
                and abs(g_x) + abs(g_y) <= 1.0):
            continue
        # the largest window that fits, and the right columns its positions can reach
        rm = radius
        reach = 0
        while rm >= min_radius:
            reach = (int(np.ceil(max_shift + step + rm * (1.0 + abs(g_x) + abs(g_y))))
                     + pad)
            if _fits(xl, yl, x0, y, rm, reach, pad, hl, wl, h, w):
                break
            rm -= 1
        if rm < min_radius or rm < 0:
            continue
        s = 2 * rm + 1
        n = s * s
        wts = w_tab[rm]
        if not w_done[rm]:  # the weights of this window size, once per call
            w_done[rm] = True
            for r in range(s):
                for c in range(s):
                    d2 = (r - rm) ** 2 + (c - rm) ** 2
                    wts[r * s + c] = 1.0 if sigma <= 0.0 else np.exp(-d2 / (2.0 * sigma ** 2))
            sw_t = 0.0
            for t in range(s * s):
                sw_t += wts[t]
            sw_tab[rm] = sw_t
        sw_w = sw_tab[rm]
        # the left window, zero weighted mean
        lx = int(np.floor(xl)) - rm - pad
        _row_strip(img_l, lx, s + 2 * pad, yl, s, cubic, lstrip)
        xs = xl - lx
        sw = 0.0
        sa = 0.0
        for r in range(s):
            for c in range(s):
                v = _sample(lstrip[r], xs + (c - rm), cubic)
                a[r * s + c] = v
                sw += wts[r * s + c]
                sa += wts[r * s + c] * v
        mean = sa / sw
        sa2 = 0.0
        for t in range(n):
            a[t] -= mean
            sa2 += wts[t] * a[t] * a[t]
        if sa2 <= 1e-12:
            continue
        # the right rows around yr, interpolated once; columns x0 - reach .. x0 + reach + 1
        x_lo = int(np.floor(x0)) - reach
        _row_strip(img_r, x_lo, 2 * reach + 2, y, s, cubic, strip)
        x = x0 - x_lo
        start = x
        # a square window: its positions x - step .. x + step within max_shift of the start
        # lie on the windows at whole columns b_lo .. b_lo + nb - 1 (and the next column)
        square = g_x == 0.0 and g_y == 0.0 and not cubic
        b_lo = int(np.floor(start - max_shift - step)) - rm
        nb = int(np.floor(start + max_shift + step)) - rm - b_lo + 2
        if square and (b_lo < 0 or b_lo + nb + s > 2 * reach + 2):
            square = False  # (not expected: the strip covers every position)
        if square:
            _base_sums(a, wts, strip, b_lo, nb, s, sa_, sab_, sbb_, sbn_)
        done = False
        moves = 0
        h_step = step
        for level in range(levels):  # the step halves from one level to the next
            done = False
            while moves < iterations:
                if square:
                    zm = _zncc_square(sa2, sw_w, x - h_step, s, b_lo, sa_, sab_, sbb_, sbn_)
                    z0 = _zncc_square(sa2, sw_w, x, s, b_lo, sa_, sab_, sbb_, sbn_)
                    zp = _zncc_square(sa2, sw_w, x + h_step, s, b_lo, sa_, sab_, sbb_, sbn_)
                else:
                    zm = _zncc_on_strip(a, sa2, wts, strip, x - h_step, s, g_x, g_y, cubic)
                    z0 = _zncc_on_strip(a, sa2, wts, strip, x, s, g_x, g_y, cubic)
                    zp = _zncc_on_strip(a, sa2, wts, strip, x + h_step, s, g_x, g_y, cubic)
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
