"""Matching layer: the sparse Hopfield network (SPEC sections 2-4) and its cv2-like class."""

from .disambiguate import disambiguate, singular_choice
from .matcher import HopfieldMatcher, hopfield_match
from .network import NetworkResult
from .stereo_match import StereoMatchResult, match_stereo

__all__ = [
    "HopfieldMatcher",
    "NetworkResult",
    "StereoMatchResult",
    "disambiguate",
    "hopfield_match",
    "match_stereo",
    "singular_choice",
]
