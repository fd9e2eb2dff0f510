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
from hopmatch.errors import HopmatchError
from hopmatch.matching.stereo_match import match_detected, split_parameters, stereo_pipeline

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
    """The describe + match half of :func:`hopmatch.match_stereo`, on given points
    (:func:`hopmatch.matching.stereo_match.match_detected`, the same code)."""
    described = []
    for image, pts, name in ((left, pts_left, "left"), (right, pts_right, "right")):
        gray, g = detector.gray_and_feature_image(image, name)
        keep, desc = detector.describe_points(g, pts)
        kept = np.compress(keep, pts, axis=0)
        described.append((kept, np.zeros(len(kept), np.float32), desc, g, gray))
    res = match_detected(described[0], described[1], matcher.config(),
                         keypoint_size=float(detector.getWindowSize()))
    return res.matched_left, res.matched_right, res.disparities


class RaisedInKernel:
    """Where a kernel made by :func:`managed_kernels` leaves the hopmatch error it caught
    (``error``, None when none), for :func:`~hopmatch_gapi.match_pair` to raise after the
    graph: raised inside a G-API kernel, it would come out as ``cv2.error: Python kernel
    failed with error!`` with the real message printed to stderr."""

    def __init__(self):
        self.error: HopmatchError | None = None


def _no_match():
    return np.zeros((0, 2), np.float32), np.zeros((0, 2), np.float32), np.zeros(0, np.float32)


def managed_kernels(**params) -> tuple["cv.GKernelPackage", RaisedInKernel]:
    """:func:`kernels` whose :class:`GMatch` kernel catches hopmatch's errors (bad images,
    a disparity range that does not fit...) into the returned :class:`RaisedInKernel` and
    gives no match instead; what :func:`~hopmatch_gapi.match_pair` compiles."""
    raised = RaisedInKernel()
    return _package(params, raised), raised


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
    return _package(params, None)


def _package(params: dict, raised: RaisedInKernel | None) -> "cv.GKernelPackage":
    """The kernel package of :func:`kernels`; with ``raised``, the :class:`GMatch`
    kernel's hopmatch errors are kept there rather than raised."""
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
            try:
                res = hopmatch.match_stereo(left, right, **params)
            except HopmatchError as exc:
                if raised is None:
                    raise
                raised.error = exc
                return _no_match()
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
