"""SPEC section 4: disambiguation of the converged network and the left-right check."""

from __future__ import annotations

import numpy as np

from .vertical import fit_row_offset


def singular_choice(group: np.ndarray, dy: np.ndarray, score: np.ndarray,
                    threshold: float) -> np.ndarray:
    """One direction of section 4: which active pairs each group (left or right point) keeps.

    A group with one active pair is *singular* and keeps it. ``Ybar`` is the mean vertical
    disparity ``dy`` of the singular pairs (0 if there are none). Repeatedly, every
    *multiple* group whose pair closest to ``Ybar`` (ties: the higher ``score``) lies within
    ``threshold`` of it keeps that pair and joins the singular class, and ``Ybar`` is
    updated; this stops when no multiple group joins.

    Parameters
    ----------
    group : (A,) int ndarray
        The group (point index) of each active pair.
    dy : (A,) float ndarray
        Vertical disparity ``y_left - y_right`` of each active pair.
    score : (A,) float ndarray
        Tie-breaker: the network's evidence for each pair.
    threshold : float
        The vertical-disparity tolerance.

    Returns
    -------
    (A,) bool ndarray
        True for the pair each group keeps.

    Examples
    --------
    >>> import numpy as np
    >>> keep = singular_choice(np.array([0, 1, 1]), np.array([0.0, 0.2, 3.0]),
    ...                        np.zeros(3), threshold=1.0)
    >>> keep.tolist()
    [True, True, False]
    """
    a = len(group)
    keep = np.zeros(a, dtype=bool)
    if a == 0:
        return keep
    counts = np.bincount(group)
    singular = counts[group] == 1
    keep[singular] = True
    pending = ~singular
    total, count = float(dy[singular].sum()), int(singular.sum())
    while pending.any():
        ybar = total / count if count else 0.0
        idx = np.flatnonzero(pending)
        off = np.abs(dy[idx] - ybar)
        # per group: the pair closest to ybar, ties broken by the larger score
        order = np.lexsort((-score[idx], off, group[idx]))
        first = np.ones(len(order), dtype=bool)
        first[1:] = group[idx][order][1:] != group[idx][order][:-1]
        best = idx[order[first]]
        accept = best[np.abs(dy[best] - ybar) < threshold]
        if len(accept) == 0:
            break
        keep[accept] = True
        pending[np.isin(group, group[accept])] = False
        total += float(dy[accept].sum())
        count += len(accept)
    return keep


def disambiguate(ni: np.ndarray, nk: np.ndarray, active: np.ndarray, dy: np.ndarray,
                 score: np.ndarray, threshold: float) -> np.ndarray:
    """Section 4 in both directions: indices of the active neurons that are singular both
    from left to right (columns) and from right to left (rows), i.e. the pairs that pass
    the left-right check.

    Parameters
    ----------
    ni, nk : (N,) int ndarrays
        Left and right point of each neuron.
    active : (N,) bool ndarray
        Converged state.
    dy : (N,) float ndarray
        Vertical disparity of each neuron.
    score : (N,) float ndarray
        Evidence of each neuron (tie-breaker).
    threshold : float
        Vertical-disparity tolerance of the disambiguation.

    Returns
    -------
    (M,) int64 ndarray
        Neuron indices, increasing.
    """
    act = np.flatnonzero(active)
    from_left = singular_choice(ni[act], dy[act], score[act], threshold)
    from_right = singular_choice(nk[act], dy[act], score[act], threshold)
    return act[from_left & from_right]


def vertically_consistent(dy: np.ndarray, threshold: float, points=None) -> np.ndarray:
    """Section 4's vertical test applied to every kept pair (``vertical_check="all"``).

    Section 4 compares only the *multiple* pairs with the mean vertical disparity ``Ybar``
    and keeps every singular pair whatever its vertical disparity. On a rectified pair (or
    along epipolar lines) all correct matches share one vertical disparity, so a singular
    pair far from it breaks the same epipolar constraint: with a search band wider than
    the tolerance these are mostly look-alikes of repetitive texture (a chessboard corner
    matched to another corner a few rows off; docs/parameters.md). This keeps a pair iff
    ``|dy - Ybar| < threshold``, with ``Ybar`` the *median* vertical disparity of the pairs
    (robust to the outliers it is meant to find; the mean is pulled towards them).

    Parameters
    ----------
    dy : (M,) float ndarray
        Vertical disparity of each kept pair (``y_left - y_right``, or the signed distance
        to the epipolar line).
    threshold : float
        The vertical-disparity tolerance (``vertical_threshold``).
    points : (M, 2) ndarray, optional
        The left point of each pair. When given, ``Ybar`` is not one number but the robust
        plane ``a + b x + c y`` through the pairs' ``dy``
        (:func:`~hopmatch.matching.vertical.fit_row_offset`, ``vertical_model="plane"``):
        a rectification that leaves a small rotation or scale makes the vertical
        disparity vary across the image, and a single median then rejects correct pairs
        at the sides. With fewer pairs than the plane needs, the median is used.

    Returns
    -------
    (M,) bool ndarray
        True for the pairs within ``threshold`` of the median (or plane); a pair with a
        non-finite ``dy`` is never within it.

    Examples
    --------
    >>> import numpy as np
    >>> vertically_consistent(np.array([0.1, -0.2, 0.0, 3.0, 0.4]), 1.0).tolist()
    [True, True, True, False, True]
    """
    dy = np.asarray(dy, dtype=np.float64)
    if len(dy) == 0:
        return np.zeros(0, dtype=bool)
    if points is not None:
        return np.abs(dy - fit_row_offset(points, dy).at(points)) < threshold
    return np.abs(dy - np.median(dy)) < threshold
