"""The ready stereo graph and :func:`match_pair`, which compiles it once per parameter set."""

from __future__ import annotations

import threading

import cv2 as cv
import numpy as np

import hopmatch

from .kernels import managed_kernels, split_params
from .ops import GMatch

__all__ = ["as_arrays", "match_pair", "stereo_graph"]


def stereo_graph() -> "cv.GComputation":
    """A ``cv.GComputation``: (left GMat, right GMat) -> (matched left points, matched right
    points, disparities), through one :class:`~hopmatch_gapi.GMatch` node.

    Compile or apply it with ``args=cv.gapi.compile_args(hopmatch_gapi.kernels(**params))``.
    """
    left, right = cv.GMat(), cv.GMat()
    ml, mr, disp = GMatch.on(left, right)
    return cv.GComputation(cv.GIn(left, right), cv.GOut(ml, mr, disp))


def as_arrays(ml, mr, disp) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """G-API outputs (tuples) as ``(M, 2) float32, (M, 2) float32, (M,) float32`` arrays.

    Examples
    --------
    >>> ml, mr, disp = as_arrays([(10.0, 5.0)], [(4.0, 5.0)], [6.0])
    >>> ml.shape, mr.dtype, disp.tolist()
    ((1, 2), dtype('float32'), [6.0])
    >>> [a.shape for a in as_arrays([], [], [])]     # no match keeps the shapes
    [(0, 2), (0, 2), (0,)]
    """
    return (np.asarray(ml, np.float32).reshape(-1, 2), np.asarray(mr, np.float32).reshape(-1, 2),
            np.asarray(disp, np.float32).reshape(-1))


class _Compiled:
    """One graph and its kernel package; G-API recompiles it only when the input sizes or
    types change (``GComputation.apply`` keeps the last compiled executable)."""

    def __init__(self, params: dict):
        self.graph = stereo_graph()
        package, self.raised = managed_kernels(**params)
        self.args = cv.gapi.compile_args(package)
        self.lock = threading.Lock()  # a GComputation is not safe to apply concurrently

    def __call__(self, left, right):
        with self.lock:
            self.raised.error = None
            out = self.graph.apply(cv.gin(left, right), args=self.args)
            if self.raised.error is not None:  # hopmatch's own error, raised in the kernel
                raise self.raised.error
            return out


_CACHE: dict = {}
_CACHE_LOCK = threading.Lock()


def _key(params: dict):
    return tuple(sorted((k, repr(v)) for k, v in params.items()))


def match_pair(left, right, **params) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Match a rectified pair through the compiled G-API graph.

    The graph is built and compiled once per parameter set (and again only when the image
    size or type changes) and reused by later calls.

    Parameters
    ----------
    left, right : (H, W) or (H, W, 3|4) ndarray
        The rectified pair, as for :func:`hopmatch.match_stereo`.
    **params
        Detector and matcher parameters, as for :func:`hopmatch.match_stereo`.

    Returns
    -------
    matched_left, matched_right : (M, 2) float32 ndarray
        (x, y) of each match in the left and right image.
    disparities : (M,) float32 ndarray
        ``x_left - x_right``.

    Raises
    ------
    InvalidArgumentError, InvalidTypeError
        As :func:`hopmatch.match_stereo` raises them (unknown parameters, images that are
        not images: before the graph; what only matching finds, such as a disparity range
        below ``min_disparity``: after it, the error raised inside the graph's kernel),
        never ``cv2.error``.
    """
    det_params, _ = split_params(params)  # unknown or invalid parameters fail here
    detector = hopmatch.DericheMoravecDetector(**det_params)
    for image, name in ((left, "left"), (right, "right")):  # as match_stereo would, before
        detector.gray_image(image, name)  # G-API's own "Failed to obtain cv::Mat"...
    key = _key(params)
    with _CACHE_LOCK:
        compiled = _CACHE.get(key)
        if compiled is None:
            compiled = _CACHE[key] = _Compiled(params)
    return as_arrays(*compiled(left, right))
