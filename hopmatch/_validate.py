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
FLOAT32_MAX = float(np.finfo(np.float32).max)
#: Smallest positive float32 (subnormal); float64 values below about half of it become 0.
_F32_TRUE_MIN = float(np.finfo(np.float32).smallest_subnormal)

#: Largest |coordinate| the matcher accepts (2**20 = 1,048,576 pixels). The network's
#: neighbour grid counts cells in int64; beyond this bound a spread-out point set (or a zero
#: neighbourhood) would overflow that count. No camera image comes near it.
MAX_COORDINATE = float(2**20)

#: Bytes of peak memory per pixel of ``DericheMoravecDetector.detectAndCompute`` with the
#: default parameters, measured (peak RSS in a fresh process, see docs/robustness.md), plus
#: the descriptors of the keypoints found.
DETECTOR_BYTES_PER_PIXEL = 45

#: Largest image hopmatch allocates for an output whose size the caller gives
#: (``sparse_disparity_image``'s shape): OpenCV's own limit on decoded images, 2**30 pixels.
MAX_IMAGE_PIXELS = 2**30

#: The detector's ``max_pixels`` by default (about 2.2 GiB of detection memory), also the
#: limit :func:`hopmatch.imageio.read_image` reads image headers against by default.
DEFAULT_MAX_PIXELS = 50_000_000


def _native(arr: np.ndarray) -> np.ndarray:
    """``arr`` in the machine's byte order (cv2 reads big-endian buffers as native ones)."""
    return arr if arr.dtype.isnative else arr.astype(arr.dtype.newbyteorder("="))


def _to_float32(arr: np.ndarray, name: str, what: str) -> np.ndarray:
    """float32 C-contiguous copy of a numeric array; values beyond the float32 range (or NaN,
    inf), and float64 arrays whose every value is too small for float32 (all would become
    0), are refused with a message naming ``name``."""
    if arr.dtype == np.float64 and arr.size:
        with np.errstate(invalid="ignore"):
            big = np.abs(arr).max()
        if np.isfinite(big) and big > FLOAT32_MAX:
            raise InvalidArgumentError(
                f"`{name}` holds {what} up to {big:.3g}, beyond the float32 range "
                f"(+-{FLOAT32_MAX:.3g}); rescale them first"
            )
        if big > 0.0 and np.float32(big) == 0.0:  # every value would become 0 in float32
            raise InvalidArgumentError(
                f"`{name}` holds {what} no larger than {big:.3g} in magnitude, below the "
                f"float32 range (smallest {_F32_TRUE_MIN:.3g}): in float32 they are all 0; "
                f"rescale them first"
            )
    with np.errstate(over="ignore", invalid="ignore"):
        out = np.ascontiguousarray(arr, dtype=np.float32)
    return writable(out)


def writable(arr: np.ndarray) -> np.ndarray:
    """``arr``, or a copy of it when it is read-only: Numba compiles a kernel again (seconds
    on a first call) for a read-only array, a type of its own."""
    return arr if arr.flags.writeable else arr.copy()


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
            f"or raise the limit to max_pixels={n} or more"
        )


def describe(value) -> str:
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
            f"`{name}` must be a numpy array (as returned by cv2.imread), got {describe(image)}"
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
        raise InvalidTypeError(f"`{name}` must be a numpy array or None, got {describe(mask)}")
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
        arr = keypoint_positions(points, name)
    else:
        if isinstance(points, (str, bytes)) or points is None:
            raise InvalidTypeError(
                f"`{name}` must be a sequence of cv2.KeyPoint or an (N, 2) array, got "
                f"{describe(points)}"
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


def keypoint_positions(keypoints, name: str) -> np.ndarray:
    """``(N, 2)`` float32 ``pt`` of a non-empty sequence of ``cv2.KeyPoint``, read now (a
    keypoint's ``pt`` is writable, so nothing read earlier is reused).

    One ``cv2.KeyPoint_convert`` call converts and checks the types at once (about 0.05 ms
    per 10k keypoints, against 0.5 ms for a Python ``isinstance`` loop); only when it fails
    is the sequence scanned, to name the offending object.
    """
    seq = keypoints if isinstance(keypoints, (list, tuple)) else list(keypoints)
    try:
        out = np.asarray(cv2.KeyPoint_convert(seq), dtype=np.float32).reshape(-1, 2)
    except cv2.error:
        out = None
    # cv2 reads a None as a keypoint at (0, 0): look for one only where such a point is
    if out is None or (not (out != 0).any(axis=1).all() and None in seq):
        bad = [kp for kp in seq if not isinstance(kp, cv2.KeyPoint)][:1]
        if not bad:
            raise InvalidTypeError(f"`{name}`: cv2.KeyPoint_convert could not read these "
                                   "keypoints")
        raise InvalidTypeError(
            f"`{name}` mixes cv2.KeyPoint with other objects (a {type(bad[0]).__name__})"
        ) from None
    return out


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
        raise InvalidTypeError(f"`{name}` must be a numpy array, got {describe(desc)}")
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
        return writable(np.ascontiguousarray(desc))
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
            f"`{name}` must be (width, height) as two integers, got {describe(size)}"
        )
    w, h = int(size[0]), int(size[1])
    if w <= 0 or h <= 0:
        raise InvalidArgumentError(f"`{name}` must be positive (width, height), got {(w, h)}")
    return (w, h)


# -- scalars -------------------------------------------------------------------------------

#: Bounds of the integers the kernels take (int64): every integer parameter is refused
#: outside them before it reaches Numba.
INT64_MIN, INT64_MAX = -(2**63), 2**63 - 1


def _interval(lo, hi, lo_open: bool) -> str:
    left = "(" if lo_open or lo is None else "["
    return f"{left}{'-inf' if lo is None else lo}, {'inf' if hi is None else hi}]"


def as_real(value, name: str, *, lo=None, hi=None, lo_open: bool = False,
            optional: bool = False) -> float | None:
    """``value`` as a finite Python float in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``).

    None is returned as None when ``optional``; bools, strings and other non-numbers raise
    :class:`InvalidTypeError`, NaN, infinities and values outside the interval
    :class:`InvalidArgumentError`, each naming ``name``.
    """
    if value is None and optional:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InvalidTypeError(f"`{name}` must be a number, got {describe(value)}")
    try:
        v = float(value)
    except OverflowError:  # a Python int beyond the float range
        v = float("inf") if value > 0 else float("-inf")
    bad = not np.isfinite(v)
    if lo is not None:
        bad = bad or (v <= lo if lo_open else v < lo)
    if hi is not None:
        bad = bad or v > hi
    if bad:
        raise InvalidArgumentError(
            f"`{name}` must be a finite number in {_interval(lo, hi, lo_open)}, got {v!r}")
    return v


def as_int(value, name: str, *, lo: int | None = None, hi: int | None = None,
           odd: bool = False, optional: bool = False) -> int | None:
    """``value`` as a Python int in ``[lo, hi]``, and within int64 whatever the bounds.

    None is returned as None when ``optional``; bools and non-integers raise
    :class:`InvalidTypeError`, values outside the interval (or even when ``odd``)
    :class:`InvalidArgumentError`, each naming ``name``.
    """
    if value is None and optional:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise InvalidTypeError(f"`{name}` must be an integer, got {describe(value)}")
    v = int(value)
    lo_b = INT64_MIN if lo is None else max(int(lo), INT64_MIN)
    hi_b = INT64_MAX if hi is None else min(int(hi), INT64_MAX)
    if not lo_b <= v <= hi_b:
        raise InvalidArgumentError(f"`{name}` must be in [{lo_b}, {hi_b}], got {v}")
    if odd and v % 2 == 0:
        raise InvalidArgumentError(f"`{name}` must be odd, got {v}")
    return v


def as_flag(value, name: str) -> bool:
    """``value`` as a bool: True, False, NumPy's bools, or the integers 0 and 1 (as cv2's
    Python bindings take a ``bool`` argument); anything else, a string such as ``"no"``
    included, is an :class:`InvalidTypeError` naming ``name``."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, numbers.Integral) and int(value) in (0, 1):
        return bool(value)
    raise InvalidTypeError(f"`{name}` must be True or False, got {describe(value)}",
                           argument=name)


# -- matrices --------------------------------------------------------------------------------


def as_array(value, name: str, what: str = "a numeric array", *, finite: bool = True,
             refuse_bool: bool = False) -> np.ndarray:
    """``value`` as a new float64 array of real numbers (any shape), finite unless
    ``finite=False`` (for inputs where NaN means "none").

    None, strings, bytes (and a bool when ``refuse_bool``) raise :class:`InvalidTypeError`
    saying ``name`` must be ``what``; so do arrays of bools, complex numbers or objects.
    """
    if value is None or isinstance(value, (str, bytes)) or (refuse_bool
                                                            and isinstance(value, bool)):
        raise InvalidTypeError(f"`{name}` must be {what}, got {describe(value)}")
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise InvalidTypeError(f"`{name}` must be {what}: {exc}") from None
    if arr.dtype == np.bool_ or not np.issubdtype(arr.dtype, np.number) or np.iscomplexobj(arr):
        raise InvalidTypeError(f"`{name}` must hold real numbers, got dtype {arr.dtype}")
    arr = np.array(arr, dtype=np.float64)  # always a copy: callers' arrays stay theirs
    if finite and not np.isfinite(arr).all():
        raise InvalidArgumentError(f"`{name}` contains NaN or infinite values")
    return arr


def as_matrix(value, name: str, shape: tuple[int, int]) -> np.ndarray:
    """A new finite float64 matrix of exactly ``shape``."""
    arr = as_array(value, name)
    if arr.shape != shape:
        raise InvalidArgumentError(
            f"`{name}` must be a {shape[0]}x{shape[1]} matrix, got shape {arr.shape} instead "
            f"of {tuple(shape)}"
        )
    return arr


#: Frobenius norms of F used as they come; outside, F is rescaled (see
#: :func:`as_fundamental_matrix`). Within them, the epipolar lines of points within
#: +-2**20 px neither overflow nor underflow in float64.
F_NORM_RANGE = (2.0**-4, 2.0**4)


def as_fundamental_matrix(F, name: str = "F", *, optional: bool = False) -> np.ndarray | None:
    """A fundamental matrix (``x_r^T F x_l = 0``, as ``cv2.findFundamentalMat`` returns it):
    any finite 3 x 3 array-like, not all zero, returned as a new C-contiguous float64
    array; None passes through when ``optional``.

    F is defined up to scale, and an extreme scale breaks the arithmetic of the epipolar
    lines (``F * 1e-200`` underflows to lines of zero length: no candidate; ``F * 1e200``
    overflows: every point on every line). A matrix whose Frobenius norm is outside
    :data:`F_NORM_RANGE` is therefore multiplied by the power of two that brings its norm
    into [0.5, 1): exact in floating point, so it changes no line, distance or match,
    only their under- and overflow.
    """
    if F is None and optional:
        return None
    if F is None or isinstance(F, (str, bytes)):
        raise InvalidTypeError(f"`{name}` must be a 3 x 3 numeric array, got {describe(F)}")
    if isinstance(F, np.ndarray) and F.shape == (9, 3):
        raise InvalidArgumentError(
            f"`{name}` must be a 3x3 matrix, got shape (9, 3): cv2.findFundamentalMat "
            "returns several stacked solutions for FM_7POINT; pick one"
        )
    f = as_matrix(F, name, (3, 3))
    if not np.any(f):
        raise InvalidArgumentError(f"`{name}` must be finite and not all zeros")
    big = float(np.abs(f).max())
    norm = big * float(np.sqrt(np.sum((f / big) ** 2)))  # no overflow on the way
    if not F_NORM_RANGE[0] <= norm <= F_NORM_RANGE[1]:
        f = np.ldexp(f, -np.frexp(norm)[1])  # norm in [0.5, 1), every entry exact
    return np.ascontiguousarray(f)


def cv2_call(what: str, func, *args, **kwargs):
    """Call a cv2 function; re-raise ``cv2.error`` as InvalidArgumentError naming ``what``."""
    try:
        return func(*args, **kwargs)
    except cv2.error as exc:
        detail = getattr(exc, "err", None) or str(exc).strip().splitlines()[-1]
        raise InvalidArgumentError(f"{what} failed in OpenCV: {detail}") from exc


# -- matches ---------------------------------------------------------------------------------


def as_match_indices(matches, name: str = "matches", *, n_query: int | None = None,
                     n_train: int | None = None) -> np.ndarray:
    """``(M, 2)`` int64 (query index, train index) pairs from a sequence of ``cv2.DMatch``
    (or one) or an ``(M, 2)`` integer array; negative indices, and indices at or beyond
    ``n_query`` / ``n_train`` when given, are refused."""
    if isinstance(matches, cv2.DMatch):
        matches = [matches]
    if isinstance(matches, np.ndarray):
        if matches.size == 0:
            return np.zeros((0, 2), np.int64)
        if not np.issubdtype(matches.dtype, np.integer):
            raise InvalidTypeError(
                f"`{name}` as an array must hold integer (query_index, train_index) pairs, "
                f"got dtype {matches.dtype}"
            )
        if matches.ndim != 2 or matches.shape[1] != 2:
            raise InvalidArgumentError(
                f"`{name}` as an array must have shape (M, 2) holding (query_index, "
                f"train_index), got shape {matches.shape}"
            )
        idx = matches.astype(np.int64)
    elif not isinstance(matches, Sequence) or isinstance(matches, (str, bytes)):
        raise InvalidTypeError(
            f"`{name}` must be a sequence of cv2.DMatch or an (M, 2) integer array, got "
            f"{describe(matches)}"
        )
    else:
        idx = np.empty((len(matches), 2), np.int64)
        for i, m in enumerate(matches):
            if isinstance(m, cv2.DMatch):
                idx[i] = m.queryIdx, m.trainIdx
            elif isinstance(m, Sequence) and len(m) and isinstance(m[0], cv2.DMatch):
                raise InvalidTypeError(
                    f"`{name}[{i}]` is a list of cv2.DMatch, as knnMatch returns; keep one "
                    "match per query, e.g. [m for m, n in knn if m.distance < 0.8 * n.distance]"
                )
            else:
                raise InvalidTypeError(f"`{name}[{i}]` must be a cv2.DMatch, got {describe(m)}")
    if (idx < 0).any():
        raise InvalidArgumentError(f"`{name}` contains negative queryIdx or trainIdx")
    if len(idx) and ((n_query is not None and idx[:, 0].max() >= n_query)
                     or (n_train is not None and idx[:, 1].max() >= n_train)):
        raise InvalidArgumentError(
            f"`{name}` refer to keypoints that do not exist: indices must be in "
            f"[0, {n_query}) for the query (left) and [0, {n_train}) for the train (right) "
            "keypoints"
        )
    return idx
