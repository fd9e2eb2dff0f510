"""CPU (Python) kernels of the hopmatch G-API operations.

G-API kernels receive only the node's inputs, so the detector and matcher parameters are
fixed when the kernel package is made: :func:`kernels` ``(**params)`` builds one package per
parameter set. Each kernel calls hopmatch's public functions, so graph results are the
direct calls' results, bit for bit.
"""

from __future__ import annotations

import cv2 as cv
import numpy as np

import hopmatch
from hopmatch.errors import InvalidArgumentError
from hopmatch.matching.stereo_match import split_parameters, stereo_pipeline

from .ops import GDetect, GMatch, GMatchPoints

__all__ = ["kernels", "split_params"]

def split_params(params: dict) -> tuple[dict, dict]:
    """``(detector params, matcher params)`` of ``params``, checked by both classes
    (:func:`hopmatch.matching.stereo_match.split_parameters`; ``preset`` goes to both).

    Unknown names raise ``InvalidArgumentError`` listing the valid ones; invalid values
    raise the classes' own errors.
    """
    det, mat = split_parameters(params, caller="hopmatch_gapi")
    stereo_pipeline(params, caller="hopmatch_gapi")  # validate now, not inside the graph
    return det, mat


def _points(pts) -> np.ndarray:
    """A G-API ``GArray<Point2f>`` value (tuple of (x, y)) as an (N, 2) float32 array."""
    return np.asarray(pts, dtype=np.float32).reshape(-1, 2)


def _describe_and_match(detector, matcher, left, pts_left, right, pts_right):
    """The describe + match half of :func:`hopmatch.match_stereo`, on given points."""
    gl, gr = detector.feature_image(left, "left"), detector.feature_image(right, "right")
    if gl.shape[0] != gr.shape[0]:
        raise InvalidArgumentError(
            f"`left` and `right` must have the same height (a rectified pair), got "
            f"{gl.shape[0]} and {gr.shape[0]}"
        )
    described = []
    for g, pts in ((gl, pts_left), (gr, pts_right)):
        keep, desc = detector.describe_points(g, pts)
        described.append((pts[keep], desc))
    (pl, dl), (pr, dr) = described
    matcher.setPairInfo(pl, pr, gl.shape[::-1], gr.shape[::-1])
    net = matcher.run(dl, dr)
    ml, mr = pl[net.query_idx], pr[net.train_idx]
    return ml, mr, (ml[:, 0] - mr[:, 0]).astype(np.float32)


def kernels(**params) -> "cv.GKernelPackage":
    """The kernel package of :class:`GDetect`, :class:`GMatch` and :class:`GMatchPoints`.

    Parameters
    ----------
    **params
        Any :class:`hopmatch.DericheMoravecDetector` or :class:`hopmatch.HopfieldMatcher`
        parameter (``preset`` applies to both), as for :func:`hopmatch.match_stereo`.

    Returns
    -------
    cv2.GKernelPackage
        Pass it as ``args=cv.gapi.compile_args(kernels(...))`` to ``apply`` or
        ``compileStreaming``.
    """
    det_params, match_params = split_params(params)

    @cv.gapi.kernel(GDetect)
    class DetectKernel:
        @staticmethod
        def run(image):
            pts, resp, _ = hopmatch.DericheMoravecDetector(**det_params).detect_points(image)
            return pts, resp

    @cv.gapi.kernel(GMatch)
    class MatchKernel:
        @staticmethod
        def run(left, right):
            res = hopmatch.match_stereo(left, right, **params)
            return res.matched_left, res.matched_right, res.disparities

    @cv.gapi.kernel(GMatchPoints)
    class MatchPointsKernel:
        @staticmethod
        def run(left, pts_left, right, pts_right):
            return _describe_and_match(
                hopmatch.DericheMoravecDetector(**det_params),
                hopmatch.HopfieldMatcher(**match_params),
                left, _points(pts_left), right, _points(pts_right))

    return cv.gapi.kernels(DetectKernel, MatchKernel, MatchPointsKernel)
