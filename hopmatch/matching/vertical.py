"""The residual vertical offset of a rectified pair, ``dy = yl - yr``, as a function of the
left position: what the guided pass and the refinement search along (beyond the paper;
docs/method.md)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .diagnostics import clear_look_alikes

#: Fewest matches a plane is fitted to; with fewer the model is their median.
PLANE_MIN_MATCHES = 50
#: Iterations of the robust (reweighted least-squares) plane fit.
PLANE_ITERATIONS = 5
#: Tukey biweight cut-off in robust standard deviations (MAD * 1.4826).
PLANE_TUKEY = 4.685
#: Largest slope (px per px, about tan 2 degrees) of a residual vertical offset: a pair
#: whose offset varies faster is not rectified, and searching along rows is no use (a
#: calibrated rig's residual stays below 1 degree; docs/parameters.md measures 1 and 2).
MAX_RESIDUAL_SLOPE = 0.036


class RowOffset(NamedTuple):
    """``dy(x, y) = a + b (x - cx) + c (y - cy)``: the vertical offset ``yl - yr`` of the
    pair at the left point (x, y), centred on (cx, cy) to keep the fit well conditioned."""

    a: float
    b: float = 0.0
    c: float = 0.0
    cx: float = 0.0
    cy: float = 0.0

    def is_residual(self) -> bool:
        """Whether the offset varies no faster than :data:`MAX_RESIDUAL_SLOPE` in x and in
        y: what the rectification of a calibrated rig leaves (a rotation below about a
        degree) with room to spare, and what the guided pass and the refinement can follow
        along rows."""
        return abs(self.b) <= MAX_RESIDUAL_SLOPE and abs(self.c) <= MAX_RESIDUAL_SLOPE

    def at(self, points: np.ndarray) -> np.ndarray:
        """(N,) float64: the offset at each (x, y) of ``points`` ((N, 2))."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        return self.a + self.b * (p[:, 0] - self.cx) + self.c * (p[:, 1] - self.cy)


def median_offset(dy: np.ndarray) -> RowOffset:
    """The constant model: the median of ``dy`` (0 without matches)."""
    dy = np.asarray(dy, dtype=np.float64)
    return RowOffset(float(np.median(dy)) if len(dy) else 0.0)


def _median(a: np.ndarray) -> float:
    """``np.median`` of a 1-D float64 array without NaN (the same value: the middle
    element, or the mean ``(a + b) / 2`` of the two middle ones), without its wrappers:
    the robust plane fit takes two per iteration."""
    n = a.shape[0]
    k = n // 2
    if n % 2:
        return np.partition(a, k)[k]
    part = np.partition(a, (k - 1, k))
    return (part[k - 1] + part[k]) / 2.0


def fit_row_offset(left: np.ndarray, dy: np.ndarray, weights=None) -> RowOffset:
    """Robust plane ``dy = a + b x + c y`` through the vertical offsets of matches.

    A small rotation of one camera about its optical axis, or a scale difference, makes
    the residual vertical disparity of a rectified pair linear in x and y; a single
    median cannot follow it. The plane is fitted by iteratively reweighted least squares
    with Tukey's biweight (:data:`PLANE_TUKEY` robust standard deviations, from the MAD of
    the residuals), starting from the median, so that wrong matches do not pull it.

    Parameters
    ----------
    left : (M, 2) ndarray
        Left points of confident matches.
    dy : (M,) ndarray
        Their ``yl - yr``.
    weights : (M,) ndarray, optional
        Prior weights (e.g. the matches' confidence), >= 0.

    Returns
    -------
    RowOffset
        The plane; the median (:func:`median_offset`) when there are fewer than
        :data:`PLANE_MIN_MATCHES` matches or their positions do not span a plane.
    """
    p = np.asarray(left, dtype=np.float64).reshape(-1, 2)
    dy = np.asarray(dy, dtype=np.float64).reshape(-1)
    finite = np.isfinite(dy) & np.isfinite(p).all(axis=1)
    p, dy = p[finite], dy[finite]
    prior = (np.ones(len(dy)) if weights is None
             else np.asarray(weights, dtype=np.float64).reshape(-1)[finite])
    base = median_offset(dy)
    if len(dy) < PLANE_MIN_MATCHES:
        return base
    cx, cy = (float(v) for v in np.median(p, axis=0))
    design = np.c_[np.ones(len(dy)), p[:, 0] - cx, p[:, 1] - cy]
    coef = robust_fit(design, dy, np.array([base.a, 0.0, 0.0]), prior)
    if coef is None:
        return base
    return RowOffset(float(coef[0]), float(coef[1]), float(coef[2]), cx, cy)


def robust_fit(design: np.ndarray, values: np.ndarray, start: np.ndarray,
               prior: np.ndarray | None = None) -> np.ndarray | None:
    """The coefficients of ``values ~ design`` by iteratively reweighted least squares
    with Tukey's biweight (:data:`PLANE_TUKEY` robust standard deviations, from the MAD of
    the residuals), :data:`PLANE_ITERATIONS` rounds from ``start``, the weights times
    ``prior`` when given; None when the weighted design loses rank (fewer independent
    rows than columns): the fit of :func:`fit_row_offset`, and of
    :func:`hopmatch.matching.unrectified.row_drift`."""
    coef = start
    for _ in range(PLANE_ITERATIONS):
        res = values - design @ coef
        scale = 1.4826 * float(_median(np.abs(res - _median(res))))
        scale = max(scale, 1e-3)
        r = res / (PLANE_TUKEY * scale)
        w = np.where(np.abs(r) < 1.0, (1.0 - r * r) ** 2, 0.0)
        sw = np.sqrt(w if prior is None else prior * w)
        # lstsq's rank uses matrix_rank's tolerance (eps * max(M, N) * the largest
        # singular value): one SVD per iteration answers both.
        fit, _, rank, _ = np.linalg.lstsq(design * sw[:, None], values * sw, rcond=None)
        if rank < design.shape[1]:
            return None
        coef = fit
    return coef


def row_plane_residual(points: np.ndarray, dy: np.ndarray) -> tuple[float, float]:
    """``(residual, curve)``: how far rows that the network's vertical model follows leave
    the correspondences at ``points`` whose rows differ by ``dy``. ``residual``: the 90th
    percentile of ``|dy|`` less the plane ``a + b x + c y`` fitted to it robustly, as the
    vertical model is (:func:`robust_fit`); ``curve``: the
    90th percentile of the gap between that plane and the quadratic surface (``x y``,
    ``x**2``, ``y**2`` terms too) fitted the same way, at the points: the part of the
    offset that is structure (a verged rig's keystone), not noise. (0, 0) for fewer than
    8 points."""
    n = len(dy)
    if n < 8:
        return 0.0, 0.0
    centred = points - points.mean(axis=0)
    u, v = (centred / max(float(np.abs(centred).max()), 1e-9)).T
    plane = np.c_[np.ones(n), u, v]
    coef = robust_fit(plane, dy, np.array([float(np.median(dy)), 0.0, 0.0]))
    if coef is None:
        return 0.0, 0.0
    quadratic = np.c_[plane, u * v, u * u, v * v]
    coef_q = robust_fit(quadratic, dy, np.r_[coef, 0.0, 0.0, 0.0])
    curve = 0.0 if coef_q is None else float(
        np.percentile(np.abs(quadratic @ coef_q - plane @ coef), 90.0))
    return float(np.percentile(np.abs(dy - plane @ coef), 90.0)), curve


#: The row-offset prior (:func:`row_offset_prior`): left points sampled first, and at most
#: (doubling while fewer than :data:`PLANE_MIN_MATCHES` clear look-alikes are found), the
#: band searched around their rows (at least), the share of the sampled look-alikes the
#: plane must fit within 1 px, the tolerance of the tight fit and how much larger a share
#: of them the plane must fit within it than the plain rows do (the spurious plane of
#: KITTI #70 as it is, 1 px at a corner, fits 54 % against the rows' 51 %; a 0.3 degree
#: rotation's planes fit 70-82 % against 30-46 %), and the offset that at least a tenth of
#: the left points must reach for anything to be shifted.
PRIOR_SAMPLE = 200
PRIOR_MAX_SAMPLE = 800
PRIOR_BAND = 4.0
PRIOR_MIN_SUPPORT = 0.5
PRIOR_TIGHT = 0.5
PRIOR_MIN_GAIN = 0.15
PRIOR_PLANE_GAIN = 0.05
PRIOR_MIN_SHIFT = 0.5


class RowOffsetPrior(NamedTuple):
    """A residual vertical offset measured before the network (:func:`row_offset_prior`):
    the plane, and the median disparity of the look-alikes it was fitted to."""

    offset: RowOffset
    disparity: float

    def aligned(self, right: np.ndarray) -> np.ndarray:
        """(N, 2) float32: the right points moved down by the offset at their left
        position (``x + disparity``), so that the search band of each left point is
        centred on its partner's row."""
        p = np.asarray(right, dtype=np.float64)
        shift = self.offset.at(np.c_[p[:, 0] + self.disparity, p[:, 1]])
        out = np.array(right, dtype=np.float32, copy=True)
        out[:, 1] = (p[:, 1] + shift).astype(np.float32)
        return out


def tight_share(offset: RowOffset, left: np.ndarray, dy: np.ndarray) -> float:
    """The share of the offsets ``dy`` at ``left`` that ``offset`` predicts within
    :data:`PRIOR_TIGHT` px."""
    return float(np.mean(np.abs(offset.at(left) - dy) <= PRIOR_TIGHT))


def row_offset_prior(q_pts, t_pts, qd, td, min_disparity, max_disparity,
                     max_vertical) -> RowOffsetPrior | None:
    """The residual vertical offset of a rectified pair, measured before the network so that
    its search band can follow it (beyond the paper; docs/method.md §4.1).

    The band of the network is ``max_vertical`` rows (1 px by default): a rectification that
    leaves 1.5 px of vertical disparity, or a rotation of 0.3 degrees, puts most true
    partners outside it. Up to :data:`PRIOR_SAMPLE` left points are compared with the right
    points within the disparity range and ``max(PRIOR_BAND, 4 max_vertical)`` rows (twice
    as many, up to :data:`PRIOR_MAX_SAMPLE`, while fewer than :data:`PLANE_MIN_MATCHES`
    clear look-alikes are found). The model is the robust plane (:func:`fit_row_offset`)
    through the clear look-alikes, or their median when the plane fits at most
    :data:`PRIOR_PLANE_GAIN` more of them within :data:`PRIOR_TIGHT` px
    (:func:`tight_share`). It is the prior when it varies slowly
    (:meth:`RowOffset.is_residual`), fits at least :data:`PRIOR_MIN_SUPPORT` of them
    within 1 px, fits at least :data:`PRIOR_MIN_GAIN` more of them within
    :data:`PRIOR_TIGHT` px than the plain rows (offset 0) do, and reaches
    :data:`PRIOR_MIN_SHIFT` px at a tenth of the left points or more. None otherwise (a
    well rectified pair: the network searches the plain band, as before).
    """
    return prior_of_look_alikes(q_pts, prior_look_alikes(q_pts, t_pts, qd, td, min_disparity,
                                                         max_disparity, max_vertical))


def prior_look_alikes(q_pts, t_pts, qd, td, min_disparity, max_disparity, max_vertical):
    """The clear look-alikes :func:`row_offset_prior` is measured on: ``(left, dy,
    disparity)`` (float64; ``dy = y_left - y_right``), or None when too few are clear."""
    band = max(PRIOR_BAND, 4.0 * max_vertical)
    sample = PRIOR_SAMPLE
    while True:
        found = clear_look_alikes(q_pts, t_pts, qd, td, min_disparity, max_disparity, band,
                                  sample)
        if (found is not None and len(found[0]) >= PLANE_MIN_MATCHES) \
                or sample >= min(len(q_pts), PRIOR_MAX_SAMPLE):
            break
        sample *= 2
    if found is None:
        return None
    qi, ti = found
    left = q_pts[qi].astype(np.float64)
    return left, left[:, 1] - t_pts[ti, 1], left[:, 0] - t_pts[ti, 0]


def rows_share_of(look_alikes, max_vertical) -> float:
    """The share of the look-alikes :func:`prior_look_alikes` found that lie within
    ``max(1, max_vertical)`` px of their row (0 when it found too few)."""
    if look_alikes is None:
        return 0.0
    return float(np.mean(np.abs(look_alikes[1]) <= max(1.0, max_vertical)))


def prior_of_look_alikes(q_pts, look_alikes) -> RowOffsetPrior | None:
    """:func:`row_offset_prior` of the look-alikes :func:`prior_look_alikes` found."""
    if look_alikes is None:
        return None
    left, dy, disparity = look_alikes
    offset = fit_row_offset(left, dy)
    constant = median_offset(dy)
    if tight_share(constant, left, dy) >= tight_share(offset, left, dy) - PRIOR_PLANE_GAIN:
        offset = constant  # a slope the look-alikes do not ask for is noise
    residual = np.abs(offset.at(left) - dy)
    if not offset.is_residual() or np.mean(residual <= 1.0) < PRIOR_MIN_SUPPORT:
        return None
    gain = np.mean(residual <= PRIOR_TIGHT) - np.mean(np.abs(dy) <= PRIOR_TIGHT)
    if gain < PRIOR_MIN_GAIN or np.percentile(np.abs(offset.at(q_pts)), 90) < PRIOR_MIN_SHIFT:
        return None
    return RowOffsetPrior(offset, float(np.median(disparity)))
