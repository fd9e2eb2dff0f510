"""Sub-pixel refinement of the disparity of every match, on the grey images (beyond the
paper; docs/method.md)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .._kernels import refine as _k
from .._threads import map_chunks, row_order
from ..errors import InvalidArgumentError
from .neighbourhood import local_planes

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
#: Farthest a refined position may lie from the one it started from, in pixels (in each
#: of the two stages).
REFINE_MAX_SHIFT = 1.5
#: Half-side of the second stage's windows (11 x 11), ...
SLANT_RADIUS = 5
#: ... down to this half-side near the image borders.
SLANT_MIN_RADIUS = 3
#: First sample spacing and levels of the second stage (it starts at the first's peak).
SLANT_STEP = 0.25
SLANT_LEVELS = 1
SLANT_TOL = 0.1
#: Cubic (Keys) interpolation in the second stage (False, the default: linear, as the
#: first; cubic gains 0.001-0.005 px of median error for about 30 ms per motorcycle pair:
#: docs/parameters.md, "The refinement's slanted second stage").
SLANT_CUBIC = False
SLANT_PASSES = 1
#: Standard deviation (px) of the Gaussian weights of the second stage's windows.
SLANT_SIGMA = 3.0
#: Half-side (px) of the square around a match whose matches give its disparity plane.
SLANT_HALF_WINDOW = 15.0
#: Neighbours farther than this (px of disparity) from their median are left out of the
#: plane, and fewer than :data:`SLANT_PLANE_MIN` inliers leave the window square.
SLANT_PLANE_INLIER = 2.0
SLANT_PLANE_MIN = 4
#: Largest |gradient| (px of disparity per px) the second stage's windows follow.
SLANT_GRADIENT_LIMIT = 0.5


class Refinement(NamedTuple):
    """What :func:`refine_disparities` found, one entry per match.

    Attributes
    ----------
    x : (M,) float64 ndarray
        Refined right x (the given one where not ``ok``).
    ok : (M,) bool ndarray
        Whether the refinement converged within ``REFINE_MAX_SHIFT`` of the start.
    peak : (M,) float64 ndarray
        ZNCC at the peak (of the first stage, the 7 x 7 square windows).
    curvature : (M,) float64 ndarray
        Minus the second derivative of the ZNCC at the peak, per px**2: how sharply the
        disparity is determined (NaN where no parabola was fitted; first stage, the scale
        :func:`hopmatch.matching.confidence.confidence_distances` was fitted on).
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
                       max_shift: float = REFINE_MAX_SHIFT, slanted: bool = True,
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
        See :func:`hopmatch._kernels.refine.refine_rows` (window half-side of the first
        stage, first sample spacing, number of spacings, most moves, convergence
        threshold, largest shift; most moves, threshold and largest shift in both stages).
    slanted : bool
        Run the second stage (below); False: the first stage only.
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
    Two stages. The first refines from ``xr`` with square ``(2 radius + 1)**2`` windows,
    uniform weights and linear interpolation. The second starts from the first's x and
    refines (one level of :data:`SLANT_STEP` spacing) with :data:`SLANT_RADIUS` windows
    (down to :data:`SLANT_MIN_RADIUS` at the borders), Gaussian weights of
    :data:`SLANT_SIGMA`, :data:`SLANT_CUBIC` interpolation (linear by default), and a right
    window sheared and stretched
    along the local disparity plane: the least-squares plane through the first stage's
    disparities of the matches within
    :data:`SLANT_HALF_WINDOW` px (:func:`hopmatch._kernels.guided.neighbour_planes`), its
    gradient clipped to :data:`SLANT_GRADIENT_LIMIT`. A match keeps the second stage's x
    where it converges, else the first's; ``ok`` where either converged.

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

    def stage(start, gx, gy, rad, min_rad, sigma, cubic, h, n_levels, eps):
        return map_chunks(
            lambda ls, xs, ys, gxs, gys: _k.refine_rows(
                img_l, img_r, ls, xs, ys, gxs, gys, int(rad), int(min_rad), float(sigma),
                bool(cubic), float(h), int(n_levels), int(iterations), float(eps),
                float(max_shift)),
            (left, start, yr, gx, gy), threads, order=order)

    order = row_order(left[:, 1])  # nearby windows one after another (cache locality)
    flat = np.zeros(len(xr))
    x, ok, peak, curv = stage(xr, flat, flat, radius, radius, 0.0, False, step, levels, tol)
    # the second stage's sizes are those of a REFINE_RADIUS first stage, scaled with it
    # (a larger image: larger windows; docs/parameters.md, "Refinement window and image size")
    f = radius / REFINE_RADIUS
    for _ in range(SLANT_PASSES if slanted and len(x) else 0):
        gx, gy = disparity_gradients(left, left[:, 0] - x, scale=f, threads=threads)
        x2, ok2, _, _ = stage(x, gx, gy, round(SLANT_RADIUS * f),
                              max(SLANT_MIN_RADIUS, round(SLANT_MIN_RADIUS * f)),
                              SLANT_SIGMA * f, SLANT_CUBIC, SLANT_STEP, SLANT_LEVELS, SLANT_TOL)
        x = np.where(ok2, x2, x)
        ok = ok | ok2
    return Refinement(x, ok, peak, curv)


def disparity_gradients(left: np.ndarray, disparity: np.ndarray, scale: float = 1.0,
                        threads: int | None = None):
    """``(gx, gy)``, (M,) float64: at each match, the gradient of the least-squares plane
    through the disparities of the matches within ``scale`` x :data:`SLANT_HALF_WINDOW` px
    of it (itself included; :func:`hopmatch._kernels.guided.neighbour_planes` with
    ``scale`` x :data:`SLANT_PLANE_INLIER` and :data:`SLANT_PLANE_MIN`), clipped to
    +-:data:`SLANT_GRADIENT_LIMIT`; 0 where there is no plane (or no finite disparity)."""
    left = np.asarray(left, dtype=np.float64).reshape(-1, 2)
    disparity = np.asarray(disparity, dtype=np.float64)
    gx = np.zeros(len(left))
    gy = np.zeros(len(left))
    good = np.flatnonzero(np.isfinite(disparity) & np.isfinite(left).all(axis=1))
    if len(good) == 0:
        return gx, gy
    pts = np.ascontiguousarray(left[good], dtype=np.float32)
    half = np.float32(SLANT_HALF_WINDOW * scale)
    _, bx, by = local_planes(pts, pts, half, half, np.ascontiguousarray(disparity[good]),
                             SLANT_PLANE_INLIER * scale, SLANT_PLANE_MIN, threads=threads)
    gx[good] = np.clip(bx, -SLANT_GRADIENT_LIMIT, SLANT_GRADIENT_LIMIT)
    gy[good] = np.clip(by, -SLANT_GRADIENT_LIMIT, SLANT_GRADIENT_LIMIT)
    return gx, gy
