"""Calibrated rectification: of an image pair (``cv2.stereoRectify`` + ``remap``) and of
points (``cv2.undistortPoints``)."""

from __future__ import annotations

import cv2
import numpy as np

from .._validate import as_points, cv2_call
from ..errors import InvalidArgumentError
from .calibration import as_calibration
from .checks import INTERPOLATIONS, as_image_pair, check_option

__all__ = ["rectify", "rectify_points"]


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
    >>> from hopmatch.stereo import StereoCalibration
    >>> K = [[500, 0, 320], [0, 500, 240], [0, 0, 1]]
    >>> cal = StereoCalibration(K, np.zeros(5), K, np.zeros(5), np.eye(3), [-0.1, 0, 0],
    ...                         image_size=(640, 480))
    >>> img = np.zeros((480, 640), np.uint8)
    >>> left_rect, right_rect, cal = rectify(img, img, cal)
    >>> left_rect.shape, left_rect.dtype, float(cal.P2[0, 3].round(3))
    ((480, 640), dtype('uint8'), -50.0)
    """
    left, right = as_image_pair(left, right)
    cal = as_calibration(calibration)
    interpolation = check_option(interpolation, "interpolation", INTERPOLATIONS)
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
    >>> from hopmatch.stereo import StereoCalibration
    >>> K = [[500, 0, 320], [0, 500, 240], [0, 0, 1]]
    >>> cal = StereoCalibration(K, np.zeros(5), K, np.zeros(5), np.eye(3), [-0.1, 0, 0],
    ...                         image_size=(640, 480)).with_rectification()
    >>> rectify_points([[320, 240], [400, 100]], cal, "left").round(3).tolist()
    [[320.0, 240.0], [400.0, 100.0]]
    """
    pts = as_points(points, "points")
    cal = as_calibration(calibration)
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
