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
  disparity (and median ``yl - yr``: :data:`VERTICAL_SUPPORT`) is within
  :data:`SUPPORT_TOLERANCE` px of the added match's, and
* where the first run estimated the pair's geometry (an unrectified pair), the match lies
  within :data:`EPIPOLAR_TOLERANCE` px of its epipolar lines.

The first run's matches are the judge: a second run that fails (grey levels under JPEG and
a gain change, docs/parameters.md "Points on both feature images") adds little. The two
runs run at once on two threads when the call has two or more.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial import cKDTree

from .._threads import run_both
from .._warnings import deferred_warnings, warn
from ..errors import BudgetExceededError, BudgetExceededWarning
from .geometry import symmetric_epipolar_error
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
#: The support test also holds for the vertical offsets ``yl - yr``: the median of the
#: supporting matches' within :data:`SUPPORT_TOLERANCE` px of the added match's. On a
#: rectified pair both runs keep near one offset; on an unrectified pair (each run has
#: estimated its own geometry) it is the second dimension of the displacement.
VERTICAL_SUPPORT = True
#: On a pair whose geometry the first run estimated (``rectified=False``; each run
#: estimates its own), an added match must lie within this many px (the mean of its two
#: point-to-line distances) of the first run's epipolar lines.
EPIPOLAR_TOLERANCE = 0.5
#: :func:`neighbour_medians` finds the pairs of this many points at a time (about 80
#: bytes per pair; a 2964 x 2000 textured pair's 291k added candidates have millions).
MEDIAN_BLOCK = 65_536
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


def points_of_both(first: np.ndarray, second: np.ndarray) -> np.ndarray:
    """The (x, y) points of both feature images: every one of ``first`` (the first run's),
    then those of ``second`` farther than :data:`SEPARATION` px from every one of them."""
    return np.concatenate((first, second[far_from(second, first, SEPARATION)]))


def neighbour_medians(points: np.ndarray, others: np.ndarray, values: np.ndarray,
                      radius: float) -> tuple[np.ndarray, np.ndarray]:
    """``(count, median)``: how many of ``others`` lie within ``radius`` of each of
    ``points`` (distance <= radius), (N,), and the median of their ``values`` (NaN where
    none): (N,) for (M,) ``values``, (N, k) for (M, k), one median per column, from one
    search of the pairs within reach. For every point at once: per column, the pairs are
    sorted by point, then by value, in one sort of ``point * span + value``, for
    :data:`MEDIAN_BLOCK` points at a time (a block's pairs held at once)."""
    values = np.asarray(values, dtype=np.float64)
    n = len(points)
    count = np.zeros(n, dtype=np.int64)
    median = np.full((n,) + values.shape[1:], np.nan)
    if n == 0 or len(others) == 0:
        return count, median
    tree = cKDTree(others)
    for lo in range(0, n, MEDIAN_BLOCK):  # the pairs of one block of points at a time
        hi = min(n, lo + MEDIAN_BLOCK)
        count[lo:hi], median[lo:hi] = _block_medians(points[lo:hi], tree, values, radius)
    return count, median


def _block_medians(points, tree, values, radius):
    """:func:`neighbour_medians` of ``points`` against the ``cKDTree`` of the others."""
    n = len(points)
    median = np.full((n,) + values.shape[1:], np.nan)
    pairs = cKDTree(points).sparse_distance_matrix(tree, radius, output_type="ndarray")
    rows = pairs["i"].astype(np.intp)
    count = np.bincount(rows, minlength=n)
    has = count > 0
    start = np.concatenate(([0], np.cumsum(count)[:-1]))[has]
    lo, hi = start + (count[has] - 1) // 2, start + count[has] // 2
    grouped = np.repeat(np.arange(n, dtype=np.float64), count)  # rows, sorted
    columns = values.reshape(len(values), -1)[pairs["j"].astype(np.intp)]
    out = median.reshape(n, -1)
    for c in range(columns.shape[1]):
        vals = columns[:, c]
        if len(vals) == 0:
            continue
        low = vals.min()
        span = vals.max() - low + 1.0
        key = np.sort(rows * span + (vals - low))  # by row, then by value
        ordered = key - grouped * span + low
        out[has, c] = 0.5 * (ordered[lo] + ordered[hi])
    return count, median


def supported(points: np.ndarray, displacements: np.ndarray, others: np.ndarray,
              other_displacements: np.ndarray) -> np.ndarray:
    """(N,) bool: which matches (left ``points``, ``displacements``: (N,) disparities, or
    (N, k) columns such as disparity and ``yl - yr``) the matches ``others`` (left points,
    ``other_displacements`` alike) support: at least :data:`MIN_SUPPORT` of them within
    :data:`SUPPORT_RADIUS` px, whose median of each column lies within
    :data:`SUPPORT_TOLERANCE` px of the match's; all of them when :data:`MIN_SUPPORT` is
    0."""
    if MIN_SUPPORT <= 0 or len(points) == 0:
        return np.full(len(points), MIN_SUPPORT <= 0)
    count, median = neighbour_medians(points, others, other_displacements, SUPPORT_RADIUS)
    own = np.asarray(displacements, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        agree = (np.abs(median - own) <= SUPPORT_TOLERANCE).reshape(len(own), -1).all(axis=1)
    return (count >= MIN_SUPPORT) & agree


def displacements(result: StereoMatchResult) -> np.ndarray:
    """What the support test compares of each match of ``result``: (M,) disparities, or
    with :data:`VERTICAL_SUPPORT` (M, 2) disparities and vertical offsets ``yl - yr``."""
    d = np.asarray(result.disparities, dtype=np.float64)
    if not VERTICAL_SUPPORT:
        return d
    dy = (result.matched_left[:, 1].astype(np.float64)
          - result.matched_right[:, 1].astype(np.float64))
    return np.column_stack([d, dy])


def added_matches(first: StereoMatchResult, second: StereoMatchResult) -> np.ndarray:
    """(M2,) bool: which of ``second``'s matches are added to ``first``'s (the module's
    tests: far from the first's matches, supported by them, on disparity and, with
    :data:`VERTICAL_SUPPORT`, ``yl - yr`` too; when the first run estimated the pair's
    geometry, within :data:`EPIPOLAR_TOLERANCE` of its epipolar lines). The support is
    measured for the far matches only."""
    keep = far_from(second.matched_left, first.matched_left, SEPARATION)
    far = np.flatnonzero(keep)
    keep[far] = supported(second.matched_left[far], displacements(second)[far],
                          first.matched_left, displacements(first))
    if first.geometry is not None and first.fundamental_matrix is not None and keep.any():
        keep &= symmetric_epipolar_error(first.fundamental_matrix, second.matched_left,
                                         second.matched_right) <= EPIPOLAR_TOLERANCE
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


def match_both_features(run, call: dict, detector, matcher,
                        threads: int = 1) -> StereoMatchResult:
    """What ``match_stereo(..., both_features=True)`` returns: ``run(**keywords)`` (that
    ``match_stereo`` on the same pair) with ``call``'s keywords and ``both_features`` off,
    then again with the detector on the other feature image, merged (:func:`merge_results`
    of :func:`added_matches`). ``detector`` is the detector the first run uses (``call``'s,
    or one made of its parameters); ``matcher`` ``call``'s instance or None, cloned, never
    changed. With ``threads`` >= 2 the two runs run at once and share the threads, the
    first run ``threads // 2`` of them and the second the rest (one each on two cores);
    each run's result is the same for any thread count, so the merge is too. The second run's
    warnings are not given: the first run has said what there is to say about the pair. A
    second run over the candidate budget (:class:`~hopmatch.errors.BudgetExceededError`) is
    left out: the first run is returned, with a
    :class:`~hopmatch.errors.BudgetExceededWarning`."""
    first_call = dict(call)
    if matcher is not None:
        first_matcher = matcher.clone(emptyTrainData=True)
        first_matcher.setBothFeatures(False)
        first_call["matcher"] = first_matcher
    else:
        first_call["both_features"] = False
    second_call = dict(first_call)
    if threads >= 2:  # an odd thread to the second run (the defaults': the longer)
        first_call["threads"] = threads // 2
        second_call["threads"] = threads - threads // 2
    other = other_feature(detector.get_params()["on"])
    if call.get("detector") is not None:
        second_call["detector"] = type(detector)(**{**detector.get_params(), "on": other})
    else:
        second_call["on"] = other

    def second_run():
        try:
            with deferred_warnings():
                return run(**second_call)
        except BudgetExceededError as error:
            return error

    first, second = run_both(lambda: run(**first_call), second_run, threads)
    if isinstance(second, BudgetExceededError):
        warn(f"both_features: the second run, on the {other} image, was left out: {second}; "
             "the matches are the first run's", BudgetExceededWarning)
        return first
    return merge_results(first, second, added_matches(first, second))
