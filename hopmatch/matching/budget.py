"""Resource budgets of the network, checked before anything of their size is allocated."""

from __future__ import annotations

import numpy as np

from .._kernels import interactions as _ki
from .._kernels import neighbours as _kn
from .._validate import as_flag
from ..errors import BudgetExceededError

#: ``record_energy`` keeps one float64 per allowed iteration: refuse more than this many
#: (1 GiB) rather than let the allocation fail.
MAX_ENERGY_TRACE = 2**27


def neighbour_pairs_bound(points: np.ndarray, half_w: float, half_h: float) -> int:
    """An upper bound on the number of (ordered) neighbour pairs the network stores: points
    are bucketed in cells of ``half_w x half_h`` (as the kernel does), and every neighbour
    of a point lies in the 3 x 3 cells around it. Counted on a dense grid in O(N + cells)
    when it has at most ``8 N + 1024`` cells, else on the occupied cells in O(N log N)
    (:func:`sparse_neighbour_pairs_bound`); O(N) memory either way."""
    n = len(points)
    if n < 2:
        return 0
    cw, ch = _kn.cell_size(half_w, half_h)
    dense = _kn.grid_neighbour_bound(np.ascontiguousarray(points, dtype=np.float32), cw, ch,
                                    8 * n + 1024)
    return int(dense) if dense >= 0 else sparse_neighbour_pairs_bound(points, half_w, half_h)


def sparse_neighbour_pairs_bound(points: np.ndarray, half_w: float, half_h: float) -> int:
    """:func:`neighbour_pairs_bound` counted on the occupied cells only (sorted cell keys),
    for points spread over far more cells than there are points."""
    n = len(points)
    if n < 2:
        return 0
    cw, ch = _kn.cell_size(half_w, half_h)
    pts = points.astype(np.float64)
    cx = np.floor((pts[:, 0] - pts[:, 0].min()) / cw).astype(np.int64) + 1
    cy = np.floor((pts[:, 1] - pts[:, 1].min()) / ch).astype(np.int64) + 1
    stride = int(cy.max()) + 2  # coordinates within +-2**20 keep cx * stride in int64
    keys, counts = np.unique(cx * stride + cy, return_counts=True)
    around = np.zeros(len(keys), dtype=np.int64)
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            other = keys + dx * stride + dy
            pos = np.minimum(np.searchsorted(keys, other), len(keys) - 1)
            around += np.where(keys[pos] == other, counts[pos], 0)
    return int((counts * around).sum()) - n


def check_neighbour_budget(points: np.ndarray, config, grown: bool = False) -> None:
    """Refuse point sets whose neighbour lists alone would exceed ``max_interactions``
    entries (many coincident or crowded points), before the kernel allocates them.
    ``grown``: the window of ``config`` was grown for sparse points (``min_neighbours``;
    the message says so)."""
    max_interactions = config.max_interactions
    if len(points) * (len(points) - 1) <= max_interactions:
        return
    bound = neighbour_pairs_bound(points, config.neighbour_width / 2,
                                  config.neighbour_height / 2)
    if bound > max_interactions:
        raise BudgetExceededError(
            f"the left points are so crowded that their neighbour lists could hold {bound} "
            f"pairs (an upper bound), more than max_interactions={max_interactions}; "
            + (f"the neighbour window was grown to {config.neighbour_width:g} x "
               f"{config.neighbour_height:g} px because most points have few neighbours "
               "(min_neighbours=0 keeps it as given); " if grown else "")
            + "remove duplicate keypoints, shrink neighbour_width/neighbour_height, use "
            "fewer keypoints, or raise max_interactions", argument="max_interactions"
        )


def interaction_capacity(ni, nk, start, nb_off, nb_idx, max_interactions: int) -> int:
    """Room to allocate for the interactions: the cheap upper bound of
    :func:`_ki.interaction_bounds` when it is within ``max_interactions``, else the exact
    count, which must be within it (:class:`BudgetExceededError` otherwise, before anything
    of that size is allocated).

    A refusal costs O(Nl + neighbour entries) when the cheap lower bound is already past
    ``max_interactions``, else O(max_interactions) steps at most: the exact count stops as
    soon as it passes it, however crowded the points are."""
    lower, upper = _ki.interaction_bounds(start, nb_off, nb_idx)
    if upper <= max_interactions:
        return upper
    if lower > max_interactions:
        n_inter = lower
    else:
        n_inter = _ki.count_interactions(ni, nk, start, nb_off, nb_idx, max_interactions)
    if n_inter > max_interactions:
        raise BudgetExceededError(
            f"the network would have at least {n_inter} interactions, more than "
            f"max_interactions={max_interactions}; shrink "
            "neighbour_width/neighbour_height, narrow the disparity range, use fewer "
            "keypoints, or raise max_interactions", argument="max_interactions"
        )
    return n_inter


def check_energy_trace(max_iterations: int, record_energy: bool) -> None:
    """Refuse ``record_energy`` when it is not a bool (:func:`~hopmatch._validate.as_flag`),
    or when its trace (one float64 per allowed iteration) would exceed
    :data:`MAX_ENERGY_TRACE` entries."""
    record_energy = as_flag(record_energy, "record_energy")
    if record_energy and max_iterations + 1 > MAX_ENERGY_TRACE:
        raise BudgetExceededError(
            f"record_energy=True keeps one float64 per iteration, and max_iterations="
            f"{max_iterations} would need {8 * (max_iterations + 1) / 2**30:.3g} GiB; lower "
            f"max_iterations to at most {MAX_ENERGY_TRACE - 1} or pass record_energy=False",
            argument="max_iterations"
        )
