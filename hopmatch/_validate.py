"""Input coercion and checks shared by every public entry point.

One helper per kind of input, so that every function says the same thing about the same
mistake. Kernels receive only what these helpers return: C-contiguous arrays of one dtype.
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence

import cv2
import numpy as np

from .errors import InvalidArgumentError, InvalidTypeError

#: Image dtypes accepted at the boundary (converted as cv2 would).
IMAGE_DTYPES = (np.uint8, np.uint16, np.int16, np.float32, np.float64)


def _describe(value) -> str:
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape} and dtype {value.dtype}"
    return f"{type(value).__name__} {value!r}"[:120]


def as_gray_image(image, name: str = "image") -> np.ndarray:
    """Return ``image`` as a C-contiguous 2-D grey image (uint8, uint16, int16 or float32).

    Accepts grey ``(H, W)`` or ``(H, W, 1)``, BGR ``(H, W, 3)`` and BGRA ``(H, W, 4)`` arrays
    of 8-bit, 16-bit or floating dtype, converted with ``cv2.cvtColor`` as OpenCV would.
    float64 becomes float32. NaN or infinite pixels are refused.
    """
    if not isinstance(image, np.ndarray):
        raise InvalidTypeError(
            f"`{name}` must be a numpy array (as returned by cv2.imread), got {_describe(image)}"
        )
    if image.dtype == np.bool_ or image.dtype.type not in IMAGE_DTYPES:
        raise InvalidTypeError(
            f"`{name}` must have dtype uint8, uint16, int16, float32 or float64, "
            f"got {image.dtype}; convert it with image.astype(np.float32)"
        )
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[:, :, 0]
    if image.ndim == 3 and image.shape[2] in (3, 4):
        if image.shape[0] == 0 or image.shape[1] == 0:
            raise InvalidArgumentError(f"`{name}` must not be empty, got shape {image.shape}")
        src = image.astype(np.float32) if image.dtype in (np.float64, np.int16) else image
        code = cv2.COLOR_BGR2GRAY if image.shape[2] == 3 else cv2.COLOR_BGRA2GRAY
        image = cv2.cvtColor(np.ascontiguousarray(src), code)
    elif image.ndim != 2:
        raise InvalidArgumentError(
            f"`{name}` must be a grey (H, W), BGR (H, W, 3) or BGRA (H, W, 4) image, "
            f"got shape {image.shape}"
        )
    if image.shape[0] == 0 or image.shape[1] == 0:
        raise InvalidArgumentError(f"`{name}` must not be empty, got shape {image.shape}")
    if image.dtype == np.float64:
        image = image.astype(np.float32)
    if image.dtype == np.float32 and not np.isfinite(image).all():
        raise InvalidArgumentError(
            f"`{name}` contains NaN or infinite pixels; replace them first "
            "(for example with np.nan_to_num)"
        )
    return np.ascontiguousarray(image)


def as_mask(mask, shape: tuple[int, int], name: str = "mask") -> np.ndarray | None:
    """Return ``mask`` as a C-contiguous bool array of ``shape``, or None when ``mask`` is None.

    Accepts uint8 (non-zero = allowed, as cv2) or bool arrays of exactly ``shape``.
    """
    if mask is None:
        return None
    if not isinstance(mask, np.ndarray):
        raise InvalidTypeError(f"`{name}` must be a numpy array or None, got {_describe(mask)}")
    if mask.dtype not in (np.uint8, np.bool_):
        raise InvalidTypeError(f"`{name}` must have dtype uint8 or bool, got {mask.dtype}")
    if mask.shape != tuple(shape):
        raise InvalidArgumentError(
            f"`{name}` must have shape {tuple(shape)} (the image's height and width), "
            f"got {mask.shape}"
        )
    return np.ascontiguousarray(mask != 0)


def as_points(points, name: str) -> np.ndarray:
    """Return keypoints or an ``(N, 2)`` array as a C-contiguous float32 ``(N, 2)`` (x, y) array.

    Accepts a sequence of ``cv2.KeyPoint`` or anything ``np.asarray`` turns into ``(N, 2)``
    or ``(N, 1, 2)`` numbers (as ``cv2.goodFeaturesToTrack`` returns). Coordinates must be
    finite.
    """
    if isinstance(points, cv2.KeyPoint):
        points = [points]
    if isinstance(points, Sequence) and len(points) > 0 and isinstance(points[0], cv2.KeyPoint):
        if not all(isinstance(kp, cv2.KeyPoint) for kp in points):
            raise InvalidTypeError(f"`{name}` mixes cv2.KeyPoint with other objects")
        arr = cv2.KeyPoint_convert(list(points)).reshape(-1, 2)
    else:
        if isinstance(points, (str, bytes)) or points is None:
            raise InvalidTypeError(
                f"`{name}` must be a sequence of cv2.KeyPoint or an (N, 2) array, got "
                f"{_describe(points)}"
            )
        try:
            arr = np.asarray(points)
        except (TypeError, ValueError) as exc:
            raise InvalidTypeError(
                f"`{name}` must be a sequence of cv2.KeyPoint or an (N, 2) array: {exc}"
            ) from None
        if arr.size == 0:
            arr = arr.reshape(0, 2)
        if arr.dtype == np.bool_ or not np.issubdtype(arr.dtype, np.number):
            raise InvalidTypeError(
                f"`{name}` must hold numbers (x, y), got dtype {arr.dtype}"
            )
        if arr.ndim == 3 and arr.shape[1:] == (1, 2):  # cv2's (N, 1, 2) point arrays
            arr = arr.reshape(-1, 2)
        if arr.ndim != 2 or arr.shape[1] != 2:
            raise InvalidArgumentError(
                f"`{name}` must have shape (N, 2) (or cv2's (N, 1, 2)) holding (x, y), "
                f"got shape {arr.shape}"
            )
    arr = np.ascontiguousarray(arr, dtype=np.float32)
    if not np.isfinite(arr).all():
        raise InvalidArgumentError(f"`{name}` contains NaN or infinite coordinates")
    return arr


def as_descriptors(desc, name: str) -> np.ndarray:
    """Return descriptors as a C-contiguous 2-D array (float32, or uint8 for binary ones)."""
    if not isinstance(desc, np.ndarray):
        raise InvalidTypeError(f"`{name}` must be a numpy array, got {_describe(desc)}")
    if desc.ndim == 1 and desc.size == 0:
        desc = desc.reshape(0, 0)
    if desc.ndim != 2:
        raise InvalidArgumentError(
            f"`{name}` must be a 2-D array with one descriptor per row, got shape {desc.shape}"
        )
    if desc.dtype == np.uint8:
        return np.ascontiguousarray(desc)
    if desc.dtype == np.bool_ or not np.issubdtype(desc.dtype, np.number):
        raise InvalidTypeError(f"`{name}` must be float32 or uint8, got dtype {desc.dtype}")
    out = np.ascontiguousarray(desc, dtype=np.float32)
    if not np.isfinite(out).all():
        raise InvalidArgumentError(f"`{name}` contains NaN or infinite values")
    return out


def as_image_size(size, name: str) -> tuple[int, int] | None:
    """Return an image size as ``(width, height)`` ints (cv2's order), or None."""
    if size is None:
        return None
    if isinstance(size, np.ndarray):
        size = tuple(size.tolist())
    if (
        not isinstance(size, Sequence)
        or len(size) != 2
        or not all(isinstance(v, numbers.Integral) and not isinstance(v, bool) for v in size)
    ):
        raise InvalidTypeError(
            f"`{name}` must be (width, height) as two integers, got {_describe(size)}"
        )
    w, h = int(size[0]), int(size[1])
    if w <= 0 or h <= 0:
        raise InvalidArgumentError(f"`{name}` must be positive (width, height), got {(w, h)}")
    return (w, h)
