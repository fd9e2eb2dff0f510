"""The ready stereo graph and :func:`match_pair`, which compiles it once per parameter set
(the last :data:`CACHE_SIZE` parameter sets' graphs are kept)."""

from __future__ import annotations

import threading
from collections import OrderedDict

import cv2 as cv
import numpy as np

import hopmatch
from hopmatch.errors import InvalidArgumentError, InvalidTypeError

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

    Parameters
    ----------
    ml, mr : sequence of (x, y), or (M, 2) or cv2's (M, 1, 2) array
        Matched left and right points (``GArray<Point2f>`` values).
    disp : sequence of numbers, or (M,) array
        Disparities (a ``GArray<float>`` value).

    Raises
    ------
    InvalidTypeError
        An argument that is not real numbers (None, a string, complex numbers...).
    InvalidArgumentError
        An argument of another shape, with NaN, infinite values or values beyond float32,
        or the three of different lengths; each message names the argument.

    Examples
    --------
    >>> ml, mr, disp = as_arrays([(10.0, 5.0)], [(4.0, 5.0)], [6.0])
    >>> ml.shape, mr.dtype, disp.tolist()
    ((1, 2), dtype('float32'), [6.0])
    >>> [a.shape for a in as_arrays([], [], [])]     # no match keeps the shapes
    [(0, 2), (0, 2), (0,)]
    """
    out = (_float32(ml, "ml", points=True), _float32(mr, "mr", points=True),
           _float32(disp, "disp", points=False))
    if not len(out[0]) == len(out[1]) == len(out[2]):
        raise InvalidArgumentError(
            f"`ml`, `mr` and `disp` must have one entry per match, got {len(out[0])}, "
            f"{len(out[1])} and {len(out[2])}",
            argument="mr" if len(out[0]) != len(out[1]) else "disp")
    return out


def _float32(value, name: str, points: bool) -> np.ndarray:
    """One argument of :func:`as_arrays`: (M, 2) points or (M,) values, as float32."""
    what = ("(x, y) points: a sequence of pairs or an (M, 2) array" if points
            else "disparities: a sequence of numbers or an (M,) array")
    if value is None or isinstance(value, (str, bytes)):
        raise InvalidTypeError(f"`{name}` must be {what}, got {type(value).__name__} "
                               f"{value!r}"[:160], argument=name)
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError) as exc:  # ragged nesting
        raise InvalidTypeError(f"`{name}` must be {what}: {exc}", argument=name) from None
    if (arr.dtype == np.bool_ or not np.issubdtype(arr.dtype, np.number)
            or np.iscomplexobj(arr)):
        raise InvalidTypeError(f"`{name}` must hold real numbers ({what}), got dtype "
                               f"{arr.dtype}", argument=name)
    if arr.size == 0:
        arr = arr.reshape((0, 2) if points else (0,))
    elif points and arr.ndim == 3 and arr.shape[1:] == (1, 2):  # cv2's (M, 1, 2)
        arr = arr.reshape(-1, 2)
    elif not points and arr.ndim == 2 and arr.shape[1] == 1:
        arr = arr.reshape(-1)
    if arr.shape[1:] != ((2,) if points else ()) or arr.ndim != (2 if points else 1):
        raise InvalidArgumentError(f"`{name}` must be {what}, got shape {arr.shape}",
                                   argument=name)
    with np.errstate(over="ignore", invalid="ignore"):
        out = np.ascontiguousarray(arr, dtype=np.float32)
    if not np.isfinite(out).all():
        raise InvalidArgumentError(f"`{name}` holds NaN, infinite values or values beyond "
                                   "the float32 range", argument=name)
    return out


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
            try:
                out = self.graph.apply(cv.gin(left, right), args=self.args)
            except cv.error:
                if self.raised.error is None:
                    raise
            # what the kernel raised (hopmatch's error, a warning turned into an error,
            # KeyboardInterrupt...), the object itself, as match_stereo would have raised it
            error, self.raised.error = self.raised.error, None
            if error is not None:
                raise error
            return out


#: How many compiled graphs (parameter sets) :func:`match_pair` keeps, the least recently
#: used dropped first: each holds a compiled G-API executable and its buffers (about
#: 0.3 MB for small images), so that many parameter sets do not add up without bound.
CACHE_SIZE = 8

_CACHE: OrderedDict = OrderedDict()
_CACHE_LOCK = threading.Lock()


def _key(params: dict):
    return tuple(sorted((k, repr(v)) for k, v in params.items()))


def match_pair(left, right, **params) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Match a pair through the compiled G-API graph: ``match_stereo(left, right,
    **params)``'s matches, bit for bit.

    The graph is built and compiled once per parameter set (and again only when the image
    size or type changes) and reused by later calls; the graphs of the last
    :data:`CACHE_SIZE` parameter sets are kept.

    Parameters
    ----------
    left, right : (H, W) or (H, W, 3|4) ndarray
        The pair, as for :func:`hopmatch.match_stereo` (with ``rectified=None``: a
        rectified pair's rows are searched).
    **params
        Detector and matcher parameters (``preset``, ``max_disparity``, ``window_size``...),
        as for :func:`hopmatch.match_stereo`. Its other keywords (``rectified``,
        ``fundamental_matrix``, ``mask_left``, ``mask_right``, ``detector``, ``matcher``,
        ``threads``, ``record_energy``) are not taken: G-API kernels receive only the two
        images, their parameters fixed in the kernel package, and the graph outputs the
        matches only (:data:`hopmatch_gapi.kernels.NOT_TAKEN` says why for each); call
        :func:`hopmatch.match_stereo` for them.

    Returns
    -------
    matched_left, matched_right : (M, 2) float32 ndarray
        (x, y) of each match in the left and right image.
    disparities : (M,) float32 ndarray
        ``x_left - x_right``.

    Raises
    ------
    InvalidArgumentError, InvalidTypeError
        As :func:`hopmatch.match_stereo` raises them: unknown or invalid parameters
        (``max_disparity`` below ``min_disparity`` included) and images that are not
        images before the graph; what only matching finds (rows of two heights with a
        disparity range given, a budget too small for the images) after it, the error
        raised inside the graph's kernel. Never ``cv2.error``. Anything else raised inside the
        kernel (a warning turned into an error by ``warnings.simplefilter("error")``,
        ``KeyboardInterrupt``) is raised too, the object itself, as from
        :func:`hopmatch.match_stereo`; warnings reach the caller as they do from it.
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
            while len(_CACHE) > max(1, CACHE_SIZE):  # a graph in use elsewhere finishes
                _CACHE.popitem(last=False)
        else:
            _CACHE.move_to_end(key)
    return as_arrays(*compiled(left, right))
