"""SPEC section 1, item 1: the Canny-Deriche gradient magnitude."""

from __future__ import annotations

import math

import cv2
import numpy as np

from .._params import real
from .._validate import as_gray_image
from ..errors import InvalidArgumentError


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


def feature_image(gray: np.ndarray, on: str, alpha: float, omega: float,
                  name: str = "image") -> np.ndarray:
    """The float32 image G that points and descriptors are measured on (SPEC section 1):
    the Canny-Deriche gradient magnitude of the validated grey image ``gray`` when ``on``
    is ``"gradient"`` (checked finite, :func:`check_finite_gradient`), else its grey
    levels."""
    if on == "gradient":
        return check_finite_gradient(deriche_magnitude(gray, alpha, omega), gray, name,
                                     alpha=alpha, omega=omega)
    return gray.astype(np.float32)


def deriche_magnitude(gray: np.ndarray, alpha: float, omega: float) -> np.ndarray:
    """:func:`deriche_gradient` on an already validated grey image (as
    :func:`~hopmatch._validate.as_gray_image` returns it) and validated parameters.

    The recursive filter starts from zero outside the image, which puts strong false edges
    along the border (up to 77 grey levels on a flat 128 image with alpha = 1). The image is
    therefore mirrored by :func:`border_width` pixels first, and the result cropped.
    """
    b = border_width(alpha)
    padded = cv2.copyMakeBorder(gray, b, b, b, b, cv2.BORDER_REFLECT)
    gx = cv2.ximgproc.GradientDericheX(padded, alpha, omega)
    gy = cv2.ximgproc.GradientDericheY(padded, alpha, omega)
    return np.ascontiguousarray(cv2.magnitude(gx, gy)[b:-b, b:-b])
