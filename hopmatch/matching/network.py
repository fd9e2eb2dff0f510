"""The sparse Hopfield network of SPEC sections 2-4 as a pure function on arrays."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._kernels import candidates as _kc
from .._kernels import interactions as _ki
from .._kernels import neighbours as _kn
from .._kernels import network as _k
from .._kernels import similarity as _ks
from ..errors import BudgetExceededError
from .disambiguate import disambiguate, vertically_consistent

_EPS = 1e-6


@dataclass(frozen=True)
class NetworkResult:
    """Everything the network computed for one pair.

    Attributes
    ----------
    query_idx, train_idx : (M,) int32 ndarrays
        The matches: left point ``query_idx[m]`` matches right point ``train_idx[m]``.
    distances : (M,) float32 ndarray
        ``1 / (1 + exp(u))`` of each match, u the neuron's final local field (eq. 12's
        bracket): near 0 for a strongly supported match, 0.5 for an undecided one.
    neuron_left, neuron_right : (N,) int32 ndarrays
        The candidate pairs (neurons) of the network.
    state : (N,) bool ndarray
        Converged state of each neuron.
    fields : (N,) float64 ndarray
        Final local field u of each neuron.
    similarity : (N,) float64 ndarray
        Normalised similarity distance of each neuron (before weighting).
    n_interactions : int
        Number of stored interactions (ordered neuron pairs).
    iterations, sweeps : int
        Left points visited, and permutations started.
    converged : bool
        Whether the stopping rule was met before ``max_iterations``.
    energy : float
        Energy (eq. 11) of the converged state, with the final input bias.
    energy_trace : (T,) float64 ndarray
        Energy (eq. 11) after each iteration, if requested; else empty. With annealing
        (``initial_bias``) each phase's energy uses that phase's input bias.
    """

    query_idx: np.ndarray
    train_idx: np.ndarray
    distances: np.ndarray
    neuron_left: np.ndarray
    neuron_right: np.ndarray
    state: np.ndarray
    fields: np.ndarray
    similarity: np.ndarray
    n_interactions: int
    iterations: int
    sweeps: int
    converged: bool
    energy: float
    energy_trace: np.ndarray = field(default_factory=lambda: np.zeros(0))


def window_contrasts(desc_l: np.ndarray, desc_r: np.ndarray):
    """``(s_l, s_r)``: each float descriptor row's ``mean |row|``, the contrast that
    normalises eq. 7 (:func:`similarity_distance`); None for binary (uint8) descriptors."""
    if desc_l.dtype == np.uint8:
        return None
    return _ks.row_mean_abs(desc_l), _ks.row_mean_abs(desc_r)


def similarity_distance(desc_l: np.ndarray, desc_r: np.ndarray, ni: np.ndarray,
                        nk: np.ndarray, gate: float | None = None,
                        contrasts=None) -> np.ndarray:
    """Normalised similarity distance of each candidate pair (eqs. 7-9).

    Float descriptors: ``M_ik`` of eq. 7 (mean absolute difference of the mean-subtracted
    windows) divided by the mean of the two windows' mean absolute values, so that it does
    not depend on contrast: 0 for identical windows, about 1 for unrelated ones, at most 2.
    This also serves any float descriptor (SIFT...). Binary (uint8) descriptors: the
    fraction of differing bits, in [0, 1].

    With a ``gate``, float pairs whose distance certainly exceeds it (their contrasts
    differ too much) are given ``inf`` without computing it; the others are exact.
    ``contrasts``: :func:`window_contrasts` of the descriptors, if already computed.
    """
    if desc_l.dtype == np.uint8:
        return _ks.hamming_fraction(desc_l, desc_r, ni, nk)
    scale_l, scale_r = contrasts if contrasts is not None else window_contrasts(desc_l, desc_r)
    return _ks.normalised_difference(desc_l, desc_r, ni, nk, scale_l, scale_r, _EPS,
                                     np.inf if gate is None else float(gate))


def _row_span_limit(n: int) -> int:
    """Largest row span the candidate search counts rows over for n points (beyond it, it
    sorts them: ``_kc.row_order``)."""
    return 4 * n + 1024


def _right_band_index(right):
    """What the rectified candidate search (``band_candidates``) needs of the right points:
    the distinct rows ``floor(y)``, each row's offsets in the order below, the points row by
    row with x increasing (ties: index increasing), and the coordinates in that order
    (``_kc.band_index``)."""
    return _kc.band_index(right, _row_span_limit(len(right)))


def _left_visit_order(left) -> np.ndarray:
    """The order the candidate search visits the left points in: row by row, index order
    within a row (cache-friendly, ``_kc.row_order``)."""
    return _kc.row_order(left, _row_span_limit(len(left)))[0]


def candidate_pairs(left, right, min_disparity, max_disparity, max_vertical, max_neurons,
                    fundamental=None, *, sort=True, contrast_gate=None):
    """Neurons: pairs with ``min_disparity <= xl - xr <= max_disparity`` and
    ``|yl - yr| <= max_vertical`` (SPEC section 3's search window), as ``(ni, nk)``.

    With a fundamental matrix, the band is around each left point's epipolar line instead:
    the right point's distance to ``F (xl, yl, 1)`` is at most ``max_vertical``.
    Raises :class:`BudgetExceededError` before allocating more than ``max_neurons``.

    The pairs are sorted by (i, k); with ``sort=False`` they are only grouped by left point
    (in the order the search visited them): sort what is left after gating with
    ``_kc.group_by_left`` (which can gate them) then ``_kc.sort_groups``, which is cheaper.

    ``contrast_gate=(contrasts, gate)`` (rectified search only; ``contrasts`` from
    :func:`window_contrasts`) leaves out the pairs :func:`similarity_distance` would put past
    ``gate`` on their contrasts alone; the budget still counts them.
    """
    band = (np.float32(min_disparity), np.float32(max_disparity), np.float32(max_vertical))
    budget = np.int64(min(max_neurons, 2**62))
    if fundamental is None:
        index = _right_band_index(right)
        if contrast_gate is None:
            scale_l, scale_r, gate = np.zeros(len(left)), np.zeros(len(right)), np.inf
        else:
            (scale_l, scale_r), gate = contrast_gate
            scale_r = scale_r[index[2]]
        ni, nk, n = _kc.band_candidates(left, _left_visit_order(left), *index, *band, budget,
                                        scale_l, np.ascontiguousarray(scale_r, np.float64),
                                        float(gate), _EPS)
    else:
        order = np.argsort(right[:, 0], kind="stable")
        ni, nk, n = _kc.epipolar_candidates(
            left, right, order, np.ascontiguousarray(right[order, 0]),
            np.ascontiguousarray(fundamental, dtype=np.float64), *band, budget)
    if n > max_neurons:
        raise BudgetExceededError(
            f"the network would have {n} neurons (candidate pairs), more than max_neurons="
            f"{max_neurons}; narrow the disparity range (min_disparity/max_disparity) or "
            "max_vertical, use fewer keypoints, or raise max_neurons"
        )
    if sort:
        ni, nk, _ = _kc.group_by_left(ni, nk, np.empty(len(ni)), len(left), False, 0.0)
        _kc.sort_groups(ni, nk, np.empty(len(ni)))
    return ni, nk


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


#: The zero-mean test of window rows: ``|mean| <= WINDOW_MEAN_TOL[0] * mean |x| + [1]``.
WINDOW_MEAN_TOL = (1e-3, 1e-9)


def _window_shaped(desc: np.ndarray) -> bool:
    """Whether rows can be the windows of eqs. 8-9: float, square length (s >= 3)."""
    if desc.dtype == np.uint8 or desc.ndim != 2 or len(desc) == 0:
        return False
    s = int(round(np.sqrt(desc.shape[1])))
    return s >= 3 and s * s == desc.shape[1]


def shift_minimal(desc_l: np.ndarray, desc_r: np.ndarray, qi: np.ndarray,
                  ti: np.ndarray) -> np.ndarray:
    """Boolean (M,): the right window of each match fits the left one better at the matched
    position than shifted by one pixel along the row (either way).

    Compares the overlapping columns of the square (s x s) descriptor windows at column
    shifts -1, 0, +1 with the mean absolute difference. A match whose cost is lower at a
    one-pixel shift is a localisation near-miss (the right keypoint is off by >= 1 px) and
    is rejected. Descriptors that are not windows pass unchanged: windows (as
    ``gradient_windows`` makes them) are float rows of square length with zero mean, SIFT,
    KAZE... rows are not (``_ks.zero_mean`` on the matched rows, :data:`WINDOW_MEAN_TOL`).
    """
    qi = np.ascontiguousarray(qi, dtype=np.int64)
    ti = np.ascontiguousarray(ti, dtype=np.int64)
    keep = np.ones(len(qi), dtype=bool)
    if len(qi) == 0 or not (_window_shaped(desc_l) and _window_shaped(desc_r)):
        return keep
    s = int(round(np.sqrt(desc_l.shape[1])))
    shift_keep, windows = _ks.shift_minimal_windows(desc_l, desc_r, qi, ti, s, *WINDOW_MEAN_TOL)
    return shift_keep if windows else keep


def neighbours_with_neurons(left, start, width, height):
    """CSR neighbour lists (SPEC section 4's ``width x height`` window) among the left points
    that have neurons; points without neurons neither have nor are neighbours, since no
    interaction can involve them."""
    return _kn.neighbour_lists_among(left, start, np.float32(width / 2), np.float32(height / 2))


def interaction_capacity(ni, nk, start, nb_off, nb_idx, max_interactions: int) -> int:
    """Room to allocate for the interactions: the cheap :func:`_ki.interaction_bound` when it
    is within ``max_interactions``, else the exact count, which must be within it
    (:class:`BudgetExceededError` otherwise, before anything of that size is allocated)."""
    bound = _ki.interaction_bound(start, nb_off, nb_idx)
    if bound <= max_interactions:
        return bound
    n_inter = _ki.count_interactions(ni, nk, start, nb_off, nb_idx)
    if n_inter > max_interactions:
        raise BudgetExceededError(
            f"the network would have {n_inter} interactions, more than max_interactions="
            f"{max_interactions}; shrink neighbour_width/neighbour_height, narrow the "
            "disparity range, use fewer keypoints, or raise max_interactions"
        )
    return n_inter


def _starts(ni: np.ndarray, n_left: int) -> np.ndarray:
    start = np.zeros(n_left + 1, dtype=np.int64)
    np.cumsum(np.bincount(ni, minlength=n_left), out=start[1:])
    return start


def run_hopfield_network(left, right, desc_l, desc_r, p: dict, *, mask=None,
                         record_energy: bool = False, fundamental=None) -> NetworkResult:
    """Match validated arrays with the network; ``p`` holds resolved matcher parameters.

    ``fundamental`` (3 x 3, optional) replaces the horizontal band by an epipolar band.

    ``left``/``right`` are (N, 2) float32 (x, y); ``mask`` an optional (Nl, Nr) bool array
    (False forbids a neuron). See :class:`hopmatch.HopfieldMatcher` for the parameters.
    """
    nl, nr = len(left), len(right)
    gate = p["similarity_gate"]
    contrasts = window_contrasts(desc_l, desc_r)
    ni, nk = candidate_pairs(
        left, right, p["min_disparity"], p["max_disparity"], p["max_vertical"],
        p["max_neurons"], fundamental, sort=False,
        contrast_gate=None if contrasts is None or gate is None else (contrasts, gate))
    if mask is not None and len(ni):
        keep = mask[ni, nk]
        ni, nk = ni[keep], nk[keep]
    sim = (similarity_distance(desc_l, desc_r, ni, nk, gate, contrasts) if len(ni)
           else np.zeros(0))
    ni, nk, sim = _kc.group_by_left(ni, nk, sim, nl, gate is not None,
                                    0.0 if gate is None else float(gate))
    _kc.sort_groups(ni, nk, sim)
    if p["max_candidates"] and len(ni):
        order = np.lexsort((sim, ni))
        rank = np.empty(len(ni), dtype=np.int64)
        first = np.searchsorted(ni[order], ni[order])
        rank[order] = np.arange(len(ni)) - first
        keep = rank < p["max_candidates"]
        ni, nk, sim = ni[keep], nk[keep], sim[keep]
    start = _starts(ni, nl)

    nb_off, nb_idx = neighbours_with_neurons(left, start, p["neighbour_width"],
                                             p["neighbour_height"])
    capacity = interaction_capacity(ni, nk, start, nb_off, nb_idx, p["max_interactions"])
    weighted = p["similarity_weight"] * sim
    off, idx, w = _ki.fill_interactions(left, right, ni, nk, start, nb_off, nb_idx, weighted,
                                        p["theta"], p["slope"], capacity)
    n_inter = off[-1]
    v = np.zeros(len(ni), dtype=np.uint8)
    biases = ([p["initial_bias"]] if p["initial_bias"] is not None else []) + [p["input_bias"]]
    iterations, sweeps, traces = 0, 0, []
    for phase, bias in enumerate(biases):
        v, it, sw, converged, trace = _k.run_network(
            v, ni, nk, start, off, idx, w, nl, nr, p["uniqueness_weight"], bias,
            np.uint64(p["seed"] + phase), p["stable_iterations"],
            p["max_iterations"] - iterations, record_energy)
        iterations, sweeps = iterations + it, sweeps + sw
        traces.append(trace)
    trace = np.concatenate(traces)
    row = np.bincount(ni[v == 1], minlength=nl).astype(np.int64)
    col = np.bincount(nk[v == 1], minlength=nr).astype(np.int64)
    u = _k.local_fields(v, ni, nk, off, idx, w, row, col, p["uniqueness_weight"],
                        p["input_bias"])
    energy = _k.network_energy(v, ni, nk, off, idx, w, row, col, p["uniqueness_weight"],
                               p["input_bias"])
    dy = vertical_offsets(left, right, ni, nk, fundamental)
    state = v.astype(bool)
    if p["cross_check"]:
        chosen = disambiguate(ni, nk, state, dy, u, p["vertical_threshold"])
    else:
        chosen = np.flatnonzero(state)
    if p["vertical_check"] == "all":
        chosen = chosen[vertically_consistent(dy[chosen], p["vertical_threshold"])]
    if p["shift_check"]:
        chosen = chosen[shift_minimal(desc_l, desc_r, ni[chosen], nk[chosen])]
    with np.errstate(over="ignore"):
        dist = (1.0 / (1.0 + np.exp(u[chosen]))).astype(np.float32)
    return NetworkResult(
        query_idx=ni[chosen].astype(np.int32), train_idx=nk[chosen].astype(np.int32),
        distances=dist, neuron_left=ni, neuron_right=nk, state=state, fields=u,
        similarity=sim, n_interactions=int(n_inter), iterations=int(iterations),
        sweeps=int(sweeps), converged=bool(converged), energy=float(energy),
        energy_trace=trace,
    )
