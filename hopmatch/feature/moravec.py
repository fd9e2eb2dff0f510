"""SPEC section 1, items 2-3: Moravec directional variance (eq. 1) and points (eq. 2)."""

from __future__ import annotations

import math

import cv2
import numpy as np

from .._interrupts import keeps_interrupts
from .._kernels import moravec as _k
from .._params import integer, real
from .._validate import as_mask
from ..errors import InvalidArgumentError, InvalidTypeError


def _as_float_image(image, name="image") -> np.ndarray:
    if not isinstance(image, np.ndarray):
        raise InvalidTypeError(f"`{name}` must be a numpy array, got {type(image).__name__}")
    if image.ndim != 2:
        raise InvalidArgumentError(
            f"`{name}` must be a 2-dimensional array, got shape {image.shape}")
    if image.dtype == np.bool_ or not np.issubdtype(image.dtype, np.number):
        raise InvalidTypeError(f"`{name}` must be a numeric array, got dtype {image.dtype}")
    out = np.ascontiguousarray(image, dtype=np.float32)
    if not np.isfinite(out).all():
        raise InvalidArgumentError(f"`{name}` contains NaN or infinite values")
    return out


#: Largest quantised |G|: window sums of squared differences then stay below 2**54.
QUANT_LEVELS_LOG2 = 19


def quantisation_step(g: np.ndarray) -> tuple[float, float]:
    """The power-of-two grid of eq. 1's exact sums: ``(factor, scale)``, G quantised being
    ``rint(float64(G) * factor)`` and ``scale`` the grid step squared (``factor ** -2``).

    ``factor = 2**e`` brings ``max |G|`` to at most ``2**19`` (for an 8-bit image's gradient,
    about 1/1000 of a grey level); a blank image gives ``(1.0, 1.0)``. The one home of the
    rule: :func:`quantise` and the box kernel (which quantises each pixel itself) both use it.
    """
    # max |G| of float32 values, exactly, without an array of |G|
    gmax = float(np.maximum(g.max(), -g.min())) if g.size else 0.0
    if gmax == 0.0:
        return 1.0, 1.0
    e = math.floor(math.log2(2.0**QUANT_LEVELS_LOG2 / gmax))
    return 2.0**e, 2.0 ** (-2 * e)


def quantise(g: np.ndarray) -> tuple[np.ndarray, float]:
    """G on a power-of-two grid as int64, and ``scale`` = the grid step squared.

    The step is the power of two that brings ``max |G|`` to at most ``2**19`` (for an 8-bit
    image's gradient, about 1/1000 of a grey level; :func:`quantisation_step`), so every
    window sum of eq. 1 is an exact integer: fast sliding sums then give the same value as
    the textbook double loop.
    """
    factor, scale = quantisation_step(g)
    return np.rint(g.astype(np.float64) * factor).astype(np.int64), scale


def response(g: np.ndarray, window_size: int, window_sigma: float = 0.0) -> np.ndarray:
    """Eq. 1 on a validated float32 image (see :func:`moravec_response`)."""
    if window_sigma > 0.0 and window_size > 1:
        gq, scale = quantise(g)
        return _weighted_response(gq, scale, window_size, window_sigma)
    factor, scale = quantisation_step(g)
    return _k.moravec_response(g, factor, window_size // 2, scale)


def window_weights(window_size: int, window_sigma: float) -> np.ndarray:
    """The 1-D weights ``k`` of the window of eq. 1: ``w(i, j) = k[i] * k[j]``.

    ``window_sigma == 0``: the box of eq. 1 as printed, all ones. Otherwise the Gaussian
    ``cv2.getGaussianKernel(window_size, window_sigma)`` scaled to sum to ``window_size``,
    so that the 2-D weights sum to ``window_size ** 2`` like the box's and V keeps its
    magnitude (and the absolute ``threshold`` its meaning).
    """
    if window_sigma <= 0.0:
        return np.ones(window_size, np.float64)
    k = cv2.getGaussianKernel(window_size, window_sigma, cv2.CV_64F).ravel()
    return k * (window_size / k.sum())


def _weighted_response(gq: np.ndarray, scale: float, window_size: int,
                       window_sigma: float) -> np.ndarray:
    """Eq. 1 with Gaussian window weights on the quantised image ``gq`` (int64).

    Each direction's squared differences (exact in float64: ``|gq| <= 2**19``) are summed
    with the separable weights of :func:`window_weights` by ``cv2.sepFilter2D`` (float64),
    then the minimum is taken over the four directions; border band as in the box kernel.
    """
    h, w = gq.shape
    out = np.zeros((h, w), np.float32)
    m = window_size // 2 + 1
    if h < 2 * m + 1 or w < 2 * m + 1:
        return out
    k = window_weights(window_size, window_sigma)
    sq = np.zeros((h, w), np.float64)  # (G(q) - G(q + u))**2 for q one pixel inside the image
    inner = sq[1:h - 1, 1:w - 1]
    buf = np.empty((h, w), np.float64)
    vmin = np.empty((h, w), np.float64)
    for t, (ux, uy) in enumerate(_k.DIRECTIONS.tolist()):
        np.subtract(gq[1:h - 1, 1:w - 1], gq[1 + uy:h - 1 + uy, 1 + ux:w - 1 + ux], out=inner,
                    casting="unsafe")
        np.square(inner, out=inner)
        cv2.sepFilter2D(sq, cv2.CV_64F, k, k, dst=buf if t else vmin,
                        borderType=cv2.BORDER_CONSTANT)
        if t:
            np.minimum(vmin, buf, out=vmin)
    del sq, inner, buf
    np.multiply(vmin, scale, out=vmin)
    out[m:h - m, m:w - m] = vmin[m:h - m, m:w - m]
    return out


@keeps_interrupts
def moravec_response(image, window_size: int = 5, window_sigma: float = 0.0) -> np.ndarray:
    """Moravec directional variance, eq. 1: ``V(p) = min_theta V_theta(p)``.

    ``V_theta(p) = sum_{q in W(p)} w(q - p) (G(q) - G(q + u_theta))**2`` over a
    ``window_size`` square window, for the unit steps ``u_theta`` = (1, 0), (1, 1), (0, 1),
    (-1, 1). The weights ``w`` are all 1 (eq. 1 as printed) unless ``window_sigma > 0``.

    Parameters
    ----------
    image : (H, W) ndarray
        The image G the variance is measured on (gradient magnitude or grey levels).
    window_size : int
        Odd side of the window W (paper: 5).
    window_sigma : float
        0 (default): the box window of eq. 1. > 0: Gaussian weights of this standard
        deviation over the same ``window_size`` square, ``w(i, j) = k[i] k[j]`` with ``k``
        from ``cv2.getGaussianKernel`` scaled so that the weights sum to
        ``window_size ** 2`` (:func:`window_weights`) -- Harris's remedy for the noisy,
        shift-sensitive response of Moravec's box window. 0.85 with ``window_size=3``
        is about the binomial window (1, 2, 1) / 4 x 3.

    Returns
    -------
    V : (H, W) float32 ndarray
        Zero where the window or its shifted copy would leave the image (within
        ``window_size // 2 + 1`` pixels of the border).

    Notes
    -----
    G is first put on a power-of-two grid fine enough for 2**19 levels (:func:`quantise`):
    the box window sums are then exact, computed by sliding sums in O(1) per pixel. The
    Gaussian sums are float64 (``cv2.sepFilter2D``), within about 1e-15 relative of the
    textbook double loop, and need about 20 more bytes per pixel.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.zeros((9, 9), np.float32); img[4, 4] = 1.0
    >>> v = moravec_response(img, window_size=3)
    >>> float(v[4, 4]), float(v[0, 0])
    (2.0, 0.0)
    """
    g = _as_float_image(image)
    window_size = integer(1, 99, odd=True)("window_size", window_size)
    window_sigma = real(0.0)("window_sigma", window_sigma)
    return response(g, window_size, window_sigma)


@keeps_interrupts
def moravec_points(
    response,
    nms_size: int = 20,
    threshold: float = 0.0,
    relative_threshold: float = 0.0,
    margin: int = 0,
    max_features: int = 0,
    subpixel: bool = False,
    mask=None,
):
    """Moravec points, eq. 2: strict local maxima of ``V`` above a threshold.

    ``p`` is kept iff ``V(p) > V(q)`` for every other ``q`` with
    ``max(|qx - px|, |qy - py|) <= nms_size // 2`` (ties are not maxima) and
    ``V(p) > max(threshold, relative_threshold * V.max())``.

    Parameters
    ----------
    response : (H, W) ndarray
        V from :func:`moravec_response`.
    nms_size : int
        Side of the neighbourhood; it spans ``nms_size // 2`` pixels on each side (the
        paper's 20 x 20 is a 21 x 21 square centred on p).
    threshold, relative_threshold : float
        Absolute threshold, and a fraction of the largest response.
    margin : int
        Points closer than this to the border are never returned.
    max_features : int
        Keep only the strongest points (0: all).
    subpixel : bool
        Refine each point by a quadratic fit of V along x and along y (offsets within
        half a pixel).
    mask : (H, W) uint8 or bool ndarray, optional
        Points are kept only where the mask is non-zero.

    Returns
    -------
    points : (N, 2) float32 ndarray
        (x, y) coordinates, strongest first.
    responses : (N,) float32 ndarray
        V at each point.
    """
    v = _as_float_image(response, "response")
    nms_size = integer(1)("nms_size", nms_size)
    threshold = real(0.0)("threshold", threshold)
    relative_threshold = real(0.0, 1.0)("relative_threshold", relative_threshold)
    margin = integer(0)("margin", margin)
    max_features = integer(0)("max_features", max_features)
    mask = as_mask(mask, v.shape)
    return select_points(v, nms_size, threshold, relative_threshold, margin, max_features,
                          bool(subpixel), mask)


def select_points(v, nms_size, threshold, relative_threshold, margin, max_features, subpixel,
                   mask):
    """:func:`moravec_points` (eq. 2) on validated arguments: ``v`` a C-contiguous float32
    response, ``mask`` None or an (H, W) bool array."""
    if v.size == 0:  # an empty image (moravec_response gives one) has no point
        return np.zeros((0, 2), np.float32), np.zeros(0, np.float32)
    # a radius past the image's sides sees the whole image already: the same maxima, and a
    # dilation kernel of at most the image's size (nms_size=2**31 asked for 4 EiB)
    radius = min(nms_size // 2, max(v.shape + (1,)))
    margin = min(margin, max(v.shape + (1,)))  # as wide as the image excludes every pixel
    thr = threshold
    if relative_threshold and v.size:  # 0 * max V would leave max(threshold, 0.0) unchanged
        thr = max(threshold, relative_threshold * float(v.max()))
    kernel = np.ones((2 * radius + 1, 2 * radius + 1), np.uint8)
    vmax = cv2.dilate(v, kernel, borderType=cv2.BORDER_CONSTANT, borderValue=-np.inf)
    with np.errstate(over="ignore"):  # a threshold beyond float32's range: inf, no point
        thr32 = np.float32(thr)
    yx, pts, resp = _k.strict_maxima(v, vmax, radius, margin, thr32, bool(subpixel))
    del vmax
    if mask is not None and len(yx):
        keep = mask[yx[:, 0], yx[:, 1]]
        pts, resp = np.compress(keep, pts, axis=0), resp[keep]
    # Strongest first is more than cv2's convention here: the network updates a left
    # point's neurons in increasing right index, so on a tie the stronger right point
    # switches on first. Raster order (row by row) was tried for its faster memory access
    # and let off-row look-alikes win on the chessboards of examples/stereo_calibration.py.
    order = strongest_first(resp)
    if max_features:
        order = order[:max_features]
    # np.take: rows in that order, ten times faster than fancy indexing on (N, 2) rows
    return np.take(pts, order, axis=0), resp.take(order)


def strongest_first(resp: np.ndarray) -> np.ndarray:
    """``np.argsort(-resp, kind="stable")`` for non-negative float32 responses, faster: the
    responses' bit patterns (monotonic for non-negative floats) and the indices make one
    unique int64 key per point, which the default sort orders exactly as a stable sort
    would. The keys being unique, sorting them (cheaper than ``argsort``) and keeping their
    low 32 bits, the index, is that argsort."""
    n = len(resp)
    bits = np.ascontiguousarray(resp, dtype=np.float32).view(np.int32).astype(np.int64)
    key = ((np.int64(0x7FFFFFFF) - bits) << np.int64(32)) | np.arange(n, dtype=np.int64)
    key.sort()
    return key & np.int64(0xFFFFFFFF)
