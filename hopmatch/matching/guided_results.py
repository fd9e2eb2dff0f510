"""What the guided second pass (:mod:`hopmatch.matching.guided`) returns and says: its
matches (:class:`GuidedMatches`), the images it falls back on (:class:`GreyFallback`), and
where each left point it considered stopped (:class:`GuidedSearch`, :data:`GUIDED_STAGES`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._kernels import guided as _k
from .similarity import match_distance

#: What :func:`~hopmatch.matching.guided.guided_search` says of each left point it
#: considered, in the order of the tests (``GuidedSearch.stage`` indexes it): accepted;
#: fewer than ``min_support`` matched neighbours (in the largest window it may take them
#: from); a window of the search leaves the image; the left window has no contrast; the
#: best ZNCC within ``search`` px lies more than ``radius`` px from the prediction; it
#: lies at the end of the searched range; its ZNCC is below ``min_zncc``; it is not ahead
#: of the runner-up (:data:`~hopmatch.matching.guided.GUIDED_SHOULDER`) by the uniqueness
#: margin; searching back from the right position finds another left position (the
#: left-right check); its field is not above ``min_field`` (continuity).
GUIDED_STAGES = ("accepted", "few neighbours", "outside image", "flat window",
                 "off prediction", "not a peak", "low ZNCC", "uniqueness margin",
                 "left-right check", "continuity")
(STAGE_ACCEPTED, STAGE_FEW_NEIGHBOURS, STAGE_OUTSIDE, STAGE_FLAT, STAGE_OFF_PREDICTION,
 STAGE_NOT_PEAK, STAGE_LOW_ZNCC, STAGE_MARGIN, STAGE_LEFT_RIGHT,
 STAGE_CONTINUITY) = range(len(GUIDED_STAGES))


@dataclass(frozen=True)
class GreyFallback:
    """The images the guided row search falls back on where its peak on the feature image
    G is too weak (:data:`~hopmatch.matching.guided.GUIDED_FALLBACK`): the pair's grey
    levels, normalised as G's input is
    (:func:`~hopmatch.feature.gradient.normalised_intensity`). The left windows of the
    points searched again are cut from ``left`` when needed (eqs. 8-9 on grey levels,
    :func:`~hopmatch.feature.descriptor.gradient_windows`, ``window_size`` a side).

    Attributes
    ----------
    left, right : (H, W) float32 ndarray
        The normalised grey images.
    window_size : int
        Side of the windows (odd; the descriptor size of G's windows).
    """

    left: np.ndarray
    right: np.ndarray
    window_size: int


@dataclass(frozen=True)
class GuidedMatches:
    """Matches of the guided pass, one entry per match.

    Attributes
    ----------
    query_idx : (K,) int32 ndarray
        Left point of each guided match (one that the network left unmatched).
    right_points : (K, 2) float32 ndarray
        Its right position (x, y), sub-pixel: on the row the vertical offset predicts.
    distances : (K,) float32 ndarray
        ``1 / (1 + exp(u))`` of the match's field u, as the network's ``distances``.
    fields : (K,) float64 ndarray
        u: eq. 12's bracket for the guided pair alone in its row and column (> 0).
    zncc, second : (K,) float64 ndarray
        The ZNCC of the peak, and the best ZNCC at least two pixels from it in the wider
        range (``zncc - second >= margin``).
    similarity : (K,) float64 ndarray
        Eq. 7's normalised distance of the pair (the network's similarity term).
    """

    query_idx: np.ndarray
    right_points: np.ndarray
    distances: np.ndarray
    fields: np.ndarray
    zncc: np.ndarray
    second: np.ndarray
    similarity: np.ndarray


def empty_guided() -> GuidedMatches:
    """A :class:`GuidedMatches` without matches."""
    z = np.zeros(0)
    return GuidedMatches(np.zeros(0, np.int32), np.zeros((0, 2), np.float32),
                         np.zeros(0, np.float32), z, z, z, z)


def accepted_matches(keep, q, xr, yr, u, best, second, sim) -> GuidedMatches:
    """The searched left points ``q`` where ``keep`` holds, as :class:`GuidedMatches`: right
    points ``(xr, yr)``, fields ``u`` (and their :func:`match_distance`), peak and second
    ZNCC ``best``, ``second`` and eq. 7's distance ``sim``, each indexed like ``q``."""
    acc = np.flatnonzero(keep)
    return GuidedMatches(
        query_idx=q[acc].astype(np.int32),
        right_points=np.stack((xr[acc], yr[acc]), axis=1).astype(np.float32),
        distances=match_distance(u[acc]).astype(np.float32), fields=u[acc],
        zncc=best[acc], second=second[acc], similarity=sim[acc])


def search_stages(status, best, min_zncc) -> np.ndarray:
    """(Q,) int8: the :data:`GUIDED_STAGES` code of each row search's kernel status, the
    kernel's "weak" peak split by its ZNCC ``best`` (below ``min_zncc``: low ZNCC; else the
    uniqueness margin); a found peak is :data:`STAGE_ACCEPTED` (the field test follows)."""
    codes = np.array([STAGE_ACCEPTED, STAGE_OUTSIDE, STAGE_FLAT, STAGE_OFF_PREDICTION,
                      STAGE_NOT_PEAK, STAGE_LEFT_RIGHT, STAGE_MARGIN], dtype=np.int8)
    out = codes[np.asarray(status, dtype=np.int64)]
    out[(status == _k.WEAK) & ~(np.asarray(best) >= min_zncc)] = STAGE_LOW_ZNCC
    return out


@dataclass(frozen=True)
class GuidedSearch:
    """What :func:`~hopmatch.matching.guided.guided_search` found: ``queries`` (Q,) int64,
    the left points it considered; ``stage`` (Q,) int8, where each stopped (:data:`GUIDED_STAGES`);
    ``matches``, the :class:`GuidedMatches` of those at :data:`STAGE_ACCEPTED`; and
    ``predicted`` (Q,) float64, the disparity the search was centred on (NaN for the
    points with too few neighbours)."""

    queries: np.ndarray
    stage: np.ndarray
    matches: GuidedMatches
    predicted: np.ndarray

    @classmethod
    def none(cls) -> GuidedSearch:
        """A search that considered no left point."""
        return cls(np.zeros(0, np.int64), np.zeros(0, np.int8), empty_guided(), np.zeros(0))

    @classmethod
    def of(cls, queries, stage) -> GuidedSearch:
        """A search that accepted none of ``queries`` (stopped at ``stage``)."""
        return cls(np.asarray(queries, np.int64), stage, empty_guided(),
                   np.full(len(queries), np.nan))
