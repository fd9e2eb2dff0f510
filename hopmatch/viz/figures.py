"""The paper's figures: Figure 5 (interest points over the gradient magnitude) and
Figure 7 (both images side by side, each match numbered on both).

``hopmatch match --figures`` writes them as ``figure5_left.png``, ``figure5_right.png``
and ``figure7.png``. Both functions return a new uint8 BGR image, as ``cv2.imwrite``
expects.
"""

from __future__ import annotations

import cv2
import numpy as np

from .._validate import as_gray_image, as_int, as_real, describe
from ..errors import InvalidTypeError
from ..feature import DericheMoravecDetector, deriche_gradient
from .draw import (
    as_colour,
    as_display_image,
    as_draw_size,
    as_index_pairs,
    check_canvas,
    drawable_points,
)
from .overview import spread_subset

__all__ = [
    "FIGURE_LABEL",
    "FIGURE_OUTLINE",
    "FIGURE_POINT",
    "draw_keypoints_on_gradient",
    "draw_labelled_matches",
]

#: BGR colours of the paper's figures: points, labels, the labels' dark outline.
FIGURE_POINT = (0, 0, 255)
FIGURE_LABEL = (0, 255, 255)
FIGURE_OUTLINE = (0, 0, 0)

#: Side in pixels of the crosses of Figure 7.
_CROSS = 7


# --------------------------------------------------------------------------------------
# Figure 5
# --------------------------------------------------------------------------------------


def _gradient_display(image, detector=None) -> np.ndarray:
    """The Canny-Deriche gradient magnitude G of ``image`` (SPEC section 1, item 1, with
    the detector's ``alpha`` and ``omega``) as a uint8 BGR picture of three equal channels.

    G is scaled so that its 99.5th percentile is white (a few very strong edges would
    otherwise leave everything else black) and clipped to 255. The white level is never
    below 1/1000 of the image's grey-level range, so the recursive filter's round-off on
    flat regions stays black; a flat image gives a black picture.

    Parameters
    ----------
    image : (H, W) or (H, W, 3|4) ndarray
        Grey or BGR(A), 8-bit, 16-bit or float.
    detector : DericheMoravecDetector, optional
        Gives ``alpha`` and ``omega``; default: a detector with the default parameters.

    Returns
    -------
    (H, W, 3) uint8 ndarray

    Raises
    ------
    InvalidTypeError
        ``detector`` is neither a DericheMoravecDetector nor None.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.zeros((20, 30), np.uint8); img[:, 15:] = 100
    >>> g = _gradient_display(img)
    >>> g.shape, int(g[10, 15, 0]), int(g[10, 2, 0])
    ((20, 30, 3), 255, 0)
    """
    if detector is None:
        detector = DericheMoravecDetector()
    elif not isinstance(detector, DericheMoravecDetector):
        raise InvalidTypeError(
            "`detector` must be a hopmatch.DericheMoravecDetector (its alpha and omega give "
            f"the gradient) or None, got {describe(detector)}"
        )
    params = detector.get_params()
    gray = as_gray_image(image, "image")
    g = deriche_gradient(gray, params["alpha"], params["omega"])
    lo, hi = cv2.minMaxLoc(gray.astype(np.float64))[:2]
    top = max(float(np.percentile(g, 99.5)), 1e-3 * (hi - lo))
    if not (hi > lo and top > 0.0):  # a flat image: no edge anywhere
        return np.zeros((*g.shape, 3), np.uint8)
    grey = np.clip(g * (255.0 / top), 0, 255).astype(np.uint8)
    return cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)


def draw_keypoints_on_gradient(image, keypoints, detector=None, *, color=FIGURE_POINT,
                               marker_size: int = 7) -> np.ndarray:
    """The paper's Figure 5: interest points over the gradient-magnitude image.

    The Canny-Deriche gradient magnitude G of ``image`` (with the detector's ``alpha`` and
    ``omega``), stretched so that its 99.5th percentile is white (a flat image gives
    black), with each point drawn as a cross (``cv2.drawMarker``).

    Parameters
    ----------
    image : (H, W) or (H, W, 3|4) ndarray
        The image the points were detected on (grey or BGR(A), 8-bit, 16-bit or float).
    keypoints : sequence of cv2.KeyPoint or (N, 2) float32 ndarray
        The points, (x, y).
    detector : DericheMoravecDetector, optional
        Gives ``alpha`` and ``omega`` of the gradient; default: a detector with the
        default parameters.
    color : (B, G, R)
        Colour of the crosses (default red): 1 to 4 numbers in 0..255, as OpenCV takes
        (:func:`~hopmatch.viz.draw.as_colour`).
    marker_size : int
        Side of the crosses in pixels, in ``[1, MAX_DRAW_SIZE]``
        (:data:`hopmatch.viz.draw.MAX_DRAW_SIZE`).

    Returns
    -------
    (H, W, 3) uint8 ndarray
        BGR picture.

    Raises
    ------
    InvalidTypeError
        ``detector`` is neither a DericheMoravecDetector nor None.
    InvalidArgumentError, InvalidTypeError
        ``image``, ``keypoints``, ``color`` or ``marker_size`` are not of the kinds above.

    See Also
    --------
    draw_labelled_matches : the paper's Figure 7.

    Examples
    --------
    >>> import numpy as np
    >>> from hopmatch import DericheMoravecDetector
    >>> img = np.zeros((48, 64), np.uint8); img[12:36, 16:48] = 200
    >>> det = DericheMoravecDetector.create(nms_size=9)
    >>> kps = det.detect(img)
    >>> fig5 = draw_keypoints_on_gradient(img, kps, det)
    >>> fig5.shape, fig5.dtype
    ((48, 64, 3), dtype('uint8'))
    >>> x, y = np.rint(kps[0].pt).astype(int)
    >>> fig5[y, x].tolist()
    [0, 0, 255]
    """
    colour = as_colour(color, "color")
    marker_size = as_draw_size(marker_size, "marker_size", lo=1)
    picture = _gradient_display(image, detector)
    pts = drawable_points(keypoints, "keypoints")
    for x, y in np.rint(pts).astype(np.int64).tolist():
        cv2.drawMarker(picture, (x, y), colour, cv2.MARKER_CROSS, marker_size, 1,
                       cv2.LINE_8)
    return picture


# --------------------------------------------------------------------------------------
# Figure 7
# --------------------------------------------------------------------------------------


def _label(picture, text: str, x: int, y: int, font_scale: float, colour) -> None:
    """Write ``text`` just up and right of (x, y), outlined in :data:`FIGURE_OUTLINE`,
    moved inside the picture where it would overflow."""
    font = cv2.FONT_HERSHEY_SIMPLEX
    (tw, th), base = cv2.getTextSize(text, font, font_scale, 1)
    h, w = picture.shape[:2]
    tx = min(max(x + 3, 0), max(w - tw - 1, 0))
    ty = min(max(y - 3, th + 1), max(h - base - 1, th + 1))
    # crisp (LINE_8) strokes: anti-aliased ones blur small digits into the outline
    cv2.putText(picture, text, (tx, ty), font, font_scale, FIGURE_OUTLINE, 3, cv2.LINE_8)
    cv2.putText(picture, text, (tx, ty), font, font_scale, colour, 1, cv2.LINE_8)


def draw_labelled_matches(left, right, kps_l, kps_r, matches, *, draw_lines: bool = False,
                          font_scale: float = 0.35, color=FIGURE_POINT,
                          label_color=FIGURE_LABEL, gap: int = 0,
                          max_labels: int | None = None) -> np.ndarray:
    """The paper's Figure 7: both images side by side, each match numbered on both.

    Match ``n`` (counting from 1, in the order given) is drawn as a cross at its left
    point and at its right point, each labelled ``n`` with ``cv2.putText``, so that a pair
    can be checked by eye without lines crossing the picture. Every number is drawn after
    every cross (and line), so no cross hides a number. With more matches than
    ``max_labels`` (the paper's figure has 33; thousands of labels overlap), only a subset
    spread over the picture is drawn (:func:`~hopmatch.viz.overview.spread_subset`), still
    numbered by its place in ``matches``.

    Parameters
    ----------
    left, right : (H, W) or (H, W, 3|4) ndarray
        The two images (grey or BGR(A); non-8-bit images are stretched for display).
    kps_l, kps_r : sequence of cv2.KeyPoint or (N, 2) float32 ndarray
        Keypoints of each image, (x, y).
    matches : sequence of cv2.DMatch or (M, 2) int ndarray
        ``queryIdx`` indexes ``kps_l``, ``trainIdx`` indexes ``kps_r``.
    draw_lines : bool
        Also join the two points of each match by a line.
    font_scale : float
        Scale of ``cv2.FONT_HERSHEY_SIMPLEX`` for the numbers, > 0 (0.35: digits about
        7 px high).
    color, label_color : (B, G, R)
        Colours of the crosses (default red) and of the numbers (default yellow, outlined
        in black): 1 to 4 numbers in 0..255, as OpenCV takes
        (:func:`~hopmatch.viz.draw.as_colour`).
    gap : int
        Pixels of black between the two images, >= 0; the picture must stay within
        :data:`~hopmatch._validate.MAX_IMAGE_PIXELS` (2**30 pixels).
    max_labels : int, optional
        Draw at most this many matches (>= 1), spread over the rows; default all.

    Returns
    -------
    (max(Hl, Hr), Wl + gap + Wr, 3) uint8 ndarray
        BGR picture.

    Raises
    ------
    InvalidArgumentError
        A match refers to a keypoint that does not exist, ``gap`` < 0,
        ``font_scale`` <= 0 or not finite, ``max_labels`` < 1, a colour outside 0..255,
        or a ``gap`` that makes the picture larger than 2**30 pixels
        (:class:`~hopmatch.errors.BudgetExceededError`, refused before any allocation).
    InvalidTypeError
        ``matches`` are neither DMatches nor integer pairs; ``gap`` or ``max_labels`` is
        not an integer, ``font_scale`` not a number, a colour not a sequence of numbers.

    See Also
    --------
    draw_keypoints_on_gradient : the paper's Figure 5.
    draw_matches : matches as lines, coloured by correctness.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.zeros((40, 50), np.uint8)
    >>> pts_l = np.float32([[20, 10], [30, 25]])
    >>> pts_r = pts_l - np.float32([6, 0])
    >>> fig7 = draw_labelled_matches(img, img, pts_l, pts_r, np.array([[0, 0], [1, 1]]))
    >>> fig7.shape, fig7.dtype
    ((40, 100, 3), dtype('uint8'))
    >>> fig7[10, 20].tolist(), fig7[10, 50 + 14].tolist()    # match 1 on both sides
    ([0, 0, 255], [0, 0, 255])
    """
    gap = as_int(gap, "gap", lo=0)
    font_scale = as_real(font_scale, "font_scale", lo=0.0, lo_open=True)
    colour, text_colour = as_colour(color, "color"), as_colour(label_color, "label_color")
    max_labels = as_int(max_labels, "max_labels", lo=1, optional=True)
    img_l, img_r = as_display_image(left, "left"), as_display_image(right, "right")
    kl = drawable_points(kps_l, "kps_l")
    kr = drawable_points(kps_r, "kps_r")
    pairs = as_index_pairs(matches, len(kl), len(kr))
    hl, wl = img_l.shape[:2]
    hr, wr = img_r.shape[:2]
    check_canvas(max(hl, hr), wl + gap + wr, "gap", gap)
    picture = np.zeros((max(hl, hr), wl + gap + wr, 3), np.uint8)
    picture[:hl, :wl] = img_l
    picture[:hr, wl + gap:] = img_r
    offset = wl + gap
    numbers = np.arange(1, len(pairs) + 1)
    if max_labels is not None and len(pairs) > max_labels:
        keep = np.sort(spread_subset(kl[pairs[:, 0]], max_labels, hl))
        pairs, numbers = pairs[keep], numbers[keep]
    ends_l = np.rint(kl[pairs[:, 0]]).astype(np.int64).tolist()
    ends_r = (np.rint(kr[pairs[:, 1]]).astype(np.int64) + [offset, 0]).tolist()
    ends = [(tuple(a), tuple(b)) for a, b in zip(ends_l, ends_r)]
    if draw_lines:
        for a, b in ends:
            cv2.line(picture, a, b, colour, 1, cv2.LINE_8)
    for a, b in ends:
        for p in (a, b):
            cv2.drawMarker(picture, p, colour, cv2.MARKER_CROSS, _CROSS, 1, cv2.LINE_8)
    for n, (a, b) in zip(numbers.tolist(), ends):
        _label(picture, str(n), a[0], a[1], font_scale, text_colour)
        _label(picture, str(n), b[0], b[1], font_scale, text_colour)
    return picture
