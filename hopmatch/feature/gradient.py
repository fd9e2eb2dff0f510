"""SPEC section 1, item 1: the Canny-Deriche gradient magnitude."""

from __future__ import annotations

import math
import threading

import cv2
import numpy as np

from .._interrupts import keeps_interrupts
from .._params import real
from .._validate import FLOAT32_MAX, as_gray_image
from ..errors import InvalidArgumentError


@keeps_interrupts
def deriche_gradient(image, alpha: float = 1.0, omega: float = 0.001) -> np.ndarray:
    """Gradient magnitude ``G = sqrt(Gx**2 + Gy**2)`` with the Canny-Deriche recursive filter.

    Parameters
    ----------
    image : (H, W) or (H, W, 3|4) ndarray
        uint8, uint16, int16, float32 or float64; colour is converted to grey as cv2 does.
    alpha : float
        Deriche's smoothing parameter (> 0); larger values smooth less.
    omega : float
        Deriche's frequency parameter (> 0: OpenCV's coefficients divide by ``sin(omega)``,
        so 0 would give NaN everywhere).

    Returns
    -------
    G : (H, W) float32 ndarray

    Notes
    -----
    Computed with ``cv2.ximgproc.GradientDericheX`` / ``GradientDericheY`` and
    ``cv2.magnitude`` on the image mirrored by ``ceil(14 / alpha)`` pixels (at most 256),
    so that the image border is not taken for an edge (:func:`border_width`).

    Examples
    --------
    >>> import numpy as np
    >>> step = np.zeros((16, 16), np.uint8); step[:, 8:] = 100
    >>> g = deriche_gradient(step, alpha=2.0)
    >>> g.dtype, g.shape, int(g[8].argmax()) in (7, 8)
    (dtype('float32'), (16, 16), True)
    """
    gray = as_gray_image(image)
    alpha = real(0.0, lo_open=True)("alpha", alpha)
    omega = real(0.0, lo_open=True)("omega", omega)
    return check_finite_gradient(deriche_magnitude(gray, alpha, omega), gray, alpha=alpha,
                                 omega=omega)


def check_finite_gradient(g: np.ndarray, gray: np.ndarray, name: str = "image", *,
                          alpha: float, omega: float) -> np.ndarray:
    """Return ``g``, or raise when it is not finite: the rest of the pipeline would only
    see NaN. An integer image cannot overflow the filter, so there the parameters are to
    blame (an extreme ``alpha`` or ``omega`` makes OpenCV's coefficients infinite or NaN);
    a float image may also hold pixels near the float32 limit that make Gx, Gy or their
    magnitude infinite."""
    if not np.isfinite(g).all():
        if np.issubdtype(gray.dtype, np.integer):
            # the parameter farther from its default (in decades) is named for the CLI
            blamed = ("alpha" if abs(math.log10(alpha)) >= abs(math.log10(omega / 0.001))
                      else "omega")
            raise InvalidArgumentError(
                f"the Canny-Deriche filter gives non-finite values with alpha={alpha!r} and "
                f"omega={omega!r}: OpenCV's coefficients overflow at such values; use "
                "values near the defaults (alpha 1.0, omega 0.001)", argument=blamed
            )
        big = float(np.abs(gray).max())
        raise InvalidArgumentError(
            f"`{name}` is too large for the float32 gradient filter (largest |pixel| "
            f"{big:.3g}): its gradient overflows; rescale it first, e.g. "
            f"image / np.abs(image).max() (or, if it is not large, the filter parameters "
            f"alpha={alpha!r}, omega={omega!r} are too extreme)"
        )
    return g


#: ``alpha`` times the width of the mirrored border (:func:`border_width`).
BORDER_DECAY = 14.0


def border_width(alpha: float) -> int:
    """Pixels of mirrored border that make the recursive filter's start-up negligible.

    Its impulse response decays about as ``(1 + alpha n) exp(-alpha n)``: ``ceil(14 /
    alpha)`` pixels leave 1.2e-5 of it, at most 0.006 of G along the border of a flat 255
    image (about 150 with no border), and a Moravec response V below 1e-6 there, far under
    the detector's threshold of 1e-3. The filter's cost grows with the padded area, so the
    border is no wider than that (docs/performance.md).
    """
    width = BORDER_DECAY / alpha  # inf for a denormal alpha: capped before the conversion
    return int(math.ceil(width)) if width < 256 else 256


#: Spread of the grey levels after :func:`normalised_intensity`: the distance between the
#: 1st and 99th percentiles, that of an 8-bit image using most of its range (the shared
#: scenes spread over 147 to 243, see docs/robustness.md, "Gain and dtype").
INTENSITY_RANGE = 230.0
#: Percentiles whose distance measures the spread: robust to a few saturated pixels, and
#: on the shared pairs closer between the two views of one scene than the standard
#: deviation, which large bright or dark regions entering one view only move.
SPREAD_PERCENTILES = (1.0, 99.0)


def intensity_spread(gray: np.ndarray) -> float:
    """The distance between the :data:`SPREAD_PERCENTILES` of ``gray``'s grey levels, on
    a regular subsample of at most about a million pixels; the standard deviation when
    that distance is 0 (an image that is mostly flat). Proportional to the gain, blind
    to an offset, whatever the dtype.

    Pixels at exactly the image's lowest level are left out when more than half the
    sample lies above it (and what is left is not flat): the black fill of a warped or
    rectified view (``cv2.remap``'s border) differs between the two views of one scene,
    and counted in it would give equal-gain views different scales.

    An 8- or 16-bit image is measured on its histogram (:func:`histogram_spread`), with
    the same result as ``np.percentile`` on its grey levels and without sorting them.
    """
    step = max(1, int(math.sqrt(gray.size / 2**20)))
    sample = gray[::step, ::step]
    if sample.dtype in (np.uint8, np.uint16):
        spread = histogram_spread(sample)
    else:
        inner = sample[sample > sample.min()]
        spread = 0.0
        if 2 * inner.size > sample.size:
            spread = percentile_spread(inner)
        if not spread > 0.0:
            spread = percentile_spread(sample)
    if not spread > 0.0:
        spread = float(cv2.meanStdDev(np.ascontiguousarray(sample, np.float32))[1][0, 0])
    return spread


def percentile_spread(values: np.ndarray) -> float:
    """The distance between the :data:`SPREAD_PERCENTILES` of ``values``."""
    lo, hi = np.percentile(values, SPREAD_PERCENTILES)
    return float(hi) - float(lo)


def histogram_spread(sample: np.ndarray) -> float:
    """:func:`intensity_spread`'s percentile distance for a uint8 or uint16 ``sample``
    (the lowest level left out under the same rule), from its histogram: the order
    statistics that ``np.percentile``'s linear method interpolates between are read off
    the cumulative counts, and interpolated with its arithmetic, so the result is the
    same to the last bit (tests/feature/test_feature_gradient.py compares the two)."""
    if sample.size == 0:
        return 0.0
    if sample.dtype == np.uint8:  # OpenCV's histogram: 3x faster than np.bincount
        counts = cv2.calcHist([np.ascontiguousarray(sample)], [0], None, [256], [0, 256])
        counts = counts.reshape(-1).astype(np.int64)  # (256, 1) in OpenCV 4, (256,) in 5
    else:
        counts = np.bincount(sample.ravel(), minlength=1)
    low = int(np.flatnonzero(counts)[0])
    spread = 0.0
    if 2 * (sample.size - counts[low]) > sample.size:
        inner = counts.copy()
        inner[low] = 0
        spread = counts_spread(inner)
    if not spread > 0.0:
        spread = counts_spread(counts)
    return spread


def counts_spread(counts: np.ndarray) -> float:
    """The distance between the :data:`SPREAD_PERCENTILES` of the integer levels whose
    histogram is ``counts`` (level i counted ``counts[i]`` times): ``np.percentile``'s
    linear method, ``a + (b - a) * t`` (``b - (b - a) * (1 - t)`` from ``t = 0.5`` on)
    between the sorted values ``a`` and ``b`` at ``floor((n - 1) q)`` and the next."""
    cum = np.cumsum(counts)
    n = int(cum[-1])
    q = np.true_divide(np.asarray(SPREAD_PERCENTILES, dtype=np.float64), 100)
    virtual = (n - 1) * q
    below = np.floor(virtual)
    gamma = virtual - below
    index = below.astype(np.intp)
    a = np.searchsorted(cum, index, side="right").astype(np.float64)
    b = np.searchsorted(cum, np.minimum(index + 1, n - 1), side="right").astype(np.float64)
    diff = b - a
    value = np.where(gamma >= 0.5, b - diff * (1 - gamma), a + diff * gamma)
    return float(value[1]) - float(value[0])


def normalised_intensity(gray: np.ndarray) -> np.ndarray:
    """The validated grey image ``gray`` as float32, scaled so that its grey levels spread
    over :data:`INTENSITY_RANGE` (:func:`intensity_spread`); a flat image is left as it is.

    The similarity of eq. 7 compares windows of the two images, and its gate takes them
    for unrelated when their contrasts differ much: a right image at half the gain of the
    left, or a uint16 image (x 257) against a uint8 one, or floats in [0, 1], gave no match
    at all. Scaling each image by its own spread makes the points, the descriptors and
    their similarity independent of gain and dtype (an offset never mattered: G and the
    windows are differences).
    """
    img = gray.astype(np.float32)
    spread = intensity_spread(gray) if img.size else 0.0
    if spread > 0.0 and np.isfinite(spread):
        factor = INTENSITY_RANGE / spread
        if factor <= FLOAT32_MAX:  # beyond it, the factor is applied in float64
            img *= np.float32(factor)
        else:  # grey levels near float32's smallest (1e-40): the factor itself overflows
            img = (gray.astype(np.float64) * factor).astype(np.float32)
    return img


#: Float grey images whose levels spread over less than this (:func:`intensity_spread`)
#: are measured normalised by the steps that read grey levels (:func:`measurable_gray`).
MIN_MEASURED_SPREAD = 1e-2


def measurable_gray(gray: np.ndarray) -> np.ndarray:
    """The validated grey image ``gray`` as the steps that read grey levels after the
    network (the sub-pixel refinement, the half-window test) measure it: itself, or, for a
    float image whose grey levels spread over less than :data:`MIN_MEASURED_SPREAD`,
    :func:`normalised_intensity`. Their correlations do not depend on the gain, but their
    flat-window floors are absolute: float images of levels near 1e-8 gave no match at all.
    Integer images (whose spread is at least one level unless flat) and float images of
    ordinary scale are returned as they are, so their results do not change."""
    if gray.dtype.kind != "f" or not gray.size:
        return gray
    spread = intensity_spread(gray)
    if 0.0 < spread < MIN_MEASURED_SPREAD:
        return normalised_intensity(gray)
    return gray


def feature_image(gray: np.ndarray, on: str, alpha: float, omega: float,
                  name: str = "image") -> np.ndarray:
    """The float32 image G that points and descriptors are measured on (SPEC section 1):
    the Canny-Deriche gradient magnitude of the validated grey image ``gray``, normalised
    first (:func:`normalised_intensity`), when ``on`` is ``"gradient"`` (checked finite,
    :func:`check_finite_gradient`), else its normalised grey levels."""
    img = normalised_intensity(gray)
    if on == "gradient":
        return check_finite_gradient(deriche_magnitude(img, alpha, omega), gray, name,
                                     alpha=alpha, omega=omega)
    return img


#: How :func:`deriche_magnitude` filters by default: ``"numba"``, hopmatch's float32 kernel
#: (``hopmatch._kernels.deriche``), or ``"opencv"``, ``cv2.ximgproc.GradientDericheX/Y``
#: (double precision, the reference the kernel is tested against; docs/method.md).
DERICHE_METHOD = "numba"
#: Below this ``alpha`` :func:`deriche_magnitude` uses OpenCV's double-precision filter:
#: the recursions' gain grows as ``1 / (1 - exp(-alpha))**2``, and float32 keeps the 1e-4
#: agreement with it only down to about ``alpha = 0.03`` (docs/method.md).
FLOAT32_MIN_ALPHA = 0.1
#: Images of at most this many pixels keep the kernel's intermediate images per thread
#: between calls: memory that is new to the process costs a page fault per 4 KiB on its
#: first write, more than the filtering itself (docs/method.md).
WORKSPACE_PIXELS = 1 << 22

_workspace = threading.local()
_NONE = np.empty((0, 0), np.float32)


def _buffers(h: int, w: int) -> dict:
    """The float32 intermediate images of :func:`deriche_components` for an ``h x w``
    image: this thread's from the last call when the shape is the same, else new ones
    (kept for the next call when ``h * w <= WORKSPACE_PIXELS``)."""
    ws = getattr(_workspace, "buffers", None)
    if ws is not None and ws["shape"] == (h, w):
        return ws
    ws = {"shape": (h, w), "resp_r": np.empty((2, w)), "resp_c": np.empty((2, h))}
    for name, shape in (("t", (w, h)), ("dt", (w, h)), ("st", (w, h)), ("d", (h, w)),
                        ("s", (h, w)), ("x", (h, w)), ("y", (h, w))):
        ws[name] = np.empty(shape, np.float32)
    _workspace.buffers = ws if h * w <= WORKSPACE_PIXELS else None
    return ws


def deriche_components(gray: np.ndarray, alpha: float, omega: float, *,
                       components: bool = False, border: int | None = None):
    """G (float32, ``gray``'s shape) of :func:`deriche_magnitude` with hopmatch's float32
    kernel; with ``components``, ``(G, Gx, Gy)``.

    ``Gx`` and ``Gy`` are ``cv2.ximgproc.GradientDericheX/Y`` of ``gray`` mirrored by
    ``border`` pixels (:func:`border_width` when None), cropped: the same recursive filters
    (:func:`hopmatch._kernels.deriche.deriche_pass`) in float32, agreeing with OpenCV's
    double-precision filters within 1e-4 of ``max |G|`` for ``alpha >=
    FLOAT32_MIN_ALPHA`` (docs/method.md). A row pass on the transposed image (lanes: the
    rows), then a column pass on its outputs transposed back (lanes: the columns).
    """
    # imported here: its kernels have explicit signatures, so importing the module compiles
    # them (or loads them from the cache); the first gradient, not `import hopmatch`, waits
    from .._kernels import deriche as _kd
    from .._kernels.deriche import coefficients as deriche_coefficients

    h, w = gray.shape
    b = border_width(alpha) if border is None else border
    ws = _buffers(h, w)
    t = ws["t"]
    if gray.dtype == np.float32:
        cv2.transpose(gray, t)
    else:
        np.copyto(t, cv2.transpose(gray))
    lo, hi, _, _ = cv2.minMaxLoc(t)
    off = np.float32(0.5 * (lo + hi))
    coeffs = deriche_coefficients(alpha, omega)
    _kd.deriche_pass(t, t, b, coeffs, True, off, ws["dt"], ws["st"], ws["resp_r"], _NONE,
                     np.float32(0.0), _NONE)
    cv2.transpose(ws["dt"], ws["d"])
    cv2.transpose(ws["st"], ws["s"])
    g = np.empty((h, w), np.float32)
    lane = ws["resp_r"].astype(np.float32)
    # Y differentiates the row smoothing, X smooths the row derivative
    _kd.deriche_pass(ws["s"], ws["d"], b, coeffs, False, np.float32(0.0), ws["y"], ws["x"],
                     ws["resp_c"], lane, off, g)
    cv2.sqrt(g, g)
    if not components:
        return g
    gx = ws["x"] + np.float32(off) * np.outer(ws["resp_c"][1], lane[0]).astype(np.float32)
    gy = ws["y"] + np.float32(off) * np.outer(ws["resp_c"][0], lane[1]).astype(np.float32)
    return g, gx, gy


def deriche_magnitude(gray: np.ndarray, alpha: float, omega: float,
                      method: str | None = None) -> np.ndarray:
    """:func:`deriche_gradient` on an already validated grey image (as
    :func:`~hopmatch._validate.as_gray_image` returns it) and validated parameters.

    The recursive filter starts from zero outside the image, which puts strong false edges
    along the border (up to 77 grey levels on a flat 128 image with alpha = 1). The image is
    therefore mirrored by :func:`border_width` pixels first, and the result cropped.
    ``method``: :data:`DERICHE_METHOD` when None; ``"numba"``
    (:func:`deriche_components`, for ``alpha >= FLOAT32_MIN_ALPHA``) or ``"opencv"``
    (``cv2.ximgproc`` on a mirrored copy).
    """
    if (method or DERICHE_METHOD) == "numba" and alpha >= FLOAT32_MIN_ALPHA:
        return deriche_components(gray, alpha, omega)
    b = border_width(alpha)
    padded = cv2.copyMakeBorder(gray, b, b, b, b, cv2.BORDER_REFLECT)
    gx = cv2.ximgproc.GradientDericheX(padded, alpha, omega)
    gy = cv2.ximgproc.GradientDericheY(padded, alpha, omega)
    return np.ascontiguousarray(cv2.magnitude(gx, gy)[b:-b, b:-b])
