"""The half-window test: matches whose grey window straddles a depth edge (beyond the
paper; docs/method.md, "Windows that straddle a depth edge").

Most wrong matches of :func:`~hopmatch.match_stereo` on the weakest scenes lie within a few
pixels of a depth edge, on the background side, with the foreground's disparity: the
window is dominated by the foreground's edge, which matches at the foreground's
disparity, while its other half shows background that is shifted by another disparity
(or occluded in the right image). Searching along the row cannot tell them apart from the
correct matches of the foreground, and the network's neighbours, all on the foreground
near such an edge, support them. What gives them away is the half of the window on the
background side: at the match's disparity it does not correlate. The test computes, at
every match's refined position, the ZNCC of the left half (columns left of the centre)
and the right half (right of it) of the two grey windows, and drops a match when a half
that has contrast (its standard deviation in the left image above
:data:`HALF_MIN_CONTRAST` times the median over the pair's matches) has a ZNCC below
:data:`HALF_MIN_ZNCC`. A half without contrast says nothing and is not judged.

It drops points on both sides of an edge (a foreground point one pixel inside the edge has
the same windows), so it buys precision with some correct matches: pooled over the 22
shared scenes, about 250 wrong matches for 300 correct ones (docs/parameters.md, "The
half-window test").
"""

from __future__ import annotations

import numpy as np

from .._kernels import halves as _k
from .._threads import map_chunks

#: Run the test in :func:`~hopmatch.match_stereo` (with the refinement; False: keep every
#: match, as before the test).
HALF_CHECK = True
#: Half-side of the windows whose halves are compared (9 x 9: each half 9 x 4), for images
#: up to the refinement's reference size; it grows with the refinement window
#: (:func:`~hopmatch.matching.stereo_match.refine_radius`).
HALF_RADIUS = 4
#: A half with contrast whose ZNCC is below this straddles a depth edge.
HALF_MIN_ZNCC = 0.4
#: A half has contrast when its standard deviation (left image) is above this fraction of
#: the median, over the pair's matches, of the mean of its two halves' standard deviations.
HALF_MIN_CONTRAST = 0.1


def half_window_zncc(gray_l, gray_r, left, right, radius: int = HALF_RADIUS,
                     threads: int | None = None):
    """``(z_left, z_right, s_left, s_right)`` of every match (
    :func:`hopmatch._kernels.halves.half_windows`): the ZNCC of the left and right halves
    of the ``(2 radius + 1)**2`` grey windows centred on ``left[m]`` and ``right[m]``, and
    the standard deviations of the left image's halves; NaN where a window does not fit.
    Computed in up to ``threads`` threads, bit-identical for any count."""
    img_l = np.ascontiguousarray(gray_l, dtype=np.float32)
    img_r = np.ascontiguousarray(gray_r, dtype=np.float32)
    left = np.ascontiguousarray(left, dtype=np.float64).reshape(-1, 2)
    right = np.ascontiguousarray(right, dtype=np.float64).reshape(-1, 2)
    if len(left) == 0:
        z = np.zeros(0)
        return z, z, z, z
    return map_chunks(lambda a, b: _k.half_windows(img_l, img_r, a, b, int(radius)),
                      (left, right), threads)


def straddling(gray_l, gray_r, left, right, radius: int | None = None,
               min_zncc: float | None = None, min_contrast: float | None = None,
               threads: int | None = None) -> np.ndarray:
    """(M,) bool: the matches (``left[m]``, ``right[m]``, sub-pixel, on the grey images)
    whose windows straddle a depth edge: a half of the left window with contrast (standard
    deviation above ``min_contrast`` times the median over the matches of the mean of the
    two halves') has a ZNCC below ``min_zncc`` with the same half of the right window
    (:func:`half_window_zncc`). False where a window does not fit in its image. None:
    :data:`HALF_RADIUS`, :data:`HALF_MIN_ZNCC`, :data:`HALF_MIN_CONTRAST`, read at the
    call."""
    radius = HALF_RADIUS if radius is None else radius
    min_zncc = HALF_MIN_ZNCC if min_zncc is None else min_zncc
    min_contrast = HALF_MIN_CONTRAST if min_contrast is None else min_contrast
    z_l, z_r, s_l, s_r = half_window_zncc(gray_l, gray_r, left, right, radius, threads)
    if len(z_l) == 0:
        return np.zeros(0, dtype=bool)
    mean = 0.5 * (s_l + s_r)
    fit = np.isfinite(mean)
    if not fit.any():
        return np.zeros(len(z_l), dtype=bool)
    floor = min_contrast * float(np.median(mean[fit]))
    with np.errstate(invalid="ignore"):
        bad_l = (s_l > floor) & (z_l < min_zncc)
        bad_r = (s_r > floor) & (z_r < min_zncc)
    return fit & (bad_l | bad_r)
