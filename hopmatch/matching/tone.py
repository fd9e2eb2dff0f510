"""Two views whose grey levels differ by a curve, not a gain: a second match through the
curve read off the first match (beyond the paper; docs/method.md section 4.7).

Two exposures of one scene, or one camera's response to another's, map grey levels
through a monotone curve. The per-image normalisation and ``gain_tolerance`` absorb a
gain, and the guided pass's ZNCC a gain per window, but the network's similarity (eq. 7)
compares windows of the gradient image, whose contrast a curve changes by a different
factor at every grey level: on the shared MotorcycleE pair (two exposures) the network
finds half the matches it finds on motorcycle. A histogram says little about such a
curve (two views show different parts of a scene), but the pair's own matches do: the
grey levels at their two ends follow the curve. :func:`tone_curve` fits it (a cubic,
robustly) and measures how far it departs from a straight line; where that exceeds
``tone_tolerance``, ``match_stereo`` maps the right view through the curve and matches
the pair again.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Fewest matches a curve is read from (fewer: no curve).
MIN_MATCHES = 200
#: Most matches a curve is read from (evenly spaced in the matches' order).
MAX_MATCHES = 1000
#: The grey level at a point is the mean of the 3 x 3 bilinear samples at offsets of this
#: many px around it: a match's two ends agree to a fraction of a pixel, and the average
#: keeps a steep edge from reading a different level at each end.
SMOOTHING = 1.0
#: Degree of the curve.
DEGREE = 3
#: Rounds of fitting; each keeps the matches within ``TRIM`` robust standard deviations of
#: the last fit (wrong matches, occlusions).
ROUNDS = 3
TRIM = 3.0
#: The right view's grey levels between these percentiles of the matches' span the fit's
#: unit interval; beyond it the curve is continued by its end slopes.
SPAN_PERCENTILES = (1.0, 99.0)


@dataclass(frozen=True)
class ToneCurve:
    """A monotone map of the right view's grey levels onto the left view's.

    Attributes
    ----------
    coefficients : (DEGREE + 1,) float64 ndarray
        The cubic (``np.polyval`` order) of ``t = (r - low) / (high - low)``.
    low, high : float
        The right grey levels mapped to ``t = 0`` and ``t = 1``.
    nonlinearity : float
        Largest distance over ``t`` in [0, 1] between the curve and the straight line
        fitted to the same matches, as a fraction of that line's rise (0 for a gain and an
        offset).
    n_matches : int
        Matches the last fit kept.
    """

    coefficients: np.ndarray
    low: float
    high: float
    nonlinearity: float
    n_matches: int

    def apply(self, gray: np.ndarray) -> np.ndarray:
        """``gray`` (the right view) mapped through the curve, float32; outside ``[low,
        high]`` continued by the curve's slope at that end."""
        t = (np.asarray(gray, dtype=np.float64) - self.low) / (self.high - self.low)
        slope = np.polyder(self.coefficients)
        inside = np.polyval(self.coefficients, np.clip(t, 0.0, 1.0))
        below = np.minimum(t, 0.0) * np.polyval(slope, 0.0)
        above = np.maximum(t - 1.0, 0.0) * np.polyval(slope, 1.0)
        return (inside + below + above).astype(np.float32)


def grey_levels(gray: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The mean grey level of ``gray`` over the 3 x 3 bilinear samples :data:`SMOOTHING`
    px apart around each (x, y) of ``points`` (float64; samples beyond the image read its
    nearest pixels)."""
    h, w = gray.shape[:2]
    step = SMOOTHING * np.array([-1.0, 0.0, 1.0])
    p = np.asarray(points, dtype=np.float64)
    x = np.clip((p[:, 0:1, None] + step[None, None, :]).repeat(3, axis=1), 0, w - 1)
    y = np.clip((p[:, 1:2, None] + step[None, :, None]).repeat(3, axis=2), 0, h - 1)
    x0 = np.minimum(np.floor(x).astype(np.intp), max(w - 2, 0))
    y0 = np.minimum(np.floor(y).astype(np.intp), max(h - 2, 0))
    ax, ay = x - x0, y - y0
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
    g = np.asarray(gray)
    top = (1 - ax) * g[y0, x0] + ax * g[y0, x1]
    bottom = (1 - ax) * g[y1, x0] + ax * g[y1, x1]
    return ((1 - ay) * top + ay * bottom).reshape(len(p), 9).mean(axis=1)


def tone_curve(gray_left: np.ndarray, gray_right: np.ndarray, points_left: np.ndarray,
               points_right: np.ndarray) -> ToneCurve | None:
    """The curve that maps the right view's grey levels onto the left view's, read at the
    two ends of each match (``points_left[i]`` with ``points_right[i]``; at most
    :data:`MAX_MATCHES` of them); None with fewer than :data:`MIN_MATCHES` matches, a flat
    right view, or a curve that is not increasing over the matches' span.

    A least-squares cubic, refitted :data:`ROUNDS` times on the matches within
    :data:`TRIM` robust standard deviations (1.4826 x the median absolute residual) of the
    last fit."""
    if len(points_left) < MIN_MATCHES:
        return None
    n = len(points_left)
    take = (np.arange(n) if n <= MAX_MATCHES
            else np.linspace(0, n - 1, MAX_MATCHES).astype(np.int64))
    left = grey_levels(gray_left, np.asarray(points_left)[take])
    right = grey_levels(gray_right, np.asarray(points_right)[take])
    low, high = np.percentile(right, SPAN_PERCENTILES)
    if not high > low:
        return None
    t = (right - low) / (high - low)
    keep = np.ones(len(t), dtype=bool)
    for _ in range(ROUNDS):
        coefficients = np.polyfit(t[keep], left[keep], DEGREE)
        residual = np.abs(left - np.polyval(coefficients, t))
        scale = 1.4826 * np.median(residual[keep])
        keep = residual <= TRIM * scale + 1e-9
        if keep.sum() < MIN_MATCHES:
            return None
    coefficients = np.polyfit(t[keep], left[keep], DEGREE)
    line = np.polyfit(t[keep], left[keep], 1)
    grid = np.linspace(0.0, 1.0, 101)
    curve = np.polyval(coefficients, grid)
    rise = abs(line[0])
    if not (np.diff(curve) > 0).all() or not rise > 0:
        return None
    nonlinearity = float(np.abs(curve - np.polyval(line, grid)).max() / rise)
    return ToneCurve(coefficients, float(low), float(high), nonlinearity, int(keep.sum()))


def rematch_through_curve(result, found_left, found_right, tolerance: float | None,
                          rematch):
    """``(result, found_right)``: ``result`` (a first match, whose detection of each view
    gave ``found_left`` and ``found_right``: ``(points, responses, descriptors, G,
    grey)``) with its :func:`tone_curve` recorded as ``result.tone_curve``; or, when
    that curve's nonlinearity exceeds ``tolerance`` (None: never), what ``rematch(grey)``
    returns for the right grey view mapped through the curve (``(result, found_right)`` of
    a second detection of the right view and a second match), with the curve recorded."""
    if tolerance is None:
        return result, found_right
    curve = tone_curve(found_left[4], found_right[4], result.matched_left,
                       result.matched_right)
    if curve is not None and curve.nonlinearity > tolerance:
        result, found_right = rematch(curve.apply(found_right[4]))
    result.tone_curve = curve
    return result, found_right
