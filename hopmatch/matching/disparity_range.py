"""A disparity range that finds itself: when ``max_disparity`` is None, a coarse pass of the
network on a thinned set of left points measures the range the full pass then searches.

The coarse pass is a sparse stand-in for an image pyramid: it needs only the keypoints and
descriptors, so :class:`~hopmatch.HopfieldMatcher` (which never sees the images) and
:func:`~hopmatch.match_stereo` resolve the range the same way. Keeping one left point in
about ``f**2`` (one per grid cell) is what a pyramid level ``f`` times coarser would see, so
every length of SPEC section 3 that measures the neighbourhood grows with it: the neighbour
window (``neighbour_width x neighbour_height``) and the compatibility edge θ (eq. 5) are
multiplied by ``f``. Every right point stays a candidate, so a thinned left point keeps its
true partner. The matches of the coarse pass give the range (trimmed of isolated extremes);
the full pass searches it widened by :data:`RANGE_FACTOR` and :data:`RANGE_MARGIN`
(docs/parameters.md, "Disparity range").
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np

from .._warnings import warn
from ..errors import BudgetExceededError, DisparityRangeWarning
from .candidates import candidate_pairs
from .neighbourhood import scaled_neighbourhood

#: Left points the coarse pass keeps (one per cell of a grid over their bounding box).
COARSE_POINTS = 1500
#: The widest search of the coarse pass, as a fraction of the left image's width (or of the
#: keypoints' horizontal extent): ``[min_disparity or -fraction W, fraction W]``. It is the
#: range hopmatch searched by default before the range found itself.
SEARCH_FRACTION = 0.25
#: The coarse pass must keep at least this many matches for its range to be trusted; with
#: fewer the full pass searches the whole coarse search range (and warns if even that
#: fails).
MIN_MATCHES = 20
#: Extremes of the coarse matches separated from the rest by a gap of more than this
#: fraction of the width (and at most :data:`MAX_TRIMMED` of them) are dropped as outliers.
GAP_FRACTION = 0.02
MAX_TRIMMED = 0.02
#: The found range ``[lo, hi]`` is widened multiplicatively (a nearest or farthest surface
#: the coarse pass missed is at most this factor nearer or farther: ``[lo / RANGE_FACTOR,
#: hi * RANGE_FACTOR]`` for positive disparities) ...
RANGE_FACTOR = 1.5
#: ... and by this fraction of the width plus :data:`RANGE_PIXELS` on both sides.
RANGE_MARGIN = 0.015
RANGE_PIXELS = 2.0


class DisparityRange(NamedTuple):
    """A resolved search range and where it came from.

    ``source`` is ``'given'`` (``max_disparity`` set by the caller), ``'coarse'`` (found by
    the coarse pass from ``n_matches`` matches spanning ``found``), ``'fallback'`` (the
    coarse pass kept too few matches: the whole coarse search range, from 0 when
    ``min_disparity`` is None) or ``'empty'`` (no
    keypoints or descriptors on a side: the coarse search range, nothing to find).
    ``frame``: where the disparities are measured when not along the pair's rows as given
    (words for the warnings; empty: the rows)."""

    min_disparity: float
    max_disparity: float
    source: str
    found: tuple[float, float] | None = None
    n_matches: int = 0
    frame: str = ""


def search_width(query_size, query_pts, train_pts) -> float:
    """The width the default ranges are fractions of: the left image's, or when unknown the
    keypoints' horizontal extent, from the smaller of 0 and their least x to their largest
    (``max x + 1`` for the pixel positions of an image; points at negative x, which the
    matcher takes, widen it), 0 without keypoints."""
    if query_size is not None:
        return float(query_size[0])
    sides = [pts[:, 0] for pts in (query_pts, train_pts) if len(pts)]
    if not sides:
        return 0.0
    low = min(0.0, min(float(x.min()) for x in sides))
    return max(float(x.max()) for x in sides) - low + 1.0


def thin_points(points: np.ndarray, target: int) -> np.ndarray:
    """Indices (increasing) of at most about ``target`` of ``points``, one per cell of a
    square grid over their bounding box (the first point of each cell in index order);
    all indices when there are at most ``target`` points."""
    n = len(points)
    if n <= target:
        return np.arange(n)
    x = points[:, 0].astype(np.float64)
    y = points[:, 1].astype(np.float64)
    cell = np.sqrt((np.ptp(x) + 1.0) * (np.ptp(y) + 1.0) / target)
    cx = np.floor((x - x.min()) / cell).astype(np.int64)
    cy = np.floor((y - y.min()) / cell).astype(np.int64)
    _, first = np.unique(cx * (int(cy.max()) + 1) + cy, return_index=True)
    return np.sort(first)


def trimmed_extent(values: np.ndarray, gap: float,
                   max_trimmed: float = MAX_TRIMMED) -> tuple[float, float]:
    """``(min, max)`` of ``values`` after dropping, at each end, the values cut off from the
    rest by a gap larger than ``gap``, as long as at most ``max_trimmed`` of them go."""
    v = np.sort(np.asarray(values, dtype=np.float64))
    n = len(v)
    limit = int(max_trimmed * n)
    jumps = np.flatnonzero(np.diff(v) > gap)
    lo = [j + 1 for j in jumps if j + 1 <= limit]
    hi = [j for j in jumps if n - 1 - j <= limit]
    a = max(lo) if lo else 0
    b = min(hi) if hi else n - 1
    return float(v[a]), float(v[b])


def widen(lo: float, hi: float, width: float) -> tuple[float, float]:
    """The search range around a found range ``[lo, hi]``: each bound moved outwards by the
    factor :data:`RANGE_FACTOR` (applied to its magnitude, so a negative bound moves left
    too) and by ``RANGE_MARGIN * width + RANGE_PIXELS``."""
    pad = RANGE_MARGIN * width + RANGE_PIXELS
    low = lo / RANGE_FACTOR if lo > 0 else lo * RANGE_FACTOR
    high = hi * RANGE_FACTOR if hi > 0 else hi / RANGE_FACTOR
    return low - pad, high + pad


def coarse_config(config, n_left: int, n_kept: int, min_disparity: float,
                  max_disparity: float):
    """``config`` for the coarse pass over ``n_kept`` of ``n_left`` left points: neighbour
    window and θ scaled by ``f = sqrt(n_left / n_kept)``, the given search range."""
    f = float(np.sqrt(n_left / max(n_kept, 1)))
    return dataclasses.replace(scaled_neighbourhood(config, f),
                               min_disparity=float(min_disparity),
                               max_disparity=float(max_disparity))


def run_on_thinned(run_network, config, q_pts, t_pts, qd, td, keep, bottom: float,
                   top: float, *, mask=None, **kwargs):
    """``run_network`` over ``[bottom, top]`` on the left points ``keep`` (of
    :func:`thin_points`) and every right point, with the neighbourhood of
    :func:`coarse_config`: the result in the indices of the kept points. A
    :class:`~hopmatch.errors.BudgetExceededError` propagates."""
    cfg = coarse_config(config, len(q_pts), len(keep), bottom, top)
    return run_network(np.ascontiguousarray(q_pts[keep]), t_pts,
                       np.ascontiguousarray(qd[keep]), td, cfg,
                       mask=None if mask is None else np.ascontiguousarray(mask[keep]),
                       **kwargs)


def coarse_extent(config, q_pts, t_pts, qd, td, bottom: float, top: float, width: float,
                  run_network, *, mask=None, fundamental=None):
    """``(lo, hi, n)``: the trimmed extent of the ``n`` matches of the coarse pass searching
    ``[bottom, top]``, or None when it keeps fewer than :data:`MIN_MATCHES` (or exceeds a
    budget)."""
    if not len(q_pts) or not len(t_pts) or not len(qd) or not len(td):
        return None
    keep = thin_points(q_pts, COARSE_POINTS)
    try:
        coarse = run_on_thinned(run_network, config, q_pts, t_pts, qd, td, keep, bottom,
                                top, mask=mask, fundamental=fundamental)
    except BudgetExceededError:
        return None
    n = len(coarse.query_idx)
    if n < MIN_MATCHES:
        return None
    d = (q_pts[keep][coarse.query_idx, 0].astype(np.float64)
         - t_pts[coarse.train_idx, 0])
    lo, hi = trimmed_extent(d, GAP_FRACTION * width + RANGE_PIXELS)
    return lo, hi, n


def search_range(config, query_size, q_pts, t_pts) -> tuple[float, float]:
    """``(bottom, top)``: the given range (``min_disparity`` None: 0), or with
    ``max_disparity`` None the coarse pass's search range ``[min_disparity or -f W, f W]``
    (``f`` = :data:`SEARCH_FRACTION`, ``W`` = :func:`search_width`)."""
    floor = config.min_disparity
    if config.max_disparity is not None:
        return 0.0 if floor is None else float(floor), float(config.max_disparity)
    top = SEARCH_FRACTION * search_width(query_size, q_pts, t_pts)
    return (-top if floor is None else min(float(floor), top)), top


def resolve_disparity_range(config, q_pts, t_pts, qd, td, query_size, run_network, *,
                            mask=None, fundamental=None) -> DisparityRange:
    """The search range of the full pass.

    Parameters
    ----------
    config : MatcherConfig
        ``max_disparity`` None asks for the coarse pass; ``min_disparity`` is then a floor
        of the range (None: no floor, the range may be negative). With ``max_disparity``
        given, ``min_disparity`` None means 0.
    q_pts, t_pts : (N, 2) float32 ndarrays
        Left and right points (checked).
    qd, td : ndarrays
        Their descriptors (checked).
    query_size : (width, height) or None
        The left image's size (see :func:`search_width`).
    run_network : callable
        :func:`~hopmatch.matching.network.run_hopfield_network` (passed in, so that this
        module does not import the network module that calls it).
    mask, fundamental
        As for ``run_hopfield_network``: the coarse pass honours both.

    Returns
    -------
    DisparityRange
    """
    floor = config.min_disparity
    bottom, top = search_range(config, query_size, q_pts, t_pts)
    if config.max_disparity is not None:
        return DisparityRange(bottom, top, "given")
    width = search_width(query_size, q_pts, t_pts)
    # a range the coarse pass cannot find is searched over positive disparities (the
    # common case) unless a floor is given: [0, top], not the coarse search's [-top, top]
    fallback = DisparityRange(max(bottom, 0.0) if floor is None else bottom, top, "fallback")
    if not len(q_pts) or not len(t_pts) or not len(qd) or not len(td):
        return fallback._replace(source="empty")
    found = coarse_extent(config, q_pts, t_pts, qd, td, bottom, top, width, run_network,
                          mask=mask, fundamental=fundamental)
    if found is None:
        return fallback
    lo, hi, n = found
    low, high = widen(lo, hi, width)
    if floor is not None:
        low = max(low, float(floor))
        high = max(high, low)
    return DisparityRange(low, high, "coarse", (lo, hi), n)


#: When the range found by the coarse pass exceeds a budget, the full pass tries these
#: shares of its widening (:func:`widen`) in turn, down to the coarse matches' own extent
#: plus :data:`RANGE_PIXELS` (0): a full-size pair whose widened range holds too many
#: candidate pairs still gets most of the margin (docs/parameters.md, "Disparity range").
BUDGET_WIDENING = (0.5, 0.25, 0.0)
#: A share of the widening but the last is searched only when the candidate pairs of one
#: left point in this many (counted within that fraction of the budget) predict that it
#: fits within :data:`BUDGET_ESTIMATE_SLACK` of the budget: a refusal then costs little
#: more than the two searches it cost before the shares (docs/robustness.md, "Budgets and
#: measured memory").
BUDGET_ESTIMATE_STEP = 8
BUDGET_ESTIMATE_SLACK = 0.9


def estimated_pairs(q_pts, t_pts, low: float, high: float, config, fundamental=None) -> float:
    """The candidate pairs of ``[low, high]`` (``config``'s band), estimated from one left
    point in :data:`BUDGET_ESTIMATE_STEP` within that share of ``config.max_neurons`` (inf
    beyond it)."""
    sample = np.ascontiguousarray(q_pts[::BUDGET_ESTIMATE_STEP])
    if not len(sample):
        return 0.0
    try:
        ni, _ = candidate_pairs(sample, t_pts, low, high, config.max_vertical,
                                max(config.max_neurons // BUDGET_ESTIMATE_STEP, 1), fundamental,
                                sort=False)
    except BudgetExceededError:
        return float("inf")
    return len(ni) * len(q_pts) / len(sample)


def run_in_range(run_network, found: DisparityRange, config, q_pts, t_pts, qd, td, **kwargs):
    """``(result, config)`` of ``run_network(q_pts, t_pts, qd, td, config, **kwargs)``, where
    ``config`` holds the range of ``found``. When a range found by the coarse pass exceeds
    a budget (:class:`~hopmatch.errors.BudgetExceededError`), the full pass runs again on
    ranges between it and the coarse matches' own extent (:data:`BUDGET_WIDENING`; the
    last is that extent with :data:`RANGE_PIXELS` of margin; the others only where
    :func:`estimated_pairs` predicts that they fit) until one fits; when none does (or the
    range is the coarse pass's fallback), on the range of ``found`` with as many left
    points as fit (:func:`run_thinned`). Each with a
    :class:`~hopmatch.errors.DisparityRangeWarning` that says what was searched; if nothing
    fits (or the range was given), the first error is raised."""
    try:
        return run_network(q_pts, t_pts, qd, td, config, **kwargs), config
    except BudgetExceededError as exc:
        if found.source not in ("coarse", "fallback"):
            raise
        first = exc
    where = f" {found.frame}" if found.frame else ""
    what = (f"the range found{where}, [{found.min_disparity:g}, {found.max_disparity:g}],"
            if found.source == "coarse" else
            f"the whole search range{where}, [{found.min_disparity:g}, "
            f"{found.max_disparity:g}] (the coarse pass kept fewer than {MIN_MATCHES} "
            "matches),")
    if found.source == "coarse":
        lo, hi = found.found
        for share in BUDGET_WIDENING:
            low = max(lo - RANGE_PIXELS + share * (found.min_disparity - lo + RANGE_PIXELS),
                      found.min_disparity)
            high = max(hi + RANGE_PIXELS + share * (found.max_disparity - hi - RANGE_PIXELS),
                       low)
            if share > 0 and estimated_pairs(q_pts, t_pts, low, high, config,
                                             kwargs.get("fundamental")) \
                    > BUDGET_ESTIMATE_SLACK * config.max_neurons:
                continue
            narrow = dataclasses.replace(config, min_disparity=low, max_disparity=high)
            try:
                result = run_network(q_pts, t_pts, qd, td, narrow, **kwargs)
            except BudgetExceededError:
                continue
            instead = ("the coarse matches' own range" if share == 0 else
                       f"{share:.0%} of its widening around the coarse matches' range")
            warn(f"max_disparity=None: {what} exceeds a budget ({first}); searching "
                 f"{instead}, [{narrow.min_disparity:g}, {narrow.max_disparity:g}], instead",
                 DisparityRangeWarning)
            return result, narrow
    thinned = run_thinned(run_network, config, q_pts, t_pts, qd, td, **kwargs)
    if thinned is None:
        raise first from None
    warn(f"max_disparity=None: {what} exceeds a budget ({first})"
         + (", and so does the coarse matches' own range" if found.source == "coarse" else "")
         + f"; the network ran there on {len(thinned.thinned)} of the {len(q_pts)} left "
         "points, the strongest of each cell of a grid, its neighbourhood scaled as the "
         "coarse pass's (match_stereo's guided pass searches the others; pass fewer "
         "keypoints, a range, or a larger max_neurons to run it on every point)",
         DisparityRangeWarning)
    return thinned, config


#: Left points whose candidate pairs estimate how many points fit in a budget
#: (:func:`run_thinned`).
THIN_SAMPLE = 2000
#: Tries of :func:`run_thinned`, each with half the points of the one before (each
#: costs at most a budget's worth of candidate search: a refusal stays quick).
THIN_TRIES = 2
#: Fewest left points :func:`run_thinned` runs the network on (fewer: it refuses).
THIN_MIN_POINTS = 200


def run_thinned(run_network, config, q_pts, t_pts, qd, td, *, mask=None, **kwargs):
    """``run_network`` on as many left points as fit ``config``'s budgets (one per cell of
    a grid over them: :func:`thin_points`, the strongest of each cell when the points come
    strongest first, as the detector gives them), its neighbourhood scaled as the coarse
    pass's (:func:`coarse_config`), every right point kept: the result in the indices of
    all the points, with ``thinned`` the left points it ran on and ``config`` ``config``.
    How many fit is estimated from the candidate pairs of :data:`THIN_SAMPLE` of them
    (:data:`BUDGET_ESTIMATE_SLACK` of ``max_neurons``), halved up to :data:`THIN_TRIES`
    times while a budget is exceeded. None when none fits, when fewer than
    :data:`THIN_MIN_POINTS` would be kept, or when every point would be (then thinning
    does not help)."""
    sample = thin_points(q_pts, THIN_SAMPLE)
    try:
        ni, _ = candidate_pairs(np.ascontiguousarray(q_pts[sample]), t_pts,
                                config.min_disparity, config.max_disparity,
                                config.max_vertical, config.max_neurons,
                                kwargs.get("fundamental"), sort=False)
    except BudgetExceededError:
        return None
    per_point = max(len(ni), 1) / max(len(sample), 1)
    target = int(BUDGET_ESTIMATE_SLACK * config.max_neurons / per_point)
    for _ in range(THIN_TRIES):
        if target < THIN_MIN_POINTS:
            return None
        keep = thin_points(q_pts, target)
        if len(keep) >= len(q_pts) or len(keep) < THIN_MIN_POINTS:
            return None
        try:
            result = run_on_thinned(run_network, config, q_pts, t_pts, qd, td, keep,
                                    config.min_disparity, config.max_disparity, mask=mask,
                                    **kwargs)
        except BudgetExceededError:
            target = len(keep) // 2
            continue
        keep = keep.astype(np.int32)
        return dataclasses.replace(result, query_idx=keep[result.query_idx],
                                   neuron_left=keep[result.neuron_left], config=config,
                                   thinned=keep)
    return None


def warn_if_negative(found: DisparityRange) -> None:
    """Warn (:class:`~hopmatch.errors.DisparityRangeWarning`) when every disparity the
    coarse pass found is negative: two views in the wrong order look like that (a right
    image offset sideways, or a verged rig, gives a range that is partly negative)."""
    if found.source == "coarse" and found.found is not None and found.found[1] < 0:
        warn(f"max_disparity=None: every disparity the coarse pass found is negative "
             f"({found.found[0]:g} to {found.found[1]:g} px): is the right image given "
             "first? The pair was matched as found; pass the left image first (or "
             "min_disparity=0 to search positive disparities only)", DisparityRangeWarning)


def warn_fallback(found: DisparityRange, n_matches: int) -> None:
    """Warn (:class:`~hopmatch.errors.DisparityRangeWarning`) when the range could not be
    found and the full pass, searching the whole fallback range, found nothing either."""
    if found.source == "fallback" and n_matches == 0:
        warn(f"max_disparity=None: the coarse pass kept fewer than {MIN_MATCHES} matches, so "
             f"the whole range [{found.min_disparity:g}, "
             f"{found.max_disparity:g}] was searched, and no match was found there; check "
             "that the left image comes first (swapped images have negative disparities), "
             "or give the range (min_disparity, max_disparity) if you know it",
             DisparityRangeWarning)
