"""The neighbour lists and local disparity planes of the guided pass and the refinement
(:func:`hopmatch._kernels.guided.query_neighbours`, :func:`~hopmatch._kernels.guided.
neighbour_planes`), computed on contiguous ranges of the queries in up to ``threads``
threads (:func:`hopmatch._threads.map_ranges`).

Each query's list and plane are computed from that query alone by the same code (the
grid of the matched points is built alike for every range), so the results are
bit-identical to one call for any thread count.
"""

from __future__ import annotations

import numpy as np

from .._kernels import guided as _kg
from .._threads import map_ranges
from .candidates import BAND_LIMIT


def half_sides(width: float, height: float, scale: float = 1.0):
    """float32 ``(scale * width / 2, scale * height / 2)``: the half-sides of a neighbourhood
    window as the neighbour kernels take them, each at most :data:`~.candidates.BAND_LIMIT`
    (coordinates lie within +-2**20 px, so a larger half-side holds the same neighbours;
    ``neighbour_width=1e39`` is inf in float32)."""
    return (np.float32(min(scale * width / 2, BAND_LIMIT)),
            np.float32(min(scale * height / 2, BAND_LIMIT)))


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
