"""The cv2 Feature2D-like DericheMoravecDetector (SPEC section 1)."""

from __future__ import annotations

from collections.abc import Sequence
from itertools import compress, repeat, starmap

import cv2
import numpy as np

from .._interrupts import keeps_interrupts
from .._params import Configurable, Param, boolean, choice, integer, real
from .._validate import DEFAULT_MAX_PIXELS, as_flag, as_gray_image, as_mask, as_points
from ..errors import InvalidArgumentError, InvalidTypeError
from .blocking import block_artifact_mask
from .descriptor import cut_windows, window_inside
from .gradient import feature_image
from .moravec import response, select_points


def keypoints_from_arrays(points: np.ndarray, responses: np.ndarray, size: float):
    """A tuple of ``cv2.KeyPoint`` (angle -1, octave 0, class_id -1) from (x, y) and responses.

    Built in bulk: ``cv2.KeyPoint`` called from C (``itertools.starmap``) on flat lists of
    the columns, so that no per-point Python frame or (x, y) list is made (the lists would
    also wake the cyclic garbage collector every 700 points). ``cv2.KeyPoint_convert``
    cannot set one response per point. Each keypoint holds exactly the float32 ``pt``,
    ``size`` and ``response`` given.
    """
    pts = np.asarray(points, dtype=np.float32).reshape(-1, 2)
    return tuple(starmap(cv2.KeyPoint, zip(
        pts[:, 0].tolist(), pts[:, 1].tolist(), repeat(float(size)), repeat(-1.0),
        np.asarray(responses, dtype=np.float32).tolist())))


class DericheMoravecDetector(Configurable):
    """Moravec interest points on a Canny-Deriche gradient-magnitude image.

    A plain Python class with the interface of ``cv2.Feature2D``: ``detect``,
    ``compute``, ``detectAndCompute``, ``descriptorSize``, ``write``/``read``... It returns
    real ``cv2.KeyPoint`` objects (``pt`` in (x, y), ``size`` = ``window_size``,
    ``response`` = V, ``angle`` -1, ``octave`` 0, ``class_id`` -1) and float32 descriptors
    holding the mean-subtracted window of G around each point (eqs. 8-9).

    Parameters
    ----------
    window_size : int
        Odd side of the Moravec window of eq. 1 (paper: 5).
    window_sigma : float
        Weights of that window: 0 (default) the box of eq. 1 as printed; > 0 Gaussian
        weights of this standard deviation over the same square, scaled to the box's total
        (Harris's remedy for Moravec's shift-sensitive box; see
        :func:`~hopmatch.feature.moravec_response` and ``docs/parameters.md``).
    nms_size : int
        Side of the neighbourhood in which a point must be the strict maximum (eq. 2;
        paper: 20). It spans ``nms_size // 2`` pixels on each side.
    threshold : float
        Absolute threshold on V (eq. 2). The default, 1e-3, only removes the numerical
        noise of the recursive filter on perfectly flat regions (V there is about 1e-9).
    relative_threshold : float
        Threshold as a fraction of the image's largest V; the larger of the two applies.
    alpha, omega : float
        Canny-Deriche filter parameters (``cv2.ximgproc.GradientDericheX/Y``), both > 0.
    on : {'gradient', 'intensity'}
        Measure V (and cut descriptors) on the gradient magnitude, as the paper does, or
        on grey levels.
    max_features : int
        Keep the strongest points only (0: keep all).
    subpixel : bool
        Refine positions by a quadratic fit of V (see ``docs/parameters.md``).
    descriptor_size : int
        Odd side of the descriptor window (eqs. 7-9).
    jpeg_guard : bool
        Detect no point where an image's only texture is JPEG's 8 x 8 block grid
        (:mod:`hopmatch.feature.blocking`): such points match the other view's at
        multiples of 8 px whatever the scene's disparity. Images without a block grid are
        unaffected. Default True; False in the ``paper`` preset.
    max_pixels : int
        Largest image (height x width) accepted; larger ones raise
        :class:`~hopmatch.errors.BudgetExceededError` before any copy is made. Detection
        needs about 45 bytes per pixel at its peak (about 20 more with
        ``window_sigma > 0``; plus 4 x ``descriptor_size ** 2`` bytes per keypoint); the
        default, 50 million pixels, bounds it near 2.2 GiB. See ``docs/robustness.md``.

    Notes
    -----
    A detector holds only its parameters: one instance may be shared by threads, as long as
    no thread changes its parameters meanwhile.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.zeros((64, 64), np.uint8); img[20:44, 20:44] = 200
    >>> det = DericheMoravecDetector.create(nms_size=9)
    >>> kps, desc = det.detectAndCompute(img, None)
    >>> len(kps) > 0, desc.shape[1] == det.descriptorSize(), desc.dtype
    (True, True, dtype('float32'))
    """

    DEFAULT_NAME = "hopmatch_DericheMoravecDetector"
    PARAMS = (
        Param("preset", "default", choice("default", "paper")),
        Param("window_size", 3, integer(1, 99, odd=True)),
        Param("window_sigma", 0.0, real(0.0)),
        Param("nms_size", 3, integer(1, 999)),
        Param("threshold", 1e-3, real(0.0)),
        Param("relative_threshold", 0.0, real(0.0, 1.0)),
        Param("alpha", 1.0, real(0.0, lo_open=True)),
        Param("omega", 0.001, real(0.0, lo_open=True)),
        Param("on", "gradient", choice("gradient", "intensity")),
        Param("max_features", 0, integer(0)),
        Param("subpixel", True, boolean()),
        Param("descriptor_size", 9, integer(1, 99, odd=True)),
        Param("jpeg_guard", True, boolean()),
        Param("max_pixels", DEFAULT_MAX_PIXELS, integer(1)),
    )

    PRESETS = {
        # section 4 of the paper: 5 x 5 Moravec window, 20 x 20 neighbourhood, integer pixels
        "paper": {"window_size": 5, "nms_size": 20, "subpixel": False, "on": "gradient",
                  "jpeg_guard": False},
    }
    PRESETS["default"] = {"window_size": 3, "nms_size": 3, "subpixel": True, "on": "gradient",
                          "jpeg_guard": True}

    def __init__(self, **params):
        self._init_params(params)

    # -- array-level API ------------------------------------------------------------------
    @keeps_interrupts
    def feature_image(self, image, name: str = "image") -> np.ndarray:
        """The float32 image G that points and descriptors are measured on (SPEC section 1),
        of ``image`` checked (``max_pixels`` included) and converted to grey; errors name
        ``name``."""
        return self.gray_and_feature_image(image, name)[1]

    def gray_image(self, image, name: str = "image") -> np.ndarray:
        """``image`` checked (``max_pixels`` included) and converted to grey
        (:func:`~hopmatch._validate.as_gray_image`; it may be ``image`` itself); errors
        name ``name``."""
        return as_gray_image(image, name, max_pixels=self._params["max_pixels"])

    @keeps_interrupts
    def gray_and_feature_image(self, image, name: str = "image"):
        """``(grey, G)``: ``image`` as :meth:`gray_image` returns it, and the feature image
        G of :meth:`feature_image`; errors name ``name``."""
        p = self._params
        gray = self.gray_image(image, name)
        return gray, feature_image(gray, p["on"], p["alpha"], p["omega"], name)

    @keeps_interrupts
    def points_on(self, g: np.ndarray, mask=None, mask_name: str = "mask"):
        """Moravec points (eqs. 1-2) of the feature image ``g``: ``(points (N, 2) float32
        (x, y), responses (N,) float32)``, strongest first; ``mask`` as for :meth:`detect`."""
        p = self._params
        mask = as_mask(mask, g.shape, mask_name)
        v = response(g, p["window_size"], p["window_sigma"])
        return select_points(v, p["nms_size"], p["threshold"], p["relative_threshold"],
                             p["window_size"] // 2 + 1, p["max_features"], p["subpixel"], mask)

    def detection_mask(self, gray: np.ndarray, mask=None, mask_name: str = "mask"):
        """Where points of the grey image ``gray`` may be detected: ``mask`` (checked, as
        for :meth:`detect`) less, with ``jpeg_guard``, where JPEG's block grid is the only
        texture (:func:`~hopmatch.feature.blocking.block_artifact_mask`); None for
        everywhere."""
        mask = as_mask(mask, gray.shape, mask_name)
        if not self._params["jpeg_guard"]:
            return mask
        allowed = block_artifact_mask(gray)
        if allowed is None:
            return mask
        return allowed if mask is None else allowed & mask

    @keeps_interrupts
    def detect_points(self, image, mask=None):
        """Points as arrays: ``(points (N, 2) float32 (x, y), responses (N,), G)``."""
        gray, g = self.gray_and_feature_image(image)
        pts, resp = self.points_on(g, self.detection_mask(gray, mask))
        return pts, resp, g

    @keeps_interrupts
    def describe_points(self, g: np.ndarray, points: np.ndarray):
        """Descriptors (eqs. 8-9) of (x, y) float32 ``points`` on the feature image ``g``:
        ``(keep, descriptors)``, ``keep`` the (N,) bool mask of the points whose descriptor
        window lies inside the image, ``descriptors`` one float32 row per kept point."""
        size = self._params["descriptor_size"]
        keep = window_inside(points, g.shape, size)
        # np.compress: the kept rows, as points[keep] but ten times faster on (N, 2) rows
        return keep, cut_windows(g, np.compress(keep, points, axis=0), size)

    @keeps_interrupts
    def detect_and_describe(self, image, mask=None, *, name: str = "image",
                            mask_name: str = "mask", keep_gray: bool = False):
        """Detect and describe ``image`` with arrays only (what :meth:`detectAndCompute`
        does, without ``cv2.KeyPoint`` objects).

        Returns
        -------
        points : (N, 2) float32 ndarray
            (x, y) of the points whose descriptor window fits in the image, strongest first.
        responses : (N,) float32 ndarray
            Their Moravec response V (eq. 1).
        descriptors : (N, descriptorSize()) float32 ndarray
            One row per point (eqs. 8-9).
        gradient : (H, W) float32 ndarray
            The feature image G they were measured on.
        gray : (H, W) ndarray
            Only with ``keep_gray=True``: the checked grey image G was computed from (as
            :func:`~hopmatch._validate.as_gray_image` returns it; it may be ``image``
            itself), for steps that work on grey levels (the sub-pixel refinement).
        """
        gray, g = self.gray_and_feature_image(image, name)
        pts, resp = self.points_on(g, self.detection_mask(gray, mask, mask_name), mask_name)
        keep, desc = self.describe_points(g, pts)
        out = (np.compress(keep, pts, axis=0), resp[keep], desc, g)
        return out + (gray,) if keep_gray else out

    def keypoints(self, points: np.ndarray, responses: np.ndarray) -> tuple:
        """``cv2.KeyPoint`` objects of (x, y) ``points`` with these ``responses``, as
        :meth:`detect` returns them (``size`` = ``window_size``)."""
        return keypoints_from_arrays(points, responses, float(self._params["window_size"]))

    # -- cv2.Feature2D API ----------------------------------------------------------------
    @keeps_interrupts
    def detect(self, image, mask=None):
        """Keypoints of ``image`` (a tuple of ``cv2.KeyPoint``), or of each image of a list."""
        if isinstance(image, (list, tuple)):
            masks = _per_image(mask, len(image))
            return [self.detect(im, m) for im, m in zip(image, masks)]
        pts, resp, _ = self.detect_points(image, mask)
        return self.keypoints(pts, resp)

    @keeps_interrupts
    def compute(self, image, keypoints, descriptors=None):
        """``(keypoints, descriptors)``: float32 rows (eqs. 8-9), one per kept keypoint.

        Keypoints whose descriptor window leaves the image are dropped, as cv2 does.
        Keypoints from any detector are accepted.
        """
        if isinstance(image, (list, tuple)):
            if not isinstance(keypoints, (list, tuple)) or len(keypoints) != len(image):
                raise InvalidArgumentError(
                    "`keypoints` must be a list with one keypoint sequence per image "
                    f"({len(image)} images)"
                )
            out = [self.compute(im, kp) for im, kp in zip(image, keypoints)]
            return [o[0] for o in out], [o[1] for o in out]
        keypoints, pts = _as_keypoint_tuple(keypoints)  # check before the costly gradient
        return self._describe_keypoints(self.feature_image(image), keypoints, pts)

    def _describe_keypoints(self, g, keypoints: tuple, pts: np.ndarray):
        """``(kept keypoints, descriptors)`` of ``keypoints`` at their positions ``pts``
        (read by :func:`_as_keypoint_tuple` in this call)."""
        keep, desc = self.describe_points(g, pts)
        if keep.all():
            return keypoints, desc
        return tuple(compress(keypoints, keep.tolist())), desc

    @keeps_interrupts
    def detectAndCompute(self, image, mask=None, descriptors=None,  # noqa: N802
                         useProvidedKeypoints=False, keypoints=None):  # noqa: N803
        """Detect and describe in one pass (G is computed once).

        With ``useProvidedKeypoints=True``, describe ``keypoints`` instead of detecting.
        """
        if as_flag(useProvidedKeypoints, "useProvidedKeypoints"):
            if keypoints is None:
                raise InvalidArgumentError(
                    "`keypoints` must be given when useProvidedKeypoints=True"
                )
            keypoints, pts = _as_keypoint_tuple(keypoints)
            return self._describe_keypoints(self.feature_image(image), keypoints, pts)
        pts, resp, desc, _ = self.detect_and_describe(image, mask)
        return self.keypoints(pts, resp), desc

    def empty(self) -> bool:
        """Always False: the detector needs no training."""
        return False

    def descriptorSize(self) -> int:  # noqa: N802
        """Length of a descriptor row: ``descriptor_size ** 2``."""
        return self._params["descriptor_size"] ** 2

    def descriptorType(self) -> int:  # noqa: N802
        """``cv2.CV_32F``."""
        return cv2.CV_32F

    def defaultNorm(self) -> int:  # noqa: N802
        """``cv2.NORM_L1``: eq. 7 is a mean absolute difference."""
        return cv2.NORM_L1


def _per_image(mask, n):
    if mask is None:
        return [None] * n
    if not isinstance(mask, (list, tuple)) or len(mask) != n:
        got = f"a list of {len(mask)}" if isinstance(mask, (list, tuple)) else type(mask).__name__
        raise InvalidArgumentError(
            f"`mask` must be None or a list of {n} masks, one per image, got {got}"
        )
    return list(mask)


def _as_keypoint_tuple(keypoints):
    """``(keypoints as a tuple, their (N, 2) float32 positions)``, or
    :class:`InvalidTypeError` naming ``keypoints``. The positions are read from the
    keypoints in this call (``KeyPoint.pt`` is writable: nothing is cached between calls)."""
    if keypoints is None:
        raise InvalidTypeError("`keypoints` must be a sequence of cv2.KeyPoint, got None")
    if isinstance(keypoints, cv2.KeyPoint):
        keypoints = (keypoints,)
    if not isinstance(keypoints, Sequence) or isinstance(keypoints, (str, bytes)):
        hint = ("; convert an (N, 2) array with cv2.KeyPoint_convert(points)"
                if isinstance(keypoints, np.ndarray) else "")
        raise InvalidTypeError(
            f"`keypoints` must be a sequence of cv2.KeyPoint, got {type(keypoints).__name__}"
            f"{hint}"
        )
    keypoints = tuple(keypoints)
    if not keypoints:
        return keypoints, np.zeros((0, 2), np.float32)
    if isinstance(keypoints[0], cv2.KeyPoint):
        try:  # converts and checks every item's type in one cv2 call
            return keypoints, as_points(keypoints, "keypoints")
        except InvalidTypeError:
            if all(isinstance(kp, cv2.KeyPoint) for kp in keypoints):
                raise
    bad = next(kp for kp in keypoints if not isinstance(kp, cv2.KeyPoint))
    raise InvalidTypeError(
        "`keypoints` must hold only cv2.KeyPoint objects, got a "
        f"{type(bad).__name__}; convert (x, y) pairs with cv2.KeyPoint_convert(points)"
    )
