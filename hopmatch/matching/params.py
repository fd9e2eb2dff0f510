"""Parameters and presets of the Hopfield matcher (one home for both the class and the
function API)."""

from __future__ import annotations

import dataclasses
from typing import Any

from .._params import Param, boolean, choice, integer, real, resolve_params
from ..errors import InvalidArgumentError

#: Parameter specs shared by :class:`HopfieldMatcher` and :func:`hopfield_match`.
MATCHER_PARAMS: tuple[Param, ...] = (
    Param("preset", "default", choice("default", "paper"), doc=(
        "Named parameter set: 'paper' gives the settings of section 4 of Achour & "
        "Mahiddine (2002), 'default' the tuned defaults (docs/parameters.md); explicit "
        "parameters win")),
    # search window of the candidates (epipolar band + disparity range)
    Param("min_disparity", None, real(optional=True), doc=(
        "Smallest disparity x_left - x_right searched, in pixels (may be negative); with "
        "max_disparity None a floor of the range found (None, the default: no floor, so "
        "a pair whose right image is offset sideways keeps its negative disparities), "
        "with max_disparity given None means 0")),
    Param("max_disparity", None, real(optional=True), doc=(
        "Largest disparity searched, in pixels; None: found by a coarse pass of the "
        "network (min_disparity its floor)")),
    Param("max_vertical", 1.0, real(0.0), doc=(
        "Half-height in pixels of the band of rows searched around each left point (with "
        "a fundamental matrix: the largest distance to its epipolar line)")),
    # neighbourhood of interactions (paper: 40 x 20)
    Param("neighbour_width", 40.0, real(0.0), doc=(
        "Width in pixels of the window of left neighbours whose neurons interact (section "
        "4; paper: 40)")),
    Param("neighbour_height", 20.0, real(0.0), doc=(
        "Height in pixels of that window of neighbours (paper: 20)")),
    Param("min_neighbours", 8.0, real(0.0, 1000.0), doc=(
        "When the median left keypoint has fewer than this many other left keypoints in "
        "the neighbour window (sparse keypoints: a large nms_size, max_features, SIFT's), "
        "the window and theta grow until it has about that many, at most 4-fold per side "
        "(hopmatch.matching.neighbourhood.grown_for_density; the network result's config, "
        "match_stereo's result.network.config or the matcher's getLastResult().config, "
        "holds the window used); 0: the window as given, as in the paper")),
    # compatibility, eq. 5
    Param("theta", 2.0, real(0.0), doc=(
        "Threshold theta of the compatibility, eq. 5, in pixels: neighbouring pairs whose "
        "disparity, length and similarity differences add up to more than it inhibit each "
        "other (paper: 10)")),
    Param("slope", 2.0, real(0.0, lo_open=True), doc=(
        "Slope lambda of the compatibility, eq. 5 (paper: 1)")),
    # similarity, eqs. 7-9, weighted into pixel units
    Param("similarity_weight", 1.0, real(0.0), doc=(
        "Pixels per unit of the normalised similarity distance in the compatibility (eq. "
        "10)")),
    Param("similarity_gate", 0.45, real(0.0, optional=True), doc=(
        "Candidates whose normalised similarity distance exceeds it get no neuron (about "
        "1 for unrelated windows); None: no gate, as in the paper")),
    Param("gain_tolerance", 1.1, real(1.0, 1e6), doc=(
        "Relative gain of two windows that eq. 7 allows for: the right window is scaled by "
        "the ratio of their contrasts, clipped to [1/t, t], before the difference (1: eq. "
        "7 as written, as in the paper)")),
    Param("max_candidates", 0, integer(0), doc=(
        "Keep only this many most similar candidates of each left point (0: all)")),
    # energy, eq. 11
    Param("input_bias", -2.5, real(), doc=(
        "External input I of the energy, eq. 11 (paper: 2)")),
    Param("initial_bias", 1.0, real(optional=True), doc=(
        "Annealing: run first with this input from the all-off state, then with "
        "input_bias from that state; None: one run with input_bias (the paper)")),
    Param("uniqueness_weight", 1.0, real(0.0), doc=(
        "Weight of the uniqueness penalties of eq. 11 (one match per point)")),
    # dynamics, eqs. 12-13
    Param("seed", 0, integer(0, 2**63 - 1), doc=(
        "Seed of the random order in which the left points are visited (the same seed "
        "gives the same matches)")),
    Param("stable_iterations", 0, integer(0), doc=(
        "Stop after this many iterations without a change (0: only at a fixed point; "
        "paper: 200)")),
    Param("max_iterations", 1_000_000, integer(1), doc=(
        "Cap on the iterations (one iteration visits one left point)")),
    # disambiguation, section 4
    Param("vertical_threshold", 1.0, real(0.0, lo_open=True), doc=(
        "Tolerance in pixels of the vertical disparity in section 4's disambiguation")),
    Param("cross_check", True, boolean(), doc=(
        "Keep only pairs that are the single choice from both sides (the left-right "
        "check)")),
    # beyond the paper: section 4's vertical test for every kept pair, not only multiples
    Param("vertical_check", "all", choice("multiple", "all"), doc=(
        "SPEC section 4's vertical test: 'multiple' applies it only to points with several "
        "active neurons (the paper); 'all' then also drops every kept pair whose vertical "
        "disparity is vertical_threshold or more from the median of the kept pairs "
        "(disambiguate.vertically_consistent; docs/parameters.md)")),
    Param("vertical_model", "plane", choice("median", "plane"), doc=(
        "the vertical disparity that vertical_check='all', the guided pass and the "
        "refinement measure from: 'median', one value for the whole pair, or 'plane', a "
        "robust plane a + b x + c y through the kept pairs (hopmatch.matching.vertical; "
        "the median when fewer than 50 pairs)")),
    # beyond the paper: reject matches whose windows align better one pixel off
    Param("shift_check", True, boolean(), doc=(
        "Reject matches whose descriptor windows align better one pixel off along the row "
        "(docs/parameters.md)")),
    # beyond the paper: what match_stereo adds to the network's matches (it needs the
    # images, so HopfieldMatcher.match on descriptors alone does not do it)
    Param("guided", True, boolean(), doc=(
        "match_stereo's guided second pass: left points the network left unmatched get a "
        "disparity from a row search near the one their matched neighbours support (or, "
        "far from every match, over the whole range where such peaks agree with one "
        "another), kept only when it passes the network's own field test, a uniqueness "
        "margin and a left-right check (hopmatch.matching.guided; result.passes == 1)")),
    Param("guided_margin", 0.1, real(0.0), doc=(
        "uniqueness margin of the guided pass: the ZNCC of the peak must exceed the best "
        "one at least 3 px away (guided.GUIDED_SHOULDER; within +-3 px) by this much")),
    Param("sharpness_ratio", 1.1, real(1.0, 1e6, optional=True), doc=(
        "match_stereo: when one view's sharpness (second over first differences along its "
        "rows) exceeds the other's by more than this factor, that view is blurred towards "
        "the other's sharpness before detection, to within a Gaussian of 0.6 px "
        "(hopmatch.feature.sharpness; result.sharpness); None: never, as in the paper")),
    Param("tone_tolerance", 0.04, real(0.0, optional=True), doc=(
        "match_stereo: when the grey levels at the two ends of a first match's pairs follow "
        "a curve that departs from a straight line by more than this fraction of its rise "
        "(two exposures, two camera responses), the right view is mapped through the "
        "curve and the pair matched again (hopmatch.matching.tone; result.tone_map); "
        "None: never, as in the paper")),
    Param("gain_field_tolerance", 0.25, real(0.0, optional=True), doc=(
        "match_stereo: when the gain between the two ends of a first match's pairs varies "
        "across the right view (vignetting, uneven light) by more than this in log units "
        "(0.25: by about a quarter), the right view is divided by that gain (with the curve of "
        "tone_tolerance) and the pair matched again (hopmatch.matching.tone; "
        "result.tone_map); None: never, as in the paper")),
    Param("channel_clip_share", 0.15, real(0.0, 1.0, lo_open=True, optional=True), doc=(
        "match_stereo, colour views: when one or two colour channels are at their top "
        "level (255, 65535) on at least this share of one view's pixels more than of the "
        "other's (a brighter view that clips), the pair is matched again on grey levels "
        "made of the other channels, and the match with more pairs kept "
        "(hopmatch.matching.channels; result.grey_channels); None: never, as in the paper")),
    Param("refine", True, boolean(), doc=(
        "match_stereo's sub-pixel refinement: every match's right x moved to the peak of "
        "the ZNCC of 7 x 7 grey windows along the row, by re-centred parabola fits "
        "(hopmatch.matching.refine)")),
    Param("both_features", True, boolean(), doc=(
        "match_stereo: match the pair a second time on the other feature image (grey "
        "levels when the detector is on the gradient, and the reverse) and add that run's "
        "matches where the first matched no left point within 1.5 px and its matches "
        "within 12 px agree on the disparity and the vertical offset "
        "(hopmatch.matching.both_features; result.passes 2 and 3, result.second); about "
        "twice the CPU time, the two runs at once with 2 or more threads; False: one run")),
    # resource budget
    Param("max_neurons", 5_000_000, integer(1), doc=(
        "Budget: most candidate pairs (neurons) allowed; more raise BudgetExceededError "
        "before anything large is allocated")),
    Param("max_interactions", 100_000_000, integer(1), doc=(
        "Budget: most stored interactions (and neighbour pairs) allowed; more raise "
        "BudgetExceededError before allocation")),
)

#: Values each preset sets (the rest keep their defaults). ``paper`` is section 4 of
#: Achour & Mahiddine (2002); ``default`` is tuned on motorcycle and ../shared/data
#: (docs/parameters.md says how).
PRESETS: dict[str, dict] = {
    "paper": {
        # 40 x 30 search window centred on i shifted by the maximal disparity (10 px)
        "min_disparity": -10.0,
        "max_disparity": 30.0,
        "max_vertical": 15.0,
        "neighbour_width": 40.0,
        "neighbour_height": 20.0,
        "min_neighbours": 0.0,
        "theta": 10.0,
        "slope": 1.0,
        "similarity_weight": 1.0,
        "similarity_gate": None,
        "gain_tolerance": 1.0,
        "max_candidates": 0,
        "input_bias": 2.0,
        "initial_bias": None,
        "uniqueness_weight": 1.0,
        "stable_iterations": 200,
        "vertical_threshold": 1.0,
        "vertical_check": "multiple",
        "shift_check": False,
        "guided": False,
        "sharpness_ratio": None,
        "tone_tolerance": None,
        "gain_field_tolerance": None,
        "channel_clip_share": None,
        "refine": False,
        "both_features": False,
        "vertical_model": "median",
    },
}

# ``preset="default"`` restores the defaults of everything another preset changes.
PRESETS["default"] = {
    name: next(p.default for p in MATCHER_PARAMS if p.name == name)
    for name in PRESETS["paper"]
}

#: The matcher's parameters as one frozen value (one field per :data:`MATCHER_PARAMS` entry,
#: same name): what :func:`~hopmatch.matching.network.hopfield_match` runs with, recorded in
#: each :class:`~hopmatch.matching.network.NetworkResult` with ``max_disparity`` resolved.
MatcherConfig = dataclasses.make_dataclass(
    "MatcherConfig", [(p.name, Any) for p in MATCHER_PARAMS], frozen=True,
    namespace={"__doc__": "The Hopfield matcher's parameters (see docs/parameters.md).",
               "__module__": __name__})


def check_disparity_order(min_disparity: float, max_disparity: float | None) -> None:
    """Refuse ``max_disparity < min_disparity`` (None: resolved later, not checked)."""
    if max_disparity is not None and min_disparity is not None \
            and max_disparity < min_disparity:
        raise InvalidArgumentError(
            f"`max_disparity` ({max_disparity}) must not be below `min_disparity` "
            f"({min_disparity}); swap them or leave max_disparity=None (a quarter "
            "of the image width)", argument="max_disparity"
        )


def matcher_config(params: dict, owner: str = "hopfield_match") -> MatcherConfig:
    """:data:`MatcherConfig` of keyword parameters (defaults, then ``preset``, then the
    keywords), each checked; unknown names raise naming ``owner``."""
    values = resolve_params(MATCHER_PARAMS, PRESETS, params, owner)
    check_disparity_order(values["min_disparity"], values["max_disparity"])
    return MatcherConfig(**values)
