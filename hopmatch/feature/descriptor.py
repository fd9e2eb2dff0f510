"""Descriptors for the similarity term (eqs. 8-9): mean-subtracted windows of G."""

from __future__ import annotations

import numpy as np

from .._interrupts import keeps_interrupts
from .._kernels import descriptor as _k
from .._validate import as_int, as_points, describe
from ..errors import BudgetExceededError, InvalidArgumentError, InvalidTypeError

#: Largest window side :func:`gradient_windows` cuts, and most values it returns in all.
MAX_WINDOW = 4095
MAX_WINDOW_VALUES = 2**30


def window_inside(points: np.ndarray, shape: tuple[int, int], size: int) -> np.ndarray:
    """Boolean (N,): the ``size`` x ``size`` window centred on each (x, y) lies in the image."""
    r = size // 2
    h, w = shape
    x, y = points[:, 0], points[:, 1]
    return (x - r >= 0) & (y - r >= 0) & (x + r <= w - 1) & (y + r <= h - 1)


@keeps_interrupts
def gradient_windows(g: np.ndarray, points: np.ndarray, size: int) -> np.ndarray:
    """Eqs. 8-9: ``V_i(x) = G(x) - mean_{W_i}(G)`` over the ``size`` x ``size`` window W_i.

    Parameters
    ----------
    g : (H, W) ndarray of finite numbers
        The image the windows are cut from (gradient magnitude, or grey levels); read as
        float32.
    points : (N, 2) array or sequence of cv2.KeyPoint
        Window centres (x, y), finite; the windows are meant to lie inside the image (see
        :func:`window_inside`), samples outside it take the nearest border pixel.
        Non-integer centres are sampled bilinearly, exactly (in float64); integer
        centres read the pixels themselves.
    size : int
        Odd side of the window, at most :data:`MAX_WINDOW`.

    Returns
    -------
    (N, size * size) float32 ndarray
        One row per point, the window in raster order minus its mean.

    Raises
    ------
    InvalidTypeError, InvalidArgumentError
        An argument that is not as above (each named); ``BudgetExceededError`` when the
        windows would hold more than :data:`MAX_WINDOW_VALUES` values.

    Examples
    --------
    >>> import numpy as np
    >>> g = np.arange(25, dtype=np.float32).reshape(5, 5)
    >>> gradient_windows(g, np.array([[2, 2]], np.float32), 3)
    array([[-6., -5., -4., -1.,  0.,  1.,  4.,  5.,  6.]], dtype=float32)
    """
    points = as_points(points, "points")  # checked: numbers, finite, (N, 2)
    if not isinstance(g, np.ndarray) or g.dtype == np.bool_ or not np.issubdtype(g.dtype,
                                                                                np.number):
        raise InvalidTypeError(f"`g` must be a numeric numpy array, got {describe(g)}")
    if np.issubdtype(g.dtype, np.complexfloating):
        raise InvalidTypeError(f"`g` must hold real numbers, got dtype {g.dtype}")
    if len(points) and (g.ndim != 2 or g.size == 0):
        raise InvalidArgumentError(f"`g` must be a non-empty 2-D image to cut windows from, "
                                   f"got shape {g.shape}")
    size = as_int(size, "size", lo=1, hi=MAX_WINDOW)
    if size % 2 == 0:
        raise InvalidArgumentError(f"`size` must be odd (a window centred on its point), "
                                   f"got {size}", argument="size")
    image = np.ascontiguousarray(g, dtype=np.float32)
    if len(points) and not np.isfinite(image).all():
        raise InvalidArgumentError("`g` must hold finite numbers (as float32), got NaN or "
                                   "infinity", argument="g")
    return cut_windows(image, points, size)


def cut_windows(g: np.ndarray, points: np.ndarray, size: int) -> np.ndarray:
    """:func:`gradient_windows` of arguments the caller has checked: ``g`` a 2-D float32
    image of finite values, ``points`` an (N, 2) float32 array of finite centres, ``size``
    an odd side within :data:`MAX_WINDOW` (the pipeline's own calls, on images it made).
    Only the budget is checked (``BudgetExceededError``)."""
    if len(points) * size * size > MAX_WINDOW_VALUES:
        raise BudgetExceededError(
            f"{len(points)} windows of {size} x {size} would hold "
            f"{len(points) * size * size} values, more than {MAX_WINDOW_VALUES} (4 GiB of "
            "float32); use a smaller `size` or fewer points", argument="size")
    points = np.ascontiguousarray(points, dtype=np.float32).reshape(-1, 2)
    return _k.bilinear_windows(np.ascontiguousarray(g, dtype=np.float32), points, size // 2)
