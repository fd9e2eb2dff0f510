"""Matching layer: the sparse Hopfield network (SPEC sections 2-4) and its cv2-like class.

``candidates`` (section 3's search window), ``similarity`` (eqs. 7-9), ``budget`` (resource
limits), ``network`` (the pure :func:`hopfield_match`, eqs. 10-13), ``disambiguate``
(section 4), ``diagnostics`` (warnings about the pair), ``matcher`` (the cv2 class) and
``stereo_match`` (detector and matcher in one call).
"""

from .disambiguate import disambiguate, singular_choice
from .matcher import HopfieldMatcher
from .network import NetworkResult, PairInfo, hopfield_match
from .params import MatcherConfig
from .stereo_match import StereoMatchResult, match_stereo

__all__ = [
    "HopfieldMatcher",
    "MatcherConfig",
    "NetworkResult",
    "PairInfo",
    "StereoMatchResult",
    "disambiguate",
    "hopfield_match",
    "match_stereo",
    "singular_choice",
]
