"""The per-query kernels of the guided pass, the seeds and the plane pass
(:func:`hopmatch._kernels.guided.row_search`, :func:`~hopmatch._kernels.guided.
continuity_field`), computed on contiguous chunks of the queries in up to ``threads``
threads (:func:`hopmatch._threads.map_chunks`).

Each query's search and field are computed from that query's own inputs by the same code,
so the results are bit-identical to one call for any thread count.
"""

from __future__ import annotations

import numpy as np

from .._kernels import guided as _kg
from .._threads import map_chunks, row_order


def row_searches(g_l, g_r, pts_l, desc_l, queries, centre, y_offset, inner, outer, back,
                 min_zncc, margin, eps, gain_tol, clip, peaks, shoulder, shear,
                 threads: int | None = None):
    """:func:`hopmatch._kernels.guided.row_search` (same arguments, ``shear`` an array of
    one value per query; same ``(status, best, second, xr, similarity)``), in up to
    ``threads`` threads, the queries taken in the order of their image rows
    (:func:`hopmatch._threads.row_order`: their windows are then found in the CPU's
    caches)."""
    queries = np.ascontiguousarray(queries, dtype=np.int64)
    return map_chunks(
        lambda qs, cs, ys, ss: _kg.row_search(g_l, g_r, pts_l, desc_l, qs, cs, ys,
                                              float(inner), int(outer), int(back),
                                              float(min_zncc), float(margin), float(eps),
                                              float(gain_tol), bool(clip), bool(peaks),
                                              int(shoulder), ss),
        (queries, np.ascontiguousarray(centre), np.ascontiguousarray(y_offset),
         np.ascontiguousarray(shear)), threads, order=row_order(pts_l[queries, 1]))


def continuity_fields(pts_q, xr, yr, sim_q, offsets, idx, rows, m_left, m_right, m_sim,
                      theta, slope, weight, bias, gx, gy, threads: int | None = None):
    """:func:`hopmatch._kernels.guided.continuity_field` (same arguments, same fields), in
    up to ``threads`` threads."""
    return map_chunks(
        lambda pq, xq, yq, sq, rq, gxq, gyq: (_kg.continuity_field(
            pq, xq, yq, sq, offsets, idx, rq, m_left, m_right, m_sim, theta, slope, weight,
            bias, gxq, gyq),),
        (pts_q, xr, yr, sim_q, rows, gx, gy), threads)[0]
