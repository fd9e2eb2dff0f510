"""Descriptors for the similarity term (eqs. 8-9): mean-subtracted windows of G."""

from __future__ import annotations

import cv2
import numpy as np


def window_inside(points: np.ndarray, shape: tuple[int, int], size: int) -> np.ndarray:
    """Boolean (N,): the ``size`` x ``size`` window centred on each (x, y) lies in the image."""
    r = size // 2
    h, w = shape
    x, y = points[:, 0], points[:, 1]
    return (x - r >= 0) & (y - r >= 0) & (x + r <= w - 1) & (y + r <= h - 1)


def gradient_windows(g: np.ndarray, points: np.ndarray, size: int) -> np.ndarray:
    """Eqs. 8-9: ``V_i(x) = G(x) - mean_{W_i}(G)`` over the ``size`` x ``size`` window W_i.

    Parameters
    ----------
    g : (H, W) float32 ndarray
        The image the windows are cut from (gradient magnitude, or grey levels).
    points : (N, 2) float32 ndarray
        Window centres (x, y); every window must lie inside the image (see
        :func:`window_inside`). Non-integer centres are sampled bilinearly
        (``cv2.remap``); integer centres read the pixels exactly.
    size : int
        Odd side of the window.

    Returns
    -------
    (N, size * size) float32 ndarray
        One row per point, the window in raster order minus its mean.

    Examples
    --------
    >>> import numpy as np
    >>> g = np.arange(25, dtype=np.float32).reshape(5, 5)
    >>> gradient_windows(g, np.array([[2, 2]], np.float32), 3)
    array([[-6., -5., -4., -1.,  0.,  1.,  4.,  5.,  6.]], dtype=float32)
    """
    n = len(points)
    if n == 0:
        return np.zeros((0, size * size), np.float32)
    r = size // 2
    dy, dx = np.mgrid[-r : r + 1, -r : r + 1].astype(np.float32)
    # cv2.remap needs maps with fewer than SHRT_MAX (32767) rows: process in chunks
    win = np.empty((n, size * size), np.float32)
    for a in range(0, n, 16384):
        pts = points[a:a + 16384]
        map_x = np.ascontiguousarray(pts[:, :1] + dx.reshape(1, -1))
        map_y = np.ascontiguousarray(pts[:, 1:] + dy.reshape(1, -1))
        win[a:a + len(pts)] = cv2.remap(g, map_x, map_y, cv2.INTER_LINEAR,
                                        borderMode=cv2.BORDER_REPLICATE)
    win -= win.mean(axis=1, keepdims=True)
    return win
