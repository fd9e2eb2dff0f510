"""Shared helpers of the benchmarks: timing, the motorcycle pair, machine description."""

from __future__ import annotations

import os
import platform
import time

import cv2
import numpy as np


def single_thread() -> None:
    """Pin OpenCV to one thread (Numba kernels are single-threaded already)."""
    cv2.setNumThreads(1)


def best_time(fn, repeat: int = 7, warmup: int = 1) -> float:
    """Best wall time of ``fn()`` over ``repeat`` runs, in seconds (after ``warmup`` runs)."""
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def best_times_interleaved(fns: dict, repeat: int = 7, warmup: int = 1, settle: int = 0) -> dict:
    """Best wall time of each function, in seconds, over ``repeat`` rounds that run every
    function once in turn: a machine that speeds up or slows down during the benchmark
    then affects every method alike, and the ratios stay fair.

    ``settle``: untimed calls of each function right before each of its timed calls, so
    that every function is timed in the state its own previous call leaves (caches, the
    allocator's free memory), as when it runs alone, and not in the state the function
    before it in the round leaves (after SIFT's large buffers, for instance, the next
    call of another pipeline page-faults its memory in again)."""
    for _ in range(warmup):
        for fn in fns.values():
            fn()
    best = {name: float("inf") for name in fns}
    for _ in range(repeat):
        for name, fn in fns.items():
            for _ in range(settle):
                fn()
            t0 = time.perf_counter()
            fn()
            best[name] = min(best[name], time.perf_counter() - t0)
    return best


def motorcycle_bgr():
    from hopmatch.datasets import load_motorcycle

    scene = load_motorcycle()
    return scene.left, scene.right, scene.disparity


def machine() -> str:
    return (f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
            f"Python {platform.python_version()}, OpenCV {cv2.__version__}, NumPy {np.__version__}")
