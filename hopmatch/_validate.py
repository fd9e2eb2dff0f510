"""Input coercion and checks shared by every public entry point.

One helper per kind of input, so that every function says the same thing about the same
mistake. Kernels receive only what these helpers return: C-contiguous arrays of one dtype.
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence

import cv2
import numpy as np

from .errors import BudgetExceededError, InvalidArgumentError, InvalidTypeError

#: Image dtypes accepted at the boundary (converted as cv2 would).
IMAGE_DTYPES = (np.uint8, np.uint16, np.int16, np.float32, np.float64)

#: Largest finite float32: float64 values beyond it cannot be represented.
_F32_MAX = float(np.finfo(np.float32).max)

#: Largest |coordinate| the matcher accepts (2**20 = 1,048,576 pixels). The network's
#: neighbour grid counts cells in int64; beyond this bound a spread-out point set (or a zero
#: neighbourhood) would overflow that count. No camera image comes near it.
MAX_COORDINATE = float(2**20)

#: Bytes of peak memory per pixel of ``DericheMoravecDetector.detectAndCompute`` with the
#: default parameters, measured (peak RSS in a fresh process, see docs/robustness.md), plus
#: the descriptors of the keypoints found.
DETECTOR_BYTES_PER_PIXEL = 45


def _native(arr: np.ndarray) -> np.ndarray:
    """``arr`` in the machine's byte order (cv2 reads big-endian buffers as native ones)."""
    return arr if arr.dtype.isnative else arr.astype(arr.dtype.newbyteorder("="))


def _to_float32(arr: np.ndarray, name: str, what: str) -> np.ndarray:
    """float32 C-contiguous copy of a numeric array; values beyond the float32 range (or NaN,
    inf) are refused with a message naming ``name``."""
    if arr.dtype == np.float64 and arr.size:
        with np.errstate(invalid="ignore"):
            big = np.abs(arr).max()
        if np.isfinite(big) and big > _F32_MAX:
            raise InvalidArgumentError(
                f"`{name}` holds {what} up to {big:.3g}, beyond the float32 range "
                f"(+-{_F32_MAX:.3g}); rescale them first"
            )
    with np.errstate(over="ignore", invalid="ignore"):
        out = np.ascontiguousarray(arr, dtype=np.float32)
    return out


def check_pixel_budget(shape, max_pixels: int | None, name: str = "image") -> None:
    """Raise :class:`BudgetExceededError` when an image of ``shape`` has more than
    ``max_pixels`` pixels (None: no limit). Checked before any copy of the image."""
    if max_pixels is None or len(shape) < 2:
        return
    n = int(shape[0]) * int(shape[1])
    if n > max_pixels:
        need = n * DETECTOR_BYTES_PER_PIXEL / 2**30
        raise BudgetExceededError(
            f"`{name}` has {shape[0]} x {shape[1]} = {n} pixels, more than max_pixels="
            f"{max_pixels}; detection needs about {DETECTOR_BYTES_PER_PIXEL} bytes per pixel "
            f"(~{need:.1f} GiB here): downscale the image (cv2.resize), process it in tiles, "
            f"or raise the limit, e.g. DericheMoravecDetector.create(max_pixels={n})"
        )


def _describe(value) -> str:
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape} and dtype {value.dtype}"
    return f"{type(value).__name__} {value!r}"[:120]


def as_gray_image(image, name: str = "image", max_pixels: int | None = None) -> np.ndarray:
    """Return ``image`` as a C-contiguous 2-D grey image (uint8, uint16, int16 or float32).

    Accepts grey ``(H, W)`` or ``(H, W, 1)``, BGR ``(H, W, 3)`` and BGRA ``(H, W, 4)`` arrays
    of 8-bit, 16-bit or floating dtype, converted with ``cv2.cvtColor`` as OpenCV would.
    float64 becomes float32; big-endian arrays become native. NaN or infinite pixels, and
    float64 pixels beyond the float32 range, are refused. With ``max_pixels``, images with
    more pixels are refused (:class:`BudgetExceededError`) before anything is copied.
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
    if image.ndim in (2, 3):
        check_pixel_budget(image.shape, max_pixels, name)
    image = _native(image)
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[:, :, 0]
    if image.ndim == 3 and image.shape[2] in (3, 4):
        if image.shape[0] == 0 or image.shape[1] == 0:
            raise InvalidArgumentError(f"`{name}` must not be empty, got shape {image.shape}")
        src = (_to_float32(image, name, "pixels") if image.dtype in (np.float64, np.int16)
               else image)
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
        image = _to_float32(image, name, "pixels")
    if image.dtype == np.float32 and not np.isfinite(image).all():
        raise InvalidArgumentError(
            f"`{name}` contains NaN or infinite pixels; replace them first "
            "(for example with np.nan_to_num)"
        )
    return np.ascontiguousarray(image)


def as_mask(mask, shape: tuple[int, int], name: str = "mask", *,
            of: str | None = None) -> np.ndarray | None:
    """Return ``mask`` as a C-contiguous bool array of ``shape``, or None when ``mask`` is None.

    Accepts uint8 (non-zero = allowed, as cv2) or bool arrays of exactly ``shape``. ``of``
    names the shape in messages; by default it is an image mask's "(height, width)", with a
    hint on resizing it.
    """
    if mask is None:
        return None
    if not isinstance(mask, np.ndarray):
        raise InvalidTypeError(f"`{name}` must be a numpy array or None, got {_describe(mask)}")
    if mask.dtype not in (np.uint8, np.bool_):
        raise InvalidTypeError(
            f"`{name}` must have dtype uint8 or bool, got {mask.dtype}; convert it with "
            f"(mask != 0).astype(np.uint8)"
        )
    if mask.shape != tuple(shape):
        if of is not None:
            expected, hint = f"{of} = {tuple(shape)}", ""
        else:
            expected = f"{tuple(shape)} (the image's height and width)"
            hint = ("; give one channel, e.g. mask[:, :, 0]" if mask.ndim == 3 and
                    mask.shape[:2] == tuple(shape) else "; resize it with cv2.resize(mask, "
                    f"({shape[1]}, {shape[0]}), interpolation=cv2.INTER_NEAREST)")
        raise InvalidArgumentError(
            f"`{name}` must have shape {expected}, got {mask.shape}{hint}"
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
        if (arr.dtype == np.bool_ or not np.issubdtype(arr.dtype, np.number)
                or np.issubdtype(arr.dtype, np.complexfloating)):
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
    arr = _to_float32(np.asarray(arr), name, "coordinates")
    if not np.isfinite(arr).all():
        raise InvalidArgumentError(
            f"`{name}` contains NaN or infinite coordinates; drop those points first"
        )
    return arr


def check_coordinate_range(points: np.ndarray, name: str, limit: float = MAX_COORDINATE):
    """Refuse (x, y) coordinates with ``|x|`` or ``|y|`` above ``limit`` (see
    :data:`MAX_COORDINATE`); ``points`` comes from :func:`as_points`."""
    if points.size:
        big = float(np.abs(points).max())
        if big > limit:
            raise InvalidArgumentError(
                f"`{name}` holds a coordinate of magnitude {big:.6g}, beyond the +-{limit:.0f} "
                "pixels the matcher accepts; these are not pixel positions of an image "
                "(check the units, or drop the outliers)"
            )


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
    if desc.shape[0] > 0 and desc.shape[1] == 0:
        raise InvalidArgumentError(
            f"`{name}` has {desc.shape[0]} rows but 0 columns: each descriptor needs at least "
            "one value (was it computed with a zero-size window?)"
        )
    if desc.dtype == np.uint8:
        return np.ascontiguousarray(desc)
    if desc.dtype == np.bool_ or not np.issubdtype(desc.dtype, np.number) or np.issubdtype(
            desc.dtype, np.complexfloating):
        raise InvalidTypeError(
            f"`{name}` must be float32 or uint8, got dtype {desc.dtype}; convert it with "
            "desc.astype(np.float32)"
        )
    out = _to_float32(desc, name, "values")
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
