"""What :func:`~hopmatch.matching.stereo_match.match_stereo` returns."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..feature.detector import keypoints_from_arrays
from ..feature.sharpness import SharpnessMatch
from .geometry import EpipolarGeometry
from .guided_results import GuidedMatches
from .matcher import dmatches
from .network import NetworkResult
from .refine import Refinement
from .tone import ToneMap
from .vertical import RowOffset

#: ``StereoMatchResult.passes`` of a match found by the network.
PASS_NETWORK = 0
#: ``StereoMatchResult.passes`` of a match found by the guided second pass.
PASS_GUIDED = 1


@dataclass(eq=False)
class StereoMatchResult:
    """What :func:`match_stereo` found.

    Attributes
    ----------
    points_left : (Nl, 2) float32 ndarray
        All detected (and described) left points, (x, y).
    points_right : (Nr + K, 2) float32 ndarray
        The ``n_detected_right`` detected right points, then one sub-pixel right point per
        guided match (K of them). With ``refine``, a detected point that a match uses is
        at its refined position (``network.train_idx`` still indexes the same rows).
    query_idx, train_idx : (M,) int32 ndarrays
        Matches as indices into ``points_left`` / ``points_right``: the network's first
        (in its order, ``network.query_idx`` but those the half-window test dropped), then
        the guided ones.
    distances : (M,) float32 ndarray
        ``DMatch.distance`` of each match, lower is better. With the refinement (the
        default): ``1 - p``, p the estimated probability that the match is correct at
        1 px from its local field u and the curvature of the ZNCC at its refined peak
        (:func:`~hopmatch.matching.confidence.confidence_distances`), one scale for both
        passes. Without it (``refine=False``, ``preset="paper"``): ``1 / (1 + exp(u))``
        (see :class:`HopfieldMatcher`); for a guided match, u is the field of the guided
        pair among its matched neighbours. ``network.distances`` is always the latter.
    network : NetworkResult
        Everything the network computed (fields, energy, energy trace...), unrefined.
    timings : dict
        Seconds spent in ``detect_left``, ``detect_right`` and ``match`` (the network and
        the steps after it), and ``geometry`` with ``rectified=False``.
    passes : (M,) uint8 ndarray
        Which pass found each match: :data:`PASS_NETWORK` (0) or :data:`PASS_GUIDED` (1);
        with ``both_features``, 2 and 3 for the network and the guided pass of the run on
        the other feature image (``second``).
    n_detected_right : int
        How many rows of ``points_right`` are detected points (the rest are guided).
    guided : GuidedMatches or None
        What the guided pass found (None when it did not run).
    refinement : Refinement or None
        The refinement of each match, in match order (None when it did not run); a match
        is moved only where ``refinement.ok``.
    row_offset : RowOffset or None
        The vertical offset ``yl - yr`` the guided pass and the refinement searched along.
    match_timings : dict
        How ``timings["match"]`` splits: seconds in the ``network``, the ``guided`` pass
        and the ``refine`` step.
    fundamental_matrix : (3, 3) float64 ndarray or None
        With ``rectified=False``: the F the matches were searched along
        (``[xr, yr, 1] @ F @ [xl, yl, 1] == 0``); otherwise the ``fundamental_matrix``
        given, or None.
    geometry : EpipolarGeometry or None
        With ``rectified=False``: how F was found (bootstrap correspondences, inliers,
        median epipolar error, or the reason none was accepted).
    sharpness : SharpnessMatch or None
        Each view's sharpness and the Gaussian sigma it was blurred with before detection
        (``sharpness_ratio``; :mod:`hopmatch.feature.sharpness`); with ``rectified=False``
        measured on the left image and the right one aligned with it (None when no
        geometry was found).
    tone_map : ToneMap or None
        The map from the right view's grey levels to the left view's (a curve and a gain
        that varies across the view), read off a first match (:mod:`hopmatch.matching.tone`;
        None: too few matches, no increasing curve, or ``tone_tolerance`` and
        ``gain_field_tolerance`` both None; with ``rectified=False`` read on the left image
        and the right one aligned with it). When its
        ``nonlinearity`` exceeds ``tone_tolerance`` or its ``field_range``
        ``gain_field_tolerance``, the right view was mapped through it and the pair matched
        again, and where that found more matches they are returned
        (``tone_map.used``).
    second : StereoMatchResult or None
        With ``both_features``: the run on the other feature image, whole; the matches
        of it that were added are those of ``passes`` 2 and 3
        (:mod:`hopmatch.matching.both_features`). None otherwise.
    grey_channels : tuple of int or None
        None: the views' grey levels were ``cv2.COLOR_BGR2GRAY``'s (or they were grey).
        Otherwise the colour channels (0 B, 1 G, 2 R) the grey levels of both views were
        made of: one view clipped the others (``channel_clip_share``;
        :mod:`hopmatch.matching.channels`).
    """

    points_left: np.ndarray
    points_right: np.ndarray
    responses_left: np.ndarray
    responses_right: np.ndarray
    query_idx: np.ndarray
    train_idx: np.ndarray
    distances: np.ndarray
    network: NetworkResult
    keypoint_size: float
    timings: dict = field(default_factory=dict)
    passes: np.ndarray | None = None
    n_detected_right: int | None = None
    guided: GuidedMatches | None = None
    refinement: Refinement | None = None
    row_offset: RowOffset | None = None
    match_timings: dict = field(default_factory=dict)
    fundamental_matrix: np.ndarray | None = None
    geometry: EpipolarGeometry | None = None
    sharpness: SharpnessMatch | None = None
    tone_map: ToneMap | None = None
    grey_channels: tuple | None = None
    second: StereoMatchResult | None = None

    def __post_init__(self):
        if self.passes is None:
            self.passes = np.zeros(len(self.query_idx), dtype=np.uint8)
        if self.n_detected_right is None:
            self.n_detected_right = len(self.points_right)

    @property
    def matched_left(self) -> np.ndarray:
        """(M, 2) float32: the left point of each match."""
        return self.points_left[self.query_idx]

    @property
    def matched_right(self) -> np.ndarray:
        """(M, 2) float32: the right point of each match."""
        return self.points_right[self.train_idx]

    @property
    def disparities(self) -> np.ndarray:
        """(M,) float32: ``x_left - x_right`` of each match."""
        return (self.matched_left[:, 0] - self.matched_right[:, 0]).astype(np.float32)

    @cached_property
    def keypoints_left(self) -> tuple:
        """Left keypoints as ``cv2.KeyPoint`` (built on first access)."""
        return keypoints_from_arrays(self.points_left, self.responses_left, self.keypoint_size)

    @cached_property
    def keypoints_right(self) -> tuple:
        """Right keypoints as ``cv2.KeyPoint`` (built on first access)."""
        return keypoints_from_arrays(self.points_right, self.responses_right, self.keypoint_size)

    @cached_property
    def matches(self) -> tuple:
        """The matches as ``cv2.DMatch`` (built on first access)."""
        return dmatches(self.query_idx, self.train_idx, self.distances)
