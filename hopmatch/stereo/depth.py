"""Disparity to depth and 3-D points: sparse disparity images, ``Z = f B / d``, ``Q``
reprojection and triangulation of matches."""

from __future__ import annotations

import numbers
from collections.abc import Sequence

import cv2
import numpy as np

from .._validate import MAX_IMAGE_PIXELS, as_matrix, as_points, as_real, cv2_call, describe
from ..errors import BudgetExceededError, InvalidArgumentError, InvalidTypeError
from .checks import as_point_pair, as_real_array, as_values

__all__ = [
    "depth_from_disparity",
    "reproject_points",
    "sparse_disparity_image",
    "triangulate_matches",
]


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
    disp = as_values(disparities, "disparities", len(pts))
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
    if h * w > MAX_IMAGE_PIXELS:
        raise BudgetExceededError(
            f"`shape` {(h, w)} asks for {h * w} pixels, more than the {MAX_IMAGE_PIXELS} of "
            "hopmatch._validate.MAX_IMAGE_PIXELS (4 GiB of float32); is it (H, W)?",
            argument="shape")
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
        ``Q[3, 2] * d + Q[3, 3] <= 0``); inf where the depth exceeds float32's range.

    Examples
    --------
    >>> depth_from_disparity(10.0, focal=500.0, baseline=0.1)
    5.0
    >>> depth_from_disparity([[50.0, 0.0]], focal=500.0, baseline=0.1)
    array([[ 1., nan]], dtype=float32)
    """
    scalar = isinstance(disparity, numbers.Real) and not isinstance(disparity, bool)
    d = as_real_array(disparity, "disparity", "a number or a numeric array", refuse_bool=True)
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
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        z = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)
        z = z.astype(np.float32)  # depths beyond float32's range become inf (see Returns)
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
    disp = as_values(disparities, "disparities", len(pts))
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
    left, right = as_point_pair(left_pts, right_pts)
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
