"""Unrectified pairs: epipolar distances, the fundamental matrix of matches
(``cv2.findFundamentalMat``) and uncalibrated rectification
(``cv2.stereoRectifyUncalibrated``).

``F`` maps left points to right epipolar lines, ``[xr, yr, 1] @ F @ [xl, yl, 1] == 0``, as
``cv2.findFundamentalMat(left_pts, right_pts)`` returns it.
"""

from __future__ import annotations

import numbers

import cv2
import numpy as np

from .._validate import as_fundamental_matrix, as_points, as_real, cv2_call
from ..errors import BudgetExceededError, InvalidArgumentError
from .checks import INTERPOLATIONS, as_image_pair, as_point_pair, check_option

__all__ = [
    "MAX_PAIRS",
    "epipolar_distance_matrix",
    "epipolar_distances",
    "estimate_fundamental",
    "rectify_uncalibrated",
]

#: Default bound on ``Nl * Nr`` for :func:`epipolar_distance_matrix` (about 100 MB peak).
MAX_PAIRS = 4_000_000

#: The methods :func:`estimate_fundamental` accepts (``cv2.FM_7POINT``, which may return
#: three solutions, is left out), with the names messages show.
_F_METHODS = {
    cv2.FM_8POINT: "cv2.FM_8POINT",
    cv2.FM_RANSAC: "cv2.FM_RANSAC",
    cv2.FM_LMEDS: "cv2.FM_LMEDS",
}
for _name in ("USAC_DEFAULT", "USAC_PARALLEL", "USAC_FM_8PTS", "USAC_FAST",
              "USAC_ACCURATE", "USAC_PROSAC", "USAC_MAGSAC"):
    if hasattr(cv2, _name):
        _F_METHODS.setdefault(getattr(cv2, _name), f"cv2.{_name}")
del _name


def _epilines(pts: np.ndarray, which: int, f: np.ndarray) -> np.ndarray:
    """(N, 3) float64 lines ``a x + b y + c = 0`` with ``a**2 + b**2 == 1``."""
    if len(pts) == 0:
        return np.zeros((0, 3), np.float64)
    lines = cv2_call("cv2.computeCorrespondEpilines with `F`", cv2.computeCorrespondEpilines,
                      pts.reshape(-1, 1, 2).astype(np.float64), which, f)
    return lines.reshape(-1, 3)


def _reduce_option(reduce):
    if reduce not in ("mean", "max"):
        raise InvalidArgumentError(f"`reduce` must be one of 'mean', 'max'; got {reduce!r}")
    return np.add if reduce == "mean" else np.maximum


def epipolar_distances(left_pts, right_pts, F, *, reduce: str = "mean") -> np.ndarray:
    """Symmetric epipolar distance of each match of an unrectified pair.

    For match ``i``: ``d_right`` = distance of ``right_pts[i]`` to the epipolar line of
    ``left_pts[i]`` in the right image, ``d_left`` the converse, both from
    ``cv2.computeCorrespondEpilines``.

    Parameters
    ----------
    left_pts, right_pts : (N, 2) array_like or sequence of cv2.KeyPoint
        ``(x, y)`` of the two points of each match (undistorted pixels).
    F : (3, 3) array_like
        Fundamental matrix with ``[xr, yr, 1] @ F @ [xl, yl, 1] == 0``
        (``cv2.findFundamentalMat(left_pts, right_pts)``).
    reduce : {'mean', 'max'}
        Combine the two distances by their mean or their maximum.

    Returns
    -------
    distances : (N,) float32 ndarray
        In pixels (inf beyond float32's range).

    Examples
    --------
    >>> import numpy as np
    >>> F = np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0.]])   # rectified pair: yl == yr
    >>> epipolar_distances([[10, 5], [10, 5]], [[3, 5], [3, 8]], F).tolist()
    [0.0, 3.0]
    """
    left, right = as_point_pair(left_pts, right_pts)
    f = as_fundamental_matrix(F)
    op = _reduce_option(reduce)
    lr = _epilines(left, 1, f)   # lines in the right image
    ll = _epilines(right, 2, f)  # lines in the left image
    dr = np.abs(np.einsum("ij,ij->i", lr[:, :2], right) + lr[:, 2])
    dl = np.abs(np.einsum("ij,ij->i", ll[:, :2], left) + ll[:, 2])
    out = op(dr, dl)
    if reduce == "mean":
        out = out / 2
    with np.errstate(over="ignore"):  # a distance beyond float32's range is inf
        return np.ascontiguousarray(out, dtype=np.float32)


def epipolar_distance_matrix(left_pts, right_pts, F, *, reduce: str = "mean",
                             max_pairs: int = MAX_PAIRS) -> np.ndarray:
    """Symmetric epipolar distance of every (left, right) pair: an ``(Nl, Nr)`` matrix.

    For candidate filtering on small point sets only: it allocates several ``Nl * Nr``
    float64 arrays, so ``Nl * Nr`` is limited to ``max_pairs`` (default 4 million, about
    100 MB peak). For aligned matches use :func:`epipolar_distances`, which is linear.

    Parameters
    ----------
    left_pts : (Nl, 2) array_like or sequence of cv2.KeyPoint
    right_pts : (Nr, 2) array_like or sequence of cv2.KeyPoint
        ``(x, y)`` points of the two images (undistorted pixels).
    F : (3, 3) array_like
        Fundamental matrix with ``[xr, yr, 1] @ F @ [xl, yl, 1] == 0``.
    reduce : {'mean', 'max'}
        As in :func:`epipolar_distances`.
    max_pairs : int
        Largest ``Nl * Nr`` accepted.

    Returns
    -------
    distances : (Nl, Nr) float32 ndarray
        ``distances[i, j]`` = ``epipolar_distances(left_pts[i], right_pts[j], F)``.

    Raises
    ------
    BudgetExceededError
        When ``Nl * Nr > max_pairs``, before any large allocation.

    Examples
    --------
    >>> import numpy as np
    >>> F = np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0.]])
    >>> epipolar_distance_matrix([[10, 5]], [[3, 5], [3, 8]], F).tolist()
    [[0.0, 3.0]]
    """
    left = as_points(left_pts, "left_pts")
    right = as_points(right_pts, "right_pts")
    f = as_fundamental_matrix(F)
    op = _reduce_option(reduce)
    if isinstance(max_pairs, bool) or not isinstance(max_pairs, numbers.Integral) or max_pairs < 0:
        raise InvalidArgumentError(f"`max_pairs` must be a non-negative integer, got {max_pairs!r}")
    pairs = len(left) * len(right)
    if pairs > max_pairs:
        raise BudgetExceededError(
            f"epipolar_distance_matrix of {len(left)} x {len(right)} points needs "
            f"{pairs:,} pairs, more than max_pairs={max_pairs:,}; filter candidates first, "
            "use epipolar_distances on aligned matches, or raise max_pairs"
        )
    lr = _epilines(left, 1, f)   # (Nl, 3), lines in the right image
    ll = _epilines(right, 2, f)  # (Nr, 3), lines in the left image
    hr = np.hstack([right.astype(np.float64), np.ones((len(right), 1))])
    hl = np.hstack([left.astype(np.float64), np.ones((len(left), 1))])
    out = op(np.abs(lr @ hr.T), np.abs(hl @ ll.T))
    if reduce == "mean":
        out /= 2
    return np.ascontiguousarray(out, dtype=np.float32)


def estimate_fundamental(left_pts, right_pts, method: int = cv2.FM_RANSAC,
                         threshold: float = 1.0, confidence: float = 0.999):
    """Fundamental matrix of matched points (``cv2.findFundamentalMat``).

    Parameters
    ----------
    left_pts, right_pts : (N, 2) array_like or sequence of cv2.KeyPoint
        ``(x, y)`` of the two points of each match, N >= 8.
    method : int
        ``cv2.FM_RANSAC`` (default), ``cv2.FM_LMEDS``, ``cv2.FM_8POINT`` or a
        ``cv2.USAC_*`` method. ``cv2.FM_7POINT`` (up to 3 solutions) is not offered.
    threshold : float
        RANSAC inlier distance to the epipolar line, in pixels (> 0).
    confidence : float
        Wanted confidence, in (0, 1).

    Returns
    -------
    F : (3, 3) float64 ndarray
        With ``[xr, yr, 1] @ F @ [xl, yl, 1] == 0`` for inliers.
    inliers : (N,) bool ndarray
        Matches consistent with ``F`` (all True for ``cv2.FM_8POINT``).

    Raises
    ------
    InvalidArgumentError
        With fewer than 8 matches, or when OpenCV finds no F (degenerate configuration:
        points on a line or a plane seen without parallax, repeated points...).

    Examples
    --------
    >>> import cv2, numpy as np
    >>> rng = np.random.default_rng(0)
    >>> left = rng.uniform(0, 100, (20, 2)).astype(np.float32)
    >>> right = left - [[8, 0]] * rng.uniform(1, 3, (20, 1))   # same rows, many depths
    >>> F, inliers = estimate_fundamental(left, right, cv2.FM_8POINT)
    >>> F.shape, bool(inliers.all()), bool(epipolar_distances(left, right, F).max() < 1e-3)
    ((3, 3), True, True)
    """
    left, right = as_point_pair(left_pts, right_pts)
    method = check_option(method, "method", _F_METHODS)
    threshold = as_real(threshold, "threshold", lo=0.0, lo_open=True)
    confidence = as_real(confidence, "confidence", lo=0.0, hi=1.0, lo_open=True)
    if confidence >= 1.0:
        raise InvalidArgumentError(f"`confidence` must be in (0, 1), got {confidence!r}")
    if len(left) < 8:
        raise InvalidArgumentError(
            f"estimate_fundamental needs at least 8 matches in `left_pts` and `right_pts`, "
            f"got {len(left)}"
        )
    f, mask = cv2_call("cv2.findFundamentalMat", cv2.findFundamentalMat,
                        left.astype(np.float64), right.astype(np.float64), method,
                        threshold, confidence)
    if f is None or f.shape != (3, 3) or not np.isfinite(f).all():
        raise InvalidArgumentError(
            f"cv2.findFundamentalMat found no fundamental matrix for these {len(left)} "
            "matches: the configuration is degenerate (points on a line, a plane without "
            "parallax, repeated points) or has too few inliers for the threshold"
        )
    inliers = (np.ones(len(left), bool) if mask is None
               else np.ascontiguousarray(mask.ravel() != 0))
    return np.ascontiguousarray(f, dtype=np.float64), inliers


def rectify_uncalibrated(left, right, left_pts, right_pts, F, *, threshold: float = 5.0,
                         interpolation: int = cv2.INTER_LINEAR):
    """Rectify an uncalibrated pair: ``cv2.stereoRectifyUncalibrated`` + ``warpPerspective``.

    Parameters
    ----------
    left, right : (H, W) or (H, W, C) ndarray
        The images (same height and width; any cv2 dtype).
    left_pts, right_pts : (N, 2) array_like or sequence of cv2.KeyPoint
        ``(x, y)`` of matches (N >= 8), ideally the inliers of :func:`estimate_fundamental`.
    F : (3, 3) array_like
        Fundamental matrix with ``[xr, yr, 1] @ F @ [xl, yl, 1] == 0``.
    threshold : float
        Matches whose epipolar distance exceeds it are ignored (> 0), as in OpenCV.
    interpolation : int
        ``cv2.INTER_NEAREST``, ``INTER_LINEAR``, ``INTER_CUBIC`` or ``INTER_LANCZOS4``.

    Returns
    -------
    left_rect, right_rect : ndarray
        Warped images, same shape and dtype as the inputs.
    H1, H2 : (3, 3) float64 ndarray
        Homographies mapping original to rectified pixels (``cv2.perspectiveTransform`` of
        points with them gives rectified points).

    Notes
    -----
    Without calibration the rectification is projective: disparities are not metric and
    strong distortion or near-degenerate matches can give extreme warps.

    Examples
    --------
    >>> import cv2, numpy as np
    >>> rng = np.random.default_rng(0)
    >>> left_pts = rng.uniform(0, 80, (20, 2)).astype(np.float32)
    >>> right_pts = left_pts - [[4, 0]] * rng.uniform(1, 3, (20, 1))
    >>> F, _ = estimate_fundamental(left_pts, right_pts, cv2.FM_8POINT)
    >>> img = rng.integers(0, 255, (60, 80), dtype=np.uint8)
    >>> left_rect, right_rect, H1, H2 = rectify_uncalibrated(img, img, left_pts, right_pts, F)
    >>> left_rect.shape, left_rect.dtype, H1.shape
    ((60, 80), dtype('uint8'), (3, 3))
    """
    left, right = as_image_pair(left, right)
    lp, rp = as_point_pair(left_pts, right_pts)
    f = as_fundamental_matrix(F)
    threshold = as_real(threshold, "threshold", lo=0.0, lo_open=True)
    interpolation = check_option(interpolation, "interpolation", INTERPOLATIONS)
    if len(lp) < 8:
        raise InvalidArgumentError(
            f"rectify_uncalibrated needs at least 8 matches in `left_pts` and `right_pts`, "
            f"got {len(lp)}"
        )
    size = (left.shape[1], left.shape[0])
    ok, h1, h2 = cv2_call("cv2.stereoRectifyUncalibrated", cv2.stereoRectifyUncalibrated,
                           lp.astype(np.float64), rp.astype(np.float64), f, size,
                           threshold=threshold)
    if not ok or h1 is None or h2 is None:
        raise InvalidArgumentError(
            "cv2.stereoRectifyUncalibrated failed: too few matches within `threshold` of "
            "their epipolar lines (check F against the points, or raise threshold)"
        )
    out = [
        cv2_call(f"cv2.warpPerspective of `{side}`", cv2.warpPerspective, img, h, size,
                  flags=interpolation, borderMode=cv2.BORDER_CONSTANT).reshape(img.shape)
        for img, h, side in ((left, h1, "left"), (right, h2, "right"))
    ]
    return out[0], out[1], np.asarray(h1, np.float64), np.asarray(h2, np.float64)
