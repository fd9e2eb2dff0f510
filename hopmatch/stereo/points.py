"""Keypoints and matches: cv2 objects to aligned point arrays and back, and disparities.

:func:`matched_points` turns a cv2 matcher's ``DMatch`` list into two aligned ``(M, 2)``
arrays, :func:`keypoints_and_matches` does the converse (for ``cv2.drawMatches``), and
:func:`match_disparities` gives the disparity ``xl - xr`` of each aligned match.
"""

from __future__ import annotations

import cv2
import numpy as np

from .._validate import as_match_indices, as_points, as_real
from ..errors import InvalidArgumentError
from .checks import as_point_pair, as_values

__all__ = ["keypoints_and_matches", "match_disparities", "matched_points"]


def matched_points(query_kpts, train_kpts, matches) -> tuple[np.ndarray, np.ndarray]:
    """The matched points of a cv2 matcher's result, as two aligned point arrays.

    Parameters
    ----------
    query_kpts : sequence of cv2.KeyPoint or (Nq, 2) array_like
        Points of the query (usually left) image; ``DMatch.queryIdx`` indexes them.
    train_kpts : sequence of cv2.KeyPoint or (Nt, 2) array_like
        Points of the train (usually right) image; ``DMatch.trainIdx`` indexes them.
    matches : sequence of cv2.DMatch or (M, 2) int array_like
        As returned by ``cv2.BFMatcher.match(query_desc, train_desc)``, or rows of
        ``(query_index, train_index)``.

    Returns
    -------
    left_pts, right_pts : (M, 2) float32 ndarray
        ``(x, y)`` of the query and train point of each match, in match order. Zero
        matches give two ``(0, 2)`` arrays.

    Raises
    ------
    InvalidArgumentError
        When an index is out of range (often: query and train swapped).
    InvalidTypeError
        When ``matches`` holds something other than ``cv2.DMatch`` (e.g. knnMatch's lists).

    Examples
    --------
    >>> import cv2
    >>> q = [cv2.KeyPoint(10, 5, 1), cv2.KeyPoint(20, 6, 1)]
    >>> t = [cv2.KeyPoint(7, 6, 1), cv2.KeyPoint(4, 5, 1)]
    >>> left, right = matched_points(q, t, [cv2.DMatch(0, 1, 0.5), cv2.DMatch(1, 0, 0.7)])
    >>> left.tolist(), right.tolist(), left.dtype
    ([[10.0, 5.0], [20.0, 6.0]], [[4.0, 5.0], [7.0, 6.0]], dtype('float32'))
    """
    query = as_points(query_kpts, "query_kpts")
    train = as_points(train_kpts, "train_kpts")
    idx = as_match_indices(matches)
    for col, pts, pname, attr in ((0, query, "query_kpts", "queryIdx"),
                                  (1, train, "train_kpts", "trainIdx")):
        bad = np.flatnonzero(idx[:, col] >= len(pts))
        if bad.size:
            i = int(bad[0])
            raise InvalidArgumentError(
                f"`matches[{i}].{attr}` = {int(idx[i, col])} is out of range for `{pname}`, "
                f"which holds {len(pts)} points ({bad.size} matches are out of range); "
                "were query and train swapped? matcher.match(query_desc, train_desc) "
                "indexes query_kpts with queryIdx"
            )
    return (np.ascontiguousarray(query[idx[:, 0]]), np.ascontiguousarray(train[idx[:, 1]]))


def keypoints_and_matches(left_pts, right_pts, distances=None, *, size: float = 1.0):
    """Real cv2 objects for aligned point arrays: the inverse of :func:`matched_points`.

    Handy for ``cv2.drawMatches`` and any code written for a cv2 matcher's output.

    Parameters
    ----------
    left_pts, right_pts : (N, 2) array_like or sequence of cv2.KeyPoint
        ``(x, y)`` of the two points of each match, row ``i`` matching row ``i``.
    distances : (N,) array_like, optional
        ``DMatch.distance`` of each match (default 0).
    size : float
        ``KeyPoint.size`` of the created keypoints (diameter, > 0).

    Returns
    -------
    kps_left, kps_right : tuple of cv2.KeyPoint
        One keypoint per row.
    dmatches : tuple of cv2.DMatch
        ``DMatch(i, i, distances[i])``: match ``i`` joins ``kps_left[i]`` and
        ``kps_right[i]``.

    Examples
    --------
    >>> kl, kr, dm = keypoints_and_matches([[10, 5]], [[4, 5]], distances=[0.5])
    >>> kl[0].pt, kr[0].pt, (dm[0].queryIdx, dm[0].trainIdx, dm[0].distance)
    ((10.0, 5.0), (4.0, 5.0), (0, 0, 0.5))
    """
    left, right = as_point_pair(left_pts, right_pts)
    n = len(left)
    size = as_real(size, "size", lo=0.0, lo_open=True)
    if distances is None:
        dist = np.zeros(n)
    else:
        dist = as_values(distances, "distances", n)
        if np.isnan(dist).any():
            raise InvalidArgumentError("`distances` contains NaN")
    kl = tuple(cv2.KeyPoint(x, y, size) for x, y in left.tolist())
    kr = tuple(cv2.KeyPoint(x, y, size) for x, y in right.tolist())
    dm = tuple(cv2.DMatch(i, i, d) for i, d in enumerate(dist.tolist()))
    return kl, kr, dm


def match_disparities(left_pts, right_pts) -> np.ndarray:
    """Disparity ``xl - xr`` of each match of a rectified pair.

    Parameters
    ----------
    left_pts, right_pts : (N, 2) array_like or sequence of cv2.KeyPoint
        ``(x, y)`` of the two points of each match, in rectified images.

    Returns
    -------
    disparities : (N,) float32 ndarray
        ``left_pts[:, 0] - right_pts[:, 0]``, in pixels.

    Examples
    --------
    >>> match_disparities([[10, 5], [30, 8]], [[4, 5], [29.5, 8]]).tolist()
    [6.0, 0.5]
    """
    left, right = as_point_pair(left_pts, right_pts)
    return np.ascontiguousarray(left[:, 0] - right[:, 0], dtype=np.float32)
