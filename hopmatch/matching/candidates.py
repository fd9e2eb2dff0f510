"""SPEC section 3: the neurons, candidate pairs in the search window of each left point."""

from __future__ import annotations

import numpy as np

from .._kernels import candidates as _kc
from .._threads import map_ranges
from ..errors import BudgetExceededError
from .similarity import EPS

#: Bounds of the search window in pixels: validated points lie within +-2**20
#: (``MAX_COORDINATE``), so a band or disparity bound beyond +-2**22 holds every pair
#: already; larger ones (``max_vertical=1e19``, beyond int64 once in rows, or 1e39, inf
#: in float32) are clamped to it, which keeps the same pairs.
BAND_LIMIT = float(2**22)


def row_span_limit(n: int) -> int:
    """Largest row span the candidate search counts rows over for n points (beyond it, it
    sorts them: ``_kc.row_order``)."""
    return 4 * n + 1024


def right_band_index(right):
    """What the rectified candidate search (``band_candidates``) needs of the right points:
    the distinct rows ``floor(y)``, each row's offsets in the order below, the points row by
    row with x increasing (ties: index increasing), and the coordinates in that order
    (``_kc.band_index``)."""
    return _kc.band_index(right, row_span_limit(len(right)))


def left_visit_order(left) -> np.ndarray:
    """The order the candidate search visits the left points in: row by row, index order
    within a row (cache-friendly, ``_kc.row_order``)."""
    return _kc.row_order(left, row_span_limit(len(left)))[0]


def candidate_pairs(left, right, min_disparity, max_disparity, max_vertical, max_neurons,
                    fundamental=None, *, sort=True, contrast_gate=None, gain_tolerance=1.0):
    """Neurons: pairs with ``min_disparity <= xl - xr <= max_disparity`` and
    ``|yl - yr| <= max_vertical`` (SPEC section 3's search window), as ``(ni, nk)``.

    With a fundamental matrix, the band is around each left point's epipolar line instead:
    the right point's distance to ``F (xl, yl, 1)`` is at most ``max_vertical``.
    Raises :class:`BudgetExceededError` before allocating more than ``max_neurons``.

    The pairs are sorted by (i, k); with ``sort=False`` they are only grouped by left point
    (in the order the search visited them): sort what is left after gating with
    ``_kc.group_by_left`` (which can gate them) then ``_kc.sort_groups``, which is cheaper.

    Bounds beyond :data:`BAND_LIMIT` are clamped to it (the same pairs).

    The rectified search runs on contiguous ranges of the left points' visit order in up
    to :func:`hopmatch._threads.current_threads` threads (:func:`hopmatch._threads.
    map_ranges`): each left point's pairs come from its own search, so the pairs, their
    order and the budget's verdict are those of one call for any thread count.

    ``contrast_gate=(contrasts, gate)`` (rectified search only; ``contrasts`` from
    :func:`window_contrasts`) leaves out the pairs :func:`similarity_distance` would put past
    ``gate`` on their contrasts alone (with the same ``gain_tolerance``); the budget still
    counts them.
    """
    band = tuple(np.float32(min(max(v, -BAND_LIMIT), BAND_LIMIT))
                 for v in (min_disparity, max_disparity, max_vertical))
    budget = np.int64(min(max_neurons, 2**62))
    if fundamental is None:
        index = right_band_index(right)
        if contrast_gate is None:
            scale_l, scale_r, gate = np.zeros(len(left)), np.zeros(len(right)), np.inf
        else:
            (scale_l, scale_r), gate = contrast_gate
            scale_r = scale_r[index[2]]
        visit = left_visit_order(left)
        scale_r = np.ascontiguousarray(scale_r, np.float64)
        # each left point's pairs from its own search, in visit order: the ranges' outputs
        # concatenated are the one call's; their counts add up (each exact while within
        # the budget, so the sum passes it exactly when the band's count does)
        def search(lo, hi, count_only=False):
            return _kc.band_candidates(left, visit[lo:hi], *index, *band, budget, scale_l,
                                       scale_r, float(gate), EPS, float(gain_tolerance),
                                       count_only)

        parts = map_ranges(search, len(visit))
        ni, nk, n = parts[0] if len(parts) == 1 else (
            np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
            sum(int(p[2]) for p in parts))
        if n > max_neurons and len(parts) > 1:
            # the count past the budget is a lower bound that depends on the ranges: the
            # one call's, for an error message that does not depend on the thread count
            # (a refusal costs about max_neurons steps; this one counts, writing nothing)
            n = search(0, len(visit), True)[2]
    else:
        order = np.argsort(right[:, 0], kind="stable")
        ni, nk, n = _kc.epipolar_candidates(
            left, right, order, np.ascontiguousarray(fundamental, dtype=np.float64), *band,
            budget)
    if n > max_neurons:
        raise BudgetExceededError(
            f"the network would have {n} neurons (candidate pairs) or more (counted until "
            f"past the budget), more than max_neurons={max_neurons}; narrow the disparity "
            "range (min_disparity/max_disparity) or max_vertical, use fewer keypoints, or "
            "raise max_neurons", argument="max_neurons"
        )
    if sort:
        ni, nk, _ = _kc.group_by_left(ni, nk, np.empty(len(ni)), len(left), False, 0.0)
        _kc.sort_groups(ni, nk, np.empty(len(ni)))
    return ni, nk


def best_two_look_alikes(ni, nk, sim):
    """The best and second-best right point of each left point among candidate pairs
    ``(ni, nk)`` grouped by left point (as :func:`candidate_pairs` returns them, sorted or
    not) with similarity distances ``sim``: ``(left, best, second)``, one entry per left
    point in increasing ``left``, ``best`` and ``second`` indices into the pairs (``second``
    -1 for a left point with one pair), ranked by distance, ties by right index, NaN last.
    The first two pairs of each left point once the pairs are sorted by (left, distance,
    right), found in one pass over them (``_kc.best_two_per_group``) instead of a sort."""
    left, best, second = _kc.best_two_per_group(ni, nk, np.asarray(sim, dtype=np.float64))
    order = np.argsort(left, kind="stable")
    return left[order], best[order], second[order]


def clear_best_look_alikes(ni, nk, sim, ratio: float):
    """``(left, best)`` of the left points whose best right point (:func:`best_two_look_alikes`)
    is clearly better than their second: distance below ``ratio`` times the second's (a
    left point with one pair has no second and is left out); increasing ``left``, ``best``
    indices into the pairs."""
    left, best, second = best_two_look_alikes(ni, nk, sim)
    two = second >= 0
    left, best, second = left[two], best[two], second[two]
    clear = np.asarray(sim)[best] < ratio * np.asarray(sim)[second]
    return left[clear], best[clear]


def vertical_offsets(left, right, ni, nk, fundamental=None) -> np.ndarray:
    """The "vertical disparity" of each pair used by section 4: ``yl - yr`` on a rectified
    pair, or the signed distance of the right point to the left point's epipolar line."""
    if fundamental is None:
        return left[ni, 1].astype(np.float64) - right[nk, 1]
    f = np.asarray(fundamental, dtype=np.float64)
    hom = np.c_[left[ni].astype(np.float64), np.ones(len(ni))]
    lines = hom @ f.T
    norm = np.hypot(lines[:, 0], lines[:, 1])
    num = lines[:, 0] * right[nk, 0] + lines[:, 1] * right[nk, 1] + lines[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(norm > 0, num / norm, np.inf)




def resolve_max_disparity(max_disparity, query_size, query_pts, train_pts) -> float:
    """``max_disparity``, or when it is None a quarter of the query image's width (or of the
    keypoints' horizontal extent when the image size is unknown)."""
    if max_disparity is not None:
        return float(max_disparity)
    if query_size is not None:
        return 0.25 * query_size[0]
    xs = [pts[:, 0].max() for pts in (query_pts, train_pts) if len(pts)]
    return 0.25 * (float(max(xs)) + 1.0) if xs else 0.0
