"""Parameters and presets of the Hopfield matcher (one home for both the class and the
function API)."""

from __future__ import annotations

import dataclasses
from typing import Any

from .._params import Param, boolean, choice, integer, real, resolve_params
from ..errors import InvalidArgumentError

#: Parameter specs shared by :class:`HopfieldMatcher` and :func:`hopfield_match`.
MATCHER_PARAMS: tuple[Param, ...] = (
    Param("preset", "default", choice("default", "paper")),
    # search window of the candidates (epipolar band + disparity range)
    Param("min_disparity", 0.0, real(optional=True)),
    Param("max_disparity", None, real(optional=True)),
    Param("max_vertical", 1.0, real(0.0)),
    # neighbourhood of interactions (paper: 40 x 20)
    Param("neighbour_width", 40.0, real(0.0)),
    Param("neighbour_height", 20.0, real(0.0)),
    # compatibility, eq. 5
    Param("theta", 2.0, real(0.0)),
    Param("slope", 2.0, real(0.0, lo_open=True)),
    # similarity, eqs. 7-9, weighted into pixel units
    Param("similarity_weight", 1.0, real(0.0)),
    Param("similarity_gate", 0.45, real(0.0, optional=True)),
    Param("max_candidates", 0, integer(0)),
    # energy, eq. 11
    Param("input_bias", -2.5, real()),
    Param("initial_bias", 1.0, real(optional=True)),
    Param("uniqueness_weight", 1.0, real(0.0)),
    # dynamics, eqs. 12-13
    Param("seed", 0, integer(0, 2**63 - 1)),
    Param("stable_iterations", 0, integer(0)),
    Param("max_iterations", 1_000_000, integer(1)),
    # disambiguation, section 4
    Param("vertical_threshold", 1.0, real(0.0, lo_open=True)),
    Param("cross_check", True, boolean()),
    # beyond the paper: section 4's vertical test for every kept pair, not only multiples
    Param("vertical_check", "all", choice("multiple", "all"), doc=(
        "SPEC section 4's vertical test: 'multiple' applies it only to points with several "
        "active neurons (the paper); 'all' then also drops every kept pair whose vertical "
        "disparity is vertical_threshold or more from the median of the kept pairs "
        "(disambiguate.vertically_consistent; docs/parameters.md)")),
    # beyond the paper: reject matches whose windows align better one pixel off
    Param("shift_check", True, boolean()),
    # resource budget
    Param("max_neurons", 5_000_000, integer(1)),
    Param("max_interactions", 100_000_000, integer(1)),
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
        "theta": 10.0,
        "slope": 1.0,
        "similarity_weight": 1.0,
        "similarity_gate": None,
        "max_candidates": 0,
        "input_bias": 2.0,
        "initial_bias": None,
        "uniqueness_weight": 1.0,
        "stable_iterations": 200,
        "vertical_threshold": 1.0,
        "vertical_check": "multiple",
        "shift_check": False,
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
            f"({min_disparity}); swap them or leave max_disparity=None (the range is "
            "then found by a coarse pass, min_disparity its floor)"
        )


def matcher_config(params: dict, owner: str = "hopfield_match") -> MatcherConfig:
    """:data:`MatcherConfig` of keyword parameters (defaults, then ``preset``, then the
    keywords), each checked; unknown names raise naming ``owner``."""
    values = resolve_params(MATCHER_PARAMS, PRESETS, params, owner)
    check_disparity_order(values["min_disparity"], values["max_disparity"])
    return MatcherConfig(**values)
