"""The sparse Hopfield network of SPEC sections 2-4 as pure functions on arrays.

:func:`hopfield_match` is the public entry: it checks its arguments once, checks every
budget, warns, and runs :func:`run_hopfield_network`. :class:`~hopmatch.HopfieldMatcher`
and :func:`~hopmatch.match_stereo` keep their pair information in a :class:`PairInfo`
and call :func:`match_pair`, the same function after the points are checked.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from .._interrupts import keeps_interrupts
from .._kernels import candidates as _kc
from .._kernels import interactions as _ki
from .._kernels import neighbours as _kn
from .._kernels import network as _k
from .._validate import (
    as_descriptors,
    as_fundamental_matrix,
    as_image_size,
    as_mask,
    as_points,
    check_coordinate_range,
)
from ..errors import InvalidArgumentError, PairInfoError
from .budget import check_energy_trace, check_neighbour_budget, interaction_capacity

# The imports marked "noqa: F401" re-export names that lived in this module before the
# matching layer was split, so they stay importable from here.
from .candidates import (  # noqa: E402, F401
    candidate_pairs,
    left_visit_order,
    resolve_max_disparity,
    right_band_index,
    vertical_offsets,
)
from .diagnostics import pair_diagnosis, warn_about_pair, warn_geometry, warn_if_few_matches
from .disambiguate import disambiguate, vertically_consistent
from .disparity_range import (
    DisparityRange,
    resolve_disparity_range,
    run_in_range,
    search_range,
    warn_fallback,
    warn_if_negative,
)
from .neighbourhood import grown_for_density, half_sides
from .params import MatcherConfig, check_disparity_order, matcher_config
from .similarity import (
    WINDOW_MEAN_TOL,  # noqa: E402, F401
    match_distance,
    shift_minimal,
    similarity_distance,
    window_contrasts,
)
from .vertical import RowOffsetPrior, prior_look_alikes, prior_of_look_alikes, rows_share_of


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
    config : MatcherConfig or None
        The parameters the network ran with, ``max_disparity`` resolved (None only for
        results built by hand).
    row_prior : RowOffsetPrior or None
        The residual vertical offset measured before the network, which the search band
        followed (:func:`~hopmatch.matching.vertical.row_offset_prior`); None when the band
        was the plain rows (a well rectified pair, a fundamental matrix, or
        ``vertical_model="median"``).
    thinned : (K,) int32 ndarray or None
        When the pair's candidate pairs exceeded a budget with the range found by itself,
        the left points (increasing indices) the network ran on, one per cell of a grid,
        its neighbour window and θ scaled by ``sqrt(Nl / K)`` as the coarse pass's
        (:func:`~hopmatch.matching.disparity_range.run_thinned`; ``config`` is then the
        unscaled parameters); None: every left point.
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
    config: MatcherConfig | None = None
    row_prior: RowOffsetPrior | None = None
    thinned: np.ndarray | None = None


class PairInfo(NamedTuple):
    """Checked pair information: the left (query) and right (train) points as (N, 2)
    float32 C-contiguous (x, y) arrays, in the order of the descriptor rows, and the image
    sizes as ``(width, height)`` or None."""

    query_points: np.ndarray
    train_points: np.ndarray
    query_size: tuple[int, int] | None = None
    train_size: tuple[int, int] | None = None

    @classmethod
    def of(cls, query_points, train_points, query_size=None, train_size=None,
           names=("queryKpts", "trainKpts", "queryImageSize", "trainImageSize")):
        """Check keypoints (``cv2.KeyPoint`` sequences or (N, 2) arrays) and sizes; errors
        name the arguments ``names``."""
        q = as_points(query_points, names[0])
        t = as_points(train_points, names[1])
        check_coordinate_range(q, names[0])
        check_coordinate_range(t, names[1])
        return cls(q, t, as_image_size(query_size, names[2]),
                   as_image_size(train_size, names[3]))


def neighbours_with_neurons(left, start, width, height):
    """CSR neighbour lists (SPEC section 4's ``width x height`` window) among the left points
    that have neurons; points without neurons neither have nor are neighbours, since no
    interaction can involve them."""
    return _kn.neighbour_lists_among(left, start, *half_sides(width, height))


def _starts(ni: np.ndarray, n_left: int) -> np.ndarray:
    start = np.zeros(n_left + 1, dtype=np.int64)
    np.cumsum(np.bincount(ni, minlength=n_left), out=start[1:])
    return start


def run_hopfield_network(left, right, desc_l, desc_r, config: MatcherConfig, *, mask=None,
                         record_energy: bool = False, fundamental=None) -> NetworkResult:
    """The network of SPEC sections 2-4 on validated arrays, within checked budgets.

    ``left``/``right`` are (N, 2) float32 C-contiguous (x, y); ``desc_l``/``desc_r`` their
    float32 or uint8 C-contiguous descriptor rows; ``config`` the parameters with
    ``max_disparity`` resolved (not None), a :data:`MatcherConfig` or a mapping with each
    of its fields; ``mask`` None or an (Nl, Nr) bool array (False
    forbids a neuron); ``fundamental`` None or a 3 x 3 float64 matrix that replaces the
    horizontal band by an epipolar band. Callers validate: :func:`match_pair` does.
    Neuron budgets (``max_neurons``, ``max_interactions``) are checked here, before the
    arrays of their size are allocated.
    """
    c = config if isinstance(config, MatcherConfig) else MatcherConfig(**config)
    nl, nr = len(left), len(right)
    gate = c.similarity_gate
    contrasts = window_contrasts(desc_l, desc_r)
    ni, nk = candidate_pairs(
        left, right, c.min_disparity, c.max_disparity, c.max_vertical,
        c.max_neurons, fundamental, sort=False,
        contrast_gate=None if contrasts is None or gate is None else (contrasts, gate),
        gain_tolerance=c.gain_tolerance)
    if mask is not None and len(ni):
        keep = mask[ni, nk]
        ni, nk = ni[keep], nk[keep]
    sim = (similarity_distance(desc_l, desc_r, ni, nk, gate, contrasts, c.gain_tolerance)
           if len(ni) else np.zeros(0))
    ni, nk, sim = _kc.group_by_left(ni, nk, sim, nl, gate is not None,
                                   0.0 if gate is None else float(gate))
    _kc.sort_groups(ni, nk, sim)
    if c.max_candidates and len(ni):
        order = np.lexsort((sim, ni))
        rank = np.empty(len(ni), dtype=np.int64)
        first = np.searchsorted(ni[order], ni[order])
        rank[order] = np.arange(len(ni)) - first
        keep = rank < c.max_candidates
        ni, nk, sim = ni[keep], nk[keep], sim[keep]
    start = _starts(ni, nl)

    nb_off, nb_idx = neighbours_with_neurons(left, start, c.neighbour_width,
                                             c.neighbour_height)
    capacity = interaction_capacity(ni, nk, start, nb_off, nb_idx, c.max_interactions)
    weighted = c.similarity_weight * sim
    off, idx, w = _ki.fill_interactions(left, right, ni, nk, start, nb_off, nb_idx, weighted,
                                       c.theta, c.slope, capacity)
    n_inter = off[-1]
    v = np.zeros(len(ni), dtype=np.uint8)
    biases = ([c.initial_bias] if c.initial_bias is not None else []) + [c.input_bias]
    iterations, sweeps, traces = 0, 0, []
    for phase, bias in enumerate(biases):
        v, it, sw, converged, trace = _k.run_network(
            v, ni, nk, start, off, idx, w, nl, nr, c.uniqueness_weight, bias,
            np.uint64(c.seed + phase), c.stable_iterations,
            c.max_iterations - iterations, record_energy)
        iterations, sweeps = iterations + it, sweeps + sw
        traces.append(trace)
    trace = np.concatenate(traces)
    row = np.bincount(ni[v == 1], minlength=nl).astype(np.int64)
    col = np.bincount(nk[v == 1], minlength=nr).astype(np.int64)
    u = _k.local_fields(v, ni, nk, off, idx, w, row, col, c.uniqueness_weight,
                        c.input_bias)
    energy = _k.network_energy(v, ni, nk, off, idx, w, row, col, c.uniqueness_weight,
                               c.input_bias)
    dy = vertical_offsets(left, right, ni, nk, fundamental)
    state = v.astype(bool)
    if c.cross_check:
        chosen = disambiguate(ni, nk, state, dy, u, c.vertical_threshold)
    else:
        chosen = np.flatnonzero(state)
    if c.vertical_check == "all":
        points = left[ni[chosen]] if c.vertical_model == "plane" else None
        chosen = chosen[vertically_consistent(dy[chosen], c.vertical_threshold, points)]
    if c.shift_check:
        chosen = chosen[shift_minimal(desc_l, desc_r, ni[chosen], nk[chosen])]
    dist = match_distance(u[chosen]).astype(np.float32)
    return NetworkResult(
        query_idx=ni[chosen].astype(np.int32), train_idx=nk[chosen].astype(np.int32),
        distances=dist, neuron_left=ni, neuron_right=nk, state=state, fields=u,
        similarity=sim, n_interactions=int(n_inter), iterations=int(iterations),
        sweeps=int(sweeps), converged=bool(converged), energy=float(energy),
        energy_trace=trace, config=c,
    )


def match_pair(pair: PairInfo, query_descriptors, train_descriptors, config: MatcherConfig, *,
               mask=None, fundamental=None, record_energy: bool = False,
               descriptors_checked: bool = False, raise_unrectified: bool = False,
               few_matches_later: list | None = None,
               fundamental_given: bool = True,
               range_found: DisparityRange | None = None) -> NetworkResult:
    """Match the descriptors of a checked pair: check the descriptors (unless
    ``descriptors_checked``: float32 or uint8 C-contiguous rows already) and the mask,
    resolve the disparity range, check every budget, warn about the geometry (SPEC-free
    checks of docs/robustness.md), run the network and return its result, whose ``config``
    holds the parameters used. ``fundamental``: None or a checked 3 x 3 float64 matrix.
    ``raise_unrectified``: raise :class:`~.diagnostics.LooksUnrectifiedError` where the
    rectification check would warn. ``few_matches_later``: a list, for a caller whose
    later passes add matches (:func:`~.stereo_match.match_detected`) or that may match
    the pair again (a second match through a tone map): the warning about the pair is
    appended to it (a callable, to be called with ``kept=`` the final number of matches:
    :func:`~.diagnostics.warn_about_pair`, the rectification or stereo-pair diagnosis
    while they are still few, else the few-matches check; and, when none of them warned
    and nothing was kept, the range fallback's warning; ``exposure=`` the caller's
    :func:`~.diagnostics.exposure_note`, when it has the images) instead of being given
    here. ``fundamental_given``: False when ``fundamental`` was estimated from the pair, not
    the caller's (the warnings' words). ``range_found``: a range the caller resolved (as
    :func:`~.disparity_range.resolve_disparity_range` does, in the frame of the points
    given), searched instead of resolving one, with the same fallbacks when it exceeds a
    budget (:func:`~.disparity_range.run_in_range`); ``config`` holds the same range (the
    row prior's look-alikes are searched in it)."""
    q_pts, t_pts = pair.query_points, pair.train_points
    if descriptors_checked:
        qd, td = query_descriptors, train_descriptors
    else:
        qd = as_descriptors(query_descriptors, "queryDescriptors")
        td = as_descriptors(train_descriptors, "trainDescriptors")
    if len(qd) != len(q_pts) or len(td) != len(t_pts):
        raise PairInfoError(
            f"descriptor counts ({len(qd)} query, {len(td)} train) disagree with the "
            f"keypoints given to setPairInfo ({len(q_pts)} query, {len(t_pts)} train)"
        )
    if len(qd) and len(td) and (qd.dtype != td.dtype or qd.shape[1] != td.shape[1]):
        raise InvalidArgumentError(
            f"`queryDescriptors` ({qd.dtype}, {qd.shape[1]} columns) and "
            f"`trainDescriptors` ({td.dtype}, {td.shape[1]} columns) must have the same "
            "type and length"
        )
    mask = as_mask(mask, (len(q_pts), len(t_pts)), "mask", of="(n_query, n_train)")
    check_energy_trace(config.max_iterations, record_energy)
    config, growth = grown_for_density(config, q_pts)
    check_neighbour_budget(q_pts, config, grown=growth > 1.0)
    prior, rows_share, t_search = None, None, t_pts
    if fundamental is None and config.vertical_model == "plane" and len(qd) and len(td):
        look_alikes = prior_look_alikes(q_pts, t_pts, qd, td,
                                        *search_range(config, pair.query_size, q_pts, t_pts),
                                        config.max_vertical)
        prior = prior_of_look_alikes(q_pts, look_alikes)
        rows_share = rows_share_of(look_alikes, config.max_vertical)
        if prior is not None:
            t_search = prior.aligned(t_pts)
    found = range_found or resolve_disparity_range(config, q_pts, t_search, qd, td,
                                                   pair.query_size, run_hopfield_network,
                                                   mask=mask, fundamental=fundamental)
    check_disparity_order(found.min_disparity, found.max_disparity)
    warn_if_negative(found)
    config = dataclasses.replace(config, min_disparity=found.min_disparity,
                                 max_disparity=found.max_disparity)
    warn_geometry(pair.query_size, pair.train_size, fundamental, config)
    result, config = run_in_range(run_hopfield_network, found, config, q_pts, t_search, qd,
                                  td, mask=mask, record_energy=record_energy,
                                  fundamental=fundamental)
    if prior is not None:
        result = dataclasses.replace(result, row_prior=prior)
    # one warning for one cause: a pair diagnosed as not rectified or not a stereo pair
    # also defeats the range search, and the diagnosis says more than the others would
    diagnosis = pair_diagnosis(len(result.query_idx), q_pts, t_pts, qd, td, fundamental,
                               config, raise_unrectified, rows_share)
    check = functools.partial(warn_if_few_matches, result, q_pts, t_pts, qd, td, config,
                              range_found=found.source != "fallback", fundamental=fundamental,
                              train_size=pair.train_size, fundamental_given=fundamental_given)
    def warn_once(kept: int | None = None, exposure: str = "") -> None:
        if not warn_about_pair(diagnosis, check, q_pts, t_pts, kept=kept,
                               exposure=exposure):
            warn_fallback(found, len(result.query_idx) if kept is None else kept)

    if few_matches_later is not None:
        # the caller's later passes, or a second match, may add matches: the warning
        # waits for the final count
        few_matches_later.append(warn_once)
    else:
        warn_once()
    return result


@keeps_interrupts
def hopfield_match(left_pts, right_pts, left_desc, right_desc, *, image_size=None,
                   train_image_size=None, mask=None, fundamental_matrix=None,
                   record_energy: bool = False, **params) -> NetworkResult:
    """Match two keypoint sets with the Hopfield network (SPEC sections 2-4).

    Parameters
    ----------
    left_pts, right_pts : (N, 2) float32 ndarray or sequence of cv2.KeyPoint
        (x, y) positions of the left (query) and right (train) points.
    left_desc, right_desc : (N, D) float32 or uint8 ndarray
        Their descriptors, one row per point.
    image_size, train_image_size : (width, height), optional
        Left and right image sizes (the left one sets the default disparity range).
    mask : (Nl, Nr) uint8 or bool ndarray, optional
        Zero forbids a pair.
    fundamental_matrix : (3, 3) array-like, optional
        For an unrectified pair (see :meth:`HopfieldMatcher.setFundamentalMatrix`).
    record_energy : bool
        Keep the energy after every iteration in ``energy_trace``.
    **params
        Any :class:`HopfieldMatcher` parameter.

    Returns
    -------
    NetworkResult
        With ``config``, the parameters used (``max_disparity`` resolved).

    Warns
    -----
    ImageSizeWarning, DisparityRangeWarning, UnrectifiedPairWarning
        See ``docs/robustness.md``; each is reported at the caller's line.
    """
    config = matcher_config(params)
    pair = PairInfo.of(left_pts, right_pts, image_size, train_image_size,
                       names=("left_pts", "right_pts", "image_size", "train_image_size"))
    fundamental = as_fundamental_matrix(fundamental_matrix, "fundamental_matrix",
                                        optional=True)
    return match_pair(pair, left_desc, right_desc, config, mask=mask,
                      fundamental=fundamental, record_energy=record_energy)
