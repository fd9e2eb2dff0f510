"""Two views whose grey levels differ by more than a gain: a second match through the
map read off the first match (beyond the paper; docs/method.md section 4.7).

Two exposures of one scene, or one camera's response to another's, map grey levels
through a monotone curve; two lenses darken their corners differently (vignetting), a
gain that varies across the image. The per-image normalisation and ``gain_tolerance``
absorb one gain for the whole view, and the guided pass's ZNCC a gain per window, but the
network's similarity (eq. 7) compares windows of the gradient image, whose contrast a
curve or a varying gain changes window by window: on the shared MotorcycleE pair (two
exposures) the network finds half the matches it finds on motorcycle. A histogram says
little about such a map (two views show different parts of a scene), but the pair's own
matches do: the grey levels at their two ends follow it. :func:`tone_map` fits ``left =
curve(right) x gain(x, y)`` (a cubic, and the exponential of a quadratic of the right
point's position), robustly, and measures how far the curve departs from a straight line
and how much the gain varies; where either exceeds its tolerance (``tone_tolerance``,
``gain_field_tolerance``), ``match_stereo`` maps the right view through it and matches
the pair again.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

#: Fewest matches a map is read from (fewer: no map).
MIN_MATCHES = 200
#: Most matches a map is read from (evenly spaced in the matches' order).
MAX_MATCHES = 1000
#: The grey level at a point is the mean of the 3 x 3 bilinear samples at offsets of this
#: many px around it: a match's two ends agree to a fraction of a pixel, and the average
#: keeps a steep edge from reading a different level at each end.
SMOOTHING = 1.0
#: Degree of the curve.
DEGREE = 3
#: Rounds of fitting: each fits the curve with the gain fixed, then the gain with the
#: curve fixed, on the matches within ``TRIM`` robust standard deviations of the last fit
#: (wrong matches, occlusions).
ROUNDS = 3
TRIM = 3.0
#: The right view's grey levels between these percentiles of the matches' span the
#: curve's unit interval; beyond it the curve is continued by its end slopes.
SPAN_PERCENTILES = (1.0, 99.0)
#: Most second matches :func:`rematch_through_map` makes, each through the map read off
#: the last one kept, while that map differs from the one before by at least
#: :data:`TONE_CHANGE` of its rise (:func:`map_change`, over :data:`CHANGE_LEVELS` levels
#: and a :data:`CHANGE_GRID` x :data:`CHANGE_GRID` grid of positions).
TONE_ROUNDS = 2
TONE_CHANGE = 0.005
CHANGE_LEVELS = 32
CHANGE_GRID = 16
#: Quantiles (evenly spaced, 0 to 100 %) of each view that :func:`histogram_tone_map`
#: pairs.
HISTOGRAM_QUANTILES = 101
#: Matches whose grey levels (either end, or the curve's value) lie below this fraction of
#: the span above its low end, or below 0, do not inform the gain (a ratio of two dark
#: levels is mostly noise).
DARK = 0.05


@dataclass(frozen=True)
class ToneMap:
    """A map of the right view's grey levels onto the left view's: ``left = curve(right) x
    exp(field(x, y))``, (x, y) in the right view.

    Attributes
    ----------
    coefficients : (DEGREE + 1,) float64 ndarray
        The curve, a cubic (``np.polyval`` order) of ``t = (r - low) / (high - low)``; for
        a map read off the histograms (``table`` set), the straight line through the
        table by least squares, of the right level ``r`` itself (what ``nonlinearity`` is
        measured against; the curve is the table's).
    low, high : float
        The right grey levels mapped to ``t = 0`` and ``t = 1``.
    field : (6,) float64 ndarray
        The log gain, ``f0 + f1 u + f2 v + f3 u^2 + f4 u v + f5 v^2`` with ``u = (x - w/2)
        / (w/2)`` and ``v = (y - h/2) / (h/2)``.
    shape : tuple of int
        ``(h, w)`` of the right view.
    field_bounds : tuple of float
        The least and largest log gain at the matches: the field is clipped to them
        (beyond the matches a quadratic is an extrapolation).
    nonlinearity : float
        Largest distance over ``t`` in [0, 1] between the curve and the straight line
        fitted to the same matches, as a fraction of that line's rise (0 for a gain and an
        offset).
    field_range : float
        ``field_bounds[1] - field_bounds[0]``: how much the log gain varies across the
        matches (0 for one gain everywhere; 0.4 is a gain that varies by half).
    n_matches : int
        Matches the last fit kept (0 for a map read off the histograms:
        :func:`histogram_tone_map`).
    table : (2, K) float64 ndarray or None
        For a map read off the histograms (:func:`histogram_tone_map`): right grey levels
        (increasing) and the left levels they map to; the curve is then the piecewise
        linear one through them (continued by its end segments' slopes), not the cubic
        (None: the cubic).
    used : bool
        Whether the matches returned are those of the right view mapped through this map:
        it called for a second match (:func:`needs_rematch`) and that match found more
        pairs than the first.
    """

    coefficients: np.ndarray
    low: float
    high: float
    field: np.ndarray
    shape: tuple
    field_bounds: tuple
    nonlinearity: float
    field_range: float
    n_matches: int
    table: np.ndarray | None = None
    used: bool = False

    def curve(self, levels: np.ndarray) -> np.ndarray:
        """The curve at right grey ``levels`` (float64); outside ``[low, high]`` continued
        by its slope at that end."""
        if self.table is not None:
            return piecewise_linear(np.asarray(levels, dtype=np.float64), *self.table)
        t = (np.asarray(levels, dtype=np.float64) - self.low) / (self.high - self.low)
        slope = np.polyder(self.coefficients)
        inside = np.polyval(self.coefficients, np.clip(t, 0.0, 1.0))
        below = np.minimum(t, 0.0) * np.polyval(slope, 0.0)
        above = np.maximum(t - 1.0, 0.0) * np.polyval(slope, 1.0)
        return inside + below + above

    def log_gain(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """The log gain at right-view positions ``(x, y)``, clipped to ``field_bounds``."""
        return np.clip(field_terms(x, y, self.shape) @ self.field, *self.field_bounds)

    def apply(self, gray: np.ndarray) -> np.ndarray:
        """``gray`` (the right view) mapped through the curve and the gain, float32."""
        h, w = self.shape
        x, y = np.broadcast_arrays(np.arange(w, dtype=np.float64)[None, :],
                                   np.arange(h, dtype=np.float64)[:, None])
        return (self.curve(gray) * np.exp(self.log_gain(x, y))).astype(np.float32)


def field_terms(x: np.ndarray, y: np.ndarray, shape) -> np.ndarray:
    """``(..., 6)``: the terms ``1, u, v, u^2, u v, v^2`` of :attr:`ToneMap.field` at
    ``(x, y)`` in a view of ``shape`` ``(h, w)``."""
    h, w = shape
    u = (np.asarray(x, dtype=np.float64) - 0.5 * w) / (0.5 * w)
    v = (np.asarray(y, dtype=np.float64) - 0.5 * h) / (0.5 * h)
    return np.stack([np.ones_like(u), u, v, u * u, u * v, v * v], axis=-1)


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


def tone_map(gray_left: np.ndarray, gray_right: np.ndarray, points_left: np.ndarray,
             points_right: np.ndarray) -> ToneMap | None:
    """The map from the right view's grey levels onto the left view's, read at the two
    ends of each match (``points_left[i]`` with ``points_right[i]``; at most
    :data:`MAX_MATCHES` of them); None with fewer than :data:`MIN_MATCHES` matches, a flat
    right view, or a curve that is not increasing over the matches' span.

    :data:`ROUNDS` rounds, each on the matches within :data:`TRIM` robust standard
    deviations (1.4826 x the median absolute residual) of the last round's map: the curve
    by least squares with the gain fixed (1 at first), then the log gain by least squares
    with the curve fixed (on the matches brighter than :data:`DARK`)."""
    n = len(points_left)
    if n < MIN_MATCHES:
        return None
    take = np.arange(n) if n <= MAX_MATCHES else np.linspace(0, n - 1, MAX_MATCHES).astype(
        np.int64)
    right_points = np.asarray(points_right, dtype=np.float64)[take]
    left = grey_levels(gray_left, np.asarray(points_left)[take])
    right = grey_levels(gray_right, right_points)
    low, high = np.percentile(right, SPAN_PERCENTILES)
    if not high > low:
        return None
    t = (right - low) / (high - low)
    terms = field_terms(right_points[:, 0], right_points[:, 1], np.shape(gray_right)[:2])
    field = np.zeros(terms.shape[1])
    keep = np.ones(len(t), dtype=bool)
    # a gain is a ratio of two positive levels (images of negative levels get no field)
    floor = max(np.percentile(left, SPAN_PERCENTILES[0]) + DARK * (np.ptp(left) or 1.0), 0.0)
    for _ in range(ROUNDS):
        gain = np.exp(terms @ field)
        coefficients = np.polyfit(t[keep], (left / gain)[keep], DEGREE)
        at = np.polyval(coefficients, t)
        bright = keep & (at > floor) & (left > floor)
        if bright.sum() >= MIN_MATCHES:
            field = np.linalg.lstsq(terms[bright], np.log(left[bright] / at[bright]),
                                    rcond=None)[0]
        residual = np.abs(left - at * np.exp(terms @ field))
        keep = residual <= TRIM * 1.4826 * np.median(residual[keep]) + 1e-9
        if keep.sum() < MIN_MATCHES:
            return None
    gain = np.exp(terms @ field)
    coefficients = np.polyfit(t[keep], (left / gain)[keep], DEGREE)
    line = np.polyfit(t[keep], (left / gain)[keep], 1)
    grid = np.linspace(0.0, 1.0, 101)
    curve = np.polyval(coefficients, grid)
    if not (np.diff(curve) > 0).all() or not line[0] > 0:
        return None
    log_gain = terms[keep] @ field
    bounds = (float(log_gain.min()), float(log_gain.max()))
    return ToneMap(coefficients=coefficients, low=float(low), high=float(high), field=field,
                   shape=tuple(np.shape(gray_right)[:2]), field_bounds=bounds,
                   nonlinearity=float(np.abs(curve - np.polyval(line, grid)).max() / line[0]),
                   field_range=bounds[1] - bounds[0], n_matches=int(keep.sum()))


def piecewise_linear(x: np.ndarray, knots: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The piecewise linear function through ``(knots[i], values[i])`` (``knots``
    increasing, at least two) at ``x``, continued beyond the ends by the end segments'
    slopes."""
    inside = np.interp(x, knots, values)
    first = (values[1] - values[0]) / (knots[1] - knots[0])
    last = (values[-1] - values[-2]) / (knots[-1] - knots[-2])
    return (inside + np.minimum(x - knots[0], 0.0) * first
            + np.maximum(x - knots[-1], 0.0) * last)


def histogram_tone_map(gray_left: np.ndarray, gray_right: np.ndarray) -> ToneMap | None:
    """The map from the right view's grey levels onto the left view's that gives the right
    view the left view's histogram: the piecewise linear curve through the pairs of the
    two views' :data:`HISTOGRAM_QUANTILES` quantiles (quantiles that share a right level,
    a clipped pile, map it to the mean of their left levels), no gain field, ``n_matches``
    0. For a first match too poor to read :func:`tone_map` off (fewer than
    :data:`MIN_MATCHES` pairs): two views of one scene show different parts of it, so a
    histogram is a rough map (docs/method.md section 4.7), but where a response curve or
    a clipped exposure left the first match next to nothing it is the map there is.
    ``nonlinearity`` is measured as :func:`tone_map`'s, over the right view's span. None
    for a flat view."""
    q = np.linspace(0.0, 100.0, HISTOGRAM_QUANTILES)
    left = np.percentile(np.asarray(gray_left, dtype=np.float64), q)
    right, group = np.unique(np.percentile(np.asarray(gray_right, dtype=np.float64), q),
                             return_inverse=True)
    left = np.bincount(group, weights=left) / np.bincount(group)
    if len(right) < 2 or not left[-1] > left[0]:
        return None
    left = np.maximum.accumulate(left)  # increasing (it is, up to rounding)
    grid = np.linspace(right[0], right[-1], 101)
    curve = piecewise_linear(grid, right, left)
    line = np.polyfit(right, left, 1)
    if not line[0] > 0:
        return None
    rise = line[0] * (right[-1] - right[0])
    return ToneMap(coefficients=line, low=float(right[0]), high=float(right[-1]),
                   field=np.zeros(6), shape=tuple(np.shape(gray_right)[:2]),
                   field_bounds=(0.0, 0.0),
                   nonlinearity=float(np.abs(curve - np.polyval(line, grid)).max() / rise),
                   field_range=0.0, n_matches=0, table=np.stack((right, left)))


def needs_rematch(found: ToneMap, tone_tolerance: float | None,
                  field_tolerance: float | None) -> bool:
    """Whether ``found``'s curve departs from a line by more than ``tone_tolerance`` or its
    gain varies by more than ``field_tolerance`` (None: that part never calls for it)."""
    return ((tone_tolerance is not None and found.nonlinearity > tone_tolerance)
            or (field_tolerance is not None and found.field_range > field_tolerance))


def rematch_through_map(gray_left: np.ndarray, gray_right: np.ndarray,
                        matched_left: np.ndarray, matched_right: np.ndarray,
                        tone_tolerance: float | None, field_tolerance: float | None,
                        rematch, rounds: int | None = None) -> tuple[ToneMap | None, object]:
    """``(map, second)``: the :func:`tone_map` of a first match (the grey views it was made
    on, its ``matched_left[i]`` with ``matched_right[i]``; None when both tolerances are
    None), and what ``rematch(grey)`` returned for the right grey view mapped through it,
    or None.

    ``rematch(grey)`` is called when the map's ``nonlinearity`` exceeds ``tone_tolerance``
    or its ``field_range`` exceeds ``field_tolerance`` (:func:`needs_rematch`) and returns
    ``(left, right, second)``: the second match's pairs (``left[i]`` with ``right[i]``,
    positions in the right view's own frame, which the map does not move) and whatever
    the caller keeps of it. ``second`` is returned (and the map's ``used`` set) only when
    that match has more pairs than the first (``len(matched_left)``): a map read off a
    first match with many wrong pairs can be wrong itself, and the count keeps such a
    second match from replacing a better first. A first match of fewer than
    :data:`MIN_MATCHES` pairs has no map read off it; with ``tone_tolerance`` set, the
    map is then read off the two views' histograms (:func:`histogram_tone_map`) and
    called for under the same rule.

    A map read off a poor first match is itself rough; so up to ``rounds`` (None:
    :data:`TONE_ROUNDS`) second matches are made, each through the map read off the last
    one kept while it still calls for one and differs from the map before it by at least
    :data:`TONE_CHANGE` (:func:`map_change`), and the one with the most pairs is returned
    with the map it was made through."""
    if tone_tolerance is None and field_tolerance is None:
        return None, None
    rounds = TONE_ROUNDS if rounds is None else int(rounds)
    found = tone_map(gray_left, gray_right, matched_left, matched_right)
    if found is None and len(matched_left) < MIN_MATCHES and tone_tolerance is not None:
        found = histogram_tone_map(gray_left, gray_right)
    if found is None or not needs_rematch(found, tone_tolerance, field_tolerance):
        return found, None
    first, kept, most = found, None, len(matched_left)
    for _ in range(max(rounds, 1)):
        left, right, second = rematch(found.apply(gray_right))
        if len(left) <= most:
            break
        first, kept, most = replace(found, used=True), second, len(left)
        found = tone_map(gray_left, gray_right, left, right)
        if (found is None or not needs_rematch(found, tone_tolerance, field_tolerance)
                or map_change(first, found, gray_right) < TONE_CHANGE):
            break
    return first, kept


def map_change(a: ToneMap, b: ToneMap, gray_right: np.ndarray) -> float:
    """How much two maps of the right view ``gray_right`` differ: the median, over
    :data:`CHANGE_LEVELS` grey levels evenly spaced between the view's 1st and 99th
    percentiles (:data:`SPAN_PERCENTILES`) and a grid of :data:`CHANGE_GRID` x
    :data:`CHANGE_GRID` positions, of ``|a - b|`` (curve times gain), over the rise of
    ``a``'s curve across those levels (0 when it does not rise)."""
    low, high = np.percentile(np.asarray(gray_right, dtype=np.float64)[::4, ::4],
                              SPAN_PERCENTILES)
    levels = np.linspace(low, high, CHANGE_LEVELS)
    h, w = a.shape
    y, x = np.meshgrid(np.linspace(0.0, h - 1.0, CHANGE_GRID),
                       np.linspace(0.0, w - 1.0, CHANGE_GRID), indexing="ij")
    x, y = x.ravel(), y.ravel()

    def mapped(m):
        return m.curve(levels)[None, :] * np.exp(m.log_gain(x, y))[:, None]

    curve = a.curve(levels)
    rise = float(curve[-1] - curve[0])
    if not rise > 0.0:
        return 0.0
    return float(np.median(np.abs(mapped(a) - mapped(b)))) / rise
