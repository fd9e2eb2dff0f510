"""Compile (or load from cache) every Numba kernel on tiny inputs: ``hopmatch.warmup``.

The kernels fall in two groups of about equal compile time (:data:`GROUPS`): the detection
with the steps after the network (guided pass, refinement, half-window test), and the
network. With ``processes=2`` and the on-disk cache on, a second interpreter compiles the
first group into the cache while this one compiles the second, then this one loads the
first from the cache: Numba compiles one kernel at a time per process (a global lock), so
two processes are the way to use two cores (docs/performance.md, "The first run").
"""

from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np

#: The groups of kernels, compiled by :func:`warm_group` (index into this tuple).
GROUPS = ("detection, guided pass, refinement and half-window test", "network")
#: Seconds :func:`warmup` waits for the second interpreter before compiling its group itself.
HELPER_TIMEOUT = 600.0


def warm_detection_and_beyond() -> None:
    """Group 0: the detector's kernels (Deriche gradient, Moravec response and maxima,
    descriptors) and those of the guided pass, the refinement and the half-window test."""
    from .feature.detector import DericheMoravecDetector
    from .matching.stereo_match import warm_up_beyond_network

    rng = np.random.default_rng(0)
    img = (rng.random((48, 64)) * 255).astype(np.uint8)
    det = DericheMoravecDetector(nms_size=3)
    pts, _, g = det.detect_points(img)
    det.describe_points(g, pts)
    warm_up_beyond_network()


def warm_network() -> None:
    """Group 1: the network's kernels (candidates along rows and along epipolar lines,
    similarity of float and binary descriptors, interactions and their bounds, the
    updates), on points and descriptors of the dtypes the detector gives them."""
    from ._kernels import interactions as _ki
    from .matching.budget import neighbour_pairs_bound
    from .matching.network import hopfield_match

    rng = np.random.default_rng(0)
    xs, ys = np.meshgrid(np.arange(10.0, 54.0, 3.0), np.arange(10.0, 38.0, 3.0))
    pts = np.ascontiguousarray(np.c_[xs.ravel(), ys.ravel()]
                               + rng.uniform(-0.5, 0.5, (xs.size, 2)), dtype=np.float32)
    desc = rng.normal(0.0, 10.0, (len(pts), 81))
    desc = np.ascontiguousarray(desc - desc.mean(axis=1, keepdims=True), dtype=np.float32)
    hopfield_match(pts, pts, desc, desc, max_disparity=4.0, record_energy=True)
    rectified = np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0]], dtype=np.float64)
    hopfield_match(pts, pts, desc, desc, max_disparity=4.0, fundamental_matrix=rectified)
    neighbour_pairs_bound(pts, 20.0, 10.0)  # only crowded inputs reach it in a match
    # the exact interaction count runs only when the cheap bound is over budget
    no_pairs, no_offsets = np.zeros(0, np.int32), np.zeros(1, np.int64)
    _ki.count_interactions(no_pairs, no_pairs, no_offsets, no_offsets, no_pairs)
    binary = (rng.random((len(pts), 32)) * 255).astype(np.uint8)
    hopfield_match(pts, pts, binary, binary, max_disparity=4.0)


def warm_group(index: int) -> None:
    """Compile (or load) the kernels of ``GROUPS[index]``."""
    (warm_detection_and_beyond, warm_network)[index]()


def start_helper():
    """A second interpreter compiling group 0 into the on-disk cache (its output
    discarded, its first-run notice silenced), or None when there is no cache to share."""
    from ._config import CACHE

    if not CACHE or not sys.executable:
        return None
    env = dict(os.environ, HOPMATCH_COMPILE_NOTICE="0")
    try:
        return subprocess.Popen(
            [sys.executable, "-c", "from hopmatch._warmup import warm_group; warm_group(0)"],
            env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL)
    except OSError:
        return None


def warmup(processes: int = 1) -> float:
    """Compile (or load) every kernel in this process; the seconds it took. With
    ``processes >= 2`` (and the on-disk cache on) group 0 is compiled by a second
    interpreter meanwhile and then loaded from the cache; should it fail, this process
    compiles it. When group 1 compiled nothing here (the cache was warm), the helper is
    stopped and group 0 loaded at once. The helper never outlives the call."""
    from numba.core import event

    t0 = time.perf_counter()
    helper = start_helper() if processes >= 2 else None
    try:
        with event.install_recorder("numba:compile") as compiled:
            warm_group(1)
        if helper is not None and not compiled.buffer:
            helper.kill()  # a warm cache: loading group 0 here is quicker than waiting
        elif helper is not None:
            try:
                helper.wait(timeout=HELPER_TIMEOUT)
            except subprocess.TimeoutExpired:
                pass
        warm_group(0)
    finally:
        if helper is not None and helper.poll() is None:
            helper.kill()
            helper.wait()
    return time.perf_counter() - t0
