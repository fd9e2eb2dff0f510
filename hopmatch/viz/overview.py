"""Pictures that read at 100 %: matches and disparities of thousands of points.

A stereo matcher returns thousands of matches; drawn as ``cv2.drawMatches`` draws them, the
lines of a rectified pair (all nearly horizontal) cover the picture. Here:

- :func:`draw_match_overview`: both images side by side in grey, every match as a dot on
  each image, a spread-out subset as lines (at most one per band of rows, so that lines do
  not lie on one another), everything coloured by disparity, wrong matches (when ground
  truth says so) marked, and a caption with the counts and the colour scale in pixels;
- :func:`draw_keypoint_disparities`: the left image in grey with the matched keypoints
  coloured by disparity and a colour bar in pixels beside it.

``hopmatch demo`` and ``hopmatch match`` write them as ``matches.png`` and
``disparity.png``. Colours are OpenCV's ``COLORMAP_TURBO`` (dark blue: the smallest
disparity of the scale, far; dark red: the largest, near), the scale chosen by
:func:`disparity_scale`. Every function returns a new uint8 BGR image.
"""

from __future__ import annotations

import math
import numbers

import cv2
import numpy as np

from .._validate import as_array, as_int, as_points, as_real, describe
from ..errors import InvalidArgumentError, InvalidTypeError
from .draw import (
    as_disparities,
    as_display_image,
    as_draw_size,
    as_flags,
    as_index_pairs,
    check_canvas,
    disparity_colours,
    drawable_points,
)

__all__ = [
    "WRONG",
    "disparity_scale",
    "draw_colour_bar",
    "draw_keypoint_disparities",
    "draw_match_overview",
    "nice_ticks",
    "spread_subset",
]

#: BGR colour of the marks of wrong matches (magenta: not in the TURBO colour map).
WRONG = (255, 0, 255)

_FONT = cv2.FONT_HERSHEY_SIMPLEX
_TEXT = (235, 235, 235)
_PANEL = (40, 40, 40)
_FONT_SCALE = 0.45
_LINE_H = 18          # caption line height, px
_BAR_W = 16           # colour bar thickness, px
_PANEL_W = 80         # width of the colour-bar panel beside the keypoint picture, px
_DIM = 0.75           # grey background brightness, so that the colours stand out


# --------------------------------------------------------------------------------------
# Scale and colours
# --------------------------------------------------------------------------------------


#: Most ticks :func:`nice_ticks` gives (a colour bar has at most 8).
MAX_TICKS = 1000


def nice_ticks(lo: float, hi: float, max_ticks: int = 6) -> list[float]:
    """Round tick values in ``[lo, hi]`` (steps of 1, 2 or 5 x 10^k), at most
    ``max_ticks`` of them, ``lo`` and ``hi`` included when they are round. ``[lo]`` when
    the range is empty or not finite, ``[lo, hi]`` when it is too wide for a float.

    Raises
    ------
    InvalidTypeError
        ``lo`` or ``hi`` is not a number, or ``max_ticks`` not an integer.
    InvalidArgumentError
        ``max_ticks`` is above :data:`MAX_TICKS` (each tick is a label to draw).

    Examples
    --------
    >>> nice_ticks(0, 66)
    [0.0, 20.0, 40.0, 60.0]
    >>> nice_ticks(16, 111, 4)
    [50.0, 100.0]
    """
    for name, value in (("lo", lo), ("hi", hi)):
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise InvalidTypeError(f"`{name}` must be a number, got {describe(value)}",
                                   argument=name)
    max_ticks = max(2, as_int(max_ticks, "max_ticks", lo=0, hi=MAX_TICKS))
    if not (np.isfinite(lo) and np.isfinite(hi)) or hi <= lo:
        return [float(lo)]
    if not np.isfinite(hi - lo):  # e.g. (-1e308, 1e308): no step of 10^k in a float
        return [float(lo), float(hi)]
    raw = (hi - lo) / (max_ticks - 1)
    mag = 10.0 ** math.floor(math.log10(raw))
    for m in (1, 2, 5, 10):
        step = m * mag
        first = math.ceil(lo / step - 1e-9) * step
        ticks = [first + k * step for k in range(int((hi - first) / step + 1e-9) + 1)]
        if len(ticks) <= max_ticks:
            return [round(t, 10) + 0.0 for t in ticks]
    return [float(lo), float(hi)]


def disparity_scale(disparities, min_disparity=None, max_disparity=None) -> tuple[float, float]:
    """``(lo, hi)`` of the colour scale: the given bounds, else ``lo = min(0, smallest
    disparity)`` and ``hi`` = the 99.5th percentile of the disparities (a few outliers do
    not squeeze the colours of all the others; larger values get the top colour), rounded
    up to half its power of ten (61 -> 65, 12 -> 15). ``(0, 1)`` without disparities.
    NaN and infinite disparities are left out.

    Raises
    ------
    InvalidTypeError
        ``disparities`` are not numbers, or a bound is not a number.
    InvalidArgumentError
        A bound is not finite, ``max_disparity`` is not greater than the scale's bottom
        (``min_disparity``, or the one chosen for it), or the scale is too wide for a float
        (``hi - lo`` beyond the float range).

    Examples
    --------
    >>> disparity_scale([3.0, 12.5, 61.0])
    (0.0, 65.0)
    >>> disparity_scale([3.0, 12.5], 0, 64)
    (0.0, 64.0)
    """
    min_disparity = as_real(min_disparity, "min_disparity", optional=True)
    max_disparity = as_real(max_disparity, "max_disparity", optional=True)
    d = as_array(disparities, "disparities", "an array of disparities", finite=False)
    d = d.reshape(-1)
    d = d[np.isfinite(d)]
    lo = min_disparity if min_disparity is not None else (
        min(0.0, math.floor(float(d.min()))) if d.size else 0.0)
    if max_disparity is not None:
        hi = max_disparity
        if not hi > lo:
            bottom = ("`min_disparity`" if min_disparity is not None
                      else "the scale's bottom, min(0, smallest disparity),")
            raise InvalidArgumentError(
                f"`max_disparity` must be greater than {bottom} {lo!r}, got {hi!r}",
                argument="max_disparity")
    elif d.size:
        top = float(np.percentile(d, 99.5))
        if not math.isfinite(top - lo):
            hi = math.inf  # refused below
        elif top > lo:
            unit = 10.0 ** math.floor(math.log10(top - lo)) / 2.0
            hi = math.ceil((top - lo) / unit - 1e-9) * unit + lo
        else:
            hi = lo + 1.0
    else:
        hi = lo + 1.0
    if not (np.isfinite(lo) and np.isfinite(hi) and np.isfinite(hi - lo)):
        raise InvalidArgumentError(
            f"the disparity scale must be finite, got [{lo}, {hi}]; give `min_disparity` "
            "and `max_disparity` less than a float's range apart")
    return lo, max(hi, lo + 1e-6)


def _colour(c) -> tuple[int, int, int]:
    return tuple(int(v) for v in c)


def _text(img, text: str, x: int, y: int, scale: float = _FONT_SCALE, colour=_TEXT) -> None:
    cv2.putText(img, text, (int(x), int(y)), _FONT, scale, colour, 1, cv2.LINE_AA)


def _text_width(text: str, scale: float = _FONT_SCALE) -> int:
    return cv2.getTextSize(text, _FONT, scale, 1)[0][0]


def _label(value: float) -> str:
    return f"{value:g}"


# --------------------------------------------------------------------------------------
# Colour bars
# --------------------------------------------------------------------------------------


def draw_colour_bar(length: int, lo: float, hi: float, *, vertical: bool = True,
                    title: str = "disparity (px)", footer: str = "") -> np.ndarray:
    """A colour-bar panel of the scale ``[lo, hi]``, with round ticks labelled in pixels.

    Vertical (for beside a picture): ``(length, 80, 3)``, ``hi`` at the top, the title on
    two lines above the bar and ``footer`` (if any) below it. Horizontal (for a caption):
    ``(34, length, 3)``, ``lo`` at the left, the title after the bar. What does not fit is
    left out: the bar when shorter than 8 px (a vertical panel keeps its title, a
    horizontal one is a plain strip), the title, and tick labels that would overlap.

    Raises
    ------
    InvalidTypeError
        ``length`` is not an integer, ``lo`` or ``hi`` not a number, ``title`` or
        ``footer`` not a string.
    InvalidArgumentError
        ``length`` < 1 or a panel beyond :data:`~hopmatch._validate.MAX_IMAGE_PIXELS`;
        ``lo`` or ``hi`` not finite, or ``hi <= lo``.

    Examples
    --------
    >>> draw_colour_bar(200, 0, 66).shape, draw_colour_bar(300, 0, 66, vertical=False).shape
    ((200, 80, 3), (34, 300, 3))
    """
    length = _check_colour_bar(length, lo, hi, vertical, title, footer)
    lo, hi = float(lo), float(hi)
    if vertical:
        panel = np.full((length, _PANEL_W, 3), _PANEL, np.uint8)
        words = title.split(" ", 1)
        for k, word in enumerate(words):
            _text(panel, word, 4, 14 + 14 * k, 0.4)
        top, bottom = 14 * len(words) + 10, length - (24 if footer else 8)
        if footer:
            _text(panel, footer, 4, length - 6, 0.35)
        if bottom - top < 8:  # too short for a bar: the title (and footer) alone
            return panel
        values = np.linspace(hi, lo, bottom - top)
        panel[top:bottom, 6:6 + _BAR_W] = disparity_colours(values, lo, hi)[:, None, :]
        n_ticks = max(2, min(8, (bottom - top) // 28))
        free = length  # the labels go up: first row above the last label written
        for t in nice_ticks(lo, hi, n_ticks):
            y = top + int(round((hi - t) / (hi - lo) * (bottom - top - 1)))
            cv2.line(panel, (6 + _BAR_W, y), (6 + _BAR_W + 4, y), _TEXT, 1)
            if y + 4 < free:  # never over the previous label
                _text(panel, _label(t), 6 + _BAR_W + 7, y + 4, 0.4)
                free = y + 4 - 12
        return panel
    panel = np.full((34, length, 3), _PANEL, np.uint8)
    title_w = _text_width(title, 0.4) + 12
    bar = max(40, length - title_w - 16)
    if 8 + bar + 8 > length:  # a narrow caption: the bar fills what there is
        bar = length - 16
    if bar < 8:  # too narrow for a bar: a plain strip
        return panel
    values = np.linspace(lo, hi, bar)
    panel[4:4 + 12, 8:8 + bar] = disparity_colours(values, lo, hi)[None, :, :]
    free = 0  # first column after the last label written
    for t in nice_ticks(lo, hi, max(2, min(8, bar // 50))):
        x = 8 + int(round((t - lo) / (hi - lo) * (bar - 1)))
        cv2.line(panel, (x, 16), (x, 19), _TEXT, 1)
        w = _text_width(_label(t), 0.4)
        left = min(max(x - w // 2, 0), length - w - 1)
        if left >= free:  # never over the previous label, nor cut at the left
            _text(panel, _label(t), left, 31, 0.4)
            free = left + w + 4
    if 8 + bar + 8 + title_w - 12 <= length:
        _text(panel, title, 8 + bar + 8, 15, 0.4)
    return panel


def _check_colour_bar(length, lo, hi, vertical: bool, title, footer) -> int:
    """The checks of :func:`draw_colour_bar`'s arguments; returns ``length`` as an int."""
    length = as_int(length, "length", lo=1)
    if vertical:
        check_canvas(length, _PANEL_W, "length", length)
    else:
        check_canvas(34, length, "length", length)
    lo, hi = as_real(lo, "lo"), as_real(hi, "hi")
    if not (hi > lo and math.isfinite(hi - lo)):
        raise InvalidArgumentError(
            f"`hi` must be greater than `lo` by a finite amount, got lo={lo!r}, hi={hi!r}",
            argument="hi")
    for name, text in (("title", title), ("footer", footer)):
        if not isinstance(text, str):
            raise InvalidTypeError(f"`{name}` must be a string, got {describe(text)}",
                                   argument=name)
    return length


# --------------------------------------------------------------------------------------
# Which matches get a line
# --------------------------------------------------------------------------------------


def spread_subset(points, n: int, height: int | None = None) -> np.ndarray:
    """Indices of at most ``n`` of ``points`` spread over the picture, for drawing lines.

    The rows are cut into ``n`` bands of equal height (at least 6 px); each band gives the
    point nearest to a target column that moves across the width from band to band (by the
    golden ratio), so that lines of a rectified pair, nearly horizontal, neither lie on one
    another nor start at one column. Deterministic; sorted by row. ``n <= 0`` gives none;
    ``height`` (>= 0, default the lowest point's row + 1) sets the bands.

    Raises
    ------
    InvalidTypeError
        ``n`` is not an integer, or ``height`` not a number.
    InvalidArgumentError
        ``height`` is negative or not finite, or ``points`` are not (x, y) points.

    Examples
    --------
    >>> import numpy as np
    >>> pts = np.float32([[x, y] for y in range(0, 100, 2) for x in range(0, 100, 10)])
    >>> idx = spread_subset(pts, 10, 100)
    >>> len(idx), len(set(np.floor(pts[idx, 1] / 10).tolist()))
    (10, 10)
    """
    pts = as_points(points, "points")
    n = as_int(n, "n")
    height = as_real(height, "height", lo=0.0, optional=True)
    if n <= 0 or len(pts) == 0:
        return np.zeros(0, np.int64)
    top = float(pts[:, 1].max()) + 1.0
    h = height if height is not None else top
    band = max(6.0, h / n)
    rows = np.floor(pts[:, 1] / band).astype(np.int64)
    x_lo, x_hi = float(pts[:, 0].min()), float(pts[:, 0].max())
    chosen = []
    golden = (math.sqrt(5.0) - 1.0) / 2.0
    for b in np.unique(rows):
        members = np.flatnonzero(rows == b)
        target = x_lo + ((b * golden) % 1.0) * (x_hi - x_lo)
        chosen.append(members[np.argmin(np.abs(pts[members, 0] - target))])
    chosen = np.asarray(chosen, np.int64)
    if len(chosen) > n:  # bands of 6 px on a short picture: keep n of them, evenly
        chosen = chosen[np.unique(np.linspace(0, len(chosen) - 1, n).astype(np.int64))]
    return chosen


# --------------------------------------------------------------------------------------
# The two pictures
# --------------------------------------------------------------------------------------


def _grey(image, name: str) -> np.ndarray:
    bgr = as_display_image(image, name)
    grey = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
    grey = (grey.astype(np.float32) * _DIM).astype(np.uint8)
    return cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)


#: Image area per match (px^2) below which the overview's dots lose their dark rim: dense
#: matches are visible as a colour field, and rims would hide the image under them.
DENSE_DOT_AREA = 150.0
#: ... and below this one the dots are single pixels (``match_stereo``'s defaults on
#: motorcycle: 13,563 matches, 27 px^2 each), so that the image stays visible under them.
DENSEST_DOT_AREA = 50.0


def _dots(img, pts: np.ndarray, colours: np.ndarray, radius: int, dx: int = 0,
          rim: bool = True) -> None:
    """Filled dots, with a dark rim (visible on light and dark backgrounds alike) when
    ``rim``; without it (dense matches) drawn crisp, not anti-aliased, so that each covers
    fewer pixels of the image (a radius-1 dot: 5 pixels instead of a blurred 3 x 3)."""
    line = cv2.LINE_AA if rim else cv2.LINE_8
    for (x, y), c in zip(np.rint(pts).astype(np.int64).tolist(), colours.tolist()):
        if rim:
            cv2.circle(img, (x + dx, y), radius + 1, (0, 0, 0), -1, cv2.LINE_AA)
        cv2.circle(img, (x + dx, y), radius, _colour(c), -1, line)


def _wrap(text: str, width: int, scale: float = _FONT_SCALE) -> list[str]:
    """``text`` cut at spaces into lines that fit ``width`` pixels (a word longer than the
    width gets a line of its own)."""
    lines, line = [], ""
    for word in text.split():
        trial = f"{line} {word}" if line else word
        if line and _text_width(trial, scale) > width:
            lines.append(line)
            line = word
        else:
            line = trial
    return lines + ([line] if line else [])


def _caption(width: int, paragraphs: list[str], lo: float, hi: float) -> np.ndarray:
    """Text (wrapped to ``width``) over a horizontal colour bar, on a dark strip. The text
    is left out when one of its words is wider than the strip (pictures a few pixels
    wide: every line would be cut), the bar when it does not fit (:func:`draw_colour_bar`).
    """
    lines = [ln for par in paragraphs for ln in _wrap(par, width - 12)]
    if any(_text_width(ln) > width - 12 for ln in lines):
        lines = []
    strip = np.full((len(lines) * _LINE_H + 8 if lines else 0, width, 3), _PANEL, np.uint8)
    for k, line in enumerate(lines):
        _text(strip, line, 6, 16 + k * _LINE_H)
    bar = draw_colour_bar(min(width, 420), lo, hi, vertical=False)
    block = np.full((bar.shape[0], width, 3), _PANEL, np.uint8)
    block[:, :bar.shape[1]] = bar
    return np.vstack([strip, block])


def draw_match_overview(left, right, kps_l, kps_r, matches, disparities=None, *,
                        correct=None, known=None, max_lines: int | None = None,
                        min_disparity=None, max_disparity=None) -> np.ndarray:
    """Both images side by side with every match as a dot and a spread-out subset as lines,
    coloured by disparity, over a caption with the counts and the colour scale. Dots have
    a dark rim unless the matches are dense (less than :data:`DENSE_DOT_AREA` px^2 of the
    left image each).

    Parameters
    ----------
    left, right : (H, W) or (H, W, 3|4) ndarray
        The two images; shown in grey, slightly dimmed.
    kps_l, kps_r : sequence of cv2.KeyPoint or (N, 2) float32 ndarray
        Keypoints of each image, (x, y).
    matches : sequence of cv2.DMatch or (M, 2) int ndarray
        ``queryIdx`` indexes ``kps_l``, ``trainIdx`` indexes ``kps_r``.
    disparities : (M,) array_like, optional
        Disparity of each match; default ``x_left - x_right``.
    correct, known : (M,) bool ndarray, optional
        Ground truth: matches known (``known``, default all) and not correct are marked
        with a magenta cross (:data:`WRONG`) on both images, and the caption gives the
        precision.
    max_lines : int, optional
        How many matches get a line (:func:`spread_subset`), >= 0; default one per 8 rows
        of the taller image, at most 100.
    min_disparity, max_disparity : float, optional
        The colour scale; default :func:`disparity_scale` of the disparities.

    Returns
    -------
    (max(Hl, Hr) + caption, Wl + Wr, 3) uint8 ndarray
        BGR picture; the caption is the counts (wrapped to the width, 18 px a line; left
        out when the picture is too narrow for a word of them) and a colour bar (34 px;
        a plain strip when too narrow for a bar: images of any size give a picture).

    Raises
    ------
    InvalidArgumentError, InvalidTypeError
        An image, the keypoints, the matches, the disparities, the flags, ``max_lines`` or
        a bound of the scale are not of the kinds above, or a match refers to a keypoint
        that does not exist.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.zeros((60, 80), np.uint8)
    >>> pts = np.float32([[30, 10], [40, 30]])
    >>> draw_match_overview(img, img, pts, pts - [5, 0], [[0, 0], [1, 1]]).shape[1:]
    (160, 3)
    """
    max_lines = as_int(max_lines, "max_lines", lo=0, optional=True)
    img_l, img_r = _grey(left, "left"), _grey(right, "right")
    kl, kr = drawable_points(kps_l, "kps_l"), drawable_points(kps_r, "kps_r")
    pairs = as_index_pairs(matches, len(kl), len(kr))
    if correct is not None:
        correct = as_flags(correct, "correct", len(pairs))
        known = np.ones(len(pairs), bool) if known is None else \
            as_flags(known, "known", len(pairs))
    ml, mr = kl[pairs[:, 0]], kr[pairs[:, 1]]
    d = (ml[:, 0] - mr[:, 0]).astype(np.float64) if disparities is None else \
        as_disparities(disparities, "disparities", len(pairs), "match", finite=False)
    lo, hi = disparity_scale(d, min_disparity, max_disparity)
    colours = disparity_colours(d, lo, hi)
    hl, wl = img_l.shape[:2]
    hr, wr = img_r.shape[:2]
    h = max(hl, hr)
    canvas = np.zeros((h, wl + wr, 3), np.uint8)
    canvas[:hl, :wl], canvas[:hr, wl:] = img_l, img_r
    if max_lines is None:
        max_lines = min(100, max(1, h // 8))
    lines = spread_subset(ml, max_lines, h) if len(pairs) else np.zeros(0, np.int64)
    for i in lines.tolist():
        a = tuple(np.rint(ml[i]).astype(int).tolist())
        b = (int(round(float(mr[i, 0]))) + wl, int(round(float(mr[i, 1]))))
        cv2.line(canvas, a, b, _colour(colours[i]), 1, cv2.LINE_AA)
    area = np.inf if len(pairs) == 0 else hl * wl / len(pairs)
    rim, radius = area >= DENSE_DOT_AREA, int(area >= DENSEST_DOT_AREA)
    _dots(canvas, ml, colours, radius, rim=rim)
    _dots(canvas, mr, colours, radius, dx=wl, rim=rim)
    for i in lines.tolist():  # the ends of the lines, larger
        for p, dx in ((ml[i], 0), (mr[i], wl)):
            x, y = int(round(float(p[0]))) + dx, int(round(float(p[1])))
            cv2.circle(canvas, (x, y), 3, _colour(colours[i]), 1, cv2.LINE_AA)
    text = [f"{len(pairs)} matches, coloured by disparity: {len(lines)} spread over the "
            f"rows drawn as lines, every match as a dot"]
    if correct is not None:
        wrong = known & ~correct
        for i in np.flatnonzero(wrong).tolist():
            for p, dx in ((ml[i], 0), (mr[i], wl)):
                x, y = int(round(float(p[0]))) + dx, int(round(float(p[1])))
                cv2.drawMarker(canvas, (x, y), WRONG, cv2.MARKER_TILTED_CROSS, 9, 2,
                               cv2.LINE_AA)
        n_known = int(known.sum())
        precision = f" (precision {correct[known].mean():.3f})" if n_known else ""
        text.append(f"correct within 1 px of the ground truth: {int((known & correct).sum())} "
                    f"of {n_known} with ground truth{precision}; magenta x: the "
                    f"{int(wrong.sum())} wrong")
    return np.vstack([canvas, _caption(wl + wr, text, lo, hi)])


def draw_keypoint_disparities(left, points, disparities, *, min_disparity=None,
                              max_disparity=None, radius: int = 2) -> np.ndarray:
    """The left image in grey with the matched keypoints coloured by disparity, and a
    colour bar in pixels beside it.

    Parameters
    ----------
    left : (H, W) or (H, W, 3|4) ndarray
        The left image.
    points : (N, 2) float32 ndarray or sequence of cv2.KeyPoint
        The matched left points, (x, y).
    disparities : (N,) array_like
        Their disparities in pixels, finite.
    min_disparity, max_disparity : float, optional
        The colour scale; default :func:`disparity_scale` of the disparities.
    radius : int
        Dot radius in pixels (each dot has a dark rim one pixel wider), in
        ``[0, MAX_DRAW_SIZE]`` (:data:`hopmatch.viz.draw.MAX_DRAW_SIZE`).

    Returns
    -------
    (H, W + 80, 3) uint8 ndarray
        BGR picture: the image, then the colour-bar panel (title "disparity (px)", round
        ticks, the number of points below).

    Raises
    ------
    InvalidArgumentError, InvalidTypeError
        The image, the points, the disparities, ``radius`` or a bound of the scale are not
        of the kinds above.

    Examples
    --------
    >>> import numpy as np
    >>> draw_keypoint_disparities(np.zeros((60, 80), np.uint8), [[5, 5]], [3.0]).shape
    (60, 160, 3)
    """
    radius = as_draw_size(radius, "radius")
    img = _grey(left, "left")
    pts = drawable_points(points, "points")
    d = as_disparities(disparities, "disparities", pts.shape[0])
    lo, hi = disparity_scale(d, min_disparity, max_disparity)
    order = np.argsort(d, kind="stable")  # the nearest (largest disparity) on top
    _dots(img, pts[order], disparity_colours(d[order], lo, hi), radius)
    panel = draw_colour_bar(img.shape[0], lo, hi, footer=f"{len(d)} pts")
    return np.hstack([img, panel])
