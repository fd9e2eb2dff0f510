"""Compile (or load from cache) every Numba kernel on tiny inputs (``hopmatch.warmup``), and
the helper process that compiles kernels alongside this one on a cold cache.

Numba compiles one kernel at a time per process (a global lock), so a second Python
interpreter is the way a cold compile uses a second core. The kernels fall in three parts
(:data:`PARTS`): the detector's, the network's, and those of the steps after the network
(guided pass, refinement, half-window test). The helper compiles parts into the on-disk
cache, and this process loads them from it when it gets to them (a kernel it reaches
before the helper has written it, it compiles itself: the same machine code either way).

- ``warmup(2)``: the helper compiles the detector and the steps after the network while
  this process compiles the network; then this process loads them.
- The first compilation of one of hopmatch's kernels in a process (a cold first
  ``match_stereo``, or any entry point) starts a helper for the steps after the network,
  which the pipeline reaches last (:func:`start_background_helper`, from
  ``hopmatch._config.CompileNotice``).

Only with the on-disk cache on (the helper's work reaches this process through it), when
hopmatch may use two or more threads (``hopmatch.setNumThreads``), and unless
``HOPMATCH_COMPILE_HELPER=0``. A helper still running when the interpreter exits is
stopped (its finished kernels stay cached: Numba writes each file whole).
"""

from __future__ import annotations

import atexit
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

#: Seconds :func:`warmup` waits for its helper before compiling the helper's part itself.
HELPER_TIMEOUT = 600.0
#: The environment variable that turns the helper off (``0``, ``false``, ``no``, ``off``).
HELPER_SWITCH = "HOPMATCH_COMPILE_HELPER"

_state = {"started": False, "helper": None, "helping": False}
_lock = threading.Lock()


def warm_detection() -> None:
    """The detector's kernels: Deriche gradient, Moravec response and maxima, descriptors."""
    from .feature.detector import DericheMoravecDetector

    rng = np.random.default_rng(0)
    img = (rng.random((48, 64)) * 255).astype(np.uint8)
    det = DericheMoravecDetector(nms_size=3)
    pts, _, g = det.detect_points(img)
    det.describe_points(g, pts)


def warm_beyond_network() -> None:
    """The kernels of the guided pass, the refinement and the half-window test."""
    from .matching.stereo_match import warm_up_beyond_network

    warm_up_beyond_network()


def warm_network() -> None:
    """The network's kernels (candidates along rows and along epipolar lines, similarity of
    float and binary descriptors, interactions and their bounds, the updates), on points
    and descriptors of the dtypes the detector gives them."""
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


#: The parts of :func:`warmup`, by name.
PARTS = {"detection": warm_detection, "network": warm_network,
         "beyond network": warm_beyond_network}


def warm(*names: str) -> None:
    """Compile (or load) the kernels of the :data:`PARTS` named, in that order."""
    for name in names:
        PARTS[name]()


def helper_wanted(processes: int) -> bool:
    """Whether a helper may start: ``processes >= 2``, the on-disk cache on, and
    :data:`HELPER_SWITCH` not off."""
    from ._config import CACHE, switched_off

    return processes >= 2 and CACHE and bool(sys.executable) and not switched_off(HELPER_SWITCH)


def start_helper(*names: str):
    """A second interpreter compiling the :data:`PARTS` ``names`` into the on-disk cache (its
    output discarded, its own notice and helper off), or None when it cannot start. Where
    its interpreter would not find this package (a source checkout put on ``sys.path`` by
    hand), its folder is appended to the helper's path: Numba keeps its cache per source
    file, so the helper must compile these files."""
    root = str(Path(__file__).resolve().parent.parent)
    env = dict(os.environ, HOPMATCH_COMPILE_NOTICE="0", **{HELPER_SWITCH: "0"})
    code = (f"import sys; r = {root!r}; r in sys.path or sys.path.append(r); "
            f"from hopmatch._warmup import warm; warm(*{list(names)!r})")
    try:
        return subprocess.Popen([sys.executable, "-c", code], env=env,
                                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
    except OSError:
        return None


def stop(helper) -> None:
    """Stop ``helper`` if it is still running, and reap it."""
    if helper is not None and helper.poll() is None:
        helper.kill()
        helper.wait()


def start_background_helper() -> bool:
    """At the first compilation of one of hopmatch's kernels in this process: a helper for
    the steps after the network (once per process, when :func:`helper_wanted` with
    ``hopmatch.getNumThreads()``), stopped at exit if still running; whether a helper
    (this one, or :func:`warmup`'s) is compiling for this process."""
    from ._threads import getNumThreads

    with _lock:
        if _state["started"]:
            return _state["helping"]
        _state["started"] = True
    if not helper_wanted(getNumThreads()):
        return False
    helper = start_helper("beyond network")
    if helper is None:
        return False
    _state["helper"] = helper
    atexit.register(stop, helper)
    return True


def warmup(processes: int | None = None) -> float:
    """Compile (or load) every kernel in this process; the seconds it took.

    ``processes``: None, ``min(2, hopmatch.getNumThreads())``. With 2 or more (and
    :func:`helper_wanted`) a helper compiles the detector and the steps after the network
    while this process compiles the network, then this process loads them (should the
    helper fail, it compiles them). When the network compiled nothing here (the cache was
    warm), the helper is stopped and the rest loaded at once. 1: this process only. The
    helper never outlives the call.
    """
    from numba.core import event

    from ._threads import getNumThreads

    processes = min(2, getNumThreads()) if processes is None else processes
    with _lock:
        _state["started"] = True  # no background helper besides this call's
    t0 = time.perf_counter()
    helper = start_helper("detection", "beyond network") if helper_wanted(processes) else None
    _state["helping"] = helper is not None
    try:
        with event.install_recorder("numba:compile") as compiled:
            warm("network")
        if helper is not None and not compiled.buffer:
            stop(helper)  # a warm cache: loading the rest here is quicker than waiting
        elif helper is not None:
            try:
                helper.wait(timeout=HELPER_TIMEOUT)
            except subprocess.TimeoutExpired:
                pass
        warm("detection", "beyond network")
    finally:
        _state["helping"] = False
        stop(helper)
    return time.perf_counter() - t0
