"""Calibration, rectification, disparity, depth and triangulation glue for cv2 users.

The thin, composable layer every OpenCV stereo program otherwise writes by hand: turning
``cv2.KeyPoint`` / ``cv2.DMatch`` lists into point arrays and back, disparities into depth
and 3-D points, reading and writing stereo calibrations, rectifying image pairs (calibrated
or not), triangulating matches and writing PLY point clouds.

Conventions, as in cv2:

* points are ``(N, 2)`` float32 arrays of ``(x, y)`` pixel coordinates (x = column,
  y = row), pixel centres at integer coordinates; wherever points are accepted, a sequence
  of ``cv2.KeyPoint`` or cv2's ``(N, 1, 2)`` point arrays are accepted too;
* the fundamental matrix ``F`` maps left points to right epipolar lines:
  ``[xr, yr, 1] @ F @ [xl, yl, 1] == 0``, as returned by
  ``cv2.findFundamentalMat(left_pts, right_pts)``;
* image sizes are ``(width, height)`` (cv2's order); array shapes are ``(H, W)``;
* disparity is ``xl - xr``, in pixels; depth and 3-D points are in the unit of the
  baseline / translation ``T``;
* every cv2 failure is re-raised as :class:`hopmatch.errors.InvalidArgumentError` naming
  the argument or file; no ``cv2.error`` leaves this module.
"""

from __future__ import annotations

import dataclasses
import numbers
import os
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from ._files import atomic_path
from ._validate import (
    IMAGE_DTYPES,
    as_array,
    as_fundamental_matrix,
    as_image_size,
    as_match_indices,
    as_matrix,
    as_points,
    as_real,
    cv2_call,
    describe,
)
from .errors import BudgetExceededError, InvalidArgumentError, InvalidTypeError

__all__ = [
    "StereoCalibration",
    "depth_from_disparity",
    "epipolar_distance_matrix",
    "epipolar_distances",
    "estimate_fundamental",
    "keypoints_and_matches",
    "match_disparities",
    "matched_points",
    "rectify",
    "rectify_points",
    "rectify_uncalibrated",
    "reproject_points",
    "sparse_disparity_image",
    "triangulate_matches",
    "write_ply",
]

#: Default bound on ``Nl * Nr`` for :func:`epipolar_distance_matrix` (about 100 MB peak).
MAX_PAIRS = 4_000_000

_INTERPOLATIONS = {
    cv2.INTER_NEAREST: "cv2.INTER_NEAREST",
    cv2.INTER_LINEAR: "cv2.INTER_LINEAR",
    cv2.INTER_CUBIC: "cv2.INTER_CUBIC",
    cv2.INTER_LANCZOS4: "cv2.INTER_LANCZOS4",
}

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


# --------------------------------------------------------------------------------------
# private helpers
# --------------------------------------------------------------------------------------

def _as_camera_matrix(value, name: str) -> np.ndarray:
    k = as_matrix(value, name, (3, 3))
    if k[0, 0] <= 0 or k[1, 1] <= 0:
        raise InvalidArgumentError(
            f"`{name}` must be a camera matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] with "
            f"positive focal lengths, got fx={k[0, 0]:g}, fy={k[1, 1]:g}"
        )
    return k


def _as_distortion(value, name: str) -> np.ndarray:
    d = as_array(value, name)
    if d.ndim > 2 or (d.ndim == 2 and 1 not in d.shape) or d.size not in (4, 5, 8, 12, 14):
        raise InvalidArgumentError(
            f"`{name}` must hold 4, 5, 8, 12 or 14 distortion coefficients (k1, k2, p1, p2"
            f"[, k3, ...]) as cv2.calibrateCamera returns them, got shape {d.shape}"
        )
    return d.reshape(1, -1)


def _as_rotation(value, name: str) -> np.ndarray:
    r = as_array(value, name)
    if r.size == 3 and r.ndim <= 2:
        r = cv2.Rodrigues(r.reshape(3, 1))[0]
    if r.shape != (3, 3):
        raise InvalidArgumentError(
            f"`{name}` must be a 3x3 rotation matrix or a rotation vector of 3 values, "
            f"got shape {r.shape}"
        )
    err = float(np.abs(r @ r.T - np.eye(3)).max())
    if err > 1e-3 or np.linalg.det(r) < 0:
        raise InvalidArgumentError(
            f"`{name}` must be a rotation matrix (R @ R.T == I, det(R) == 1); it is off by "
            f"{err:.3g} with det {np.linalg.det(r):.3g}"
        )
    return r


def _as_translation(value, name: str) -> np.ndarray:
    t = as_array(value, name)
    if t.size != 3 or t.ndim > 2:
        raise InvalidArgumentError(
            f"`{name}` must hold 3 values (tx, ty, tz), got shape {t.shape}"
        )
    if not np.any(t):
        raise InvalidArgumentError(f"`{name}` must not be zero: a stereo pair needs a baseline")
    return t.reshape(3, 1)


def _as_pair(left_pts, right_pts, left_name="left_pts", right_name="right_pts"):
    left = as_points(left_pts, left_name)
    right = as_points(right_pts, right_name)
    if len(left) != len(right):
        raise InvalidArgumentError(
            f"`{left_name}` and `{right_name}` must have the same length (one row per match), "
            f"got {len(left)} and {len(right)}"
        )
    return left, right


def _as_values(values, name: str, n: int) -> np.ndarray:
    """An (n,) float64 vector; NaN allowed (no value), infinities refused."""
    if values is None or isinstance(values, (str, bytes)):
        raise InvalidTypeError(f"`{name}` must be a 1-D numeric array, got {describe(values)}")
    try:
        arr = np.asarray(values)
    except (TypeError, ValueError) as exc:
        raise InvalidTypeError(f"`{name}` must be a 1-D numeric array: {exc}") from None
    if arr.dtype == np.bool_ or not np.issubdtype(arr.dtype, np.number) or np.iscomplexobj(arr):
        raise InvalidTypeError(f"`{name}` must hold real numbers, got dtype {arr.dtype}")
    if arr.size == 0:
        arr = arr.reshape(0)
    if arr.ndim != 1 or arr.shape[0] != n:
        raise InvalidArgumentError(
            f"`{name}` must have shape ({n},) (one value per point), got shape {arr.shape}"
        )
    arr = arr.astype(np.float64)
    if np.isinf(arr).any():
        raise InvalidArgumentError(f"`{name}` contains infinite values (use NaN for 'none')")
    return arr


def _as_image(image, name: str) -> np.ndarray:
    """Any image cv2.remap / cv2.warpPerspective accept, kept as it is (no grey conversion)."""
    if not isinstance(image, np.ndarray):
        raise InvalidTypeError(
            f"`{name}` must be a numpy array (as returned by cv2.imread), got {describe(image)}"
        )
    if image.dtype == np.bool_ or image.dtype.type not in IMAGE_DTYPES:
        raise InvalidTypeError(
            f"`{name}` must have dtype uint8, uint16, int16, float32 or float64, got {image.dtype}"
        )
    if image.ndim not in (2, 3) or (image.ndim == 3 and image.shape[2] not in (1, 3, 4)):
        raise InvalidArgumentError(
            f"`{name}` must be a grey (H, W) or (H, W, 1), BGR (H, W, 3) or BGRA (H, W, 4) "
            f"image, got shape {image.shape}"
        )
    if image.shape[0] == 0 or image.shape[1] == 0:
        raise InvalidArgumentError(f"`{name}` must not be empty, got shape {image.shape}")
    return np.ascontiguousarray(image)


def _as_image_pair(left, right):
    left = _as_image(left, "left")
    right = _as_image(right, "right")
    if left.shape[:2] != right.shape[:2]:
        raise InvalidArgumentError(
            f"`left` and `right` must have the same height and width, got {left.shape[:2]} "
            f"and {right.shape[:2]}"
        )
    return left, right


def _check_option(value, name: str, options: dict) -> int:
    if value not in options or isinstance(value, bool):
        valid = ", ".join(options.values())
        raise InvalidArgumentError(f"`{name}` must be one of {valid}; got {value!r}")
    return int(value)


def _as_path(path, name: str = "path") -> Path:
    if not isinstance(path, (str, os.PathLike)):
        raise InvalidTypeError(f"`{name}` must be a str or os.PathLike, got {describe(path)}")
    return Path(path)


# --------------------------------------------------------------------------------------
# keypoints and matches
# --------------------------------------------------------------------------------------

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
    left, right = _as_pair(left_pts, right_pts)
    n = len(left)
    size = as_real(size, "size", lo=0.0, lo_open=True)
    if distances is None:
        dist = np.zeros(n)
    else:
        dist = _as_values(distances, "distances", n)
        if np.isnan(dist).any():
            raise InvalidArgumentError("`distances` contains NaN")
    kl = tuple(cv2.KeyPoint(x, y, size) for x, y in left.tolist())
    kr = tuple(cv2.KeyPoint(x, y, size) for x, y in right.tolist())
    dm = tuple(cv2.DMatch(i, i, d) for i, d in enumerate(dist.tolist()))
    return kl, kr, dm


# --------------------------------------------------------------------------------------
# disparity, depth, 3-D points
# --------------------------------------------------------------------------------------

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
    left, right = _as_pair(left_pts, right_pts)
    return np.ascontiguousarray(left[:, 0] - right[:, 0], dtype=np.float32)


def sparse_disparity_image(left_pts, disparities, shape) -> np.ndarray:
    """Scatter sparse disparities into an image, NaN where there is no match.

    Each point is rounded to its nearest pixel. When several points fall on one pixel, the
    largest disparity (the nearest surface) is kept. NaN disparities are ignored.

    Parameters
    ----------
    left_pts : (N, 2) array_like or sequence of cv2.KeyPoint
        ``(x, y)`` of the matched points in the left (reference) image.
    disparities : (N,) array_like
        Disparity of each point, e.g. from :func:`match_disparities`.
    shape : tuple of int
        ``(H, W)`` of the output, or an image's ``.shape`` ``(H, W, C)``.

    Returns
    -------
    image : (H, W) float32 ndarray
        Disparity at the matched pixels, NaN elsewhere.

    Raises
    ------
    InvalidArgumentError
        When a point rounds to a pixel outside the image.

    Examples
    --------
    >>> img = sparse_disparity_image([[1, 0], [2.4, 1]], [3.0, 5.0], (2, 4))
    >>> img
    array([[nan,  3., nan, nan],
           [nan, nan,  5., nan]], dtype=float32)
    """
    pts = as_points(left_pts, "left_pts")
    disp = _as_values(disparities, "disparities", len(pts))
    if (
        not isinstance(shape, (Sequence, np.ndarray))
        or len(shape) not in (2, 3)
        or not all(isinstance(v, numbers.Integral) and not isinstance(v, bool) for v in shape)
    ):
        raise InvalidTypeError(
            f"`shape` must be (H, W) (or an image's (H, W, C) shape) as integers, "
            f"got {describe(shape)}"
        )
    h, w = int(shape[0]), int(shape[1])
    if h <= 0 or w <= 0:
        raise InvalidArgumentError(f"`shape` must be positive (H, W), got {(h, w)}")
    cols = np.rint(pts[:, 0]).astype(np.int64)
    rows = np.rint(pts[:, 1]).astype(np.int64)
    outside = np.flatnonzero((cols < 0) | (cols >= w) | (rows < 0) | (rows >= h))
    if outside.size:
        i = int(outside[0])
        raise InvalidArgumentError(
            f"`left_pts` has {outside.size} points outside an image of shape (H, W) = "
            f"{(h, w)}, the first being row {i}: (x, y) = {tuple(pts[i].tolist())}; "
            "are the points (x, y) and the shape (H, W)?"
        )
    out = np.full((h, w), np.nan, np.float32)
    np.fmax.at(out, (rows, cols), disp.astype(np.float32))
    return out


def depth_from_disparity(disparity, *, Q=None, focal=None, baseline=None, doffs=0.0):
    """Depth Z from disparity: ``Z = focal * baseline / (d + doffs)``, or from ``Q``.

    Give either ``Q`` (the 4x4 matrix of ``cv2.stereoRectify``), which gives
    ``Z = Q[2, 3] / (Q[3, 2] * d + Q[3, 3])``, or ``focal`` and ``baseline`` (and, for
    Middlebury-style data whose principal points differ, ``doffs = cx_right - cx_left``).

    Parameters
    ----------
    disparity : float or ndarray
        Disparity ``xl - xr`` in pixels, any shape; NaN means "none".
    Q : (4, 4) array_like, optional
        Disparity-to-depth matrix of ``cv2.stereoRectify``.
    focal : float, optional
        Focal length in pixels (> 0) of the rectified pair.
    baseline : float, optional
        Distance between the optical centres (> 0); Z comes out in its unit.
    doffs : float
        Offset added to the disparity: ``cx_right - cx_left`` in pixels (Middlebury's
        ``doffs``; default 0). Not allowed with ``Q``, whose ``Q[3, 3]`` holds it.

    Returns
    -------
    depth : float or float32 ndarray
        Same shape as ``disparity`` (a float for a scalar). NaN where the disparity is NaN
        or puts the point at or beyond infinity (``d + doffs <= 0``; with ``Q``,
        ``Q[3, 2] * d + Q[3, 3] <= 0``).

    Examples
    --------
    >>> depth_from_disparity(10.0, focal=500.0, baseline=0.1)
    5.0
    >>> depth_from_disparity([[50.0, 0.0]], focal=500.0, baseline=0.1)
    array([[ 1., nan]], dtype=float32)
    """
    scalar = isinstance(disparity, numbers.Real) and not isinstance(disparity, bool)
    if disparity is None or isinstance(disparity, (str, bytes, bool)):
        raise InvalidTypeError(
            f"`disparity` must be a number or a numeric array, got {describe(disparity)}"
        )
    try:
        d = np.asarray(disparity)
    except (TypeError, ValueError) as exc:
        raise InvalidTypeError(f"`disparity` must be a number or a numeric array: {exc}") from None
    if d.dtype == np.bool_ or not np.issubdtype(d.dtype, np.number) or np.iscomplexobj(d):
        raise InvalidTypeError(f"`disparity` must hold real numbers, got dtype {d.dtype}")
    d = d.astype(np.float64)
    if Q is not None:
        if focal is not None or baseline is not None:
            raise InvalidArgumentError(
                "give either `Q` or `focal` and `baseline`, not both (Q already holds them)"
            )
        if doffs != 0.0:
            raise InvalidArgumentError(
                "`doffs` cannot be used with `Q`: Q[3, 3] already holds the principal-point offset"
            )
        q = as_matrix(Q, "Q", (4, 4))
        num, den = q[2, 3], q[3, 2] * d + q[3, 3]
    else:
        missing = [n for n, v in (("focal", focal), ("baseline", baseline)) if v is None]
        if missing:
            raise InvalidArgumentError(
                f"give `Q` or both `focal` and `baseline`; missing {', '.join(missing)}"
            )
        f = as_real(focal, "focal", lo=0.0, lo_open=True)
        b = as_real(baseline, "baseline", lo=0.0, lo_open=True)
        off = as_real(doffs, "doffs")
        num, den = f * b, d + off
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)
    z = z.astype(np.float32)
    return float(z) if scalar else z


def reproject_points(left_pts, disparities, Q) -> np.ndarray:
    """3-D points of rectified matches, ``[X, Y, Z, W] = Q @ [x, y, d, 1]``.

    The sparse counterpart of ``cv2.reprojectImageTo3D``, through
    ``cv2.perspectiveTransform``.

    Parameters
    ----------
    left_pts : (N, 2) array_like or sequence of cv2.KeyPoint
        ``(x, y)`` of the matched points in the rectified left image.
    disparities : (N,) array_like
        Their disparities ``xl - xr`` in pixels; NaN means "none".
    Q : (4, 4) array_like
        Disparity-to-depth matrix of ``cv2.stereoRectify`` (``StereoCalibration.Q``).

    Returns
    -------
    xyz : (N, 3) float32 ndarray
        Points in the *rectified* left camera's frame (rotate by ``R1.T`` for the
        original left camera's), in the unit of ``T``. Rows are NaN where the disparity is
        NaN or puts the point at or beyond infinity (``W <= 0``).

    Examples
    --------
    >>> import numpy as np
    >>> Q = np.array([[1, 0, 0, -320], [0, 1, 0, -240], [0, 0, 0, 500], [0, 0, 10, 0.]])
    >>> reproject_points([[320, 240], [420, 240]], [10, 50], Q).tolist()
    [[0.0, 0.0, 5.0], [0.20000000298023224, 0.0, 1.0]]
    """
    pts = as_points(left_pts, "left_pts")
    disp = _as_values(disparities, "disparities", len(pts))
    q = as_matrix(Q, "Q", (4, 4))
    if len(pts) == 0:
        return np.zeros((0, 3), np.float32)
    valid = ~np.isnan(disp)
    src = np.empty((len(pts), 1, 3), np.float64)
    src[:, 0, :2] = pts
    src[:, 0, 2] = np.where(valid, disp, 0.0)
    w = src[:, 0, :] @ q[3, :3] + q[3, 3]
    xyz = cv2_call("cv2.perspectiveTransform with `Q`", cv2.perspectiveTransform, src, q)
    xyz = xyz.reshape(-1, 3).astype(np.float32)
    xyz[~(valid & (w > 0))] = np.nan
    return xyz


def triangulate_matches(left_pts, right_pts, P1, P2) -> np.ndarray:
    """3-D points of matches seen by two projective cameras (``cv2.triangulatePoints``).

    Parameters
    ----------
    left_pts, right_pts : (N, 2) array_like or sequence of cv2.KeyPoint
        ``(x, y)`` of the two points of each match. They must be *undistorted* (use
        :func:`rectify_points`, or ``cv2.undistortPoints(..., P=K)``) for ``P1``, ``P2``.
    P1, P2 : (3, 4) array_like
        Projection matrices of the left and right cameras, e.g. ``K1 @ [I | 0]`` and
        ``K2 @ [R | T]``, or ``StereoCalibration.P1``/``P2`` for rectified points.

    Returns
    -------
    xyz : (N, 3) float32 ndarray
        Points in the frame ``P1`` and ``P2`` project from (the left camera's for the two
        examples above); NaN rows for points at infinity.

    Examples
    --------
    >>> import numpy as np
    >>> K = np.array([[500, 0, 320], [0, 500, 240], [0, 0, 1.]])
    >>> P1 = K @ np.hstack([np.eye(3), np.zeros((3, 1))])
    >>> P2 = K @ np.hstack([np.eye(3), [[-0.1], [0], [0]]])
    >>> xyz = triangulate_matches([[320, 240], [370, 240]], [[310, 240], [360, 240]], P1, P2)
    >>> xyz.shape, xyz.dtype, xyz[:, 2].round(6).tolist(), xyz[:, 0].round(6).tolist()
    ((2, 3), dtype('float32'), [5.0, 5.0], [0.0, 0.5])
    """
    left, right = _as_pair(left_pts, right_pts)
    p1 = as_matrix(P1, "P1", (3, 4))
    p2 = as_matrix(P2, "P2", (3, 4))
    if len(left) == 0:
        return np.zeros((0, 3), np.float32)
    h = cv2_call(
        "cv2.triangulatePoints with `P1`, `P2`", cv2.triangulatePoints, p1, p2,
        np.ascontiguousarray(left.T, dtype=np.float64),
        np.ascontiguousarray(right.T, dtype=np.float64),
    )
    w = h[3]
    ok = np.abs(w) > 1e-12 * np.abs(h[:3]).max(axis=0).clip(min=1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        xyz = (h[:3] / np.where(ok, w, 1.0)).T
    xyz[~ok] = np.nan
    return np.ascontiguousarray(xyz, dtype=np.float32)


def write_ply(path, xyz, colors=None) -> int:
    """Write a point cloud as ASCII PLY, atomically.

    The file is written beside ``path`` under a temporary name and moved onto ``path``
    only when complete: on any error no file (and no half-written file) is left and an
    existing ``path`` is unchanged.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; its folder must exist.
    xyz : (N, 3) array_like
        Points. Rows with a NaN or infinite coordinate (no match) are skipped.
    colors : (N, 3) uint8 ndarray, optional
        RGB colour of each point. cv2 images are BGR: pass ``image[rows, cols, ::-1]``.

    Returns
    -------
    count : int
        Number of vertices written.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "cloud.ply")
    >>> write_ply(path, [[0, 0, 1], [0.5, 0, float("nan")]])
    1
    >>> print(open(path).read().splitlines()[-1])
    0 0 1
    """
    path = _as_path(path)
    pts = _as_array_nonfinite(xyz, "xyz")
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InvalidArgumentError(
            f"`xyz` must have shape (N, 3) holding (X, Y, Z), got shape {pts.shape}"
        )
    cols = None
    if colors is not None:
        if not isinstance(colors, np.ndarray):
            raise InvalidTypeError(
                f"`colors` must be a uint8 numpy array or None, got {describe(colors)}"
            )
        if colors.dtype != np.uint8:
            raise InvalidTypeError(
                f"`colors` must have dtype uint8 (RGB 0-255), got {colors.dtype}; convert "
                "with np.clip(colors, 0, 255).astype(np.uint8)"
            )
        if colors.shape != (len(pts), 3):
            raise InvalidArgumentError(
                f"`colors` must have shape ({len(pts)}, 3), one RGB row per point of `xyz`, "
                f"got shape {colors.shape}"
            )
        cols = colors
    keep = np.isfinite(pts).all(axis=1)
    pts = pts[keep]
    if cols is not None:
        cols = cols[keep]
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="ascii", newline="\n") as fh:
            _write_ply_body(fh, pts.astype(np.float32), cols)
            fh.flush()
            os.fsync(fh.fileno())
    return int(len(pts))


def _as_array_nonfinite(value, name):
    """Like _as_array but NaN/inf allowed (they are filtered by the caller)."""
    if value is None or isinstance(value, (str, bytes)):
        raise InvalidTypeError(f"`{name}` must be a numeric array, got {describe(value)}")
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise InvalidTypeError(f"`{name}` must be a numeric array: {exc}") from None
    if arr.dtype == np.bool_ or not np.issubdtype(arr.dtype, np.number) or np.iscomplexobj(arr):
        raise InvalidTypeError(f"`{name}` must hold real numbers, got dtype {arr.dtype}")
    if arr.size == 0:
        arr = arr.reshape(0, 3)
    return arr.astype(np.float64)


def _write_ply_body(fh, pts: np.ndarray, cols: np.ndarray | None) -> None:
    header = ["ply", "format ascii 1.0", "comment written by hopmatch",
              f"element vertex {len(pts)}",
              "property float x", "property float y", "property float z"]
    if cols is not None:
        header += ["property uchar red", "property uchar green", "property uchar blue"]
    header.append("end_header")
    fh.write("\n".join(header) + "\n")
    if len(pts) == 0:
        return
    if cols is None:
        np.savetxt(fh, pts, fmt="%.9g")
    else:
        rows = (f"{x:.9g} {y:.9g} {z:.9g} {r} {g} {b}\n"
                for (x, y, z), (r, g, b) in zip(pts.tolist(), cols.tolist()))
        fh.writelines(rows)


# --------------------------------------------------------------------------------------
# calibration and calibrated rectification
# --------------------------------------------------------------------------------------

#: Key spellings read by StereoCalibration.from_file, canonical name first.
CALIBRATION_KEYS = {
    "K1": ("K1", "M1", "cameraMatrix1", "camera_matrix1", "camera_matrix_1", "cameraMatrixL",
           "camera_matrix_left", "mtx1", "mtxL"),
    "D1": ("D1", "distCoeffs1", "dist_coeffs1", "distortion_coefficients1",
           "distortion_coefficients_1", "distCoeffsL", "dist_coeffs_left", "dist1", "distL"),
    "K2": ("K2", "M2", "cameraMatrix2", "camera_matrix2", "camera_matrix_2", "cameraMatrixR",
           "camera_matrix_right", "mtx2", "mtxR"),
    "D2": ("D2", "distCoeffs2", "dist_coeffs2", "distortion_coefficients2",
           "distortion_coefficients_2", "distCoeffsR", "dist_coeffs_right", "dist2", "distR"),
    "R": ("R", "rotation", "rotation_matrix"),
    "T": ("T", "translation", "translation_vector"),
    "R1": ("R1",), "R2": ("R2",), "P1": ("P1",), "P2": ("P2",), "Q": ("Q",),
}
_REQUIRED = ("K1", "D1", "K2", "D2", "R", "T")
_SIZE_KEYS = ("image_size", "imageSize", "img_size")


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class StereoCalibration:
    """A calibrated stereo pair, as ``cv2.stereoCalibrate`` and ``cv2.stereoRectify`` give it.

    All matrices are stored as float64 arrays; the constructor checks their shapes.
    ``R``, ``T`` take points from the left camera's frame to the right's
    (``X_right = R @ X_left + T``), as ``cv2.stereoCalibrate`` returns them.

    Parameters
    ----------
    K1, K2 : (3, 3) array_like
        Camera matrices of the left and right cameras.
    D1, D2 : array_like of 4, 5, 8, 12 or 14 values
        Distortion coefficients (stored as ``(1, n)``).
    R : (3, 3) array_like, or rotation vector of 3 values
        Rotation from the left to the right camera.
    T : array_like of 3 values
        Translation from the left to the right camera (stored as ``(3, 1)``), in the unit
        all 3-D results come out in.
    image_size : (width, height), optional
        Size of the calibration images (cv2's order). Taken from the images by
        :func:`rectify` when None.
    R1, R2 : (3, 3) array_like, optional
        Rectification rotations of ``cv2.stereoRectify``.
    P1, P2 : (3, 4) array_like, optional
        Projection matrices in the rectified frames.
    Q : (4, 4) array_like, optional
        Disparity-to-depth matrix.

    Examples
    --------
    >>> import numpy as np
    >>> K = [[500, 0, 320], [0, 500, 240], [0, 0, 1]]
    >>> cal = StereoCalibration(K, np.zeros(5), K, np.zeros(5), np.eye(3), [-0.1, 0, 0],
    ...                         image_size=(640, 480))
    >>> cal
    StereoCalibration(image_size=(640, 480), baseline=0.1, rectified=False)
    >>> cal.with_rectification().P2[0, 3].round(3)
    np.float64(-50.0)
    """

    K1: np.ndarray
    D1: np.ndarray
    K2: np.ndarray
    D2: np.ndarray
    R: np.ndarray
    T: np.ndarray
    image_size: tuple[int, int] | None = None
    R1: np.ndarray | None = None
    R2: np.ndarray | None = None
    P1: np.ndarray | None = None
    P2: np.ndarray | None = None
    Q: np.ndarray | None = None

    def __post_init__(self):
        checked = _check_calibration_fields(
            {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        )
        for key, value in checked.items():
            object.__setattr__(self, key, value)

    # -- derived quantities -------------------------------------------------------------
    @property
    def rectified(self) -> bool:
        """True when R1, R2, P1, P2 and Q are all present."""
        return all(getattr(self, k) is not None for k in ("R1", "R2", "P1", "P2", "Q"))

    @property
    def baseline(self) -> float:
        """Distance between the optical centres, ``||T||``, in the unit of ``T``."""
        return float(np.linalg.norm(self.T))

    def fundamental_matrix(self) -> np.ndarray:
        """The (3, 3) fundamental matrix ``F = K2^-T [T]x R K1^-1`` of the pair.

        For *undistorted* pixel coordinates: ``[xr, yr, 1] @ F @ [xl, yl, 1] == 0``.
        Normalised so that ``||F|| = 1``.
        """
        t = self.T.ravel()
        tx = np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]])
        f = np.linalg.inv(self.K2).T @ tx @ self.R @ np.linalg.inv(self.K1)
        return f / np.linalg.norm(f)

    def with_rectification(self, alpha: float = 0.0, *, zero_disparity: bool = True,
                           image_size=None) -> StereoCalibration:
        """A copy with R1, R2, P1, P2, Q computed by ``cv2.stereoRectify``.

        Parameters
        ----------
        alpha : float
            Free scaling of ``cv2.stereoRectify``: 0 keeps only valid pixels, 1 keeps all
            source pixels, -1 lets OpenCV choose.
        zero_disparity : bool
            ``cv2.CALIB_ZERO_DISPARITY``: same principal point in both rectified views, so
            points at infinity have disparity 0.
        image_size : (width, height), optional
            Needed when the calibration has none.
        """
        size = as_image_size(image_size, "image_size") or self.image_size
        if size is None:
            raise InvalidArgumentError(
                "this calibration has no image_size; pass image_size=(width, height)"
            )
        alpha = _check_alpha(alpha)
        if not isinstance(zero_disparity, (bool, np.bool_)):
            raise InvalidTypeError(
                f"`zero_disparity` must be a bool, got {describe(zero_disparity)}"
            )
        flags = cv2.CALIB_ZERO_DISPARITY if zero_disparity else 0
        r1, r2, p1, p2, q, _, _ = cv2_call(
            "cv2.stereoRectify with this calibration", cv2.stereoRectify,
            self.K1, self.D1, self.K2, self.D2, size, self.R, self.T,
            flags=flags, alpha=alpha,
        )
        return dataclasses.replace(self, image_size=size, R1=r1, R2=r2, P1=p1, P2=p2, Q=q)

    def __repr__(self) -> str:
        return (f"StereoCalibration(image_size={self.image_size}, "
                f"baseline={self.baseline:.6g}, rectified={self.rectified})")

    # -- files ----------------------------------------------------------------------------
    @classmethod
    def from_file(cls, path, extrinsics=None) -> StereoCalibration:
        """Read a calibration from an OpenCV FileStorage file (YAML, XML or JSON).

        Reads the key spellings of :data:`CALIBRATION_KEYS`: ``K1``/``M1``/
        ``cameraMatrix1``..., ``D1``/``distCoeffs1``..., ``R``, ``T`` and optionally ``R1``,
        ``R2``, ``P1``, ``P2``, ``Q``; the image size from ``image_size`` (or ``imageSize``)
        = [width, height], or ``image_width`` and ``image_height``.

        OpenCV's ``stereo_calib.cpp`` sample writes ``intrinsics.yml`` (M1, D1, M2, D2) and
        ``extrinsics.yml`` (R, T, R1, R2, P1, P2, Q): pass the first as ``path`` and the
        second as ``extrinsics``, which is also found on its own beside an
        ``intrinsics.*`` file.

        Parameters
        ----------
        path : str or os.PathLike
            The file.
        extrinsics : str or os.PathLike, optional
            A second file whose keys fill those missing from the first.

        Raises
        ------
        InvalidArgumentError
            When a file cannot be read, or lacks a required key (the message names the
            file, the missing keys and the keys it holds), or holds a malformed matrix.
        """
        path = _as_path(path)
        values, spelled, found = _read_storage(path, "path")
        sources = {k: path for k in values}
        missing_rt = [k for k in ("R", "T") if k not in values]
        if extrinsics is None and missing_rt and "intrinsics" in path.name:
            guess = path.with_name(path.name.replace("intrinsics", "extrinsics"))
            if guess.is_file():
                extrinsics = guess
        if extrinsics is not None:
            epath = _as_path(extrinsics, "extrinsics")
            evalues, espelled, efound = _read_storage(epath, "extrinsics")
            for k, v in evalues.items():
                if k not in values:
                    values[k] = v
                    sources[k] = epath
                    spelled[k] = espelled[k]
            found = found + [f"{k} ({epath.name})" for k in efound]
        missing = [k for k in _REQUIRED if k not in values]
        if missing:
            spellings = "; ".join(f"{k}: {', '.join(CALIBRATION_KEYS[k])}" for k in missing)
            hint = ""
            if found == ["imagelist"]:
                hint = (" It looks like an image list (the input of OpenCV's stereo_calib "
                        "sample), not a calibration.")
            elif missing == ["R", "T"] or set(missing) <= {"R", "T"}:
                hint = (" OpenCV's stereo_calib sample writes R and T to extrinsics.yml: "
                        "pass it as extrinsics=...")
            files = str(path) + (f" and {extrinsics}" if extrinsics is not None else "")
            raise InvalidArgumentError(
                f"{files} holds no complete stereo calibration: missing {', '.join(missing)} "
                f"(accepted keys: {spellings}); it holds: {', '.join(found) or 'nothing'}.{hint}"
            )
        for field, value in values.items():
            try:
                _FIELD_CHECKS[field](value, field)
            except (InvalidArgumentError, InvalidTypeError) as exc:
                raise InvalidArgumentError(
                    f"{sources[field]}: key {spelled[field]!r} (read as {field}) is malformed: "
                    f"{exc}"
                ) from None
        return cls(**values)

    def to_file(self, path) -> None:
        """Write the calibration to an OpenCV FileStorage file, atomically.

        The format follows the extension (``.yml``/``.yaml``, ``.xml``, ``.json``, optionally
        followed by ``.gz``). Keys: K1, D1, K2, D2, R, T, image_width, image_height and,
        when present, R1, R2, P1, P2, Q; :meth:`from_file` reads them back. The file is
        written under a temporary name beside ``path`` and moved onto it when complete.
        """
        path = _as_path(path)
        ext = path.suffixes[-2] if path.suffix == ".gz" and len(path.suffixes) > 1 else path.suffix
        if ext.lower() not in (".yml", ".yaml", ".xml", ".json"):
            raise InvalidArgumentError(
                f"`path` must end in .yml, .yaml, .xml or .json (optionally + .gz), as "
                f"cv2.FileStorage chooses the format from it; got {str(path)!r}"
            )
        with atomic_path(path) as tmp:
            try:
                fs = cv2.FileStorage(str(tmp), cv2.FILE_STORAGE_WRITE)
            except (cv2.error, SystemError) as exc:
                raise InvalidArgumentError(f"cannot write {path}: {exc}") from None
            if not fs.isOpened():
                raise InvalidArgumentError(f"cannot write {path}: cv2.FileStorage did not open it")
            try:
                for key in ("K1", "D1", "K2", "D2", "R", "T"):
                    fs.write(key, getattr(self, key))
                if self.image_size is not None:
                    fs.write("image_width", int(self.image_size[0]))
                    fs.write("image_height", int(self.image_size[1]))
                for key in ("R1", "R2", "P1", "P2", "Q"):
                    if getattr(self, key) is not None:
                        fs.write(key, getattr(self, key))
            except cv2.error as exc:
                raise InvalidArgumentError(f"cannot write {path}: {exc.err}") from exc
            finally:
                fs.release()


_FIELD_CHECKS = {
    "K1": _as_camera_matrix,
    "D1": _as_distortion,
    "K2": _as_camera_matrix,
    "D2": _as_distortion,
    "R": _as_rotation,
    "T": _as_translation,
    "image_size": as_image_size,
    "R1": lambda v, n: as_matrix(v, n, (3, 3)),
    "R2": lambda v, n: as_matrix(v, n, (3, 3)),
    "P1": lambda v, n: as_matrix(v, n, (3, 4)),
    "P2": lambda v, n: as_matrix(v, n, (3, 4)),
    "Q": lambda v, n: as_matrix(v, n, (4, 4)),
}


def _check_calibration_fields(values: dict) -> dict:
    """Coerce calibration fields (None stays None for the optional ones)."""
    out = {}
    for key, value in values.items():
        if value is None and key not in _REQUIRED:
            out[key] = None
        else:
            out[key] = _FIELD_CHECKS[key](value, key)
    return out


def _read_node(node, what: str):
    """A FileNode as a float64 array (matrix, sequence or number)."""
    try:
        if node.isMap():
            mat = node.mat()
            if mat is None:
                raise InvalidArgumentError(f"{what} is a map, not an OpenCV matrix")
            return np.asarray(mat, dtype=np.float64)
        if node.isSeq():
            vals = []
            for i in range(node.size()):
                item = node.at(i)
                if item.isSeq():
                    vals.append([item.at(j).real() for j in range(item.size())])
                elif item.isInt() or item.isReal():
                    vals.append(item.real())
                else:
                    raise InvalidArgumentError(f"{what} holds a non-numeric item")
            try:
                return np.asarray(vals, dtype=np.float64)
            except ValueError:
                raise InvalidArgumentError(f"{what} is a ragged sequence") from None
        if node.isInt() or node.isReal():
            return np.asarray(node.real(), dtype=np.float64)
    except cv2.error as exc:
        raise InvalidArgumentError(f"{what} is malformed: {exc.err}") from exc
    raise InvalidArgumentError(f"{what} is not a matrix or a number")


def _read_storage(path: Path, name: str) -> tuple[dict, dict, list[str]]:
    """The calibration values found in one FileStorage file, their spellings, its keys."""
    if not path.is_file():
        raise InvalidArgumentError(f"`{name}`: no such file {str(path)!r}")
    if path.stat().st_size == 0:
        raise InvalidArgumentError(f"`{name}`: {str(path)!r} is empty")
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as exc:  # cv2 raises SystemError for some non-text files
        detail = getattr(exc, "err", None) or str(exc)
        raise InvalidArgumentError(
            f"`{name}`: {str(path)!r} is not an OpenCV FileStorage file (YAML/XML/JSON): {detail}"
        ) from None
    try:
        if not fs.isOpened():
            raise InvalidArgumentError(
                f"`{name}`: cv2.FileStorage cannot parse {str(path)!r}; is it an OpenCV "
                "YAML (starting with %YAML:1.0), XML or JSON file?"
            )
        root = fs.root()
        found = list(root.keys()) if root.isMap() else []
        values, spelled = {}, {}
        for field, spellings in CALIBRATION_KEYS.items():
            for key in spellings:
                if key in found:
                    values[field] = _read_node(fs.getNode(key), f"key {key!r} of {path}")
                    spelled[field] = key
                    break
        for key in _SIZE_KEYS:
            if key in found:
                size = _read_node(fs.getNode(key), f"key {key!r} of {path}").ravel()
                values["image_size"] = _size_from_values(size, f"key {key!r} of {path}")
                spelled["image_size"] = key
                break
        else:
            if "image_width" in found and "image_height" in found:
                w = _read_node(fs.getNode("image_width"), f"key 'image_width' of {path}")
                h = _read_node(fs.getNode("image_height"), f"key 'image_height' of {path}")
                values["image_size"] = _size_from_values(
                    np.array([w.ravel()[0], h.ravel()[0]]), f"image_width/image_height of {path}"
                )
                spelled["image_size"] = "image_width/image_height"
        return values, spelled, found
    finally:
        fs.release()


def _size_from_values(size: np.ndarray, what: str) -> tuple[int, int]:
    if size.size != 2 or not np.all(size == np.round(size)) or np.any(size <= 0):
        raise InvalidArgumentError(
            f"{what} must be [width, height] as positive integers, got {size.tolist()}"
        )
    return int(size[0]), int(size[1])


def _check_alpha(alpha) -> float:
    a = as_real(alpha, "alpha")
    if not (a == -1.0 or 0.0 <= a <= 1.0):
        raise InvalidArgumentError(f"`alpha` must be -1 or in [0, 1], got {a!r}")
    return a


def _as_calibration(calibration, name: str = "calibration") -> StereoCalibration:
    if not isinstance(calibration, StereoCalibration):
        raise InvalidTypeError(
            f"`{name}` must be a StereoCalibration (e.g. StereoCalibration.from_file(path)), "
            f"got {describe(calibration)}"
        )
    return calibration


def rectify(left, right, calibration, alpha: float = 0.0, *,
            interpolation: int = cv2.INTER_LINEAR):
    """Rectify a calibrated pair: ``cv2.stereoRectify``, ``initUndistortRectifyMap``, ``remap``.

    Parameters
    ----------
    left, right : (H, W) or (H, W, C) ndarray
        The images, as cv2.imread returns them (any cv2 dtype, grey or colour). Their size
        must be the calibration's ``image_size`` when it has one.
    calibration : StereoCalibration
        The pair's calibration; R1, R2, P1, P2, Q are recomputed for ``alpha``.
    alpha : float
        Free scaling of ``cv2.stereoRectify``: 0 keeps only valid pixels, 1 all source
        pixels, -1 OpenCV's default.
    interpolation : int
        ``cv2.INTER_NEAREST``, ``INTER_LINEAR``, ``INTER_CUBIC`` or ``INTER_LANCZOS4``.

    Returns
    -------
    left_rect, right_rect : ndarray
        Rectified images, same shape and dtype as the inputs (black outside the source).
    calibration : StereoCalibration
        The calibration with ``image_size``, R1, R2, P1, P2 and Q filled: use ``Q`` with
        :func:`reproject_points` / :func:`depth_from_disparity`, and :func:`rectify_points`
        to rectify points instead of images.

    Notes
    -----
    The maps are computed on each call; for video, compute them once with
    ``cv2.initUndistortRectifyMap`` from the returned calibration.

    Examples
    --------
    >>> import numpy as np
    >>> K = [[500, 0, 320], [0, 500, 240], [0, 0, 1]]
    >>> cal = StereoCalibration(K, np.zeros(5), K, np.zeros(5), np.eye(3), [-0.1, 0, 0],
    ...                         image_size=(640, 480))
    >>> img = np.zeros((480, 640), np.uint8)
    >>> left_rect, right_rect, cal = rectify(img, img, cal)
    >>> left_rect.shape, left_rect.dtype, float(cal.P2[0, 3].round(3))
    ((480, 640), dtype('uint8'), -50.0)
    """
    left, right = _as_image_pair(left, right)
    cal = _as_calibration(calibration)
    interpolation = _check_option(interpolation, "interpolation", _INTERPOLATIONS)
    size = (left.shape[1], left.shape[0])
    if cal.image_size is not None and tuple(cal.image_size) != size:
        raise InvalidArgumentError(
            f"`left` and `right` are {size[0]}x{size[1]} (width x height) but the calibration "
            f"was made for {cal.image_size[0]}x{cal.image_size[1]}; resize the images or "
            "scale the calibration"
        )
    cal = cal.with_rectification(alpha, image_size=size)
    out = []
    for img, k, d, r, p, side in ((left, cal.K1, cal.D1, cal.R1, cal.P1, "left"),
                                  (right, cal.K2, cal.D2, cal.R2, cal.P2, "right")):
        mx, my = cv2_call(f"cv2.initUndistortRectifyMap for `{side}`",
                           cv2.initUndistortRectifyMap, k, d, r, p, size, cv2.CV_32FC1)
        out.append(cv2_call(f"cv2.remap of `{side}`", cv2.remap, img, mx, my, interpolation,
                             borderMode=cv2.BORDER_CONSTANT).reshape(img.shape))
    return out[0], out[1], cal


def rectify_points(points, calibration, which: str = "left") -> np.ndarray:
    """Map points of an original image to the rectified image (``cv2.undistortPoints``).

    Sparse stereo does not need rectified images: rectify the keypoints, then use
    :func:`match_disparities`, :func:`reproject_points` or :func:`triangulate_matches`
    with ``P1``, ``P2``.

    Parameters
    ----------
    points : (N, 2) array_like or sequence of cv2.KeyPoint
        ``(x, y)`` in the original (distorted) image.
    calibration : StereoCalibration
        With R1, R2, P1, P2 (``calibration.with_rectification()`` or :func:`rectify`).
    which : {'left', 'right'}
        Which camera the points come from.

    Returns
    -------
    points : (N, 2) float32 ndarray
        ``(x, y)`` in the rectified image.

    Examples
    --------
    >>> import numpy as np
    >>> K = [[500, 0, 320], [0, 500, 240], [0, 0, 1]]
    >>> cal = StereoCalibration(K, np.zeros(5), K, np.zeros(5), np.eye(3), [-0.1, 0, 0],
    ...                         image_size=(640, 480)).with_rectification()
    >>> rectify_points([[320, 240], [400, 100]], cal, "left").round(3).tolist()
    [[320.0, 240.0], [400.0, 100.0]]
    """
    pts = as_points(points, "points")
    cal = _as_calibration(calibration)
    if which not in ("left", "right"):
        raise InvalidArgumentError(f"`which` must be one of 'left', 'right'; got {which!r}")
    if not cal.rectified:
        raise InvalidArgumentError(
            "`calibration` has no rectification (R1, R2, P1, P2, Q); use "
            "calibration.with_rectification(alpha) or the calibration rectify() returns"
        )
    if len(pts) == 0:
        return np.zeros((0, 2), np.float32)
    k, d, r, p = ((cal.K1, cal.D1, cal.R1, cal.P1) if which == "left"
                  else (cal.K2, cal.D2, cal.R2, cal.P2))
    out = cv2_call("cv2.undistortPoints of `points`", cv2.undistortPoints,
                    pts.reshape(-1, 1, 2).astype(np.float64), k, d, R=r, P=p)
    return np.ascontiguousarray(out.reshape(-1, 2), dtype=np.float32)


# --------------------------------------------------------------------------------------
# unrectified pairs: epipolar geometry
# --------------------------------------------------------------------------------------

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
        In pixels.

    Examples
    --------
    >>> import numpy as np
    >>> F = np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0.]])   # rectified pair: yl == yr
    >>> epipolar_distances([[10, 5], [10, 5]], [[3, 5], [3, 8]], F).tolist()
    [0.0, 3.0]
    """
    left, right = _as_pair(left_pts, right_pts)
    f = as_fundamental_matrix(F)
    op = _reduce_option(reduce)
    lr = _epilines(left, 1, f)   # lines in the right image
    ll = _epilines(right, 2, f)  # lines in the left image
    dr = np.abs(np.einsum("ij,ij->i", lr[:, :2], right) + lr[:, 2])
    dl = np.abs(np.einsum("ij,ij->i", ll[:, :2], left) + ll[:, 2])
    out = op(dr, dl)
    if reduce == "mean":
        out = out / 2
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
    left, right = _as_pair(left_pts, right_pts)
    method = _check_option(method, "method", _F_METHODS)
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
    left, right = _as_image_pair(left, right)
    lp, rp = _as_pair(left_pts, right_pts)
    f = as_fundamental_matrix(F)
    threshold = as_real(threshold, "threshold", lo=0.0, lo_open=True)
    interpolation = _check_option(interpolation, "interpolation", _INTERPOLATIONS)
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
