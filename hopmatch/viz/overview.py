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

import cv2
import numpy as np

from .._validate import as_points
from ..errors import InvalidArgumentError
from .draw import (
    as_disparities,
    as_display_image,
    as_index_pairs,
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


def nice_ticks(lo: float, hi: float, max_ticks: int = 6) -> list[float]:
    """Round tick values in ``[lo, hi]`` (steps of 1, 2 or 5 x 10^k), at most
    ``max_ticks`` of them, ``lo`` and ``hi`` included when they are round.

    Examples
    --------
    >>> nice_ticks(0, 66)
    [0.0, 20.0, 40.0, 60.0]
    >>> nice_ticks(16, 111, 4)
    [50.0, 100.0]
    """
    if not (np.isfinite(lo) and np.isfinite(hi)) or hi <= lo:
        return [float(lo)]
    max_ticks = max(2, int(max_ticks))
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

    Examples
    --------
    >>> disparity_scale([3.0, 12.5, 61.0])
    (0.0, 65.0)
    >>> disparity_scale([3.0, 12.5], 0, 64)
    (0.0, 64.0)
    """
    d = np.asarray(disparities, np.float64).reshape(-1)
    d = d[np.isfinite(d)]
    lo = float(min_disparity) if min_disparity is not None else (
        min(0.0, math.floor(float(d.min()))) if d.size else 0.0)
    if max_disparity is not None:
        hi = float(max_disparity)
    elif d.size:
        top = float(np.percentile(d, 99.5))
        if top > lo:
            unit = 10.0 ** math.floor(math.log10(top - lo)) / 2.0
            hi = math.ceil((top - lo) / unit - 1e-9) * unit + lo
        else:
            hi = lo + 1.0
    else:
        hi = lo + 1.0
    if not (np.isfinite(lo) and np.isfinite(hi)):
        raise InvalidArgumentError(f"the disparity scale must be finite, got [{lo}, {hi}]")
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
    ``(34, length, 3)``, ``lo`` at the left, the title after the bar.

    Examples
    --------
    >>> draw_colour_bar(200, 0, 66).shape, draw_colour_bar(300, 0, 66, vertical=False).shape
    ((200, 80, 3), (34, 300, 3))
    """
    length = int(length)
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
        for t in nice_ticks(lo, hi, n_ticks):
            y = top + int(round((hi - t) / (hi - lo) * (bottom - top - 1)))
            cv2.line(panel, (6 + _BAR_W, y), (6 + _BAR_W + 4, y), _TEXT, 1)
            _text(panel, _label(t), 6 + _BAR_W + 7, y + 4, 0.4)
        return panel
    panel = np.full((34, length, 3), _PANEL, np.uint8)
    title_w = _text_width(title, 0.4) + 12
    bar = max(40, length - title_w - 16)
    values = np.linspace(lo, hi, bar)
    panel[4:4 + 12, 8:8 + bar] = disparity_colours(values, lo, hi)[None, :, :]
    for t in nice_ticks(lo, hi, max(2, min(8, bar // 50))):
        x = 8 + int(round((t - lo) / (hi - lo) * (bar - 1)))
        cv2.line(panel, (x, 16), (x, 19), _TEXT, 1)
        w = _text_width(_label(t), 0.4)
        _text(panel, _label(t), min(max(x - w // 2, 0), length - w - 1), 31, 0.4)
    if 8 + bar + 8 + title_w - 12 <= length:
        _text(panel, title, 8 + bar + 8, 15, 0.4)
    return panel


# --------------------------------------------------------------------------------------
# Which matches get a line
# --------------------------------------------------------------------------------------


def spread_subset(points, n: int, height: int | None = None) -> np.ndarray:
    """Indices of at most ``n`` of ``points`` spread over the picture, for drawing lines.

    The rows are cut into ``n`` bands of equal height (at least 6 px); each band gives the
    point nearest to a target column that moves across the width from band to band (by the
    golden ratio), so that lines of a rectified pair, nearly horizontal, neither lie on one
    another nor start at one column. Deterministic; sorted by row.

    Examples
    --------
    >>> import numpy as np
    >>> pts = np.float32([[x, y] for y in range(0, 100, 2) for x in range(0, 100, 10)])
    >>> idx = spread_subset(pts, 10, 100)
    >>> len(idx), len(set(np.floor(pts[idx, 1] / 10).tolist()))
    (10, 10)
    """
    pts = as_points(points, "points")
    n = int(n)
    if n <= 0 or len(pts) == 0:
        return np.zeros(0, np.int64)
    top = float(pts[:, 1].max()) + 1.0
    h = float(height) if height is not None else top
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
    """Text (wrapped to ``width``) over a horizontal colour bar, on a dark strip."""
    lines = [ln for par in paragraphs for ln in _wrap(par, width - 12)]
    strip = np.full((len(lines) * _LINE_H + 8, width, 3), _PANEL, np.uint8)
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
        How many matches get a line (:func:`spread_subset`); default one per 8 rows of the
        taller image, at most 100.
    min_disparity, max_disparity : float, optional
        The colour scale; default :func:`disparity_scale` of the disparities.

    Returns
    -------
    (max(Hl, Hr) + caption, Wl + Wr, 3) uint8 ndarray
        BGR picture; the caption is the counts (wrapped to the width, 18 px a line) and a
        colour bar (34 px).

    Examples
    --------
    >>> import numpy as np
    >>> img = np.zeros((60, 80), np.uint8)
    >>> pts = np.float32([[30, 10], [40, 30]])
    >>> draw_match_overview(img, img, pts, pts - [5, 0], [[0, 0], [1, 1]]).shape[1:]
    (160, 3)
    """
    img_l, img_r = _grey(left, "left"), _grey(right, "right")
    kl, kr = drawable_points(kps_l, "kps_l"), drawable_points(kps_r, "kps_r")
    pairs = as_index_pairs(matches, len(kl), len(kr))
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
    rim = len(pairs) == 0 or hl * wl / len(pairs) >= DENSE_DOT_AREA
    _dots(canvas, ml, colours, 1, rim=rim)
    _dots(canvas, mr, colours, 1, dx=wl, rim=rim)
    for i in lines.tolist():  # the ends of the lines, larger
        for p, dx in ((ml[i], 0), (mr[i], wl)):
            x, y = int(round(float(p[0]))) + dx, int(round(float(p[1])))
            cv2.circle(canvas, (x, y), 3, _colour(colours[i]), 1, cv2.LINE_AA)
    text = [f"{len(pairs)} matches, coloured by disparity: {len(lines)} spread over the "
            f"rows drawn as lines, every match as a dot"]
    if correct is not None:
        correct = np.asarray(correct, bool).reshape(-1)
        known = np.ones(len(pairs), bool) if known is None else \
            np.asarray(known, bool).reshape(-1)
        if correct.shape != (len(pairs),) or known.shape != (len(pairs),):
            raise InvalidArgumentError(
                f"`correct` and `known` must have one flag per match ({len(pairs)})")
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
        Dot radius in pixels (each dot has a dark rim one pixel wider).

    Returns
    -------
    (H, W + 80, 3) uint8 ndarray
        BGR picture: the image, then the colour-bar panel (title "disparity (px)", round
        ticks, the number of points below).

    Examples
    --------
    >>> import numpy as np
    >>> draw_keypoint_disparities(np.zeros((60, 80), np.uint8), [[5, 5]], [3.0]).shape
    (60, 160, 3)
    """
    img = _grey(left, "left")
    pts = drawable_points(points, "points")
    d = as_disparities(disparities, "disparities", pts.shape[0])
    lo, hi = disparity_scale(d, min_disparity, max_disparity)
    order = np.argsort(d, kind="stable")  # the nearest (largest disparity) on top
    _dots(img, pts[order], disparity_colours(d[order], lo, hi), int(radius))
    panel = draw_colour_bar(img.shape[0], lo, hi, footer=f"{len(d)} pts")
    return np.hstack([img, panel])
