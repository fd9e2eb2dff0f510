"""Slow, obviously correct references for every hopmatch kernel.

Written for readability, not speed: plain Python loops over pixels, points and neurons,
one equation of SPEC.md at a time. The tests compare the Numba kernels with these
functions, bit for bit where the kernel is compiled ``exact=True`` (Moravec, eqs. 1-2) and
to a stated tolerance elsewhere.

Only keep problems small: the dense network builds the full ``N x N`` matrix T over the
``N`` candidate neurons.
"""

from __future__ import annotations

import math

import numpy as np

from hopmatch._kernels import network as _kn

#: The unit steps u_theta of eq. 1 as (dx, dy): 0, 45, 90 and 135 degrees.
DIRECTIONS = ((1, 0), (1, 1), (0, 1), (-1, 1))


# ======================================================================================
# SPEC section 1: Moravec points
# ======================================================================================


def deriche_coefficients(alpha, omega):
    """OpenCV's ``(a, b1, b2, a0, a1, a2, a3)`` of ``cv2.ximgproc.GradientDericheX/Y``
    (``deriche_filter.cpp``), in float64, formula by formula."""
    ea, e2a = math.exp(-alpha), math.exp(-2 * alpha)
    co, so = math.cos(omega), math.sin(omega)
    c = (1 - 2 * ea * co + e2a) / (ea * so)
    a = -c * ea * so
    b1, b2 = -2 * ea * co, e2a
    a2po2 = alpha * alpha + omega * omega
    k = (1 - 2 * ea * co + e2a) * a2po2 / (2 * alpha * ea * so + omega - omega * e2a)
    c1, c2 = k * alpha / a2po2, k * omega / a2po2
    a0 = c2
    a1 = (-c2 * co + c1 * so) * ea
    return a, b1, b2, a0, a1, a1 - c2 * b1, -c2 * b2


def deriche_derivative_1d(x, coeffs, column):
    """OpenCV's derivative filter of the sequence ``x`` (float64): ``a (g1 - g2)`` with the
    causal ``g1[i] = x[i-1] - b1 g1[i-1] - b2 g1[i-2]`` and the anti-causal ``g2[i] = x[i+1]
    - b1 g2[i+1] - b2 g2[i+2]``, and OpenCV's first two values of each, which differ
    between its column filter (``VerticalIIRFilter``) and its row filter."""
    a, b1, b2 = coeffs[:3]
    n = len(x)
    g1, g2 = np.zeros(n), np.zeros(n)
    g1[0] = x[0]
    if n > 1:
        g1[1] = (x[0] if column else x[1]) - b1 * g1[0]
    for i in range(2, n):
        g1[i] = x[i - 1] - b1 * g1[i - 1] - b2 * g1[i - 2]
    g2[n - 1] = x[n - 1]
    if n > 1:
        g2[n - 2] = x[n - 1] + (b1 if column else -b1) * g2[n - 1]
    for i in range(n - 3, -1, -1):
        g2[i] = x[i + 1] - b1 * g2[i + 1] - b2 * g2[i + 2]
    return a * (g1 - g2)


def deriche_smoothing_1d(x, coeffs, column):
    """OpenCV's smoothing filter of ``x`` (float64): ``g1 + g2`` with ``g1[i] = a0 x[i] + a1
    x[i-1] - b1 g1[i-1] - b2 g1[i-2]`` and ``g2[i] = a2 x[i+1] + a3 x[i+2] - b1 g2[i+1] -
    b2 g2[i+2]``, and OpenCV's first two values of each (row and column filters differ in
    ``g1[1]``)."""
    _, b1, b2, a0, a1, a2, a3 = coeffs
    n = len(x)
    g1, g2 = np.zeros(n), np.zeros(n)
    g1[0] = (a0 + a1) * x[0]
    if n > 1:
        g1[1] = a0 * x[1] + a1 * (x[0] if column else x[1]) - b1 * g1[0]
    for i in range(2, n):
        g1[i] = a0 * x[i] + a1 * x[i - 1] - b1 * g1[i - 1] - b2 * g1[i - 2]
    g2[n - 1] = (a2 + a3) * x[n - 1]
    if n > 1:
        g2[n - 2] = (a2 + a3) * x[n - 1] - b2 * g2[n - 1]
    for i in range(n - 3, -1, -1):
        g2[i] = a2 * x[i + 1] + a3 * x[i + 2] - b1 * g2[i + 1] - b2 * g2[i + 2]
    return g1 + g2


def deriche_xy(image, alpha, omega):
    """``cv2.ximgproc.GradientDericheX`` and ``GradientDericheY`` of ``image`` as OpenCV
    computes them: X is the row derivative, rounded to float32, then the column smoothing;
    Y the column derivative, rounded, then the row smoothing. float32 results."""
    c = deriche_coefficients(alpha, omega)
    img = np.asarray(image, dtype=np.float64)
    rows = np.array([deriche_derivative_1d(r, c, False) for r in img])
    rows = rows.astype(np.float32).astype(np.float64)
    gx = np.array([deriche_smoothing_1d(col, c, True) for col in rows.T]).T
    cols = np.array([deriche_derivative_1d(col, c, True) for col in img.T]).T
    cols = cols.astype(np.float32).astype(np.float64)
    gy = np.array([deriche_smoothing_1d(r, c, False) for r in cols])
    return gx.astype(np.float32), gy.astype(np.float32)


def deriche_padded_xy(image, alpha, omega, border):
    """:func:`deriche_xy` of ``image`` mirrored by ``border`` pixels
    (``cv2.BORDER_REFLECT``: ``cba|abc``, repeated when the border is wider than the
    image), cropped back to ``image``'s shape."""
    img = np.asarray(image)
    padded = np.pad(img, border, mode="symmetric") if border else img
    gx, gy = deriche_xy(padded, alpha, omega)
    h, w = img.shape
    return gx[border:border + h, border:border + w], gy[border:border + h, border:border + w]


def directional_variances(g, window_size):
    """Eq. 1 for each direction separately: ``V_theta(p)`` as a (4, H, W) float64 array.

    ``V_theta(p) = sum_{q in W(p)} (G(q) - G(q + u_theta))**2``. The window sum is taken
    as the kernel documents it: each window row summed left to right, then the row sums
    top to bottom, all in float64. Pixels within ``radius + 1`` of the border get 0.
    """
    g = np.asarray(g, dtype=np.float32)
    h, w = g.shape
    r = window_size // 2
    m = r + 1
    out = np.zeros((4, h, w), dtype=np.float64)
    for t, (ux, uy) in enumerate(DIRECTIONS):
        for y in range(m, h - m):
            for x in range(m, w - m):
                total = 0.0
                for qy in range(y - r, y + r + 1):
                    row = 0.0
                    for qx in range(x - r, x + r + 1):
                        d = float(g[qy, qx]) - float(g[qy + uy, qx + ux])
                        row += d * d
                    total += row
                out[t, y, x] = total
    return out


def weighted_moravec_response(g, window_size, window_sigma):
    """Eq. 1 with Gaussian window weights: ``V(p) = min_theta V_theta(p)``,
    ``V_theta(p) = sum_{q in W(p)} w(q - p) (G(q) - G(q + u_theta))**2`` (float64 sums,
    float32 result).

    ``w(i, j) = k(i) k(j)`` with ``k(i) = exp(-i**2 / (2 sigma**2))`` for
    ``i = -r..r``, normalised so that ``sum_i k(i) = window_size`` (the 2-D weights then
    sum to ``window_size ** 2``, like the box's). Pixels within ``r + 1`` of the border get
    0.
    """
    g = np.asarray(g, dtype=np.float32)
    h, w = g.shape
    r = window_size // 2
    m = r + 1
    k = [np.exp(-(i * i) / (2.0 * window_sigma**2)) for i in range(-r, r + 1)]
    k = [window_size * ki / sum(k) for ki in k]
    out = np.zeros((h, w), dtype=np.float32)
    for y in range(m, h - m):
        for x in range(m, w - m):
            best = None
            for ux, uy in DIRECTIONS:
                total = 0.0
                for i, qy in enumerate(range(y - r, y + r + 1)):
                    for j, qx in enumerate(range(x - r, x + r + 1)):
                        d = float(g[qy, qx]) - float(g[qy + uy, qx + ux])
                        total += k[i] * k[j] * d * d
                best = total if best is None else min(best, total)
            out[y, x] = best
    return out


def quantise(g, levels_log2=19):
    """G on the power-of-two grid the Moravec kernel works on.

    The grid step is ``2**-e`` with ``e`` the largest integer such that
    ``max|G| * 2**e <= 2**levels_log2``. Returns ``(gq, step)``: the integer multiples
    ``gq = round(G * 2**e)`` (int64, ties to even) and ``step = 2**-e``; ``gq * step`` is
    the quantised image, exactly representable in float32. A blank image gives zeros and
    step 1.
    """
    g = np.asarray(g, dtype=np.float32).astype(np.float64)
    gmax = float(np.abs(g).max()) if g.size else 0.0
    if gmax == 0.0:
        return np.zeros(g.shape, dtype=np.int64), 1.0
    limit = 2.0**levels_log2
    e = 0
    while gmax * 2.0**e > limit:
        e -= 1
    while gmax * 2.0 ** (e + 1) <= limit:
        e += 1
    return np.rint(g * 2.0**e).astype(np.int64), 2.0**-e


def moravec_response(g, window_size):
    """Eq. 1: ``V(p) = min_theta V_theta(p)`` (float64 sums, float32 result).

    On a quantised image (``gq * step`` of :func:`quantise`) every sum is exact, so any
    order of summation gives these bits."""
    vt = directional_variances(g, window_size)
    h, w = vt.shape[1:]
    out = np.zeros((h, w), dtype=np.float32)
    r = window_size // 2
    m = r + 1
    for y in range(m, h - m):
        for x in range(m, w - m):
            out[y, x] = min(vt[0, y, x], vt[1, y, x], vt[2, y, x], vt[3, y, x])
    return out


def strict_maxima(v, radius, margin, threshold):
    """Eq. 2: (y, x) of the pixels with ``V(p) > threshold`` and ``V(p) > V(q)`` for every
    other pixel q of the image with ``max(|qx - px|, |qy - py|) <= radius``, at least
    ``margin`` pixels from the border; raster order, (N, 2) int64.

    No dilation: each pixel is compared with each of its neighbours directly. The threshold
    is compared in float32, as V is.
    """
    v = np.asarray(v, dtype=np.float32)
    threshold = np.float32(threshold)
    h, w = v.shape
    found = []
    for y in range(margin, h - margin):
        for x in range(margin, w - margin):
            c = v[y, x]
            if not c > threshold:
                continue
            is_max = True
            for qy in range(y - radius, y + radius + 1):
                for qx in range(x - radius, x + radius + 1):
                    if (qy, qx) == (y, x) or not (0 <= qy < h and 0 <= qx < w):
                        continue
                    if not c > v[qy, qx]:
                        is_max = False
            if is_max:
                found.append((y, x))
    return np.array(found, dtype=np.int64).reshape(-1, 2)


def quadratic_offsets(v, yx):
    """Sub-pixel offsets (dx, dy), float32 (N, 2), of the points (y, x) of ``yx``: the vertex
    of the parabola through V at p - 1, p, p + 1 along each axis (neighbours clamped to the
    image), 0 where ``V(p-1) - 2 V(p) + V(p+1) >= 0``, clipped to half a pixel. The NumPy
    formula the library used before it moved into the kernel ``strict_maxima``; the point is
    ``float32(x, y) + offsets``, added in float32."""
    v = np.asarray(v, dtype=np.float32)
    y, x = yx[:, 0], yx[:, 1]
    h, w = v.shape
    xm, xp = np.clip(x - 1, 0, w - 1), np.clip(x + 1, 0, w - 1)
    ym, yp = np.clip(y - 1, 0, h - 1), np.clip(y + 1, 0, h - 1)
    c = v[y, x].astype(np.float64)
    out = np.zeros((len(yx), 2), np.float32)
    for axis, (lo, hi) in enumerate(((v[y, xm], v[y, xp]), (v[ym, x], v[yp, x]))):
        lo, hi = lo.astype(np.float64), hi.astype(np.float64)
        den = lo - 2.0 * c + hi
        with np.errstate(divide="ignore", invalid="ignore"):
            off = np.where(den < 0, 0.5 * (lo - hi) / den, 0.0)
        out[:, axis] = np.clip(off, -0.5, 0.5)
    return out


def gradient_windows(g, pts, size):
    """Eqs. 8-9: ``V_i(x) = G(x) - mean_{W_i}(G)``, the window in raster order, float64
    (N, size * size). G is sampled bilinearly at non-integer centres (the textbook
    four-pixel formula), and samples outside the image take the nearest border pixel."""
    g = np.asarray(g, dtype=np.float32)
    h, w = g.shape
    r = size // 2

    def pixel(yy, xx):
        return float(g[min(max(yy, 0), h - 1), min(max(xx, 0), w - 1)])

    out = np.zeros((len(pts), size * size), dtype=np.float64)
    for n, (x, y) in enumerate(pts):
        x, y = float(x), float(y)
        x0, y0 = math.floor(x), math.floor(y)
        ax, ay = x - x0, y - y0
        values = []
        for dy in range(-r, r + 1):
            for dx in range(-r, r + 1):
                xx, yy = x0 + dx, y0 + dy
                top = (1 - ax) * pixel(yy, xx) + ax * pixel(yy, xx + 1)
                bottom = (1 - ax) * pixel(yy + 1, xx) + ax * pixel(yy + 1, xx + 1)
                values.append((1 - ay) * top + ay * bottom)
        mean = sum(values) / len(values)
        out[n] = [value - mean for value in values]
    return out


# ======================================================================================
# SPEC sections 2-3: the network, dense
# ======================================================================================


def candidate_pairs(left, right, min_disparity, max_disparity, max_vertical):
    """Every (i, k) with ``min_disparity <= xl - xr <= max_disparity`` and
    ``|yl - yr| <= max_vertical``, in (i, k) order; differences in float32 as the points."""
    left = np.asarray(left, dtype=np.float32)
    right = np.asarray(right, dtype=np.float32)
    dmin, dmax, vmax = (np.float32(min_disparity), np.float32(max_disparity),
                        np.float32(max_vertical))
    pairs = []
    for i in range(len(left)):
        for k in range(len(right)):
            d = left[i, 0] - right[k, 0]
            dy = abs(left[i, 1] - right[k, 1])
            if dmin <= d <= dmax and dy <= vmax:
                pairs.append((i, k))
    return pairs


def best_two_by_sorting(ni, nk, sim):
    """Each left point's first two pairs once the pairs are sorted by (left, distance,
    right) with NumPy (NaN last): ``{left: (best, second or -1)}``, pair indices."""
    order = np.lexsort((np.asarray(nk), np.asarray(sim, dtype=np.float64), np.asarray(ni)))
    out = {}
    for t in order.tolist():
        i = int(ni[t])
        if i not in out:
            out[i] = [t, -1]
        elif out[i][1] < 0:
            out[i][1] = t
    return {i: tuple(v) for i, v in out.items()}


def epipolar_candidate_pairs(left, right, min_disparity, max_disparity, max_vertical, f):
    """Every (i, k) with ``min_disparity <= xl - xr <= max_disparity`` (float32, as the
    points) and the right point within ``max_vertical`` of the epipolar line
    ``F (xl, yl, 1)`` (float64), in (i, k) order."""
    left = np.asarray(left, dtype=np.float32)
    right = np.asarray(right, dtype=np.float32)
    dmin, dmax = np.float32(min_disparity), np.float32(max_disparity)
    f = np.asarray(f, dtype=np.float64)
    pairs = []
    for i in range(len(left)):
        a, b, c = f @ [float(left[i, 0]), float(left[i, 1]), 1.0]
        norm = math.hypot(a, b)
        for k in range(len(right)):
            d = left[i, 0] - right[k, 0]
            num = a * float(right[k, 0]) + b * float(right[k, 1]) + c
            dist = num / norm if norm else math.inf
            if dmin <= d <= dmax and abs(dist) <= max_vertical:
                pairs.append((i, k))
    return pairs


def neighbours(points, width, height):
    """For each point i, the sorted list of the other points j with ``|xj - xi| <= width/2``
    and ``|yj - yi| <= height/2``."""
    points = np.asarray(points, dtype=np.float32)
    hw, hh = np.float32(width / 2), np.float32(height / 2)
    out = []
    for i in range(len(points)):
        out.append([
            j for j in range(len(points))
            if j != i and abs(points[j, 0] - points[i, 0]) <= hw
            and abs(points[j, 1] - points[i, 1]) <= hh
        ])
    return out


def similarity(a, b, eps=1e-6, gain_tolerance=1.0):
    """Normalised eq. 7 distance between two descriptor rows (see
    ``hopmatch.matching.similarity.similarity_distance``): for uint8 rows the fraction of
    differing bits; for float rows ``mean|a - g b|`` over the mean of ``mean|a|`` and
    ``mean|b|``, where ``g = mean|a| / mean|b|`` clipped to ``[1/t, t]`` for the
    ``gain_tolerance`` t (1 when t is 1 or b is flat)."""
    if a.dtype == np.uint8:
        bits = 0
        for x, y in zip(a.tolist(), b.tolist()):
            bits += bin(x ^ y).count("1")
        return bits / (8 * len(a))
    a = [float(x) for x in a]
    b = [float(x) for x in b]
    n = len(a)
    scale_a = sum(abs(x) for x in a) / n
    scale_b = sum(abs(y) for y in b) / n
    g = 1.0
    if gain_tolerance > 1.0 and scale_b > 0.0:
        g = min(max(scale_a / scale_b, 1.0 / gain_tolerance), gain_tolerance)
    m = sum(abs(x - g * y) for x, y in zip(a, b)) / n
    return m / (0.5 * (scale_a + scale_b) + eps)


def compatibility(x, theta, slope):
    """Eq. 5: ``C = 2 / (1 + exp(slope (X - theta))) - 1``."""
    z = slope * (x - theta)
    if z > 700.0:  # exp overflows; the limit is -1
        return -1.0
    return 2.0 / (1.0 + np.exp(z)) - 1.0


def dense_network(left, right, desc_l, desc_r, p, weight_dtype=np.float32):
    """The network of eqs. 5, 6, 10 and 11 built directly, with dense matrices.

    Neurons are the candidate pairs (i, k) of the search window, minus those whose
    similarity exceeds ``p["similarity_gate"]`` and, with ``p["max_candidates"]``, all but
    each left point's most similar ones (ties: lower k). Returns a dict with

    - ``ni, nk`` (N,): the neurons, in (i, k) order; ``start`` (Nl + 1,) their offsets;
    - ``sim`` (N,): the normalised similarity of each neuron;
    - ``adj`` (N, N) bool: (i, k) and (j, l) interact through C (j a neighbour of i,
      j != i, l != k);
    - ``C`` (N, N): ``C_ik,jl`` of eq. 5 where ``adj``, else 0, rounded to ``weight_dtype``
      (the kernels store float32 weights);
    - ``T`` (N, N): ``C - w (delta_ij + delta_kl)`` with a zero diagonal (eq. 11),
      w = ``p["uniqueness_weight"]``.
    """
    left = np.asarray(left, dtype=np.float32)
    right = np.asarray(right, dtype=np.float32)
    pairs = candidate_pairs(left, right, p["min_disparity"], p["max_disparity"],
                            p["max_vertical"])
    tol = p.get("gain_tolerance", 1.0)
    sims = {pair: similarity(desc_l[pair[0]], desc_r[pair[1]], gain_tolerance=tol)
            for pair in pairs}
    if p["similarity_gate"] is not None:
        pairs = [pair for pair in pairs if sims[pair] <= p["similarity_gate"]]
    if p["max_candidates"]:
        kept = []
        for i in range(len(left)):
            mine = sorted((pair for pair in pairs if pair[0] == i),
                          key=lambda pair: (sims[pair], pair[1]))
            kept += sorted(mine[: p["max_candidates"]])
        pairs = kept
    n = len(pairs)
    ni = np.array([i for i, _ in pairs], dtype=np.int64)
    nk = np.array([k for _, k in pairs], dtype=np.int64)
    sim = np.array([sims[pair] for pair in pairs], dtype=np.float64)
    start = np.zeros(len(left) + 1, dtype=np.int64)
    for i in ni:
        start[i + 1] += 1
    start = np.cumsum(start)
    nbrs = neighbours(left, p["neighbour_width"], p["neighbour_height"])
    lam = p["similarity_weight"]
    uw = p["uniqueness_weight"]

    def dist(a, b):
        return float(np.hypot(float(a[0]) - float(b[0]), float(a[1]) - float(b[1])))

    adj = np.zeros((n, n), dtype=bool)
    c = np.zeros((n, n), dtype=np.float64)
    t = np.zeros((n, n), dtype=np.float64)
    for a, (i, k) in enumerate(pairs):
        for b, (j, l) in enumerate(pairs):
            if a == b:
                continue
            if j in nbrs[i] and l != k:
                d_ik = dist(left[i], right[k])                       # eq. 6
                d_jl = dist(left[j], right[l])
                big_d = dist(left[i], left[j]) - dist(right[k], right[l])
                x = abs(d_ik - d_jl) + abs(big_d) + lam * sim[a] + lam * sim[b]  # eq. 10
                adj[a, b] = True
                c[a, b] = float(weight_dtype(compatibility(x, p["theta"], p["slope"])))
            t[a, b] = c[a, b] - uw * ((i == j) + (k == l))
    return {"ni": ni, "nk": nk, "start": start, "sim": sim, "adj": adj, "C": c, "T": t}


def energy(t, bias, v):
    """Eq. 11: ``E = -1/2 V^T T V - I sum V``."""
    v = np.asarray(v, dtype=np.float64)
    return float(-0.5 * v @ t @ v - bias * v.sum())


def kernel_sweeps(start, seed):
    """The kernel's visit order, sweep after sweep (an endless generator of arrays).

    Regenerated with the kernel's own SplitMix64 ``shuffle``, as ``run_network`` does: the
    left points that have neurons, in increasing order, shuffled in place once per sweep
    (each sweep shuffles the previous permutation), from the state ``seed``.
    """
    n_left = len(start) - 1
    perm = np.array([i for i in range(n_left) if start[i + 1] > start[i]], dtype=np.int64)
    state = np.uint64(seed)
    while True:
        state = np.uint64(_kn.shuffle(perm, state))  # numba returns a Python int
        yield perm.copy()


def dense_run(t, bias, start, v0, sweeps, stable_iterations, max_iterations):
    """Eq. 13, one neuron at a time, on the dense T, replaying ``sweeps`` (an iterable of
    visit orders: lists of left points).

    Each visit (one *iteration*) updates the visited point's neurons in increasing k:
    ``u = T V + I``; ``V <- 1`` if u > 0, ``0`` if u < 0, unchanged if u = 0. Stops as
    ``run_network`` documents: a sweep that changed nothing, ``stable_iterations``
    consecutive unchanged visits (if > 0), or ``max_iterations`` visits.

    Returns ``(v, iterations, sweeps, converged, energies)`` with ``energies[t]`` the energy
    (eq. 11, recomputed from scratch) after visit t, index 0 the start.
    """
    v = np.array(v0, dtype=np.uint8)
    energies = [energy(t, bias, v)]
    iterations = 0
    n_sweeps = 0
    unchanged_run = 0
    converged = False
    for order in sweeps:
        if iterations >= max_iterations or len(order) == 0:
            break
        n_sweeps += 1
        sweep_changed = False
        stop = False
        for i in order:
            if iterations >= max_iterations:
                break
            changed = False
            for a in range(start[i], start[i + 1]):
                u = float(t[a] @ v.astype(np.float64)) + bias
                if u > 0 and v[a] == 0:
                    v[a] = 1
                    changed = True
                elif u < 0 and v[a] == 1:
                    v[a] = 0
                    changed = True
            iterations += 1
            energies.append(energy(t, bias, v))
            if changed:
                sweep_changed = True
                unchanged_run = 0
            else:
                unchanged_run += 1
                if stable_iterations > 0 and unchanged_run >= stable_iterations:
                    converged = True
                    stop = True
                    break
        if stop:
            break
        if not sweep_changed:
            converged = True
            break
    return v, iterations, n_sweeps, converged, np.array(energies)


def dense_match(left, right, desc_l, desc_r, p):
    """The whole network of ``run_hopfield_network`` on dense matrices: the network of
    :func:`dense_network`, then one phase per input bias (``initial_bias`` if not None, then
    ``input_bias``) seeded ``seed + phase``, each phase starting from the previous state.

    Returns ``(net, v, iterations, energies_per_phase)``.
    """
    net = dense_network(left, right, desc_l, desc_r, p)
    v = np.zeros(len(net["ni"]), dtype=np.uint8)
    biases = ([p["initial_bias"]] if p["initial_bias"] is not None else []) + [p["input_bias"]]
    iterations = 0
    phases = []
    for phase, bias in enumerate(biases):
        v, it, _, _, energies = dense_run(
            net["T"], bias, net["start"], v, kernel_sweeps(net["start"], p["seed"] + phase),
            p["stable_iterations"], p["max_iterations"] - iterations)
        iterations += it
        phases.append(energies)
    return net, v, iterations, phases


# ======================================================================================
# SPEC section 4: disambiguation
# ======================================================================================


def singular_choice(group, dy, score, threshold):
    """Section 4 in one direction, with loops.

    Groups with one active pair are singular and keep it. Then, repeatedly:
    ``Ybar`` = mean ``dy`` of the kept pairs (0 if none); in every still-multiple group, the
    pair closest to ``Ybar`` (ties: higher score, then lower index) is kept if it lies
    strictly within ``threshold`` of ``Ybar``, and its group becomes singular; stop when no
    group joins.
    """
    n = len(group)
    keep = np.zeros(n, dtype=bool)
    members: dict[int, list[int]] = {}
    for a in range(n):
        members.setdefault(int(group[a]), []).append(a)
    kept_dy = []
    pending = []
    for g, pairs in members.items():
        if len(pairs) == 1:
            keep[pairs[0]] = True
            kept_dy.append(float(dy[pairs[0]]))
        else:
            pending.append(g)
    while pending:
        ybar = sum(kept_dy) / len(kept_dy) if kept_dy else 0.0
        joined = []
        for g in pending:
            best = min(members[g], key=lambda a: (abs(float(dy[a]) - ybar), -float(score[a]), a))
            if abs(float(dy[best]) - ybar) < threshold:
                joined.append(best)
        if not joined:
            break
        for a in joined:
            keep[a] = True
            kept_dy.append(float(dy[a]))
            pending.remove(int(group[a]))
    return keep


def shift_minimal(desc_l, desc_r, qi, ti):
    """For each match, whether the mean |difference| of the overlapping columns of the two
    square windows is no larger at shift 0 than at column shifts -1 and +1 (float64)."""
    s = int(round(np.sqrt(desc_l.shape[1])))
    a = desc_l[qi].reshape(-1, s, s).astype(np.float64)
    b = desc_r[ti].reshape(-1, s, s).astype(np.float64)
    c_minus = np.abs(a[:, :, 1:] - b[:, :, :-1]).mean(axis=(1, 2))
    c_zero = np.abs(a[:, :, 1:-1] - b[:, :, 1:-1]).mean(axis=(1, 2))
    c_plus = np.abs(a[:, :, :-1] - b[:, :, 1:]).mean(axis=(1, 2))
    return (c_zero <= c_minus) & (c_zero <= c_plus)


def vertically_consistent(dy, threshold):
    """``vertical_check="all"`` with loops: the median of ``dy`` (the middle value of the
    sorted list, or the mean of the two middle values), then keep a pair iff its ``dy`` is
    strictly within ``threshold`` of that median."""
    values = sorted(float(v) for v in dy)
    n = len(values)
    if n == 0:
        return np.zeros(0, dtype=bool)
    if n % 2:
        median = values[n // 2]
    else:
        median = 0.5 * (values[n // 2 - 1] + values[n // 2])
    return np.array([abs(float(v) - median) < threshold for v in dy], dtype=bool)
