"""Drawing keypoints, matches and sparse disparities with OpenCV.

Every function returns a new uint8 BGR image, as ``cv2.imwrite`` expects. Images may be
grey or BGR(A), 8-bit, 16-bit or float; other depths than 8-bit are stretched to 0..255
for display (:func:`as_display_image`). Keypoints are ``cv2.KeyPoint`` sequences or
``(N, 2)`` (x, y) arrays; matches are ``cv2.DMatch`` sequences or ``(M, 2)`` (left index,
right index) arrays (:func:`as_index_pairs`).

The checks of drawing parameters shared by every module of :mod:`hopmatch.viz` live here:
colours (:func:`as_colour`), radii and marker sizes (:func:`as_draw_size`), flags
(:func:`as_flags`) and the size of a picture the caller's arguments set
(:func:`check_canvas`).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence

import cv2
import numpy as np

from .._validate import (
    MAX_IMAGE_PIXELS,
    as_array,
    as_gray_image,
    as_int,
    as_match_indices,
    as_points,
    as_real,
    check_coordinate_range,
    describe,
    keypoint_positions,
)
from ..errors import BudgetExceededError, InvalidArgumentError, InvalidTypeError

__all__ = [
    "GREEN",
    "GREY",
    "MAX_DRAW_SIZE",
    "RED",
    "as_colour",
    "as_disparities",
    "as_display_image",
    "as_draw_size",
    "as_flags",
    "as_index_pairs",
    "check_canvas",
    "disparity_colours",
    "draw_disparity",
    "draw_keypoints",
    "draw_matches",
    "drawable_points",
]

#: BGR colours of correct, wrong and unknown matches.
GREEN = (0, 200, 0)
RED = (0, 0, 255)
GREY = (160, 160, 160)

#: Largest dot radius and marker size drawn, in pixels (4096: a dot that covers an 8K
#: picture). The drawn radius of a keypoint (half its ``size``) is clipped to it.
MAX_DRAW_SIZE = 2**12


# --------------------------------------------------------------------------------------
# Inputs
# --------------------------------------------------------------------------------------


def as_display_image(image, name: str) -> np.ndarray:
    """``image`` as a C-contiguous uint8 BGR array to draw on.

    An 8-bit BGR or BGRA array keeps its three colour channels (a copy only when the
    channels are not contiguous already); anything else must pass
    :func:`hopmatch._validate.as_gray_image` (type, depth, shape, finiteness), is stretched
    to 0..255 (``cv2.NORM_MINMAX``) unless it is 8-bit, and becomes three equal channels.

    Raises
    ------
    InvalidArgumentError, InvalidTypeError
        ``image`` is empty or not an image; the message names ``name``.
    """
    if isinstance(image, np.ndarray) and image.ndim == 3 and image.shape[2] in (3, 4) \
            and image.dtype == np.uint8:
        bgr = image[:, :, :3]
        if bgr.shape[0] == 0 or bgr.shape[1] == 0:
            raise InvalidArgumentError(f"`{name}` must not be empty, got shape {image.shape}")
        return np.ascontiguousarray(bgr)
    gray = as_gray_image(image, name)
    if gray.dtype != np.uint8:
        gray = cv2.normalize(gray.astype(np.float32), None, 0, 255, cv2.NORM_MINMAX)
        gray = gray.astype(np.uint8)
    return cv2.cvtColor(gray, cv2.COLOR_GRAY2BGR)


def drawable_points(points, name: str) -> np.ndarray:
    """:func:`~hopmatch._validate.as_points`, refusing coordinates beyond
    +-:data:`~hopmatch._validate.MAX_COORDINATE` px as the matcher does (OpenCV draws at
    int32 positions: a point at 1e12 px was a ``cv2.error``); keypoints are checked alike."""
    pts = as_points(points, name)
    check_coordinate_range(pts, name)
    return pts


def as_disparities(values, name: str, n: int, per: str = "point", *,
                   finite: bool = True) -> np.ndarray:
    """``values`` as ``(n,)`` float64 disparities, one per ``per`` (finite unless
    ``finite=False``); errors name ``name`` (strings, objects and ragged lists were NumPy's
    bare ValueError or TypeError)."""
    d = as_array(values, name, "an array of disparities", finite=finite).reshape(-1)
    if d.shape[0] != n:
        raise InvalidArgumentError(f"`{name}` must have one value per {per} ({n}), got "
                                   f"{d.shape[0]}")
    return d


def _is_sequence_of(values, kind) -> bool:
    return isinstance(values, Sequence) and not isinstance(values, (str, bytes)) \
        and all(isinstance(v, kind) for v in values)


def as_index_pairs(matches, n_left: int, n_right: int) -> np.ndarray:
    """``(M, 2)`` int64 (left index, right index) pairs of ``matches``.

    ``matches`` is a sequence of ``cv2.DMatch`` (``queryIdx`` indexes the left keypoints,
    ``trainIdx`` the right ones) or anything ``np.asarray`` turns into an ``(M, 2)``
    integer array, nested lists such as ``[[0, 0], [1, 2]]`` included. Indices must be in
    ``[0, n_left)`` and ``[0, n_right)``; the checks are those of
    :func:`hopmatch._validate.as_match_indices`.

    Raises
    ------
    InvalidTypeError
        Not DMatches nor integers.
    InvalidArgumentError
        Not ``(M, 2)``, or an index refers to a keypoint that does not exist.
    """
    if not _is_sequence_of(matches, cv2.DMatch) and not isinstance(matches, np.ndarray):
        try:
            matches = np.asarray(matches)
        except (TypeError, ValueError):
            pass  # as_match_indices names the argument and what it got
    return as_match_indices(matches, n_query=n_left, n_train=n_right)


def _as_keypoints(keypoints, name: str) -> list:
    """A list of ``cv2.KeyPoint`` from keypoints or an ``(N, 2)`` (x, y) array (size 5)."""
    if _is_sequence_of(keypoints, cv2.KeyPoint):
        check_coordinate_range(keypoint_positions(keypoints, name), name)
        return list(keypoints)
    pts = drawable_points(keypoints, name)
    return [cv2.KeyPoint(float(x), float(y), 5.0) for x, y in pts.tolist()]


def _as_dmatches(matches, n_left: int, n_right: int) -> list:
    """A list of ``cv2.DMatch`` (the given ones, or made from index pairs), checked by
    :func:`as_index_pairs`."""
    pairs = as_index_pairs(matches, n_left, n_right)
    if _is_sequence_of(matches, cv2.DMatch):
        return list(matches)
    return [cv2.DMatch(int(q), int(t), 0.0) for q, t in pairs.tolist()]


def as_flags(values, name: str, n: int) -> np.ndarray:
    """``values`` as an ``(n,)`` bool array, one flag per match.

    Raises
    ------
    InvalidTypeError
        Not an array of bools (a string, numbers, objects).
    InvalidArgumentError
        Not one flag per match.
    """
    try:
        values = np.asarray(values)
    except (TypeError, ValueError):  # ragged lists: NumPy's own error
        raise InvalidTypeError(f"`{name}` must be a bool array, got {describe(values)}",
                               argument=name) from None
    if values.dtype != np.bool_:
        raise InvalidTypeError(f"`{name}` must be a bool array, got dtype {values.dtype}")
    if values.shape != (n,):
        raise InvalidArgumentError(
            f"`{name}` must have shape ({n},), one flag per match, got {values.shape}"
        )
    return values


def as_colour(value, name: str) -> tuple[int, ...]:
    """``value`` as a colour to draw with: a tuple of 1 to 4 ints in 0..255.

    As OpenCV takes a ``Scalar``: ``(B, G, R)``, or fewer numbers (the missing channels are
    0), or four (the fourth is ignored on a BGR picture); a tuple, list or 1-D array of real
    numbers, rounded to the nearest integer.

    Raises
    ------
    InvalidTypeError
        Not a sequence of numbers (a colour name such as ``"red"``, None, a bare number).
    InvalidArgumentError
        Fewer than 1 or more than 4 numbers, or one outside 0..255 (or NaN).
    """
    if isinstance(value, np.ndarray) and value.ndim == 1:
        value = value.tolist()
    if not isinstance(value, Sequence) or isinstance(value, (str, bytes)) or not all(
            isinstance(v, numbers.Real) and not isinstance(v, bool) for v in value):
        raise InvalidTypeError(
            f"`{name}` must be a colour (B, G, R) of numbers in 0..255, as OpenCV takes, "
            f"got {describe(value)}", argument=name)
    if not 1 <= len(value) <= 4 or not all(0 <= v <= 255 for v in value):
        raise InvalidArgumentError(
            f"`{name}` must be a colour (B, G, R) of 1 to 4 numbers in 0..255, got "
            f"{tuple(value)!r}", argument=name)
    return tuple(int(round(float(v))) for v in value)


def as_draw_size(value, name: str, *, lo: int = 0) -> int:
    """``value`` as a radius or marker size in pixels: an integer in
    ``[lo, MAX_DRAW_SIZE]`` (:data:`MAX_DRAW_SIZE`; OpenCV refuses negative radii and
    sizes beyond a C int, and a larger dot would only cover the picture more slowly).

    Raises
    ------
    InvalidTypeError
        Not an integer (OpenCV's drawing functions take integer sizes).
    InvalidArgumentError
        Outside ``[lo, MAX_DRAW_SIZE]``.
    """
    return as_int(value, name, lo=lo, hi=MAX_DRAW_SIZE)


def check_canvas(height: int, width: int, name: str, value) -> None:
    """Refuse a picture of ``height`` x ``width`` pixels beyond
    :data:`~hopmatch._validate.MAX_IMAGE_PIXELS` (2**30) before it is allocated; ``name``
    and ``value`` are the argument that sets its size, for the message.

    Raises
    ------
    BudgetExceededError
        The picture would be too large (an :class:`InvalidArgumentError`).
    """
    n = int(height) * int(width)
    if n > MAX_IMAGE_PIXELS:
        raise BudgetExceededError(
            f"`{name}` = {value!r} would make a {height} x {width} picture ({n} pixels, "
            f"{3 * n / 2**30:.3g} GiB in BGR), more than the {MAX_IMAGE_PIXELS} pixels "
            "hopmatch draws; give a smaller value", argument=name)


# --------------------------------------------------------------------------------------
# Drawing
# --------------------------------------------------------------------------------------


def draw_matches(left, right, kps_l, kps_r, matches, correct=None, *, known=None,
                 draw_single_points: bool = False) -> np.ndarray:
    """Draw matches side by side with ``cv2.drawMatches``.

    Parameters
    ----------
    left, right : (H, W) or (H, W, 3|4) ndarray
        The two images (grey or BGR(A); non-8-bit images are stretched for display).
    kps_l, kps_r : sequence of cv2.KeyPoint or (N, 2) float32 ndarray
        Keypoints of each image, (x, y).
    matches : sequence of cv2.DMatch or (M, 2) int ndarray
        ``queryIdx`` indexes ``kps_l``, ``trainIdx`` indexes ``kps_r``.
    correct : (M,) bool ndarray, optional
        When given, correct matches are drawn green and wrong ones red (on top); else
        OpenCV's default random colours.
    known : (M,) bool ndarray, optional
        With ``correct``: matches whose correctness is unknown (False here, e.g. no ground
        truth) are drawn grey.
    draw_single_points : bool
        Also draw the keypoints that have no match.

    Returns
    -------
    (max(Hl, Hr), Wl + Wr, 3) uint8 ndarray
        BGR picture.

    Raises
    ------
    InvalidArgumentError, InvalidTypeError
        An image, the keypoints, the matches or the flags are not of the kinds above, or
        a match refers to a keypoint that does not exist.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.zeros((40, 50), np.uint8)
    >>> pts = np.float32([[10, 10], [30, 20]])
    >>> draw_matches(img, img, pts, pts, np.array([[0, 0], [1, 1]]), np.array([True, False])).shape
    (40, 100, 3)
    """
    img_l, img_r = as_display_image(left, "left"), as_display_image(right, "right")
    kl, kr = _as_keypoints(kps_l, "kps_l"), _as_keypoints(kps_r, "kps_r")
    dm = _as_dmatches(matches, len(kl), len(kr))
    single = 0 if draw_single_points else cv2.DrawMatchesFlags_NOT_DRAW_SINGLE_POINTS
    if correct is None:
        return cv2.drawMatches(img_l, kl, img_r, kr, dm, None, flags=single)
    correct = as_flags(correct, "correct", len(dm))
    known = np.ones(len(dm), bool) if known is None else as_flags(known, "known", len(dm))
    # unknown first, wrong last: the red lines stay visible on top
    groups = [(GREY, ~known), (GREEN, known & correct), (RED, known & ~correct)]
    out = None
    for colour, keep in groups:
        chosen = [m for m, k in zip(dm, keep.tolist()) if k]
        if out is None:
            out = cv2.drawMatches(img_l, kl, img_r, kr, chosen, None, matchColor=colour,
                                  singlePointColor=(255, 160, 0), flags=single)
        else:
            out = cv2.drawMatches(img_l, kl, img_r, kr, chosen, out, matchColor=colour,
                                  flags=cv2.DrawMatchesFlags_DRAW_OVER_OUTIMG
                                  | cv2.DrawMatchesFlags_NOT_DRAW_SINGLE_POINTS)
    return out


def disparity_colours(disparities, lo: float, hi: float) -> np.ndarray:
    """``(N, 3)`` uint8 BGR colours of ``disparities`` on ``COLORMAP_TURBO``: ``lo`` dark
    blue, ``hi`` dark red, values outside clipped (all dark blue when ``hi <= lo``).

    Raises
    ------
    InvalidTypeError
        ``disparities`` are not numbers, or ``lo`` or ``hi`` is not a number.
    InvalidArgumentError
        ``lo`` or ``hi`` is not finite.
    """
    lo, hi = as_real(lo, "lo"), as_real(hi, "hi")
    d = as_array(disparities, "disparities", "an array of disparities", finite=False)
    d = d.reshape(-1)
    if d.size == 0:
        return np.zeros((0, 3), np.uint8)
    span = hi - lo
    scale = 255.0 / span if hi > lo and math.isfinite(span) else 0.0
    levels = np.clip((d - lo) * scale, 0, 255).astype(np.uint8).reshape(-1, 1)
    return cv2.applyColorMap(levels, cv2.COLORMAP_TURBO).reshape(-1, 3)


def draw_disparity(left, points, disparities, max_disparity=None, *, radius: int = 2,
                   min_disparity: float = 0.0) -> np.ndarray:
    """Draw sparse disparities as coloured dots (``COLORMAP_TURBO``) over the grey left image.

    Parameters
    ----------
    left : (H, W) or (H, W, 3|4) ndarray
        The left image; it is shown in grey.
    points : (N, 2) float32 ndarray or sequence of cv2.KeyPoint
        Left points, (x, y).
    disparities : (N,) ndarray
        Their disparities in pixels, finite.
    max_disparity : float, optional
        Disparity drawn red (the top of the colour map), greater than ``min_disparity``;
        default: the largest given. ``min_disparity`` (default 0) is drawn dark blue; values
        outside are clipped (all dark blue when the largest given is not above it).
    radius : int
        Dot radius in pixels, in ``[0, MAX_DRAW_SIZE]`` (:data:`MAX_DRAW_SIZE`).

    Returns
    -------
    (H, W, 3) uint8 ndarray
        BGR picture; the grey image alone when there are no points.

    Raises
    ------
    InvalidArgumentError
        Not one finite disparity per point, ``min_disparity`` or ``max_disparity`` is not
        finite, ``max_disparity`` is not greater than ``min_disparity``, or ``radius`` is
        outside its range.
    InvalidTypeError
        ``radius`` is not an integer, or a bound of the scale is not a number.

    Examples
    --------
    >>> import numpy as np
    >>> draw_disparity(np.zeros((30, 40), np.uint8), np.float32([[5, 5]]), [3.0]).shape
    (30, 40, 3)
    """
    radius = as_draw_size(radius, "radius")
    lo = as_real(min_disparity, "min_disparity")
    hi = as_real(max_disparity, "max_disparity", optional=True)
    if hi is not None and not (hi > lo and math.isfinite(hi - lo)):
        raise InvalidArgumentError(
            f"`max_disparity` must be greater than `min_disparity` ({lo!r}) by a finite "
            f"amount, got {hi!r}", argument="max_disparity")
    gray = as_display_image(left, "left")
    gray = cv2.cvtColor(cv2.cvtColor(gray, cv2.COLOR_BGR2GRAY), cv2.COLOR_GRAY2BGR)
    pts = drawable_points(points, "points")
    disp = as_disparities(disparities, "disparities", pts.shape[0])
    if len(disp) == 0:
        return gray
    hi = float(disp.max()) if hi is None else hi
    colours = disparity_colours(disp, lo, hi).tolist()
    for (x, y), c in zip(np.rint(pts).astype(int).tolist(), colours):
        cv2.circle(gray, (x, y), radius, tuple(int(v) for v in c), -1, cv2.LINE_AA)
    return gray


def draw_keypoints(image, keypoints, color=(0, 255, 0)) -> np.ndarray:
    """Draw keypoints with ``cv2.drawKeypoints`` (circles of the keypoint size).

    Parameters
    ----------
    image : (H, W) or (H, W, 3|4) ndarray
        Grey or BGR(A); non-8-bit images are stretched for display.
    keypoints : sequence of cv2.KeyPoint or (N, 2) float32 ndarray
        (x, y); array rows are drawn as keypoints of size 5. Each circle has the radius
        ``size / 2``, clipped to ``[0, MAX_DRAW_SIZE]`` (:data:`MAX_DRAW_SIZE`; a NaN
        size is drawn as 0): OpenCV cannot draw the circle of a keypoint of size 1e30,
        nor of a negative size.
    color : (B, G, R)
        1 to 4 numbers in 0..255, as OpenCV takes (:func:`as_colour`).

    Returns
    -------
    (H, W, 3) uint8 ndarray
        BGR picture.

    Raises
    ------
    InvalidArgumentError, InvalidTypeError
        ``image``, ``keypoints`` or ``color`` are not of the kinds above.

    Examples
    --------
    >>> import numpy as np
    >>> draw_keypoints(np.zeros((30, 40), np.uint16), np.float32([[5, 5]])).shape
    (30, 40, 3)
    """
    colour = as_colour(color, "color")
    img = as_display_image(image, "image")
    kps = _with_drawable_sizes(_as_keypoints(keypoints, "keypoints"))
    return cv2.drawKeypoints(img, kps, None, color=colour,
                             flags=cv2.DrawMatchesFlags_DRAW_RICH_KEYPOINTS)


def _with_drawable_sizes(keypoints: list) -> list:
    """``keypoints``, those whose drawn radius (``size / 2``) is outside
    ``[0, MAX_DRAW_SIZE]`` or NaN replaced by copies of size clipped to that range (0 for
    NaN); the caller's keypoints are left as they are."""
    top = 2.0 * MAX_DRAW_SIZE
    out = []
    for kp in keypoints:
        size = kp.size
        if not 0.0 <= size <= top:  # NaN, negative or too large
            size = 0.0 if math.isnan(size) else min(max(size, 0.0), top)
            kp = cv2.KeyPoint(kp.pt[0], kp.pt[1], size, kp.angle, kp.response, kp.octave,
                              kp.class_id)
        out.append(kp)
    return out
