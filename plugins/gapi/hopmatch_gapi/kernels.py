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
from hopmatch.matching.disparity_range import search_range
from hopmatch.matching.params import check_disparity_order
from hopmatch.matching.stereo_match import match_detected, split_parameters, stereo_pipeline

from .ops import GDetect, GMatch, GMatchPoints

__all__ = ["NOT_TAKEN", "kernels", "split_params"]

#: :func:`hopmatch.match_stereo`'s keywords that are not detector or matcher parameters,
#: which the G-API operations do not take, and why.
NOT_TAKEN = {
    "rectified": "GMatch matches as match_stereo(left, right, **params) does with "
                 "rectified=None (the rows searched, a pair that does not look rectified "
                 "matched as an unrectified one), and GMatchPoints searches the rows",
    "fundamental_matrix": "the operations take no geometry (GMatch as match_stereo with "
                          "rectified=None, GMatchPoints along the rows)",
    "mask_left": "G-API kernels receive only their graph inputs, the two images",
    "mask_right": "G-API kernels receive only their graph inputs, the two images",
    "detector": "give the detector's parameters as keywords instead",
    "matcher": "give the matcher's parameters as keywords instead",
    "threads": "set hopmatch.setNumThreads(n) instead",
    "record_energy": "the operations output the matches only",
}


def split_params(params: dict) -> tuple[dict, dict]:
    """``(detector params, matcher params)`` of ``params``, checked by both classes
    (:func:`hopmatch.matching.stereo_match.split_parameters`; ``preset`` goes to both),
    and checked as matching checks them: a ``max_disparity`` below ``min_disparity``
    (None: 0 when ``max_disparity`` is given).

    Unknown names raise ``InvalidArgumentError`` listing the valid ones (the keywords of
    :data:`NOT_TAKEN` saying why they are not taken); invalid values raise the classes' own
    errors. Budgets (``max_pixels``, ``max_neurons``...) are checked for validity only:
    whether one suffices depends on the images, and is found while matching
    (``BudgetExceededError``).
    """
    for name in sorted(set(params) & set(NOT_TAKEN)):
        raise InvalidArgumentError(
            f"hopmatch_gapi does not take `{name}`: {NOT_TAKEN[name]}; call "
            f"hopmatch.match_stereo(left, right, {name}=...) for it", argument=name)
    det, mat = split_parameters(params, caller="hopmatch_gapi")
    _, matcher = stereo_pipeline(params, caller="hopmatch_gapi")  # validate now, not in a graph
    config = matcher.config()
    if config.max_disparity is not None:  # the range as matching resolves it (min None: 0)
        no_points = np.zeros((0, 2), np.float32)
        check_disparity_order(*search_range(config, None, no_points, no_points))
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
    """Where a kernel made by :func:`managed_kernels` leaves the exception it caught
    (``error``, None when none), for :func:`~hopmatch_gapi.match_pair` to raise after the
    graph: raised inside a G-API kernel, any exception (hopmatch's errors, a warning turned
    into an error, ``KeyboardInterrupt``...) would come out as ``cv2.error: Python kernel
    failed with error!`` with the real one printed to stderr."""

    def __init__(self):
        self.error: BaseException | None = None


def _no_match():
    return np.zeros((0, 2), np.float32), np.zeros((0, 2), np.float32), np.zeros(0, np.float32)


def managed_kernels(**params) -> tuple["cv.GKernelPackage", RaisedInKernel]:
    """:func:`kernels` whose :class:`GMatch` kernel catches whatever it raises (hopmatch's
    errors, warnings turned into errors, ``KeyboardInterrupt``: any ``BaseException``) into
    the returned :class:`RaisedInKernel` and gives no match instead; what
    :func:`~hopmatch_gapi.match_pair` compiles."""
    raised = RaisedInKernel()
    return _package(params, raised), raised


def kernels(**params) -> "cv.GKernelPackage":
    """The kernel package of :class:`GDetect`, :class:`GMatch` and :class:`GMatchPoints`.

    Parameters
    ----------
    **params
        Any :class:`hopmatch.DericheMoravecDetector` or :class:`hopmatch.HopfieldMatcher`
        parameter (``preset`` applies to both), as for :func:`hopmatch.match_stereo`;
        match_stereo's other keywords (``rectified``, ``fundamental_matrix``, the masks...)
        are not taken (:data:`NOT_TAKEN` says why). Checked at once, as
        :func:`~hopmatch_gapi.match_pair` checks them (:func:`split_params`): what the two
        classes refuse, and a ``max_disparity`` below ``min_disparity`` (0 when None).

    Returns
    -------
    cv2.GKernelPackage
        Pass it as ``args=cv.gapi.compile_args(kernels(...))`` to ``apply`` or
        ``compileStreaming``.

    Raises
    ------
    InvalidArgumentError, InvalidTypeError
        For unknown or invalid parameters, naming the parameter. A budget
        (``max_pixels``, ``max_neurons``...) that is valid but too small for the images
        fails only when the graph runs, inside it (``cv2.error``, as every error raised in
        a graph of your own).
    """
    return _package(params, None)


def _package(params: dict, raised: RaisedInKernel | None) -> "cv.GKernelPackage":
    """The kernel package of :func:`kernels`; with ``raised``, what the :class:`GMatch`
    kernel raises is kept there rather than raised."""
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
            except BaseException as exc:  # noqa: B036 (KeyboardInterrupt too: forwarded)
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
