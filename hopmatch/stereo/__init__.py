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
  the argument or file; no ``cv2.error`` leaves this package.

Import every name from here (``from hopmatch.stereo import rectify``). The modules:
``points`` (cv2 keypoints and matches to point arrays and back, disparities), ``depth``
(depth, reprojection, triangulation), ``ply`` (point clouds), ``calibration``
(:class:`StereoCalibration`, its files, and :func:`calibrate_from_corners`),
``rectification`` (calibrated pairs), ``epipolar`` (unrectified pairs) and ``checks`` (the
boundary checks they share).

Examples
--------
From a cv2 matcher's output to depth, on a rectified pair of focal 500 px and baseline
0.1 m:

>>> import cv2
>>> from hopmatch.stereo import depth_from_disparity, match_disparities, matched_points
>>> left_kps = [cv2.KeyPoint(120, 40, 1), cv2.KeyPoint(300, 80, 1)]
>>> right_kps = [cv2.KeyPoint(95, 80, 1), cv2.KeyPoint(110, 40, 1)]
>>> matches = [cv2.DMatch(0, 1, 0), cv2.DMatch(1, 0, 0)]
>>> left, right = matched_points(left_kps, right_kps, matches)
>>> depth_from_disparity(match_disparities(left, right), focal=500.0, baseline=0.1).tolist()
[5.0, 0.24390244483947754]
"""

from .calibration import CALIBRATION_KEYS as CALIBRATION_KEYS
from .calibration import MAX_CALIBRATION_CORNERS as MAX_CALIBRATION_CORNERS
from .calibration import StereoCalibration, calibrate_from_corners
from .depth import (
    depth_from_disparity,
    reproject_points,
    sparse_disparity_image,
    triangulate_matches,
)
from .epipolar import MAX_PAIRS as MAX_PAIRS
from .epipolar import (
    epipolar_distance_matrix,
    epipolar_distances,
    estimate_fundamental,
    rectify_uncalibrated,
)
from .ply import write_ply
from .points import keypoints_and_matches, match_disparities, matched_points
from .rectification import rectify, rectify_points

__all__ = [
    "StereoCalibration",
    "calibrate_from_corners",
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
