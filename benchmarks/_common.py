"""Shared helpers of the benchmarks: timing, the motorcycle pair, machine description, and
the ``--smoke`` option every benchmark script takes.

``--smoke`` runs a script on a tiny input in a few seconds (a centre crop of motorcycle,
one timing round, a few sizes or scenes): it checks that the script still runs and prints
the tables the documentation quotes (``tests/benchmarks/test_benchmarks_smoke.py``); its
figures mean nothing. Without it every script does exactly its full run.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import pstats
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np

#: Help text of the ``--smoke`` option.
SMOKE_HELP = ("run on a tiny input in a few seconds, to check that the script works and "
              "prints its tables (the figures then mean nothing)")
#: Width and height of the centre crop of motorcycle that ``--smoke`` runs use.
SMOKE_SIZE = (240, 160)
#: The scenes a ``--smoke`` run keeps of a scene list (the built-in one and a small one).
SMOKE_SCENES = ("motorcycle", "middlebury/tsukuba")
#: How many pairs of a pair list (chessboards) a ``--smoke`` run keeps.
SMOKE_PAIRS = 2


def add_smoke_option(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Add ``--smoke`` (``args.smoke``, default False) to ``parser`` and return it."""
    parser.add_argument("--smoke", action="store_true", help=SMOKE_HELP)
    return parser


def add_refine_radius_option(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Add ``--refine-radius N`` (``args.refine_radius``, default None: the rule of
    ``hopmatch.matching.stereo_match.refine_radius``); see :func:`force_refine_radius`."""
    parser.add_argument("--refine-radius", type=int, default=None,
                        help="refine with this window half-side whatever the image size "
                             "(default: the size rule of stereo_match.refine_radius)")
    return parser


def force_refine_radius(radius: int | None) -> None:
    """Make ``match_stereo`` refine with half-side ``radius`` on images of any size, in
    this process (None: leave the size rule alone). For measuring the rule only."""
    if radius is None:
        return
    from hopmatch.matching import stereo_match

    stereo_match.refine_radius = lambda shape: int(radius)


def as_jpeg(image: np.ndarray, quality) -> np.ndarray:
    """``image`` saved as a JPEG of ``quality`` and read back (``image`` itself for None)."""
    if quality is None:
        return image
    ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    return cv2.imdecode(buf, cv2.IMREAD_UNCHANGED)


def smoke_crop(image: np.ndarray, size: tuple[int, int] = SMOKE_SIZE) -> np.ndarray:
    """The centre ``size = (width, height)`` crop of ``image`` (a contiguous copy).

    The same crop of both images of a rectified pair and of its disparity map is again a
    rectified pair with valid ground truth (a crop shifts both images alike)."""
    w, h = size
    y0 = max(0, (image.shape[0] - h) // 2)
    x0 = max(0, (image.shape[1] - w) // 2)
    return np.ascontiguousarray(image[y0:y0 + h, x0:x0 + w])


def smoke_scene(scene):
    """``scene`` (a :class:`hopmatch.datasets.StereoScene`) with its images and every
    per-pixel map cropped by :func:`smoke_crop`; name and metadata unchanged."""
    shape = scene.left.shape[:2]
    maps = {f.name: smoke_crop(getattr(scene, f.name)) for f in dataclasses.fields(scene)
            if isinstance(getattr(scene, f.name), np.ndarray)
            and getattr(scene, f.name).shape[:2] == shape}
    return dataclasses.replace(scene, **maps)


def smoke_scenes(names) -> list:
    """The names of :data:`SMOKE_SCENES` among ``names``, in their order (the first name
    when none of them is there)."""
    names = list(names)
    kept = [n for n in names if n in SMOKE_SCENES]
    return kept or names[:1]


def single_thread() -> None:
    """Pin OpenCV and hopmatch to one thread (``cv2.setNumThreads(1)``,
    ``hopmatch.setNumThreads(1)``); rows with more threads pass ``threads=`` explicitly."""
    import hopmatch

    cv2.setNumThreads(1)
    hopmatch.setNumThreads(1)


def run_fresh_interpreter(child: str, args: list, cache_dir: str | None,
                          notice: bool, extra_env: dict | None = None) -> dict:
    """Run the script ``child`` (``python -c child *args``) in a fresh interpreter with
    ``NUMBA_CACHE_DIR=cache_dir`` (None: as set now), the first-run notice on
    (``notice``) or off (``HOPMATCH_COMPILE_NOTICE=0``) and ``extra_env`` set; the JSON
    object its last line of stdout prints. Raises ``RuntimeError`` with its stderr when it
    fails."""
    env = dict(os.environ) if cache_dir is None else dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    env.update(extra_env or {})
    if notice:
        env.pop("HOPMATCH_COMPILE_NOTICE", None)
    else:
        env["HOPMATCH_COMPILE_NOTICE"] = "0"
    out = subprocess.run([sys.executable, "-c", child, *args], env=env, capture_output=True,
                         text=True)
    if out.returncode:
        raise RuntimeError(f"the measuring interpreter failed:\n{out.stderr}")
    return json.loads(out.stdout.strip().splitlines()[-1])


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


def motorcycle_bgr(smoke: bool = False):
    """``(left, right, disparity)`` of motorcycle (BGR images, float32 ground truth);
    ``smoke``: their :func:`smoke_crop`."""
    from hopmatch.datasets import load_motorcycle

    scene = load_motorcycle()
    if smoke:
        scene = smoke_scene(scene)
    return scene.left, scene.right, scene.disparity


def machine() -> str:
    return (f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
            f"Python {platform.python_version()}, OpenCV {cv2.__version__}, NumPy {np.__version__}")


def profile_rows(profiler, pairs: int, rows: int) -> tuple[list, float]:
    """The ``rows`` functions with the most own time under ``profiler`` (a finished
    ``cProfile.Profile`` that ran ``pairs`` pairs): ``([(name, own seconds per pair)...],
    total own seconds per pair)``, the name ``file.py:function`` (built-ins by name)."""
    stats = pstats.Stats(profiler).stats
    top = sorted(stats.items(), key=lambda kv: kv[1][2], reverse=True)[:rows]
    total = sum(v[2] for v in stats.values()) / pairs
    return ([(name if path == "~" else f"{Path(path).name}:{name}", own / pairs)
             for (path, _line, name), (_, _, own, _, _) in top], total)
