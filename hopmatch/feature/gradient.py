"""SPEC section 1, item 1: the Canny-Deriche gradient magnitude."""

from __future__ import annotations

import cv2
import numpy as np

from .._params import real
from .._validate import as_gray_image


def deriche_gradient(image, alpha: float = 1.0, omega: float = 0.001) -> np.ndarray:
    """Gradient magnitude ``G = sqrt(Gx**2 + Gy**2)`` with the Canny-Deriche recursive filter.

    Parameters
    ----------
    image : (H, W) or (H, W, 3|4) ndarray
        uint8, uint16, int16, float32 or float64; colour is converted to grey as cv2 does.
    alpha : float
        Deriche's smoothing parameter (> 0); larger values smooth less.
    omega : float
        Deriche's frequency parameter (>= 0).

    Returns
    -------
    G : (H, W) float32 ndarray

    Notes
    -----
    Computed with ``cv2.ximgproc.GradientDericheX`` / ``GradientDericheY`` and
    ``cv2.magnitude``.

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
    omega = real(0.0)("omega", omega)
    return _deriche(gray, alpha, omega)


def _deriche(gray: np.ndarray, alpha: float, omega: float) -> np.ndarray:
    """``deriche_gradient`` on an already validated grey image."""
    gx = cv2.ximgproc.GradientDericheX(gray, alpha, omega)
    gy = cv2.ximgproc.GradientDericheY(gray, alpha, omega)
    return cv2.magnitude(gx, gy)
