"""Scoring sparse matches on a rectified pair against ground-truth disparity.

Conventions (as in :mod:`hopmatch.datasets`): points are ``(N, 2)`` float32 ``(x, y)``
arrays, as ``cv2.KeyPoint_convert`` gives them; the ground truth is a ``(H, W)`` disparity
of the **left** image with NaN (or inf) where unknown; the left point ``(x, y)`` corresponds
to the right point ``(x - d, y)``, so the disparity of a match is ``xl - xr``.

Everything here is vectorised: no Python loop over points. Nearest-neighbour questions
are answered with :class:`scipy.spatial.cKDTree`.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ._validate import as_points, as_real, describe
from .errors import InvalidArgumentError, InvalidTypeError

__all__ = ["MatchScore", "correct_matches", "error_histogram", "repeatability",
           "score_matches"]


# --------------------------------------------------------------------------------------
# Private input helpers
# --------------------------------------------------------------------------------------


def _as_disparity(disparity, name: str = "disparity_gt") -> np.ndarray:
    """(H, W) float32, C-contiguous; non-finite values mean "unknown"."""
    if not isinstance(disparity, np.ndarray):
        raise InvalidTypeError(
            f"`{name}` must be a numpy array (H, W) of disparities in pixels, got "
            f"{describe(disparity)}"
        )
    if disparity.dtype == np.bool_ or not np.issubdtype(disparity.dtype, np.number):
        raise InvalidTypeError(f"`{name}` must hold numbers, got dtype {disparity.dtype}")
    if disparity.ndim != 2:
        raise InvalidArgumentError(
            f"`{name}` must be a 2-dimensional (H, W) disparity map, got shape "
            f"{disparity.shape}"
        )
    if disparity.shape[0] == 0 or disparity.shape[1] == 0:
        raise InvalidArgumentError(f"`{name}` must not be empty, got shape {disparity.shape}")
    return np.ascontiguousarray(disparity, dtype=np.float32)


#: Widest tolerance (px) of the recall of :func:`score_matches`: it enumerates the keypoint
#: pairs within it, as many as every pair of a dense image beyond a few hundred pixels.
MAX_RECALL_TOLERANCE = 64.0


def _thresholds(thresholds) -> tuple[float, ...]:
    if isinstance(thresholds, numbers.Real) and not isinstance(thresholds, bool):
        thresholds = (thresholds,)
    if isinstance(thresholds, np.ndarray):
        thresholds = thresholds.tolist()
    if not isinstance(thresholds, Sequence) or isinstance(thresholds, (str, bytes)):
        raise InvalidTypeError(
            f"`thresholds` must be a sequence of pixel tolerances such as (0.5, 1.0, 2.0), "
            f"got {describe(thresholds)}"
        )
    if len(thresholds) == 0:
        raise InvalidArgumentError("`thresholds` must hold at least one tolerance, got none")
    out = tuple(as_real(t, "thresholds", lo=0.0, lo_open=True) for t in thresholds)
    return tuple(dict.fromkeys(out))  # unique, order kept


def _gt_at(points: np.ndarray, disparity: np.ndarray) -> np.ndarray:
    """Ground truth at the nearest pixel of each (x, y) point; NaN outside or unknown.

    The nearest pixel is ``floor(x + 0.5)``, ``floor(y + 0.5)`` (halves round up).
    """
    h, w = disparity.shape
    out = np.full(points.shape[0], np.nan, dtype=np.float32)
    if points.shape[0] == 0:
        return out
    xi = np.floor(points[:, 0].astype(np.float64) + 0.5)
    yi = np.floor(points[:, 1].astype(np.float64) + 0.5)
    inside = (xi >= 0) & (xi < w) & (yi >= 0) & (yi < h)
    out[inside] = disparity[yi[inside].astype(np.intp), xi[inside].astype(np.intp)]
    out[~np.isfinite(out)] = np.nan
    return out


def _label(t: float) -> str:
    return f"{t:g}"


# --------------------------------------------------------------------------------------
# Match scoring
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class MatchScore:
    """Result of :func:`score_matches`.

    Attributes
    ----------
    n_matches : int
        Number of matches given.
    n_scored : int
        Matches whose left point has finite ground truth (inside the image).
    thresholds : tuple of float
        The disparity tolerances, in pixels.
    vertical_tolerance : float or None
        As given; None means "the same as each threshold".
    correct : dict of float to int
        ``t -> number of scored matches with |(xl - xr) - d_gt| <= t`` and
        ``|yl - yr| <= vertical tolerance``.
    precision : dict of float to float
        ``t -> correct[t] / n_scored``; NaN when nothing was scored.
    recall : dict of float to float, or None
        ``t -> correct[t] / matchable[t]`` (NaN when nothing is matchable); None unless
        both keypoint sets were given.
    matchable : dict of float to int, or None
        ``t -> number of left keypoints with ground truth whose true correspondent
        ``(xl - d_gt, yl)`` has a right keypoint within ``t`` in x and the vertical
        tolerance in y``; None unless both keypoint sets were given.
    errors : (n_scored,) float32 ndarray
        Signed disparity errors ``(xl - xr) - d_gt`` of the scored matches, in match order.
    scored : (n_matches,) bool ndarray
        Which matches were scored.
    """

    n_matches: int
    n_scored: int
    thresholds: tuple
    vertical_tolerance: float | None
    correct: dict
    precision: dict
    recall: dict | None
    matchable: dict | None
    errors: np.ndarray
    scored: np.ndarray

    def as_dict(self) -> dict:
        """One flat row for a table (e.g. ``pandas.DataFrame([s.as_dict() for s in ...])``).

        Keys: ``n_matches``, ``n_scored``, ``mean_abs_error``, ``median_abs_error`` (NaN
        when nothing was scored), then per threshold ``t``: ``correct@t``,
        ``precision@t`` and, when known, ``matchable@t`` and ``recall@t``.
        """
        abs_err = np.abs(self.errors)
        row = {
            "n_matches": self.n_matches,
            "n_scored": self.n_scored,
            "mean_abs_error": float(abs_err.mean()) if abs_err.size else math.nan,
            "median_abs_error": float(np.median(abs_err)) if abs_err.size else math.nan,
        }
        for t in self.thresholds:
            row[f"correct@{_label(t)}"] = self.correct[t]
            row[f"precision@{_label(t)}"] = self.precision[t]
            if self.matchable is not None:
                row[f"matchable@{_label(t)}"] = self.matchable[t]
                row[f"recall@{_label(t)}"] = self.recall[t]
        return row

    def __repr__(self) -> str:
        prec = ", ".join(f"{_label(t)}: {p:.3f}" for t, p in self.precision.items())
        rec = ""
        if self.recall is not None:
            rec = ", recall={" + ", ".join(
                f"{_label(t)}: {r:.3f}" for t, r in self.recall.items()
            ) + "}"
        return (
            f"MatchScore(n_matches={self.n_matches}, n_scored={self.n_scored}, "
            f"precision={{{prec}}}{rec})"
        )


def _count_matchable(
    left_kp: np.ndarray,
    right_kp: np.ndarray,
    disparity: np.ndarray,
    thresholds: tuple[float, ...],
    vertical_tolerance: float | None,
) -> dict:
    """For each t: left keypoints whose true correspondent has a right keypoint in the box
    |dx| <= t, |dy| <= (vertical_tolerance or t)."""
    d = _gt_at(left_kp, disparity)
    has_gt = np.isfinite(d)
    if not has_gt.any() or right_kp.shape[0] == 0:
        return {t: 0 for t in thresholds}
    target = np.column_stack([left_kp[has_gt, 0] - d[has_gt],
                              left_kp[has_gt, 1]]).astype(np.float64)
    right = right_kp.astype(np.float64)
    radius = max(max(thresholds), vertical_tolerance or 0.0)
    # All (target, right) pairs within the Chebyshev radius, as arrays: the box test below
    # then needs no Python loop.
    pairs = cKDTree(target).sparse_distance_matrix(
        cKDTree(right), radius * (1 + 1e-9), p=np.inf, output_type="ndarray"
    )
    i, j = pairs["i"], pairs["j"]
    dx = np.abs(target[i, 0] - right[j, 0])
    dy = np.abs(target[i, 1] - right[j, 1])
    out = {}
    for t in thresholds:  # a loop over thresholds, not over points
        vt = t if vertical_tolerance is None else vertical_tolerance
        ok = (dx <= t) & (dy <= vt)
        out[t] = int(np.unique(i[ok]).size)
    return out


def score_matches(
    left_pts,
    right_pts,
    disparity_gt,
    thresholds=(0.5, 1.0, 2.0),
    vertical_tolerance=None,
    right_keypoints=None,
    left_keypoints=None,
) -> MatchScore:
    """Score sparse matches on a rectified pair against ground-truth disparity.

    Match ``k`` pairs ``left_pts[k]`` with ``right_pts[k]``. Its ground truth ``d_gt`` is
    read at the nearest pixel of the left point (``floor(x + 0.5)``, ``floor(y + 0.5)``).
    It is *scored* when that value is finite (points outside the image or on unknown
    pixels are not scored), and *correct at t* when
    ``|(xl - xr) - d_gt| <= t`` and ``|yl - yr| <= vertical_tolerance`` (or ``<= t`` when
    ``vertical_tolerance`` is None).

    Parameters
    ----------
    left_pts, right_pts : (N, 2) float32 array_like or sequence of cv2.KeyPoint
        Matched points, ``(x, y)``, row ``k`` of each forming match ``k``.
    disparity_gt : (H, W) ndarray
        Ground-truth disparity of the left image in pixels; NaN or inf = unknown. To score
        only non-occluded pixels, set the others to NaN first.
    thresholds : sequence of float
        Disparity tolerances ``t`` in pixels (each > 0).
    vertical_tolerance : float, optional
        Allowed ``|yl - yr|`` in pixels (>= 0); default: the same as each ``t``.
    right_keypoints, left_keypoints : (M, 2) float32 array_like or cv2.KeyPoint sequence, optional
        All points the matcher could choose from. When both are given, ``matchable`` and
        ``recall`` are computed: a left keypoint with ground truth is matchable at ``t``
        when a right keypoint lies within ``t`` in x and the vertical tolerance in y of
        its true correspondent ``(xl - d_gt, yl)``. For recall to be meaningful the
        matches should be drawn from these keypoints.

    Returns
    -------
    score : MatchScore
        Counts, ``precision`` and ``recall`` per threshold, and the signed errors.
        With no match, counts are 0, precision NaN and the arrays empty.

    Raises
    ------
    InvalidArgumentError, InvalidTypeError
        Wrong shapes (the message gives expected and actual), unequal numbers of left and
        right points, non-finite coordinates, non-positive thresholds, only one of the
        keypoint sets, or with them a tolerance beyond :data:`MAX_RECALL_TOLERANCE`.

    Examples
    --------
    >>> import numpy as np
    >>> gt = np.full((10, 20), 4.0, np.float32); gt[:, :5] = np.nan
    >>> left = np.array([[10, 2], [12, 5], [3, 3]], np.float32)
    >>> right = np.array([[6, 2], [6.5, 5], [0, 3]], np.float32)
    >>> s = score_matches(left, right, gt, thresholds=(1.0, 2.0))
    >>> s.n_scored, s.correct, s.precision
    (2, {1.0: 1, 2.0: 2}, {1.0: 0.5, 2.0: 1.0})
    >>> s.errors
    array([0. , 1.5], dtype=float32)
    """
    left = as_points(left_pts, "left_pts")
    right = as_points(right_pts, "right_pts")
    if left.shape[0] != right.shape[0]:
        raise InvalidArgumentError(
            f"`left_pts` and `right_pts` must have the same number of rows (one per "
            f"match), got {left.shape[0]} and {right.shape[0]}"
        )
    disparity = _as_disparity(disparity_gt)
    ts = _thresholds(thresholds)
    vt = (None if vertical_tolerance is None
          else as_real(vertical_tolerance, "vertical_tolerance", lo=0.0))
    if (right_keypoints is None) != (left_keypoints is None):
        raise InvalidArgumentError(
            "recall needs both `left_keypoints` and `right_keypoints`; got only "
            + ("`right_keypoints`" if left_keypoints is None else "`left_keypoints`")
        )

    d = _gt_at(left, disparity)
    scored = np.isfinite(d)
    n_scored = int(scored.sum())
    errors = ((left[scored, 0] - right[scored, 0]) - d[scored]).astype(np.float32)
    dy = np.abs(left[scored, 1] - right[scored, 1])
    abs_err = np.abs(errors)

    correct, precision = {}, {}
    for t in ts:  # a loop over thresholds, not over points
        vtol = t if vt is None else vt  # as float64: a threshold beyond float32 is not cast
        c = int(np.count_nonzero((abs_err <= np.float64(t)) & (dy <= np.float64(vtol))))
        correct[t] = c
        precision[t] = c / n_scored if n_scored else math.nan

    recall = matchable = None
    if right_keypoints is not None:
        widest = max(max(ts), vt or 0.0)
        if widest > MAX_RECALL_TOLERANCE:
            raise InvalidArgumentError(
                f"recall (with `left_keypoints` and `right_keypoints`) counts the keypoint "
                f"pairs within the tolerance, so it takes tolerances of at most "
                f"{MAX_RECALL_TOLERANCE:g} px; got {widest:g} (`thresholds` or "
                "`vertical_tolerance`); precision alone takes any", argument="thresholds")
        lk = as_points(left_keypoints, "left_keypoints")
        rk = as_points(right_keypoints, "right_keypoints")
        matchable = _count_matchable(lk, rk, disparity, ts, vt)
        recall = {t: (correct[t] / matchable[t] if matchable[t] else math.nan) for t in ts}

    return MatchScore(
        n_matches=int(left.shape[0]),
        n_scored=n_scored,
        thresholds=ts,
        vertical_tolerance=vt,
        correct=correct,
        precision=precision,
        recall=recall,
        matchable=matchable,
        errors=np.ascontiguousarray(errors),
        scored=scored,
    )


def correct_matches(score: MatchScore, left_pts, right_pts, tolerance: float = 1.0):
    """Which matches are correct at ``tolerance`` px: the per-match form of
    ``score.correct[tolerance]``.

    Parameters
    ----------
    score : MatchScore
        What :func:`score_matches` returned for these matches.
    left_pts, right_pts : (N, 2) float32 array_like or sequence of cv2.KeyPoint
        The matched points given to :func:`score_matches`.
    tolerance : float
        Disparity tolerance ``t`` in pixels (> 0). The vertical tolerance is the score's
        ``vertical_tolerance``, or ``t`` when that is None, as in :func:`score_matches`.

    Returns
    -------
    correct : (N,) bool ndarray
        Scored, with ``|(xl - xr) - d_gt| <= t`` and ``|yl - yr|`` within the vertical
        tolerance; ``correct.sum() == score.correct[t]`` when ``t`` is one of the score's
        thresholds.
    known : (N,) bool ndarray
        The matches that have ground truth (``score.scored``).

    Examples
    --------
    >>> import numpy as np
    >>> gt = np.full((10, 20), 4.0, np.float32); gt[:, :5] = np.nan
    >>> left = np.array([[10, 2], [12, 5], [3, 3]], np.float32)
    >>> right = np.array([[6, 2], [6.5, 5], [0, 3]], np.float32)
    >>> s = score_matches(left, right, gt, thresholds=(1.0,))
    >>> correct, known = correct_matches(s, left, right, 1.0)
    >>> correct.tolist(), known.tolist()
    ([True, False, False], [True, True, False])
    """
    if not isinstance(score, MatchScore):
        raise InvalidTypeError(
            f"`score` must be the MatchScore of score_matches, got {describe(score)}",
            argument="score")
    left = as_points(left_pts, "left_pts")
    right = as_points(right_pts, "right_pts")
    if not left.shape[0] == right.shape[0] == score.n_matches:
        raise InvalidArgumentError(
            f"`left_pts` and `right_pts` must hold the {score.n_matches} matches that were "
            f"scored, got {left.shape[0]} and {right.shape[0]} points", argument="left_pts")
    tol = as_real(tolerance, "tolerance", lo=0.0, lo_open=True)
    vtol = tol if score.vertical_tolerance is None else score.vertical_tolerance
    known = np.asarray(score.scored, dtype=bool)
    correct = np.zeros(len(known), dtype=bool)
    idx = np.flatnonzero(known)
    dy = np.abs(left[idx, 1] - right[idx, 1])
    correct[idx] = (np.abs(score.errors) <= tol) & (dy <= vtol)
    return correct, known


# --------------------------------------------------------------------------------------
# Other metrics
# --------------------------------------------------------------------------------------


def error_histogram(errors, bins=(0.0, 0.5, 1.0, 2.0, 4.0, np.inf), absolute: bool = True):
    """Histogram of disparity errors (e.g. ``MatchScore.errors``).

    Parameters
    ----------
    errors : (N,) array_like
        Disparity errors in pixels; must be finite.
    bins : int or (B + 1,) array_like
        Bin edges, increasing (the last may be ``np.inf``), or a number of equal bins over
        ``[0, max]`` (``[min, max]`` when ``absolute`` is False).
    absolute : bool
        Histogram ``|errors|`` (default) or the signed errors.

    Returns
    -------
    counts : (B,) int64 ndarray
    edges : (B + 1,) float64 ndarray
        As :func:`numpy.histogram`: bins are half-open ``[a, b)`` except the last.

    Examples
    --------
    >>> counts, edges = error_histogram([0.1, -0.7, 1.5, 3.0], bins=[0, 1, 2, np.inf])
    >>> counts.tolist(), edges.tolist()
    ([2, 1, 1], [0.0, 1.0, 2.0, inf])
    """
    try:
        err = np.asarray(errors, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidTypeError(
            f"`errors` must be a 1-D array of numbers, got {describe(errors)}"
        ) from None
    if err.ndim != 1:
        raise InvalidArgumentError(f"`errors` must be 1-dimensional (N,), got shape {err.shape}")
    if not np.isfinite(err).all():
        raise InvalidArgumentError("`errors` contains NaN or infinite values; drop them first")
    if absolute:
        err = np.abs(err)
    if isinstance(bins, numbers.Integral) and not isinstance(bins, bool):
        if bins < 1:
            raise InvalidArgumentError(f"`bins` must be >= 1 when a count, got {bins}")
        if err.size:
            lo, hi = (0.0 if absolute else float(err.min())), float(err.max())
        else:
            lo, hi = 0.0, 1.0
        edges = np.linspace(lo, hi if hi > lo else lo + 1.0, int(bins) + 1)
    else:
        try:
            edges = np.asarray(bins, dtype=np.float64)
        except (TypeError, ValueError):
            raise InvalidTypeError(
                f"`bins` must be an int or a sequence of edges, got {describe(bins)}"
            ) from None
        if (edges.ndim != 1 or edges.size < 2 or np.isnan(edges).any()
                or (np.diff(edges) <= 0).any()):
            raise InvalidArgumentError(
                f"`bins` must be at least two strictly increasing edges, got {edges.tolist()}"
            )
    counts, edges = np.histogram(err, bins=edges)
    return counts.astype(np.int64), edges.astype(np.float64)


def repeatability(left_pts, right_pts, disparity_gt, tolerance: float = 1.0):
    """Fraction of left points whose true correspondent was also detected in the right image.

    For each left point with ground truth ``d_gt`` (nearest pixel, as in
    :func:`score_matches`), its true correspondent is ``(xl - d_gt, yl)``; it is
    *repeated* when some right point lies within ``tolerance`` pixels of it (Euclidean).

    Parameters
    ----------
    left_pts : (N, 2) float32 array_like or sequence of cv2.KeyPoint
        Points detected in the left image, ``(x, y)``.
    right_pts : (M, 2) float32 array_like or sequence of cv2.KeyPoint
        Points detected in the right image, ``(x, y)``.
    disparity_gt : (H, W) ndarray
        Ground-truth disparity of the left image; NaN or inf = unknown.
    tolerance : float
        Radius in pixels (>= 0).

    Returns
    -------
    fraction : float
        ``n_repeated / n_with_gt``; NaN when no left point has ground truth.
    n_with_gt : int
        Left points with finite ground truth.
    n_repeated : int
        Of those, how many are repeated.

    Examples
    --------
    >>> import numpy as np
    >>> gt = np.full((10, 20), 3.0, np.float32)
    >>> left = np.array([[10, 4], [15, 6]], np.float32)
    >>> right = np.array([[7.5, 4], [2, 2]], np.float32)
    >>> repeatability(left, right, gt, tolerance=1.0)
    (0.5, 2, 1)
    """
    left = as_points(left_pts, "left_pts")
    right = as_points(right_pts, "right_pts")
    disparity = _as_disparity(disparity_gt)
    tol = as_real(tolerance, "tolerance", lo=0.0)
    d = _gt_at(left, disparity)
    has_gt = np.isfinite(d)
    n_gt = int(has_gt.sum())
    if n_gt == 0:
        return math.nan, 0, 0
    if right.shape[0] == 0:
        return 0.0, n_gt, 0
    target = np.column_stack([left[has_gt, 0] - d[has_gt], left[has_gt, 1]]).astype(np.float64)
    dist, _ = cKDTree(right.astype(np.float64)).query(target, k=1)
    n_rep = int(np.count_nonzero(dist <= tol))
    return n_rep / n_gt, n_gt, n_rep
