"""One confidence for every match of :func:`~hopmatch.match_stereo`, network and guided
alike (beyond the paper; docs/method.md, "A confidence that ranks").

The network's ``1 / (1 + exp(u))`` (u the local field, eq. 12's bracket) ranks its own
matches, and the guided pass computes the same field for its pairs, but the field alone
does not say how sharply the images fix the disparity. The refinement does: the
curvature of the ZNCC at its peak (:class:`~hopmatch.matching.refine.Refinement`). The
confidence is a logistic model of both,

``p = 1 / (1 + exp(-(a + b clip(u, -U, U) + c log max(curvature, k_min))))``,

fitted once (pooled over motorcycle and the shared scenes, the same coefficients for
both passes: docs/parameters.md gives the fit and its per-scene ranking), and
``distance = 1 - p``: an estimate of the probability that the match is wrong at 1 px.
It decreases as u or the curvature grows, so keeping the matches below a distance
threshold keeps the best-supported, best-determined ones.
"""

from __future__ import annotations

import numpy as np

#: Intercept a of the logistic model.
CONFIDENCE_BIAS = 3.1
#: Weight b of the local field u.
CONFIDENCE_FIELD = 0.31
#: Weight c of the log curvature of the ZNCC at the refined peak.
CONFIDENCE_CURVATURE = 0.37
#: Fields beyond +-this are clipped (the network's strongest matches all look alike).
FIELD_LIMIT = 10.0
#: Smallest curvature (per px**2) used; a match without a fitted peak (NaN) counts as this.
CURVATURE_FLOOR = 1e-3


def fields_of_distances(distances: np.ndarray) -> np.ndarray:
    """The local field u of each ``1 / (1 + exp(u))`` distance (float64), clipped to
    ``+-FIELD_LIMIT`` (within 1e-3 of u inside the limit, float32 rounding of distances
    near 1 being the largest loss; 0 and 1 map to the limits)."""
    d = np.asarray(distances, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.log1p(-d) - np.log(d)
    return np.clip(np.nan_to_num(u, nan=0.0, posinf=FIELD_LIMIT, neginf=-FIELD_LIMIT),
                   -FIELD_LIMIT, FIELD_LIMIT)


def match_confidence(fields: np.ndarray, curvature: np.ndarray) -> np.ndarray:
    """Estimated probability that each match is correct at 1 px (float64, in (0, 1)).

    Parameters
    ----------
    fields : (M,) array_like
        Local field u of each match (eq. 12's bracket; for a guided match, its field
        among its matched neighbours), clipped to ``+-FIELD_LIMIT``.
    curvature : (M,) array_like
        Minus the second derivative of the ZNCC at the refined peak, per px**2
        (``Refinement.curvature``); NaN or below ``CURVATURE_FLOOR`` counts as the floor.

    Returns
    -------
    (M,) float64 ndarray
        ``1 / (1 + exp(-(a + b u + c log k)))`` with the module's coefficients;
        non-decreasing in u and in the curvature.
    """
    u = np.clip(np.asarray(fields, dtype=np.float64), -FIELD_LIMIT, FIELD_LIMIT)
    k = np.nan_to_num(np.asarray(curvature, dtype=np.float64), nan=CURVATURE_FLOOR)
    z = (CONFIDENCE_BIAS + CONFIDENCE_FIELD * u
         + CONFIDENCE_CURVATURE * np.log(np.maximum(k, CURVATURE_FLOOR)))
    return 1.0 / (1.0 + np.exp(-z))


def confidence_distances(fields: np.ndarray, curvature: np.ndarray) -> np.ndarray:
    """``DMatch.distance`` of each match of :func:`~hopmatch.match_stereo` with the
    refinement on: ``1 - match_confidence(fields, curvature)`` as float32, in [0, 1]
    (lower is better; keeping the matches with ``distance <= t`` keeps those whose
    estimated probability of being wrong is at most about t)."""
    return (1.0 - match_confidence(fields, curvature)).astype(np.float32)
