"""Matches on both feature images (``match_stereo(..., both_features=True)``; method.md 4.11).

Moravec points on the gradient magnitude (the paper's, the detector's default) and on grey
levels (``on="intensity"``) are largely different points. With ``both_features`` the pair
is matched twice, once on each feature image, each run with its own network, guided pass
and refinement; the second run's matches are added to the first's where the first has not
matched that place and agrees with them:

* their left point lies more than :data:`SEPARATION` px from every left point the first
  run matched (no second match of one place), and
* the first run supports them (:func:`supported`): at least :data:`MIN_SUPPORT` of its
  matches lie within :data:`SUPPORT_RADIUS` px of the left point, and their median
  disparity is within :data:`SUPPORT_TOLERANCE` px of the added match's. The first run's
  matches are the judge: a second run that fails (grey levels under JPEG and a gain
  change, docs/parameters.md "Points on both feature images") adds little.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial import cKDTree

from .._warnings import deferred_warnings, warn
from ..errors import BudgetExceededError, BudgetExceededWarning
from .stereo_result import PASS_GUIDED, StereoMatchResult

#: A second-run match is added only when its left point lies farther than this (px) from
#: every left point the first run matched.
SEPARATION = 1.5
#: The first run's matches within this distance (px) of a second-run match's left point
#: are its support ...
SUPPORT_RADIUS = 12.0
#: ... of which there must be at least this many (0: no support test) ...
MIN_SUPPORT = 3
#: ... whose median disparity must lie within this many px of its own.
SUPPORT_TOLERANCE = 1.0
#: ``result.passes`` of a second-run match: this plus its pass in that run (2: its
#: network, 3: its guided pass).
SECOND_RUN_PASSES = PASS_GUIDED + 1


def other_feature(on: str) -> str:
    """The feature image the second run detects on: grey levels for the gradient, and the
    gradient for grey levels."""
    return "gradient" if on == "intensity" else "intensity"


def far_from(points: np.ndarray, others: np.ndarray, separation: float) -> np.ndarray:
    """(N,) bool: which (x, y) ``points`` lie farther than ``separation`` from every one of
    ``others``."""
    if len(points) == 0 or len(others) == 0:
        return np.ones(len(points), dtype=bool)
    nearest, _ = cKDTree(others).query(points, k=1)
    return nearest > separation


def neighbour_medians(points: np.ndarray, others: np.ndarray, values: np.ndarray,
                      radius: float) -> tuple[np.ndarray, np.ndarray]:
    """``(count, median)``, each (N,): how many of ``others`` lie within ``radius`` of each
    of ``points`` (distance <= radius) and the median of their ``values`` (NaN where none),
    for every point at once (the pairs sorted by point, then by value)."""
    n = len(points)
    count = np.zeros(n, dtype=np.int64)
    median = np.full(n, np.nan)
    if n == 0 or len(others) == 0:
        return count, median
    pairs = cKDTree(points).sparse_distance_matrix(cKDTree(others), radius,
                                                   output_type="ndarray")
    rows, cols = pairs["i"].astype(np.intp), pairs["j"].astype(np.intp)
    vals = np.asarray(values, dtype=np.float64)[cols]
    order = np.lexsort((vals, rows))
    rows, vals = rows[order], vals[order]
    count = np.bincount(rows, minlength=n)
    start = np.concatenate(([0], np.cumsum(count)[:-1]))
    has = count > 0
    lo = start[has] + (count[has] - 1) // 2
    hi = start[has] + count[has] // 2
    median[has] = 0.5 * (vals[lo] + vals[hi])
    return count, median


def supported(points: np.ndarray, disparities: np.ndarray, others: np.ndarray,
              other_disparities: np.ndarray) -> np.ndarray:
    """(N,) bool: which matches (left ``points``, ``disparities``) the matches ``others``
    (left points, ``other_disparities``) support: at least :data:`MIN_SUPPORT` of them
    within :data:`SUPPORT_RADIUS` px, whose median disparity lies within
    :data:`SUPPORT_TOLERANCE` px of the match's; all of them when :data:`MIN_SUPPORT` is
    0."""
    if MIN_SUPPORT <= 0:
        return np.ones(len(points), dtype=bool)
    count, median = neighbour_medians(points, others, other_disparities, SUPPORT_RADIUS)
    with np.errstate(invalid="ignore"):
        agree = np.abs(median - np.asarray(disparities, dtype=np.float64)) <= SUPPORT_TOLERANCE
    return (count >= MIN_SUPPORT) & agree


def added_matches(first: StereoMatchResult, second: StereoMatchResult) -> np.ndarray:
    """(M2,) bool: which of ``second``'s matches are added to ``first``'s (the module's
    two tests)."""
    keep = far_from(second.matched_left, first.matched_left, SEPARATION)
    keep &= supported(second.matched_left, second.disparities, first.matched_left,
                      first.disparities)
    return keep


def merge_results(first: StereoMatchResult, second: StereoMatchResult,
                  keep: np.ndarray) -> StereoMatchResult:
    """``first`` with the matches of ``second`` where ``keep`` (bool, one per match of
    ``second``) appended.

    The arrays keep :class:`StereoMatchResult`'s layout: ``points_left`` is the first
    run's left points, then the second's; ``points_right`` the first run's detected right
    points, the second's, then the first run's guided right points and the second's, so
    that ``n_detected_right`` rows come first and ``first.network``'s indices stay valid.
    ``passes`` of the added matches are :data:`SECOND_RUN_PASSES` plus their pass;
    ``refinement`` (when both runs refined) is concatenated alike; ``guided``,
    ``network``, ``row_offset`` and the geometry stay the first run's, and the second run
    is ``result.second``.
    """
    keep = np.asarray(keep, dtype=bool)
    n1, n2 = first.n_detected_right, second.n_detected_right
    k1 = len(first.points_right) - n1
    right = (first.points_right[:n1], second.points_right[:n2], first.points_right[n1:],
             second.points_right[n2:])
    resp = (first.responses_right[:n1], second.responses_right[:n2],
            first.responses_right[n1:], second.responses_right[n2:])
    t1 = first.train_idx.astype(np.int64)
    t2 = second.train_idx[keep].astype(np.int64)
    train = np.concatenate((np.where(t1 < n1, t1, t1 + n2),
                            np.where(t2 < n2, n1 + t2, n1 + n2 + k1 + (t2 - n2))))
    query = np.concatenate((first.query_idx.astype(np.int64),
                            second.query_idx[keep].astype(np.int64) + len(first.points_left)))
    refinement = None
    if first.refinement is not None and second.refinement is not None:
        refinement = type(first.refinement)(*(np.concatenate((a, b[keep])) for a, b in
                                              zip(first.refinement, second.refinement)))
    return dataclasses.replace(
        first,
        points_left=np.concatenate((first.points_left, second.points_left)),
        responses_left=np.concatenate((first.responses_left, second.responses_left)),
        points_right=np.concatenate(right).astype(np.float32, copy=False),
        responses_right=np.concatenate(resp).astype(np.float32, copy=False),
        query_idx=query.astype(np.int32), train_idx=train.astype(np.int32),
        distances=np.concatenate((first.distances, second.distances[keep])).astype(
            np.float32, copy=False),
        passes=np.concatenate((first.passes, second.passes[keep] + SECOND_RUN_PASSES)
                              ).astype(np.uint8),
        n_detected_right=n1 + n2, refinement=refinement, second=second)


def match_both_features(run, call: dict, detector, matcher) -> StereoMatchResult:
    """What ``match_stereo(..., both_features=True)`` returns: ``run(**keywords)`` (that
    ``match_stereo`` on the same pair) with ``call``'s keywords and ``both_features`` off,
    then again with the detector on the other feature image, merged (:func:`merge_results`
    of :func:`added_matches`). ``detector`` is the detector the first run uses (``call``'s,
    or one made of its parameters); ``matcher`` ``call``'s instance or None, cloned, never
    changed. The second run's warnings are not given: the first run has said what there
    is to say about the pair. A second run over the candidate budget
    (:class:`~hopmatch.errors.BudgetExceededError`) is left out: the first run is returned,
    with a :class:`~hopmatch.errors.BudgetExceededWarning`."""
    first_call = dict(call)
    if matcher is not None:
        first_matcher = matcher.clone(emptyTrainData=True)
        first_matcher.setBothFeatures(False)
        first_call["matcher"] = first_matcher
    else:
        first_call["both_features"] = False
    second_call = dict(first_call)
    other = other_feature(detector.get_params()["on"])
    if call.get("detector") is not None:
        second_call["detector"] = type(detector)(**{**detector.get_params(), "on": other})
    else:
        second_call["on"] = other
    first = run(**first_call)
    try:
        with deferred_warnings():
            second = run(**second_call)
    except BudgetExceededError as error:
        warn(f"both_features: the second run, on the {other} image, was left out: {error}; "
             "the matches are the first run's", BudgetExceededWarning)
        return first
    return merge_results(first, second, added_matches(first, second))
