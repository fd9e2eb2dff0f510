"""Sub-pixel refinement of the disparity of every match, on the grey images (beyond the
paper; docs/method.md)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .._kernels import refine as _k
from .._threads import map_chunks
from ..errors import InvalidArgumentError

#: Half-side of the refinement windows (7 x 7 pixels of the grey images).
REFINE_RADIUS = 3
#: Spacing of the three ZNCC samples of each parabola fit, in pixels.
REFINE_STEP = 0.5
#: Levels of the refinement: the sample spacing halves from one to the next.
REFINE_LEVELS = 2
#: Moves below this (px) end a level's iterations.
REFINE_TOL = 0.02
#: Most parabola moves per match, all levels together.
REFINE_ITERATIONS = 16
#: Farthest a refined position may lie from the one it started from, in pixels.
REFINE_MAX_SHIFT = 1.5


class Refinement(NamedTuple):
    """What :func:`refine_disparities` found, one entry per match.

    Attributes
    ----------
    x : (M,) float64 ndarray
        Refined right x (the given one where not ``ok``).
    ok : (M,) bool ndarray
        Whether the refinement converged within ``REFINE_MAX_SHIFT`` of the start.
    peak : (M,) float64 ndarray
        ZNCC at the peak.
    curvature : (M,) float64 ndarray
        Minus the second derivative of the ZNCC at the peak, per px**2: how sharply the
        disparity is determined (NaN where no parabola was fitted).
    """

    x: np.ndarray
    ok: np.ndarray
    peak: np.ndarray
    curvature: np.ndarray


def as_float_image(image: np.ndarray) -> np.ndarray:
    """A C-contiguous float32 view or copy of a 2-D image (the one dtype the kernel is
    compiled for)."""
    return np.ascontiguousarray(image, dtype=np.float32)


def refine_disparities(gray_l, gray_r, left, xr, yr, *, radius: int = REFINE_RADIUS,
                       step: float = REFINE_STEP, levels: int = REFINE_LEVELS,
                       iterations: int = REFINE_ITERATIONS,
                       tol: float = REFINE_TOL,
                       max_shift: float = REFINE_MAX_SHIFT,
                       threads: int | None = None) -> Refinement:
    """Refine the right x of each match to the peak of the ZNCC of the grey windows.

    Parameters
    ----------
    gray_l, gray_r : (H, W) ndarray
        The grey images (any real dtype; converted to float32).
    left : (M, 2) ndarray
        Left points (x, y), sub-pixel; their windows are sampled bilinearly.
    xr, yr : (M,) ndarray
        Starting right x, and the right row of each match (``yl`` minus the pair's
        vertical offset there); ``yr`` is not refined.
    radius, step, levels, iterations, tol, max_shift
        See :func:`hopmatch._kernels.refine.refine_rows` (window half-side, first sample
        spacing, number of spacings, most moves, convergence threshold, largest shift).
    threads : int, optional
        Refine in up to this many threads (None: :func:`hopmatch._threads.current_threads`);
        each match is refined on its own, so results are bit-identical for any count.

    Returns
    -------
    Refinement
        The refined x and what the fit says of it. A match is refined only where both
        windows lie inside the images and the fit converges within ``max_shift``.

    Notes
    -----
    The ZNCC is invariant to gain and offset, so a pair with different exposures is
    refined as well as a pair without. The fit is re-centred until its three samples are
    symmetric about the peak, which removes the pull towards whole pixels of a single fit
    at integer shifts (tested against a NumPy reference on synthetic sub-pixel shifts).
    """
    left = np.ascontiguousarray(left, dtype=np.float64).reshape(-1, 2)
    xr = np.ascontiguousarray(xr, dtype=np.float64).reshape(-1)
    yr = np.ascontiguousarray(yr, dtype=np.float64).reshape(-1)
    if not (len(left) == len(xr) == len(yr)):
        raise InvalidArgumentError(f"`left`, `xr` and `yr` must have one row per match, got "
                         f"{len(left)}, {len(xr)} and {len(yr)}")
    img_l, img_r = as_float_image(gray_l), as_float_image(gray_r)
    x, ok, peak, curv = map_chunks(
        lambda ls, xs, ys: _k.refine_rows(img_l, img_r, ls, xs, ys, int(radius), float(step),
                                          int(levels), int(iterations), float(tol),
                                          float(max_shift)),
        (left, xr, yr), threads)
    return Refinement(x, ok, peak, curv)
