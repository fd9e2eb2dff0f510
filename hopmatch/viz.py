"""Pictures of keypoints, matches and sparse disparities, and atomic file writers.

Drawing uses OpenCV only (``cv2.drawMatches``, ``cv2.drawKeypoints``,
``cv2.applyColorMap``); the plots (:func:`plot_energy`, :func:`plot_precision_vs_correct`,
:func:`plot_error_histogram`) need matplotlib, imported when called
(``pip install hopmatch[all]``), and never touch pyplot's global state. Every function returns a uint8 BGR image, as
``cv2.imwrite`` expects; inputs may be grey or BGR(A), 8-bit, 16-bit or float (other depths
are stretched to 0..255 for display).

Files are written atomically by :func:`write_image_atomic` and :func:`write_text_atomic`:
the data goes to a temporary name in the destination folder and is renamed
(``os.replace``) when complete, so a failed write never leaves a partial file.
"""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from pathlib import Path

import cv2
import numpy as np

from ._files import (  # noqa: F401 (re-exported: hopmatch.viz.write_text_atomic...)
    encode_image,
    write_bytes_atomic,
    write_image_atomic,
    write_temp,
    write_text_atomic,
)
from ._validate import as_gray_image, as_match_indices, as_points, describe
from .errors import InvalidArgumentError, InvalidTypeError

__all__ = [
    "draw_disparity",
    "draw_keypoints",
    "draw_keypoints_on_gradient",
    "draw_labelled_matches",
    "draw_matches",
    "plot_energy",
    "plot_error_histogram",
    "plot_precision_vs_correct",
    "write_image_atomic",
    "write_text_atomic",
]

#: BGR colours of correct, wrong and unknown matches.
GREEN = (0, 200, 0)
RED = (0, 0, 255)
GREY = (160, 160, 160)


# --------------------------------------------------------------------------------------
# Input helpers
# --------------------------------------------------------------------------------------


def _as_display(image, name: str) -> np.ndarray:
    """``image`` as a uint8 BGR array for drawing (grey becomes 3 equal channels)."""
    if isinstance(image, np.ndarray) and image.ndim == 3 and image.shape[2] in (3, 4) \
            and image.dtype == np.uint8:
        bgr = image[:, :, :3]
        if bgr.shape[0] == 0 or bgr.shape[1] == 0:
            raise InvalidArgumentError(f"`{name}` must not be empty, got shape {image.shape}")
        return np.ascontiguousarray(bgr)
    gray = as_gray_image(image, name)  # checks type, dtype, shape, finiteness
    if gray.dtype != np.uint8:
        gray = cv2.normalize(gray.astype(np.float32), None, 0, 255, cv2.NORM_MINMAX)
        gray = gray.astype(np.uint8)
    return cv2.cvtColor(gray, cv2.COLOR_GRAY2BGR)


def _as_keypoints(keypoints, name: str) -> list:
    """A list of ``cv2.KeyPoint`` from keypoints or an ``(N, 2)`` (x, y) array."""
    if isinstance(keypoints, Sequence) and not isinstance(keypoints, (str, bytes)) \
            and all(isinstance(kp, cv2.KeyPoint) for kp in keypoints):
        return list(keypoints)
    pts = as_points(keypoints, name)
    return [cv2.KeyPoint(float(x), float(y), 5.0) for x, y in pts.tolist()]


def _as_dmatches(matches, n_left: int, n_right: int) -> list:
    """A list of ``cv2.DMatch`` from DMatches or an ``(M, 2)`` (left index, right index) array."""
    if isinstance(matches, Sequence) and not isinstance(matches, (str, bytes)) \
            and all(isinstance(m, cv2.DMatch) for m in matches):
        as_match_indices(matches, n_query=n_left, n_train=n_right)
        return list(matches)
    if not isinstance(matches, np.ndarray):
        try:
            matches = np.asarray(matches)
        except (TypeError, ValueError):
            pass
    pairs = as_match_indices(matches, n_query=n_left, n_train=n_right)
    return [cv2.DMatch(int(q), int(t), 0.0) for q, t in pairs.tolist()]


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

    Examples
    --------
    >>> import numpy as np
    >>> img = np.zeros((40, 50), np.uint8)
    >>> pts = np.float32([[10, 10], [30, 20]])
    >>> draw_matches(img, img, pts, pts, np.array([[0, 0], [1, 1]]), np.array([True, False])).shape
    (40, 100, 3)
    """
    img_l, img_r = _as_display(left, "left"), _as_display(right, "right")
    kl, kr = _as_keypoints(kps_l, "kps_l"), _as_keypoints(kps_r, "kps_r")
    dm = _as_dmatches(matches, len(kl), len(kr))
    single = 0 if draw_single_points else cv2.DrawMatchesFlags_NOT_DRAW_SINGLE_POINTS
    if correct is None:
        return cv2.drawMatches(img_l, kl, img_r, kr, dm, None, flags=single)
    correct = _flags(correct, "correct", len(dm))
    known = np.ones(len(dm), bool) if known is None else _flags(known, "known", len(dm))
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


def _flags(values, name: str, n: int) -> np.ndarray:
    values = np.asarray(values)
    if values.dtype != np.bool_:
        raise InvalidTypeError(f"`{name}` must be a bool array, got dtype {values.dtype}")
    if values.shape != (n,):
        raise InvalidArgumentError(
            f"`{name}` must have shape ({n},), one flag per match, got {values.shape}"
        )
    return values


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
        Their disparities in pixels.
    max_disparity : float, optional
        Disparity drawn red (the top of the colour map); default: the largest given.
        ``min_disparity`` (default 0) is drawn dark blue; values outside are clipped.
    radius : int
        Dot radius in pixels.

    Returns
    -------
    (H, W, 3) uint8 ndarray
        BGR picture.

    Examples
    --------
    >>> import numpy as np
    >>> draw_disparity(np.zeros((30, 40), np.uint8), np.float32([[5, 5]]), [3.0]).shape
    (30, 40, 3)
    """
    gray = _as_display(left, "left")
    gray = cv2.cvtColor(cv2.cvtColor(gray, cv2.COLOR_BGR2GRAY), cv2.COLOR_GRAY2BGR)
    pts = as_points(points, "points")
    disp = np.asarray(disparities, dtype=np.float64).reshape(-1)
    if disp.shape[0] != pts.shape[0]:
        raise InvalidArgumentError(
            f"`disparities` must have one value per point ({pts.shape[0]}), got {disp.shape[0]}"
        )
    if not np.isfinite(disp).all():
        raise InvalidArgumentError("`disparities` contains NaN or infinite values")
    if len(disp) == 0:
        return gray
    lo = float(min_disparity)
    hi = float(max_disparity) if max_disparity is not None else float(disp.max())
    if not np.isfinite(hi):
        raise InvalidArgumentError(f"`max_disparity` must be finite, got {max_disparity}")
    scale = 255.0 / (hi - lo) if hi > lo else 0.0
    levels = np.clip((disp - lo) * scale, 0, 255).astype(np.uint8).reshape(-1, 1)
    colours = cv2.applyColorMap(levels, cv2.COLORMAP_TURBO).reshape(-1, 3).tolist()
    for (x, y), c in zip(np.rint(pts).astype(int).tolist(), colours):
        cv2.circle(gray, (x, y), int(radius), tuple(int(v) for v in c), -1, cv2.LINE_AA)
    return gray


def draw_keypoints(image, keypoints, color=(0, 255, 0)) -> np.ndarray:
    """Draw keypoints with ``cv2.drawKeypoints`` (circles of the keypoint size).

    Parameters
    ----------
    image : (H, W) or (H, W, 3|4) ndarray
    keypoints : sequence of cv2.KeyPoint or (N, 2) float32 ndarray
        (x, y).
    color : (B, G, R)

    Returns
    -------
    (H, W, 3) uint8 ndarray
    """
    img = _as_display(image, "image")
    kps = _as_keypoints(keypoints, "keypoints")
    return cv2.drawKeypoints(img, kps, None, color=color,
                             flags=cv2.DrawMatchesFlags_DRAW_RICH_KEYPOINTS)


def render_energy(trace, fmt: str = "png") -> bytes:
    """The energy plot of :func:`plot_energy` as encoded bytes (``fmt``: png, pdf, svg...)."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise ImportError(
            "plotting the energy needs matplotlib: pip install hopmatch[all] "
            "(or pip install matplotlib)"
        ) from None
    trace = np.asarray(trace, dtype=np.float64).reshape(-1)
    fig = Figure(figsize=(6.4, 3.6), dpi=100)
    FigureCanvasAgg(fig)  # no pyplot: the global backend is left alone
    ax = fig.add_subplot(1, 1, 1)
    if trace.size:
        ax.plot(np.arange(1, trace.size + 1), trace, lw=1.0, color="tab:blue")
    else:
        ax.text(0.5, 0.5, "no energy recorded", ha="center", va="center",
                transform=ax.transAxes)
    ax.set_xlabel("iteration (left point visited)")
    ax.set_ylabel("energy (eq. 11)")
    ax.set_title("Hopfield network energy")
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt)
    return buf.getvalue()


def plot_energy(trace, path) -> Path:
    """Plot the network energy after each iteration and save it (atomically) to ``path``.

    Parameters
    ----------
    trace : (T,) float ndarray
        ``NetworkResult.energy_trace`` (run with ``record_energy=True``).
    path : str or os.PathLike
        Output file; its suffix picks the format (``.png``, ``.pdf``, ``.svg``).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ImportError
        matplotlib is not installed (``pip install hopmatch[all]``).
    """
    path = Path(path)
    fmt = path.suffix.lstrip(".").lower() or "png"
    write_bytes_atomic(path, render_energy(trace, fmt))
    return path


def _figure(size):
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise ImportError(
            "plotting needs matplotlib: pip install hopmatch[all] (or pip install matplotlib)"
        ) from None
    fig = Figure(figsize=size, dpi=100)
    FigureCanvasAgg(fig)  # no pyplot: the global backend is left alone
    return fig


def _encode_figure(fig, fmt: str) -> bytes:
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt, bbox_inches="tight")  # keeps a legend outside the axes
    return buf.getvalue()


def _format_of(path: Path) -> str:
    return path.suffix.lstrip(".").lower() or "png"


_MARKERS = "os^Dv<>pP*Xh"


def render_precision_vs_correct(rows, threshold: float = 1.0, fmt: str = "png",
                                title: str | None = None) -> bytes:
    """The plot of :func:`plot_precision_vs_correct` as encoded bytes."""
    key_c, key_p = f"correct@{threshold:g}", f"precision@{threshold:g}"
    rows = list(rows)
    for row in rows:
        if not isinstance(row, Mapping) or not {"method", key_c, key_p} <= set(row):
            raise InvalidArgumentError(
                f"each row must be a mapping with 'method', {key_c!r} and {key_p!r} (as "
                f"hopmatch.compare.compare returns), got {describe(row)}"
            )
    fig = _figure((7.0, 4.6))
    ax = fig.add_subplot(1, 1, 1)
    methods = list(dict.fromkeys(row["method"] for row in rows))
    cmap = _tab_colours(len(methods))
    for k, method in enumerate(methods):
        pts = [(row[key_c], row[key_p]) for row in rows
               if row["method"] == method and not np.isnan(row[key_p])]
        if not pts:
            continue
        x, y = zip(*pts)
        ax.scatter(np.maximum(x, 1), y, label=method, color=cmap[k],
                   marker=_MARKERS[k % len(_MARKERS)], s=36, alpha=0.85,
                   edgecolors="black" if method.startswith("hopmatch") else "none",
                   linewidths=0.6)
    if not rows:
        ax.text(0.5, 0.5, "no results", ha="center", va="center", transform=ax.transAxes)
    ax.set_xscale("log")
    ax.set_ylim(0.0, 1.02)
    ax.set_xlabel(f"correct matches (within {threshold:g} px; log scale)")
    ax.set_ylabel(f"precision@{threshold:g}")
    n_scenes = len({row.get("scene") for row in rows})
    ax.set_title(title or f"Precision@{threshold:g} against correct@{threshold:g} "
                          f"({n_scenes} scene{'s' if n_scenes != 1 else ''})", fontsize=11)
    ax.grid(True, alpha=0.3, which="both")
    if methods:
        ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=8, frameon=False)
    return _encode_figure(fig, fmt)


def _tab_colours(n: int) -> list:
    from matplotlib import colormaps

    cmap = colormaps["tab20" if n > 10 else "tab10"]
    return [cmap(i % cmap.N) for i in range(n)]


def plot_precision_vs_correct(rows, path, threshold: float = 1.0,
                              title: str | None = None) -> Path:
    """Scatter precision against the number of correct matches, one point per method and
    scene, and save it (atomically) to ``path``.

    Parameters
    ----------
    rows : sequence of mapping
        Rows of :func:`hopmatch.compare.compare` (or any mappings with ``method``,
        ``correct@t`` and ``precision@t``; ``scene`` is used for the title).
    path : str or os.PathLike
        Output file; its suffix picks the format (``.png``, ``.pdf``, ``.svg``).
    threshold : float
        The tolerance ``t`` of the columns plotted.
    title : str, optional

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ImportError
        matplotlib is not installed (``pip install hopmatch[all]``).
    """
    path = Path(path)
    write_bytes_atomic(path, render_precision_vs_correct(rows, threshold, _format_of(path),
                                                         title))
    return path


#: Default bin edges of the error histogram, in pixels (|error|).
ERROR_BINS = (0.0, 0.5, 1.0, 2.0, 4.0, 8.0, np.inf)


def render_error_histogram(errors_by_method, bins=ERROR_BINS, fmt: str = "png",
                           title: str | None = None) -> bytes:
    """The plot of :func:`plot_error_histogram` as encoded bytes."""
    from .evaluate import error_histogram

    if not isinstance(errors_by_method, Mapping):
        raise InvalidTypeError(
            "`errors_by_method` must be a mapping {method name: errors}, got "
            f"{describe(errors_by_method)}"
        )
    hists = {}
    for name, err in errors_by_method.items():
        counts, edges = error_histogram(err, bins=bins)
        hists[name] = counts / max(int(counts.sum()), 1)
    fig = _figure((8.0, 4.2))
    ax = fig.add_subplot(1, 1, 1)
    if hists:
        labels = [f"{a:g}–{b:g}" if np.isfinite(b) else f"≥ {a:g}"
                  for a, b in zip(edges[:-1], edges[1:])]
        n = len(hists)
        width = 0.8 / n
        colours = _tab_colours(n)
        x = np.arange(len(labels))
        for k, (name, frac) in enumerate(hists.items()):
            ax.bar(x - 0.4 + (k + 0.5) * width, frac, width, label=name, color=colours[k])
        ax.set_xticks(x, labels)
        ax.legend(loc="upper right", fontsize=8, ncol=2 if n > 6 else 1, frameon=False)
    else:
        ax.text(0.5, 0.5, "no errors", ha="center", va="center", transform=ax.transAxes)
    ax.set_xlabel("|disparity error| (px)")
    ax.set_ylabel("fraction of scored matches")
    ax.set_title(title or "Disparity error histogram")
    ax.grid(True, axis="y", alpha=0.3)
    return _encode_figure(fig, fmt)


def plot_error_histogram(errors_by_method, path, bins=ERROR_BINS,
                         title: str | None = None) -> Path:
    """Histogram of absolute disparity errors, one group of bars per bin and one bar per
    method (fraction of that method's scored matches), saved (atomically) to ``path``.

    Parameters
    ----------
    errors_by_method : mapping of str to (N,) array_like
        Signed or absolute disparity errors (e.g. ``MatchScore.errors``) per method.
    path : str or os.PathLike
        Output file; its suffix picks the format.
    bins : (B + 1,) sequence of float
        Bin edges on ``|error|`` (see :func:`hopmatch.evaluate.error_histogram`).
    title : str, optional

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ImportError
        matplotlib is not installed (``pip install hopmatch[all]``).
    """
    path = Path(path)
    write_bytes_atomic(path, render_error_histogram(errors_by_method, bins, _format_of(path),
                                                    title))
    return path


# --------------------------------------------------------------------------------------
# Atomic writers
# --------------------------------------------------------------------------------------


# --------------------------------------------------------------------------------------
# The paper's figures: 5 (points over the gradient image) and 7 (numbered matches)
# --------------------------------------------------------------------------------------

#: BGR colours of the paper's figures: points, labels, the labels' dark outline.
FIGURE_POINT = (0, 0, 255)
FIGURE_LABEL = (0, 255, 255)
FIGURE_OUTLINE = (0, 0, 0)


def _gradient_display(image, detector) -> np.ndarray:
    """The Canny-Deriche gradient magnitude of ``image`` as a uint8 BGR picture.

    Stretched so that the 99.5th percentile of G is white: a few very strong edges would
    otherwise leave everything else black. The scale never goes below 1/1000 of the
    image's grey-level range, so the recursive filter's round-off on flat regions (G about
    1e-9) stays black.
    """
    from .feature.detector import DericheMoravecDetector
    from .feature.gradient import deriche_gradient

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
    ``omega``), stretched so that its 99.5th percentile is white, with each point drawn
    as a cross (``cv2.drawMarker``).

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
        Colour of the crosses (default red).
    marker_size : int
        Side of the crosses in pixels.

    Returns
    -------
    (H, W, 3) uint8 ndarray
        BGR picture.

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
    picture = _gradient_display(image, detector)
    pts = as_points(keypoints, "keypoints")
    colour = tuple(int(c) for c in color)
    for x, y in np.rint(pts).astype(np.int64).tolist():
        cv2.drawMarker(picture, (x, y), colour, cv2.MARKER_CROSS, int(marker_size), 1,
                       cv2.LINE_8)
    return picture


def _label(picture, text: str, x: int, y: int, font_scale: float, colour) -> None:
    """``text`` just up and right of (x, y), outlined, kept inside the picture."""
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
                          label_color=FIGURE_LABEL, gap: int = 0) -> np.ndarray:
    """The paper's Figure 7: both images side by side, each match numbered on both.

    Match ``n`` (counting from 1, in the order given) is drawn as a cross at its left
    point and at its right point, each labelled ``n`` with ``cv2.putText``, so that a pair
    can be checked by eye without lines crossing the picture.

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
        Scale of ``cv2.FONT_HERSHEY_SIMPLEX`` for the numbers (0.35: about 7 px high).
    color, label_color : (B, G, R)
        Colours of the crosses (default red) and of the numbers (default yellow, outlined
        in black).
    gap : int
        Pixels of black between the two images.

    Returns
    -------
    (max(Hl, Hr), Wl + gap + Wr, 3) uint8 ndarray
        BGR picture.

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
    img_l, img_r = _as_display(left, "left"), _as_display(right, "right")
    kl = as_points(kps_l, "kps_l")
    kr = as_points(kps_r, "kps_r")
    dm = _as_dmatches(matches, len(kl), len(kr))
    gap = int(gap)
    if gap < 0:
        raise InvalidArgumentError(f"`gap` must be >= 0 pixels, got {gap}")
    if not (np.isfinite(font_scale) and font_scale > 0):
        raise InvalidArgumentError(f"`font_scale` must be > 0, got {font_scale}")
    hl, wl = img_l.shape[:2]
    hr, wr = img_r.shape[:2]
    picture = np.zeros((max(hl, hr), wl + gap + wr, 3), np.uint8)
    picture[:hl, :wl] = img_l
    picture[:hr, wl + gap:] = img_r
    offset = wl + gap
    colour = tuple(int(c) for c in color)
    text_colour = tuple(int(c) for c in label_color)
    ends = []
    for m in dm:
        xl, yl = (int(v) for v in np.rint(kl[m.queryIdx]))
        xr, yr = (int(v) for v in np.rint(kr[m.trainIdx]))
        ends.append(((xl, yl), (xr + offset, yr)))
    if draw_lines:
        for a, b in ends:
            cv2.line(picture, a, b, colour, 1, cv2.LINE_8)
    # all numbers after all crosses: a cross never hides a number
    for a, b in ends:
        for p in (a, b):
            cv2.drawMarker(picture, p, colour, cv2.MARKER_CROSS, 7, 1, cv2.LINE_8)
    for n, (a, b) in enumerate(ends, start=1):
        _label(picture, str(n), a[0], a[1], font_scale, text_colour)
        _label(picture, str(n), b[0], b[1], font_scale, text_colour)
    return picture
