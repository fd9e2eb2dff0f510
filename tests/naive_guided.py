"""Slow, obviously correct references for the kernels of the guided pass, the sub-pixel
refinement, the half-window test and the vertical-offset model
(``hopmatch._kernels.guided``, ``hopmatch._kernels.refine``, ``hopmatch._kernels.halves``).
Plain NumPy on one point at a time, written from the kernels' docstrings; the tests compare
the kernels with them to a stated tolerance."""

from __future__ import annotations

import math

import numpy as np


def neighbours(queries, matched, half_w, half_h):
    """For each query, the set of matched indices j with ``|xj - xq| <= half_w`` and
    ``|yj - yq| <= half_h`` (differences in float32)."""
    out = []
    for xq, yq in np.asarray(queries, np.float32):
        dx = np.abs(matched[:, 0] - np.float32(xq))
        dy = np.abs(matched[:, 1] - np.float32(yq))
        out.append(set(np.flatnonzero((dx <= np.float32(half_w)) & (dy <= np.float32(half_h)))
                       .tolist()))
    return out


def bilinear(g, x, y):
    """g at the fractional (x, y), bilinear, in float64."""
    x0, y0 = math.floor(x), math.floor(y)
    ax, ay = x - x0, y - y0
    g = g.astype(np.float64)
    return ((1 - ay) * ((1 - ax) * g[y0, x0] + ax * g[y0, x0 + 1])
            + ay * ((1 - ax) * g[y0 + 1, x0] + ax * g[y0 + 1, x0 + 1]))


def window(g, x, y, s):
    """The ``s x s`` window of g centred on (x, y), bilinear, as a float64 raster row."""
    r = s // 2
    return np.array([bilinear(g, x + c - r, y + rr - r) for rr in range(s) for c in range(s)])


def sheared_window(g, x, y, s, shear):
    """:func:`window` with its row ``rr`` moved by ``-shear (rr - s // 2)`` px in x (the
    right window on a surface whose disparity grows by ``shear`` px per row)."""
    r = s // 2
    return np.array([bilinear(g, x + c - r - shear * (rr - r), y + rr - r)
                     for rr in range(s) for c in range(s)])


def zncc(a, b):
    """Zero-mean normalised cross-correlation of two windows (-1 for a flat b)."""
    a = np.asarray(a, np.float64) - np.mean(a)
    b = np.asarray(b, np.float64) - np.mean(b)
    den = math.sqrt(float(a @ a) * float(b @ b))
    return float(a @ b) / den if den > 1e-12 else -1.0


def normalised_distance(a, b, eps=1e-6, gain_tol=1.0):
    """Eq. 7 normalised: ``mean |a - g b| / (0.5 (mean |a| + mean |b|) + eps)`` of two
    zero-mean windows, g = ``mean |a| / mean |b|`` clipped to ``[1 / gain_tol,
    gain_tol]`` (1 when ``gain_tol`` is 1 or b is flat)."""
    a = np.asarray(a, np.float64) - np.mean(a)
    b = np.asarray(b, np.float64) - np.mean(b)
    sa, sb = np.mean(np.abs(a)), np.mean(np.abs(b))
    g = 1.0 if gain_tol <= 1.0 or not sb > 0 else min(max(sa / sb, 1.0 / gain_tol), gain_tol)
    return float(np.mean(np.abs(a - g * b)) / (0.5 * (sa + sb) + eps))


def row_search_one(g_l, g_r, xl, yl, left_window, centre, y_offset, inner, outer, back,
                   min_zncc, margin, gain_tol=1.0, clip=False, peaks=False, shoulder=2,
                   shear=0.0):
    """The row search of one query as ``hopmatch._kernels.guided.row_search`` documents it:
    ``(found, best, second, xr, similarity)``; ``found`` False when any test fails, and
    the values NaN when the search did not reach them. ``clip``: the columns are first
    clipped to those whose windows (and one more column, and the rows' slides) lie in the
    right image; the
    caller checks the rest of the kernel's ``OUTSIDE``. ``peaks``: the runner-up is the
    best ZNCC beyond the first rise on either side of the best column (past its valleys);
    else the best ZNCC at least ``shoulder`` columns from it. ``shear``: the right windows
    are the :func:`sheared_window` at each whole column, and the one at the refined x is
    interpolated linearly between the two whole columns around it."""
    s = int(round(math.sqrt(len(left_window))))
    yr = yl - y_offset
    c0 = math.floor(centre + 0.5)
    cols = list(range(c0 - outer - 1, c0 + outer + 2))
    if clip:  # the slid rows too: left by up to ceil(|shear| r), right by floor + 1
        r = s // 2
        lo = r + math.ceil(abs(shear) * r)
        hi = g_r.shape[1] - r - 2 - (math.floor(abs(shear) * r) + (shear != 0))
        cols = [c for c in cols if lo <= c <= hi]
        if len(cols) < 3:
            nan = float("nan")
            return False, nan, nan, nan, nan
    z = [zncc(left_window, sheared_window(g_r, c, yr, s, shear)) for c in cols]
    inner_idx = range(1, len(cols) - 1)
    mb = max(inner_idx, key=lambda m: (z[m], -m))  # first best
    if peaks:
        lo = mb - 1
        while lo >= 1 and z[lo] <= z[lo + 1]:
            lo -= 1
        hi = mb + 1
        while hi <= len(cols) - 2 and z[hi] <= z[hi - 1]:
            hi += 1
        second = max([z[m] for m in inner_idx if m <= lo or m >= hi], default=-1.0)
    else:
        second = max([z[m] for m in inner_idx if abs(m - mb) >= shoulder], default=-1.0)
    best = z[mb]
    nan = float("nan")
    if abs(cols[mb] - centre) > inner or z[mb - 1] > best or z[mb + 1] > best:
        return False, best, second, nan, nan
    if not (best >= min_zncc and best - second >= margin):
        return False, best, second, nan, nan
    den = z[mb - 1] - 2 * best + z[mb + 1]
    delta = min(max(0.5 * (z[mb - 1] - z[mb + 1]) / den, -0.5), 0.5) if den < 0 else 0.0
    xr = cols[mb] + delta
    fx = math.floor(xr)
    right = ((1 - (xr - fx)) * sheared_window(g_r, fx, yr, s, shear)
             + (xr - fx) * sheared_window(g_r, fx + 1, yr, s, shear))
    sim = normalised_distance(left_window, right, gain_tol=gain_tol)
    here = zncc(right, left_window)
    for t in range(1, back + 1):
        for sign in (-1, 1):
            if zncc(right, window(g_l, xl + sign * t, yl, s)) > here:
                return False, best, second, xr, sim
    return True, best, second, xr, sim


def compatibility(x, theta, slope):
    """Eq. 5."""
    return 2.0 / (1.0 + math.exp(min(slope * (x - theta), 700.0))) - 1.0


def field(pl, pr, sim, neighbours_left, neighbours_right, neighbours_sim, theta, slope,
          weight, bias, gradient=(0.0, 0.0)):
    """Eq. 12's bracket of the pair (pl, pr) alone in its row and column: ``bias + sum_j
    C(|d - d_j| + |D - D'| + weight (sim + sim_j))`` (eqs. 5, 6, 10), each neighbour's
    right point first moved left by ``gx (xq - xj) + gy (yq - yj)`` (``gradient = (gx,
    gy)``: the neighbour carried along a local plane to the query)."""
    d = math.hypot(pl[0] - pr[0], pl[1] - pr[1])
    total = bias
    for ql, qr, sj in zip(neighbours_left, neighbours_right, neighbours_sim):
        e = gradient[0] * (pl[0] - ql[0]) + gradient[1] * (pl[1] - ql[1])
        qr = (qr[0] - e, qr[1])
        dj = math.hypot(ql[0] - qr[0], ql[1] - qr[1])
        len_l = math.hypot(pl[0] - ql[0], pl[1] - ql[1])
        len_r = math.hypot(pr[0] - qr[0], pr[1] - qr[1])
        total += compatibility(abs(d - dj) + abs(len_l - len_r) + weight * (sim + sj), theta,
                               slope)
    return total


def local_plane(query, neighbours_left, disparities, inlier, min_count, reach=None,
                refits=0):
    """The guided pass's prediction at ``query`` from its matched neighbours, as
    ``hopmatch._kernels.guided.neighbour_planes`` documents it: ``(prediction, gx, gy)``,
    the least-squares plane ``d = a + gx (x - xq) + gy (y - yq)`` (``np.linalg.lstsq``)
    through the neighbours within ``inlier`` of their median, then ``refits`` times through
    those within ``inlier`` of the plane before (a refit with fewer than ``min_count`` of
    them, or a degenerate one, keeps the plane before); or the median with zero gradient
    when the first fit has fewer than ``min_count`` inliers or is degenerate, or a lies
    more than ``reach`` (None: ``inlier``) from the median."""
    d = np.asarray(disparities, np.float64)
    if len(d) == 0:
        return float("nan"), 0.0, 0.0
    m = float(np.median(d))
    reach = inlier if reach is None else reach
    rel = np.asarray(neighbours_left, np.float64) - np.asarray(query, np.float64)
    a_all = np.c_[np.ones(len(d)), rel]
    plane = None
    centre = np.full(len(d), m)  # the first band: around the median
    for _ in range(refits + 1):
        keep = np.abs(d - centre) <= inlier
        if keep.sum() < min_count:
            break
        a_mat = a_all[keep]
        n = a_mat.T @ a_mat
        if not np.linalg.det(n) > 1e-9 * n[0, 0] * n[1, 1] * n[2, 2]:
            break
        plane, *_ = np.linalg.lstsq(a_mat, d[keep], rcond=None)
        centre = a_all @ plane
    if plane is None or abs(plane[0] - m) > reach:
        return m, 0.0, 0.0
    return float(plane[0]), float(plane[1]), float(plane[2])


def parabola_search(z, xr, step, levels, iterations, tol, max_shift):
    """The step search of ``hopmatch._kernels.refine.refine_rows`` on the score ``z(x)``
    from ``xr``: at each of ``levels`` step sizes (``step`` halved each level), a parabola
    through ``z`` at ``x - h, x, x + h`` moves ``x`` (by at most ``h``; a full step uphill
    where the three are not a peak) until a move is below ``tol``; ``iterations`` moves in
    all. ``(x, ok)``: ``(xr, False)`` when a level does not settle or ``x`` leaves
    ``xr +- max_shift``."""
    x, h, moves = xr, step, 0
    for _ in range(levels):
        done = False
        while moves < iterations:
            zm, z0, zp = z(x - h), z(x), z(x + h)
            den = zm - 2 * z0 + zp
            if zm > z0 or zp > z0 or den >= 0:
                move = h if zp > zm else -h
            else:
                move = h * min(max(0.5 * (zm - zp) / den, -1.0), 1.0)
            x += move
            moves += 1
            if abs(move) < tol:
                done = True
                break
            if abs(x - xr) > max_shift:
                break
        if not done or abs(x - xr) > max_shift:
            return xr, False
        h /= 2
    return x, True


def refine_one(img_l, img_r, xl, yl, xr, yr, radius, step, levels, iterations, tol,
               max_shift):
    """The refinement of one match as ``hopmatch._kernels.refine.refine_rows`` documents
    it: ``(x, ok)``."""
    s = 2 * radius + 1
    a = window(img_l, xl, yl, s)

    def z(x):
        return zncc(a, window(img_r, x, yr, s))

    return parabola_search(z, xr, step, levels, iterations, tol, max_shift)


def keys_cubic(g, x, y, a=-0.5):
    """g at the fractional (x, y) by Keys' cubic convolution (parameter a) on the 4 x 4
    pixels around it, in float64."""
    def weights(t):
        return [a * (t**3 - 2 * t**2 + t), (a + 2) * t**3 - (a + 3) * t**2 + 1,
                -(a + 2) * t**3 + (2 * a + 3) * t**2 - a * t, -a * (t**3 - t**2)]
    x0, y0 = math.floor(x), math.floor(y)
    wx, wy = weights(x - x0), weights(y - y0)
    g = g.astype(np.float64)
    return sum(wy[j] * wx[i] * g[y0 - 1 + j, x0 - 1 + i] for j in range(4) for i in range(4))


def weighted_zncc(a, b, w):
    """ZNCC of two windows with weights w: the weighted means removed, then
    ``sum w a b / sqrt(sum w a**2 sum w b**2)``."""
    a, b, w = (np.asarray(v, np.float64) for v in (a, b, w))
    a = a - (w @ a) / w.sum()
    b = b - (w @ b) / w.sum()
    return float((w * a) @ b) / math.sqrt(float((w * a) @ a) * float((w * b) @ b))


def refine_one_slanted(img_l, img_r, xl, yl, xr, yr, gx, gy, radius, sigma, cubic, step,
                       levels, iterations, tol, max_shift):
    """The refinement of one match as ``hopmatch._kernels.refine.refine_rows`` documents it
    for a window of half-side ``radius`` that fits the images, Gaussian weights of
    ``sigma`` (uniform for 0), linear or cubic interpolation, and the right window on the
    disparity plane of gradient (gx, gy): ``(x, ok)``."""
    sample = keys_cubic if cubic else bilinear
    offs = [(c, r) for r in range(-radius, radius + 1) for c in range(-radius, radius + 1)]
    w = np.array([1.0 if sigma <= 0 else math.exp(-(c * c + r * r) / (2 * sigma * sigma))
                  for c, r in offs])
    a = [sample(img_l, xl + c, yl + r) for c, r in offs]

    def z(x):
        return weighted_zncc(a, [sample(img_r, x + c * (1 - gx) - r * gy, yr + r)
                                 for c, r in offs], w)

    return parabola_search(z, xr, step, levels, iterations, tol, max_shift)


def half_windows(g_l, g_r, left, right, radius):
    """Reference of ``hopmatch._kernels.halves.half_windows``: for each match, the ZNCC of
    the left halves (offsets c < 0) and of the right halves (c > 0) of the ``(2 radius +
    1)**2`` windows centred on ``left[m]`` (g_l) and ``right[m]`` (g_r), bilinear, and the
    population standard deviation of each half of the left window; NaN where a window or
    the pixels its interpolation reads leave an image."""
    out = np.full((4, len(left)), np.nan)
    for m, ((xl, yl), (xr, yr)) in enumerate(zip(left, right)):
        ok = True
        for (x, y), g in (((xl, yl), g_l), ((xr, yr), g_r)):
            h, w = g.shape
            ok &= (math.floor(x) - radius >= 0 and math.floor(x) + radius + 1 <= w - 1
                   and math.floor(y) - radius >= 0 and math.floor(y) + radius + 1 <= h - 1)
        if not ok:
            continue
        for side, cols in ((0, range(-radius, 0)), (1, range(1, radius + 1))):
            a = np.array([bilinear(g_l, xl + c, yl + r) for r in range(-radius, radius + 1)
                          for c in cols])
            b = np.array([bilinear(g_r, xr + c, yr + r) for r in range(-radius, radius + 1)
                          for c in cols])
            a0, b0 = a - a.mean(), b - b.mean()
            den = math.sqrt(float(a0 @ a0) * float(b0 @ b0))
            out[side, m] = float(a0 @ b0) / den if den > 1e-12 else 0.0
            out[2 + side, m] = math.sqrt(float(a0 @ a0) / len(a))
    return tuple(out)
