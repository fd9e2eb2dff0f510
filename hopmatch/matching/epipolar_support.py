"""Where an estimated fundamental matrix is pinned down by its own evidence.

An F estimated from bootstrap correspondences (:func:`~hopmatch.matching.geometry.
estimate_geometry`) is accurate where its inliers lie and may be far off elsewhere: when
the inliers crowd one part of the scene (a chessboard's repeated corners give the bootstrap
nothing to match on the board, and F is fitted to the background), or where a raw photo's
lens distortion bends the true epipolar lines away from any F. A match found along such an
F's rows there agrees with F, so F's own error cannot judge it.

:func:`epipolar_spread` asks instead how well the inliers determine F at the match: F is
fitted again (eight-point, :data:`SUPPORT_RESAMPLES` times) on inliers drawn with
replacement (a bootstrap, with a fixed seed), and the spread of the match's epipolar error
over those fits is the uncertainty of F's lines there. :func:`unsupported` marks the matches
whose spread exceeds :data:`SUPPORT_LIMIT` (per pyramid level of the bootstrap, as its
MAGSAC threshold): ``match_stereo(..., rectified=False)`` drops them (docs/pipelines.md,
"Matches F cannot vouch for").
"""

from __future__ import annotations

import cv2
import numpy as np

from .geometry import BOOTSTRAP_SIDE, EpipolarGeometry, bootstrap_level, symmetric_epipolar_error

#: Refits of F on resampled inliers (:func:`epipolar_spread`), and the largest standard
#: deviation of a match's symmetric epipolar error over them, in full-resolution pixels per
#: pyramid level of the bootstrap, for F to vouch for the match (:func:`unsupported`).
SUPPORT_RESAMPLES = 30
SUPPORT_LIMIT = 0.5
#: Fewest inliers to resample; with fewer, no match is judged (F stands or falls whole).
SUPPORT_MIN_INLIERS = 16
#: Share of the matches whose drop :func:`support_notes` reports.
SUPPORT_WARN_SHARE = 0.25


def epipolar_spread(inliers_left, inliers_right, left, right,
                    resamples: int = SUPPORT_RESAMPLES, seed: int = 0) -> np.ndarray:
    """(N,) float64: for each correspondence ``left[i] <-> right[i]``, the standard
    deviation of its symmetric epipolar error (px) over ``resamples`` fundamental matrices
    fitted (``cv2.findFundamentalMat``, eight-point) to the inlier correspondences
    ``inliers_left <-> inliers_right`` drawn with replacement (``numpy.random.
    default_rng(seed)``: the same draws in any process). Small where the inliers pin F's
    epipolar lines down, large where F is extrapolated. Resamples that give no 3 x 3 F are
    skipped; NaN for every correspondence when none gives one."""
    il = np.asarray(inliers_left, np.float64).reshape(-1, 2)
    ir = np.asarray(inliers_right, np.float64).reshape(-1, 2)
    left = np.asarray(left, np.float64).reshape(-1, 2)
    right = np.asarray(right, np.float64).reshape(-1, 2)
    rng = np.random.default_rng(seed)
    errors = []
    for _ in range(resamples):
        k = rng.integers(0, len(il), len(il))
        try:
            F, _ = cv2.findFundamentalMat(il[k], ir[k], cv2.FM_8POINT)
        except cv2.error:  # a draw of too few distinct points
            continue
        if F is None or F.shape != (3, 3) or not np.isfinite(F).all():
            continue
        errors.append(symmetric_epipolar_error(F / np.linalg.norm(F), left, right))
    if not errors:
        return np.full(len(left), np.nan)
    return np.std(np.array(errors), axis=0)


def unsupported(geometry: EpipolarGeometry, image_shape, left, right) -> np.ndarray:
    """(N,) bool: the matches ``left[i] <-> right[i]`` (full-resolution pixels of images
    of ``image_shape``, (H, W) or (H, W, C)) that the bootstrap inliers of ``geometry``
    do not vouch for: their :func:`epipolar_spread` exceeds :data:`SUPPORT_LIMIT` x
    2**level, level the pyramid level of the bootstrap
    (:func:`~hopmatch.matching.geometry.bootstrap_level`, longer side at most
    :data:`~hopmatch.matching.geometry.BOOTSTRAP_SIDE`), or is NaN. None is marked when
    ``geometry`` has fewer than :data:`SUPPORT_MIN_INLIERS` inliers or no F."""
    n = len(left)
    if geometry.fundamental is None or geometry.n_inliers < SUPPORT_MIN_INLIERS or n == 0:
        return np.zeros(n, bool)
    spread = epipolar_spread(geometry.left_points[geometry.inliers],
                             geometry.right_points[geometry.inliers], left, right)
    limit = SUPPORT_LIMIT * 2.0 ** bootstrap_level(image_shape, BOOTSTRAP_SIDE)
    return ~(spread <= limit)


def support_notes(drop) -> list[str]:
    """The warning about the matches :func:`unsupported` marked (``drop``), as a list of
    one message when they are at least :data:`SUPPORT_WARN_SHARE` of them, else empty."""
    n, k = len(drop), int(np.count_nonzero(drop))
    if n == 0 or k < SUPPORT_WARN_SHARE * n:
        return []
    return [f"match_stereo(rectified=False) dropped {k} of its {n} matches: they lie where "
            "the bootstrap correspondences do not determine the epipolar geometry (few or "
            "none there: a repeated pattern, a bare surface, lens distortion), so the "
            "estimated fundamental matrix cannot vouch for them. With a calibration, "
            "rectify the pair (hopmatch.stereo.rectify) or pass fundamental_matrix"]
