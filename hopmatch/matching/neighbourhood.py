"""The neighbour window (SPEC section 4) beyond the network's own lists: its growth for
sparse keypoints (:func:`grown_for_density`, :func:`scaled_neighbourhood`), and the
neighbour lists and local disparity planes of the guided pass and the refinement
(:func:`hopmatch._kernels.guided.query_neighbours`, :func:`~hopmatch._kernels.guided.
neighbour_planes`), computed on contiguous ranges of the queries in up to ``threads``
threads (:func:`hopmatch._threads.map_ranges`).

Each query's list and plane are computed from that query alone by the same code (the
grid of the matched points is built alike for every range), so the results are
bit-identical to one call for any thread count.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .._kernels import guided as _kg
from .._kernels import neighbours as _kn
from .._threads import map_ranges
from .candidates import BAND_LIMIT


def half_sides(width: float, height: float, scale: float = 1.0):
    """float32 ``(scale * width / 2, scale * height / 2)``: the half-sides of a neighbourhood
    window as the neighbour kernels take them, each at most :data:`~.candidates.BAND_LIMIT`
    (coordinates lie within +-2**20 px, so a larger half-side holds the same neighbours;
    ``neighbour_width=1e39`` is inf in float32)."""
    return (np.float32(min(scale * width / 2, BAND_LIMIT)),
            np.float32(min(scale * height / 2, BAND_LIMIT)))


#: Left points whose neighbours :func:`median_neighbours` counts: a stride sample of this
#: many (all of them when there are fewer).
DENSITY_SAMPLE = 2000
#: Most the neighbour window grows, per side, for sparse keypoints
#: (:func:`grown_for_density`).
MAX_WINDOW_GROWTH = 4.0


def median_neighbours(points: np.ndarray, width: float, height: float, cap: int) -> float:
    """Median, over a stride sample of :data:`DENSITY_SAMPLE` of ``points`` ((N, 2) (x, y),
    N >= 2, in their order), of how many other points lie in each one's ``width x height``
    window (:func:`hopmatch._kernels.neighbours.neighbour_counts`), each counted up to
    ``cap``: the median is exact when it is below ``cap``."""
    pts = np.ascontiguousarray(points, dtype=np.float32)
    step = -(-len(pts) // DENSITY_SAMPLE)
    sample = np.arange(0, len(pts), step, dtype=np.int64)
    counts = _kn.neighbour_counts(pts, sample, *half_sides(width, height), int(cap))
    return float(np.median(counts))


def scaled_neighbourhood(config, factor: float):
    """``config`` (a :class:`~hopmatch.matching.params.MatcherConfig`) with the neighbour
    window and θ (eq. 5) scaled by ``factor``: on a slanted surface the disparity
    differences of neighbours grow with their distance, and θ bounds them. The coarse
    pass's thinned points and sparse keypoints (:func:`grown_for_density`) alike."""
    return dataclasses.replace(config, neighbour_width=config.neighbour_width * factor,
                               neighbour_height=config.neighbour_height * factor,
                               theta=config.theta * factor)


def grown_for_density(config, points: np.ndarray) -> tuple:
    """``(config, factor)``: the neighbour window grown for sparse left ``points``.

    When the median left point has fewer than ``config.min_neighbours`` other left points in
    its neighbour window (:func:`median_neighbours`), the window and θ are scaled
    (:func:`scaled_neighbourhood`) by ``sqrt(min_neighbours / max(median, 0.5))``, at most
    :data:`MAX_WINDOW_GROWTH`: for points of even density the median then comes to about
    ``min_neighbours``. The network's continuity (eqs. 10-12) rests on neighbours, and
    the defaults were set on the detector's own density; a larger ``nms_size``,
    ``max_features``, or SIFT's and ORB's keypoints can leave a few or none
    (docs/parameters.md, "Sparse keypoints"). Otherwise, and with ``min_neighbours`` 0,
    ``config`` itself and 1.0."""
    target = float(config.min_neighbours)
    if target <= 0 or len(points) < 2:
        return config, 1.0
    median = median_neighbours(points, config.neighbour_width, config.neighbour_height,
                               int(np.ceil(target)))
    if median >= target:
        return config, 1.0
    factor = min(MAX_WINDOW_GROWTH, float(np.sqrt(target / max(median, 0.5))))
    return scaled_neighbourhood(config, factor), factor


def query_neighbours(queries, matched, half_w, half_h, threads: int | None = None):
    """:func:`hopmatch._kernels.guided.query_neighbours` (same arguments, same CSR
    ``(offsets, indices)``), in up to ``threads`` threads."""
    parts = map_ranges(lambda lo, hi: _kg.query_neighbours(queries[lo:hi], matched, half_w,
                                                           half_h), len(queries), threads)
    if len(parts) == 1:
        return parts[0]
    offsets = [np.zeros(1, dtype=np.int64)]
    base = 0
    for off, _ in parts:
        offsets.append(off[1:] + base)
        base += int(off[-1])
    return np.concatenate(offsets), np.concatenate([idx for _, idx in parts])


def neighbour_planes(queries, offsets, idx, m_left, values, inlier, min_count,
                     reach: float = -1.0, refits: int = 0, threads: int | None = None):
    """:func:`hopmatch._kernels.guided.neighbour_planes` (same arguments, same
    ``(prediction, gx, gy)``), in up to ``threads`` threads."""
    parts = map_ranges(lambda lo, hi: _kg.neighbour_planes(queries[lo:hi], offsets[lo:hi + 1],
                                                           idx, m_left, values, inlier,
                                                           min_count, reach, refits),
                       len(offsets) - 1, threads)
    if len(parts) == 1:
        return parts[0]
    return tuple(np.concatenate([p[k] for p in parts]) for k in range(3))


#: :func:`local_planes` finds the neighbours of this many queries at a time, so that their
#: lists (about 170 per match within the refinement's window on a 2964 x 2000 textured
#: pair) never all exist at once.
PLANE_BLOCK = 32_768


def local_planes(queries, matched, half_w, half_h, values, inlier, min_count,
                 threads: int | None = None):
    """:func:`neighbour_planes` of each query over the ``matched`` points within ``half_w``
    x ``half_h`` of it (:func:`query_neighbours`; ``values`` one per matched point), for
    :data:`PLANE_BLOCK` queries at a time: the same ``(prediction, gx, gy)`` as one call
    (each query's list and plane are its own), with the neighbour lists of one block held
    at a time."""
    parts = []
    for lo in range(0, max(len(queries), 1), PLANE_BLOCK):  # no query: one empty block
        block = queries[lo:lo + PLANE_BLOCK]
        off, idx = query_neighbours(block, matched, half_w, half_h, threads=threads)
        parts.append(neighbour_planes(block, off, idx, matched, values, inlier, min_count,
                                      threads=threads))
        del off, idx  # freed before the next block's lists are made
    if len(parts) == 1:
        return parts[0]
    return tuple(np.concatenate([p[k] for p in parts]) for k in range(3))


def nearest_of(points, off, idx, matched, k):
    """The CSR neighbour lists ``(off, idx)`` of ``points`` cut to each point's ``k``
    nearest (Euclidean distance to ``matched[idx]``; ties by index), in the order of
    distance."""
    cnt = np.diff(off)
    owner = np.repeat(np.arange(len(cnt)), cnt)
    dist = np.hypot(matched[idx, 0].astype(np.float64) - points[owner, 0],
                    matched[idx, 1].astype(np.float64) - points[owner, 1])
    order = np.lexsort((idx, dist, owner))
    keep = order[np.arange(len(order)) - off[owner[order]] < k]
    new_off = np.zeros(len(cnt) + 1, dtype=np.int64)
    np.cumsum(np.minimum(cnt, k), out=new_off[1:])
    return new_off, np.ascontiguousarray(idx[keep])
