"""Black padding: what a warp (``cv2.warpAffine``, ``cv2.remap`` after
``cv2.stereoRectify``, a rotated photo) leaves around an image, which shows nothing."""

from __future__ import annotations

import cv2
import numpy as np

#: :func:`black_padding` holds only when what it leaves is (nearly) convex: its outline's
#: area over its convex hull's at least this.
PADDING_SOLIDITY = 0.97


def black_padding(gray: np.ndarray) -> np.ndarray:
    """Where ``gray`` is black padding (bool): the pixels of exactly 0 connected (4-way)
    to a corner of the image, when they number at least the image's longer side and leave
    a convex region (:func:`convex_inside`), as
    ``cv2.warpAffine``, ``cv2.remap`` after ``cv2.stereoRectify`` or a rotated photo
    leave them, in an image of any dtype. Such pixels show nothing, and would set the
    image's grey scale."""
    gray = np.asarray(gray)
    h, w = gray.shape
    if not (gray[[0, 0, h - 1, h - 1], [0, w - 1, 0, w - 1]] == 0).any():
        return np.zeros((h, w), bool)  # no black corner to fill from: no padding
    zero = (gray == 0).view(np.uint8)  # any dtype: floodFill takes 8U and 32F
    flood = np.zeros((h + 2, w + 2), np.uint8)
    for x, y in ((0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)):
        if zero[y, x] and not flood[y + 1, x + 1]:
            cv2.floodFill(zero, flood, (x, y), 0, 0, 0,
                          4 | cv2.FLOODFILL_MASK_ONLY | cv2.FLOODFILL_FIXED_RANGE
                          | (255 << 8))
    pad = flood[1:-1, 1:-1] > 0
    if int(pad.sum()) < max(h, w) or not convex_inside(~pad):
        return np.zeros((h, w), bool)
    return pad


def convex_inside(inside: np.ndarray) -> bool:
    """Whether the pixels of ``inside`` (bool) form one region (up to specks) whose
    outline covers at least :data:`PADDING_SOLIDITY` of its convex hull, as the image of a
    rectangle under a warp does (a dark corner of an underexposed photo does not leave
    one)."""
    contours, _ = cv2.findContours(inside.view(np.uint8), cv2.RETR_EXTERNAL,
                                   cv2.CHAIN_APPROX_SIMPLE)
    if not contours:
        return False
    areas = [cv2.contourArea(c) for c in contours]
    k = int(np.argmax(areas))
    hull = cv2.contourArea(cv2.convexHull(contours[k]))
    # specks the interpolation leaves along the warp's edge do not count
    return (hull > 0 and areas[k] >= PADDING_SOLIDITY * hull
            and sum(areas) - areas[k] <= (1 - PADDING_SOLIDITY) * areas[k])


def fill_padding(gray: np.ndarray) -> np.ndarray:
    """``gray`` with its :func:`black_padding` set to the median of the other pixels (a
    copy; ``gray`` itself when it has none)."""
    pad = black_padding(gray)
    if not pad.any() or pad.all():
        return gray
    out = gray.copy()
    out[pad] = np.median(gray[~pad])
    return out
