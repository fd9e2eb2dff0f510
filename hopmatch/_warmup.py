"""Compile (or load from cache) every Numba kernel on tiny inputs."""

from __future__ import annotations

import time

import numpy as np


def warmup() -> float:
    from ._kernels import interactions as _ki
    from .feature.detector import DericheMoravecDetector
    from .matching.budget import neighbour_pairs_bound
    from .matching.network import hopfield_match
    from .matching.stereo_match import warm_up_beyond_network

    t0 = time.perf_counter()
    rng = np.random.default_rng(0)
    img = (rng.random((48, 64)) * 255).astype(np.uint8)
    det = DericheMoravecDetector(nms_size=3)
    pts, _, g = det.detect_points(img)
    pts = pts[(pts[:, 0] > 8) & (pts[:, 1] > 8) & (pts[:, 0] < 55) & (pts[:, 1] < 39)]
    _, desc = det.describe_points(g, pts)
    hopfield_match(pts, pts, desc, desc, max_disparity=4.0, record_energy=True)
    rectified = np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0]], dtype=np.float64)
    hopfield_match(pts, pts, desc, desc, max_disparity=4.0, fundamental_matrix=rectified)
    neighbour_pairs_bound(pts, 20.0, 10.0)  # only crowded inputs reach it in a match
    # the exact interaction count runs only when the cheap bound is over budget
    no_pairs, no_offsets = np.zeros(0, np.int32), np.zeros(1, np.int64)
    _ki.count_interactions(no_pairs, no_pairs, no_offsets, no_offsets, no_pairs)
    binary = (rng.random((len(pts), 32)) * 255).astype(np.uint8)
    hopfield_match(pts, pts, binary, binary, max_disparity=4.0)
    warm_up_beyond_network()  # the guided pass and the refinement of match_stereo
    return time.perf_counter() - t0
