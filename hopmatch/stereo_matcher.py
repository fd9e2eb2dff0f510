"""``StereoHopfield``: hopmatch behind the interface of OpenCV's ``cv2.StereoMatcher``.

Code written for ``cv2.StereoBM_create`` / ``cv2.StereoSGBM_create`` (OpenCV's
``samples/python/stereo_match.py``, ``cv2.reprojectImageTo3D``, WLS filters reading CV_16S
maps) runs with only its creation line changed: :meth:`StereoHopfield.compute` returns a
disparity image of the left view in OpenCV's conventions, filled at the matched keypoints
only (hopmatch is a sparse matcher). ``docs/migration.md`` ("Replacing StereoSGBM") shows
the swap and says what differs.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from ._interrupts import keeps_interrupts
from ._params import Configurable, Param, integer
from ._validate import describe
from .errors import InvalidArgumentError, InvalidTypeError
from .feature.detector import DericheMoravecDetector
from .matching.matcher import HopfieldMatcher
from .matching.stereo_match import StereoMatchResult, match_stereo, stereo_pipeline

__all__ = ["DISP_SCALE", "StereoHopfield"]

#: Fixed-point scale of the CV_16S output: OpenCV's ``StereoMatcher::DISP_SCALE`` (16,
#: four fractional bits).
DISP_SCALE = 16

#: Largest disparity range the CV_16S output can hold: ``(minDisparity - 1) * 16`` and
#: ``(minDisparity + numDisparities - 1) * 16`` must fit in int16.
_INT16_DISPARITY = 2047

# The parameters under OpenCV's names, then every other detector and matcher parameter
# under its hopmatch name (descriptor_size is blockSize; the disparity range is
# minDisparity / numDisparities; preset is shared by both parts).
_CV2_PARAMS = (
    Param("minDisparity", 0, integer(-_INT16_DISPARITY, _INT16_DISPARITY), doc=(
        "Smallest disparity searched, in pixels (x_left - x_right); may be negative. "
        "Pixels without a match get (minDisparity - 1) * 16 in the CV_16S output.")),
    Param("numDisparities", 0, integer(0, 2 * _INT16_DISPARITY + 1), doc=(
        "Number of disparities searched: minDisparity .. minDisparity + numDisparities - 1 "
        "(any positive number; OpenCV's block matchers want a multiple of 16, hopmatch "
        "does not). 0: hopmatch's own range (max_disparity=None), resolved per pair.")),
    Param("blockSize", 9, integer(1, 99, odd=True), doc=(
        "Odd side of the descriptor window compared between the images (eqs. 7-9), "
        "hopmatch's descriptor_size.")),
)
_RENAMED = {"min_disparity", "max_disparity", "descriptor_size"}
_OTHER_PARAMS = tuple(
    p for p in DericheMoravecDetector.PARAMS + HopfieldMatcher.PARAMS
    if p.name not in _RENAMED and not (p.name == "preset" and p in HopfieldMatcher.PARAMS)
)


def _preset_values(name: str) -> dict[str, Any]:
    """The values preset ``name`` gives, under this class's parameter names."""
    values = {**DericheMoravecDetector.PRESETS.get(name, {}),
              **HopfieldMatcher.PRESETS.get(name, {})}
    lo, hi = values.pop("min_disparity", None), values.pop("max_disparity", None)
    if "descriptor_size" in values:
        values["blockSize"] = values.pop("descriptor_size")
    if lo is not None:
        values["minDisparity"] = int(np.floor(lo))
        values["numDisparities"] = 0 if hi is None else int(np.ceil(hi)) - int(np.floor(lo)) + 1
    return values


class StereoHopfield(Configurable):
    """hopmatch with the interface of ``cv2.StereoMatcher`` (``StereoBM``, ``StereoSGBM``).

    :meth:`compute` detects Moravec points on both images, matches them with the Hopfield
    network (:func:`~hopmatch.match_stereo`) and returns the disparity image of the left
    view as OpenCV's block matchers do: CV_16S, disparity x 16 (four fractional bits),
    ``(minDisparity - 1) * 16`` where there is no match; or float32 in pixels on request
    (``dtype=np.float32``; no match: ``minDisparity - 1``). Only the pixels of matched left
    keypoints hold a disparity: code such as ``mask = disp > disp.min()`` (OpenCV's
    ``stereo_match.py``) or ``disp >= minDisparity`` selects exactly the matches.

    Parameters
    ----------
    minDisparity : int
        Smallest disparity searched, in pixels (``x_left - x_right``); may be negative.
    numDisparities : int
        Number of disparities searched, ``minDisparity .. minDisparity + numDisparities -
        1``; any positive number (OpenCV's matchers want a multiple of 16; hopmatch does
        not). 0 (the default): hopmatch's own range (``max_disparity=None``), resolved for
        each pair.
    blockSize : int
        Odd side of the descriptor window (``descriptor_size``, eqs. 7-9), 1..99.
    **params
        Any other :class:`~hopmatch.DericheMoravecDetector` or
        :class:`~hopmatch.HopfieldMatcher` parameter under its own name (``preset``,
        ``window_size``, ``max_vertical``, ``seed`` ...), except ``min_disparity``,
        ``max_disparity`` and ``descriptor_size``, which the three above replace. Each has
        a ``getX``/``setX`` accessor (``getWindowSize``), as the three have theirs
        (``getMinDisparity``, ``setNumDisparities``, ``getBlockSize`` ...).

    Notes
    -----
    What a ``StereoSGBM`` user should know (``docs/migration.md``):

    * ``create`` takes ``minDisparity``, ``numDisparities`` and ``blockSize`` by position or
      keyword, as ``cv2.StereoSGBM_create`` does; SGBM's other knobs (``P1``, ``P2``,
      ``disp12MaxDiff``, ``uniquenessRatio``, ``speckleWindowSize``, ``speckleRange``,
      ``preFilterCap``, ``mode``) have no counterpart and are refused with the list of
      valid parameters: the network's continuity (``theta``, ``slope``) replaces the
      smoothness penalties, its left-right check (``cross_check``) the uniqueness and
      disp12 checks, and a sparse result has no speckles to remove.
    * Like ``cv2.StereoBM``, ``blockSize`` must be odd.
    * The pair must be rectified (same rows). The output is sparse: a few thousand pixels
      of a 741 x 500 pair, each one a match that survived the network and the checks.
      :meth:`getLastResult` gives them as arrays (points, disparities, ``cv2.DMatch``).
    * ``write``/``read``/``save``/``load`` go through ``cv2.FileStorage`` like an OpenCV
      algorithm's; the node is :meth:`getDefaultName`.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(1)
    >>> left = (rng.random((120, 160)) * 255).astype(np.uint8)
    >>> right = np.roll(left, -6, axis=1)               # disparity 6 everywhere
    >>> stereo = StereoHopfield.create(minDisparity=0, numDisparities=16, blockSize=9)
    >>> disp = stereo.compute(left, right)
    >>> disp.dtype, disp.shape, int(disp.min())          # CV_16S, no match: (0 - 1) * 16
    (dtype('int16'), (120, 160), -16)
    >>> int(np.median(disp[disp >= 0]))                  # 6 px x 16
    96
    >>> stereo.getNumDisparities(), stereo.getBlockSize()
    (16, 9)
    """

    DEFAULT_NAME = "hopmatch_StereoHopfield"
    PARAMS = _CV2_PARAMS + _OTHER_PARAMS
    PRESETS = {name: _preset_values(name)
               for name in sorted(set(DericheMoravecDetector.PRESETS)
                                  | set(HopfieldMatcher.PRESETS))}

    def __init__(self, minDisparity=None, numDisparities=None, blockSize=None,  # noqa: N803
                 **params):
        for name, value in (("minDisparity", minDisparity),
                            ("numDisparities", numDisparities), ("blockSize", blockSize)):
            if value is not None:
                params[name] = value
        self._init_params(params)
        self._last: StereoMatchResult | None = None

    @classmethod
    def create(cls, minDisparity=None, numDisparities=None, blockSize=None,  # noqa: N803
               **params) -> StereoHopfield:
        """cv2-style factory, as ``cv2.StereoSGBM_create(minDisparity, numDisparities,
        blockSize, ...)``: ``StereoHopfield.create(16, 96, 9)`` or by keyword."""
        return cls(minDisparity, numDisparities, blockSize, **params)

    def _check_consistency(self) -> None:
        lo, n = self._params["minDisparity"], self._params["numDisparities"]
        if n and lo + n - 1 > _INT16_DISPARITY:
            raise InvalidArgumentError(
                f"`numDisparities` ({n}) with `minDisparity` ({lo}) reaches disparity "
                f"{lo + n - 1}, beyond the {_INT16_DISPARITY} px a CV_16S disparity x 16 can "
                "hold; narrow the range", argument="numDisparities")

    # -- the hopmatch pipeline -------------------------------------------------------------
    def pipeline_parameters(self) -> dict[str, Any]:
        """The parameters of :func:`~hopmatch.match_stereo` this matcher runs with:
        ``min_disparity = minDisparity``, ``max_disparity = minDisparity + numDisparities -
        1`` (None when ``numDisparities`` is 0), ``descriptor_size = blockSize``, the rest
        as given."""
        p = dict(self._params)
        lo, n = p.pop("minDisparity"), p.pop("numDisparities")
        p["descriptor_size"] = p.pop("blockSize")
        p["min_disparity"] = float(lo)
        p["max_disparity"] = float(lo + n - 1) if n else None
        return p

    @keeps_interrupts
    def compute(self, left, right, disparity=None, *, dtype=None) -> np.ndarray:
        """The disparity image of the left view, as ``cv2.StereoMatcher.compute``.

        Parameters
        ----------
        left, right : (H, W) or (H, W, 3|4) ndarray
            A rectified pair (grey, BGR or BGRA; 8-bit, 16-bit or float), as for
            :func:`~hopmatch.match_stereo`.
        disparity : (H, W) int16 or float32 ndarray, optional
            Output array, filled and returned (as cv2's optional output argument); its
            dtype chooses the format unless ``dtype`` is given too (they must agree).
        dtype : numpy dtype or cv2 depth, optional
            ``np.int16`` / ``cv2.CV_16S`` (default): disparity x 16, rounded to the nearest
            integer; ``np.float32`` / ``cv2.CV_32F``: disparity in pixels.

        Returns
        -------
        (H, W) int16 or float32 ndarray
            Disparity at the pixel nearest to each matched left keypoint (where two
            keypoints share a pixel, the larger disparity); elsewhere
            ``(minDisparity - 1) * 16`` (int16) or ``minDisparity - 1`` (float32).

        Raises
        ------
        InvalidArgumentError, InvalidTypeError
            Bad images (as :func:`~hopmatch.match_stereo`), a ``disparity`` array of
            another shape or dtype, or read-only, or a ``dtype`` other than the two above.

        Warns
        -----
        HopmatchWarning
            As :func:`~hopmatch.match_stereo` (image sizes, disparity range, unrectified
            pair).
        """
        from .stereo.depth import sparse_disparity_image  # hopmatch.stereo loads on first use

        out_dtype = self._output_dtype(disparity, dtype, left)  # before the work
        detector, matcher = stereo_pipeline(self.pipeline_parameters(), "StereoHopfield")
        result = match_stereo(left, right, detector=detector, matcher=matcher)
        self._last = result
        shape = _left_shape(left)
        lo = self._params["minDisparity"]
        dense = sparse_disparity_image(result.matched_left, result.disparities, shape)
        unmatched = np.isnan(dense)
        if out_dtype == np.float32:
            values = np.where(unmatched, np.float32(lo - 1), dense).astype(np.float32)
        else:
            top = float(np.nanmax(dense)) if not unmatched.all() else float(lo)
            if top * DISP_SCALE > np.iinfo(np.int16).max:
                raise InvalidArgumentError(
                    f"a match has disparity {top:g} px, beyond the {_INT16_DISPARITY} px a "
                    "CV_16S disparity x 16 can hold; set numDisparities, or ask for "
                    "dtype=np.float32", argument="numDisparities")
            scaled = np.rint(np.where(unmatched, lo - 1, dense) * DISP_SCALE)
            values = scaled.astype(np.int16)
        if disparity is None:
            return values
        disparity[...] = values
        return disparity

    @staticmethod
    def _output_dtype(disparity, dtype, left):
        """The dtype :meth:`compute` fills, from ``dtype`` and the output array
        ``disparity``; an output array must be int16 or float32 (the one ``dtype`` asks
        for), of the left image's ``(H, W)`` (a left image that is not one is left to
        :func:`~hopmatch.match_stereo` to refuse) and writeable."""
        wanted = None
        if dtype is not None:
            if isinstance(dtype, (int, np.integer)) and not isinstance(dtype, bool):
                wanted = {cv2.CV_16S: np.int16, cv2.CV_32F: np.float32}.get(int(dtype))
            else:
                try:
                    wanted = np.dtype(dtype).type
                except TypeError:
                    wanted = None
            if wanted not in (np.int16, np.float32):
                raise InvalidArgumentError(
                    "`dtype` must be np.int16 / cv2.CV_16S (disparity x 16) or np.float32 / "
                    f"cv2.CV_32F (pixels), got {describe(dtype)}", argument="dtype")
        if disparity is None:
            return wanted or np.int16
        if not isinstance(disparity, np.ndarray):
            raise InvalidTypeError(
                f"`disparity` must be a NumPy array (the output), got {describe(disparity)}",
                argument="disparity")
        if disparity.dtype.type not in (np.int16, np.float32):
            raise InvalidArgumentError(
                f"`disparity` must be int16 (CV_16S) or float32, got {disparity.dtype}",
                argument="disparity")
        if wanted is not None and disparity.dtype.type != wanted:
            raise InvalidArgumentError(
                f"`disparity` is {disparity.dtype} but `dtype` asks for "
                f"{np.dtype(wanted)}; give one of them", argument="disparity")
        if len(np.shape(left)) >= 2 and disparity.shape != _left_shape(left):
            raise InvalidArgumentError(
                f"`disparity` must have the left image's shape {_left_shape(left)} (H, W), got "
                f"{disparity.shape}", argument="disparity")
        if not disparity.flags.writeable:
            raise InvalidArgumentError(
                "`disparity` must be writeable (it is filled in place), got a read-only array; "
                "pass a copy, or no output array", argument="disparity")
        return disparity.dtype.type

    def getLastResult(self) -> StereoMatchResult | None:  # noqa: N802 (cv2 naming)
        """The :class:`~hopmatch.StereoMatchResult` of the last :meth:`compute` (the
        matches as arrays and cv2 objects), or None."""
        return self._last

    # -- cv2.Algorithm housekeeping (save, load: Configurable's) --------------------------
    def empty(self) -> bool:
        """False: a StereoHopfield is ready to compute as soon as it is created."""
        return False

    def clear(self) -> None:
        """Forget the last result."""
        self._last = None

    def __setstate__(self, state):
        super().__setstate__(state)
        self._last = None


def _left_shape(left) -> tuple[int, int]:
    """``(H, W)`` of the left image (checked by :func:`~hopmatch.match_stereo` already)."""
    return tuple(int(v) for v in np.shape(left)[:2])
