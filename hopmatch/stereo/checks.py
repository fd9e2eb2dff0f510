"""Boundary checks of :mod:`hopmatch.stereo`: camera models, point pairs, images, options.

The generic checks (numbers, matrices, points, fundamental matrices, match indices, cv2
calls) live in :mod:`hopmatch._validate`; this module holds the ones that only the stereo
functions take. Each returns a new, coerced value or raises
:class:`~hopmatch.errors.InvalidTypeError` / :class:`~hopmatch.errors.InvalidArgumentError`
naming the argument, what was expected and what came.
"""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

from .._validate import IMAGE_DTYPES, as_array, as_matrix, as_points, as_real, describe
from ..errors import InvalidArgumentError, InvalidTypeError

__all__ = [
    "INTERPOLATIONS",
    "as_alpha",
    "as_camera_matrix",
    "as_distortion",
    "as_image",
    "as_image_pair",
    "as_path",
    "as_point_pair",
    "as_real_array",
    "as_rotation",
    "as_translation",
    "as_values",
    "check_option",
]

#: The interpolations :func:`~hopmatch.stereo.rectify` and
#: :func:`~hopmatch.stereo.rectify_uncalibrated` accept, with the names messages show.
INTERPOLATIONS = {
    cv2.INTER_NEAREST: "cv2.INTER_NEAREST",
    cv2.INTER_LINEAR: "cv2.INTER_LINEAR",
    cv2.INTER_CUBIC: "cv2.INTER_CUBIC",
    cv2.INTER_LANCZOS4: "cv2.INTER_LANCZOS4",
}


# -- camera model ------------------------------------------------------------------------


def as_camera_matrix(value, name: str) -> np.ndarray:
    """A new float64 (3, 3) camera matrix with positive focal lengths ``fx``, ``fy``."""
    k = as_matrix(value, name, (3, 3))
    if k[0, 0] <= 0 or k[1, 1] <= 0:
        raise InvalidArgumentError(
            f"`{name}` must be a camera matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] with "
            f"positive focal lengths, got fx={k[0, 0]:g}, fy={k[1, 1]:g}"
        )
    return k


def as_distortion(value, name: str) -> np.ndarray:
    """Distortion coefficients (4, 5, 8, 12 or 14 of them, any vector shape) as ``(1, n)``."""
    d = as_array(value, name)
    if d.ndim > 2 or (d.ndim == 2 and 1 not in d.shape) or d.size not in (4, 5, 8, 12, 14):
        raise InvalidArgumentError(
            f"`{name}` must hold 4, 5, 8, 12 or 14 distortion coefficients (k1, k2, p1, p2"
            f"[, k3, ...]) as cv2.calibrateCamera returns them, got shape {d.shape}"
        )
    return d.reshape(1, -1)


def as_rotation(value, name: str) -> np.ndarray:
    """A (3, 3) rotation matrix from a matrix or a Rodrigues vector of 3 values.

    The matrix must be orthonormal within 1e-3 (``R @ R.T == I``) with a positive
    determinant.
    """
    r = as_array(value, name)
    if r.size == 3 and r.ndim <= 2:
        r = cv2.Rodrigues(r.reshape(3, 1))[0]
    if r.shape != (3, 3):
        raise InvalidArgumentError(
            f"`{name}` must be a 3x3 rotation matrix or a rotation vector of 3 values, "
            f"got shape {r.shape}"
        )
    err = float(np.abs(r @ r.T - np.eye(3)).max())
    if err > 1e-3 or np.linalg.det(r) < 0:
        raise InvalidArgumentError(
            f"`{name}` must be a rotation matrix (R @ R.T == I, det(R) == 1); it is off by "
            f"{err:.3g} with det {np.linalg.det(r):.3g}"
        )
    return r


def as_translation(value, name: str) -> np.ndarray:
    """A non-zero translation of 3 values (any vector shape) as ``(3, 1)``."""
    t = as_array(value, name)
    if t.size != 3 or t.ndim > 2:
        raise InvalidArgumentError(
            f"`{name}` must hold 3 values (tx, ty, tz), got shape {t.shape}"
        )
    if not np.any(t):
        raise InvalidArgumentError(f"`{name}` must not be zero: a stereo pair needs a baseline")
    return t.reshape(3, 1)


def as_alpha(alpha) -> float:
    """The free scaling of ``cv2.stereoRectify``: -1 or a number in [0, 1]."""
    a = as_real(alpha, "alpha")
    if not (a == -1.0 or 0.0 <= a <= 1.0):
        raise InvalidArgumentError(f"`alpha` must be -1 or in [0, 1], got {a!r}")
    return a


# -- points and per-point values -----------------------------------------------------------


def as_point_pair(left_pts, right_pts, left_name: str = "left_pts",
                  right_name: str = "right_pts") -> tuple[np.ndarray, np.ndarray]:
    """Two aligned ``(N, 2)`` float32 point arrays (row ``i`` of each: match ``i``)."""
    left = as_points(left_pts, left_name)
    right = as_points(right_pts, right_name)
    if len(left) != len(right):
        raise InvalidArgumentError(
            f"`{left_name}` and `{right_name}` must have the same length (one row per match), "
            f"got {len(left)} and {len(right)}"
        )
    return left, right


def as_real_array(value, name: str, what: str = "a numeric array", *,
                  refuse_bool: bool = False) -> np.ndarray:
    """``value`` as a new float64 array of any shape, NaN and infinities kept
    (:func:`hopmatch._validate.as_array` with ``finite=False``)."""
    return as_array(value, name, what, finite=False, refuse_bool=refuse_bool)


def as_values(values, name: str, n: int) -> np.ndarray:
    """An ``(n,)`` float64 vector, one value per point; NaN allowed (no value), infinities
    refused."""
    arr = as_real_array(values, name, "a 1-D numeric array")
    if arr.size == 0:
        arr = arr.reshape(0)
    if arr.ndim != 1 or arr.shape[0] != n:
        raise InvalidArgumentError(
            f"`{name}` must have shape ({n},) (one value per point), got shape {arr.shape}"
        )
    if np.isinf(arr).any():
        raise InvalidArgumentError(f"`{name}` contains infinite values (use NaN for 'none')")
    return arr


# -- images, options, paths ----------------------------------------------------------------


def as_image(image, name: str) -> np.ndarray:
    """Any image ``cv2.remap`` / ``cv2.warpPerspective`` accept, kept as it is (no grey
    conversion): grey ``(H, W)`` or ``(H, W, 1)``, BGR or BGRA, of a dtype of
    :data:`hopmatch._validate.IMAGE_DTYPES`; returned C-contiguous."""
    if not isinstance(image, np.ndarray):
        raise InvalidTypeError(
            f"`{name}` must be a numpy array (as returned by cv2.imread), got {describe(image)}"
        )
    if image.dtype == np.bool_ or image.dtype.type not in IMAGE_DTYPES:
        raise InvalidTypeError(
            f"`{name}` must have dtype uint8, uint16, int16, float32 or float64, got {image.dtype}"
        )
    if image.ndim not in (2, 3) or (image.ndim == 3 and image.shape[2] not in (1, 3, 4)):
        raise InvalidArgumentError(
            f"`{name}` must be a grey (H, W) or (H, W, 1), BGR (H, W, 3) or BGRA (H, W, 4) "
            f"image, got shape {image.shape}"
        )
    if image.shape[0] == 0 or image.shape[1] == 0:
        raise InvalidArgumentError(f"`{name}` must not be empty, got shape {image.shape}")
    return np.ascontiguousarray(image)


def as_image_pair(left, right) -> tuple[np.ndarray, np.ndarray]:
    """``left`` and ``right`` checked by :func:`as_image`, of the same height and width."""
    left = as_image(left, "left")
    right = as_image(right, "right")
    if left.shape[:2] != right.shape[:2]:
        raise InvalidArgumentError(
            f"`left` and `right` must have the same height and width, got {left.shape[:2]} "
            f"and {right.shape[:2]}"
        )
    return left, right


def check_option(value, name: str, options: dict) -> int:
    """``value`` as an int when it is a key of ``options`` (cv2 constant -> its name, as
    :data:`INTERPOLATIONS`); the message lists the names. Bools are refused."""
    if value not in options or isinstance(value, bool):
        valid = ", ".join(options.values())
        raise InvalidArgumentError(f"`{name}` must be one of {valid}; got {value!r}")
    return int(value)


def as_path(path, name: str = "path") -> Path:
    """``path`` (a str or an ``os.PathLike``) as a :class:`pathlib.Path`."""
    if not isinstance(path, (str, os.PathLike)):
        raise InvalidTypeError(f"`{name}` must be a str or os.PathLike, got {describe(path)}")
    return Path(path)
