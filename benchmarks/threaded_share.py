"""How much of match_stereo's CPU time runs in hopmatch's thread helpers (Amdahl's bound).

Run: ``python benchmarks/threaded_share.py`` (motorcycle, one thread, 10 pairs). Every
function handed to ``hopmatch._threads``'s ``map_chunks``, ``map_ranges`` and ``run_both``
is timed in CPU time (``time.process_time``) while the pair is matched with
``threads=1``: that is the work a second thread can share. Prints the CPU ms per pair
inside and outside those functions, the threaded share, and the two-thread bound
``T1 / (serial + split)``, ``split`` being each region's time halved where it has at least
two chunks (``2 * MIN_CHUNK`` items; ``run_both``: the longer of its two calls). Then the
serial CPU time by function (cProfile with ``process_time``, disabled inside the thread
helpers' functions): the stages still on one thread, own ms per pair. Last, where a second
thread's time goes: the same pairs matched with ``threads=1`` and ``threads=2`` in
alternation, each call of a helper timed in wall time by the function that called it (the
outermost call only): its ms per pair at one and two threads (medians over the pairs) and
their ratio, and the same of the time outside the helpers and of the whole call; and what
the machine allows: the first stage of the refinement's kernel (``refine_rows``, on the
pair's matches) run once, and two copies of the same call at once in two threads (best of
``--pairs`` runs each): their efficiency is the one-copy time over the two-copy time, 1
when two threads run two kernels as fast as one runs one (a machine whose cores share
caches, memory bandwidth or a clock that drops with load gives less). ``--smoke``: on a
240 x 160 crop, 2 pairs (figures meaningless).

Every call matches one run (``both_features=False``): the threading inside a run. With
``both_features`` (the default since 2026-12-07) two threads first run the two runs at
once, one thread each (``benchmarks/end_to_end.py``'s two-thread row; N threads: N // 2
for the first run, the rest for the second).
"""

from __future__ import annotations

import argparse
import cProfile
import sys
import threading
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_smoke_option, motorcycle_bgr, profile_rows, single_thread  # noqa: E402

import hopmatch  # noqa: E402
from hopmatch import _threads  # noqa: E402
from hopmatch._kernels.refine import refine_rows  # noqa: E402
from hopmatch.matching import refine  # noqa: E402

#: The calls' parameters: one run, whose threading this measures (the module's docstring).
ONE_RUN = {"both_features": False}


class Regions:
    """Wrappers of the thread helpers that time the functions they are handed."""

    def __init__(self):
        self.depth = 0
        self.inside = 0.0  # CPU s inside the helpers' functions
        self.split = 0.0  # the same, as two threads would take it
        self.profiler = None

    def timed(self, fn):
        def run(*args):
            if self.depth:
                return fn(*args)
            self.depth += 1
            if self.profiler is not None:
                self.profiler.disable()
            t0 = time.process_time()
            try:
                return fn(*args)
            finally:
                self.last = time.process_time() - t0
                self.inside += self.last
                if self.profiler is not None:
                    self.profiler.enable()
                self.depth -= 1
        return run

    def map_chunks(self, fn, split, threads=None, order=None):
        before = self.inside
        out = _threads.map_chunks(self.timed(fn), split, 1, order)
        self._split(self.inside - before, len(split[0]))
        return out

    def map_ranges(self, fn, n, threads=None):
        before = self.inside
        out = _threads.map_ranges(self.timed(fn), n, 1)
        self._split(self.inside - before, n)
        return out

    def run_both(self, first, second, threads):
        if self.depth:
            return first(), second()
        a = self.timed(first)()
        t_a = self.last
        b = self.timed(second)()
        self.split += max(t_a, self.last)
        return a, b

    def _split(self, t, n):
        self.split += t / 2 if n // _threads.MIN_CHUNK >= 2 else t


class Sites:
    """Wrappers of the thread helpers that keep the caller's thread count and time each
    outermost call in wall time, by the function that called the helper."""

    def __init__(self):
        self.depth = 0
        self.wall = {}  # site -> seconds, in the pair being matched

    def timed(self, helper):
        def run(*args, **kwargs):
            if self.depth:
                return helper(*args, **kwargs)
            caller = sys._getframe(1).f_code
            site = f"{Path(caller.co_filename).name}:{caller.co_name}"
            self.depth += 1
            t0 = time.perf_counter()
            try:
                return helper(*args, **kwargs)
            finally:
                self.wall[site] = self.wall.get(site, 0.0) + time.perf_counter() - t0
                self.depth -= 1
        return run


HELPERS = ("map_chunks", "map_ranges", "run_both")


def patch(replacement) -> dict:
    """Replace the helpers in every hopmatch module that imported them by
    ``replacement(name)``; returns what was replaced, for :func:`unpatch`."""
    replaced = {}
    for name, module in list(sys.modules.items()):
        if not name.startswith("hopmatch") or module is _threads:
            continue
        for helper in HELPERS:
            if getattr(module, helper, None) is getattr(_threads, helper):
                replaced[name, helper] = getattr(_threads, helper)
                setattr(module, helper, replacement(helper))
    return replaced


def unpatch(replaced: dict) -> None:
    """Put back what :func:`patch` replaced."""
    for (name, helper), original in replaced.items():
        setattr(sys.modules[name], helper, original)


def two_thread_regions(gl, gr, pairs: int) -> None:
    """The table of the module's docstring (medians over the pairs: a 2-core virtual
    machine's slow outliers hit the two-thread runs harder, and would decide the means)."""
    sites = Sites()
    replaced = patch(lambda helper: sites.timed(getattr(_threads, helper)))
    runs = {1: [], 2: []}  # per pair: (match_stereo's seconds, {site: seconds})
    for _ in range(pairs):
        for threads in (1, 2):
            sites.wall = {}
            t0 = time.perf_counter()
            hopmatch.match_stereo(gl, gr, threads=threads, **ONE_RUN)
            runs[threads].append((time.perf_counter() - t0, sites.wall))
    unpatch(replaced)

    def median(threads, of) -> float:
        return float(np.median([of(total, wall) for total, wall in runs[threads]])) * 1e3

    names = sorted({site for t in runs for _, wall in runs[t] for site in wall},
                   key=lambda site: -median(1, lambda _, wall: wall.get(site, 0.0)))
    print("Where a second thread's time goes (wall time, threads=1 and threads=2 in "
          "alternation, by the function that called the helper; ms per pair, the median "
          f"of {pairs} pairs):\n")
    print("| called from | ms, 1 thread | ms, 2 threads | speed-up |")
    print("|---|---:|---:|---:|")
    rows = [(f"`{site}`", lambda _, wall, site=site: wall.get(site, 0.0)) for site in names]
    rows += [("all the helpers", lambda _, wall: sum(wall.values())),
             ("outside them", lambda total, wall: total - sum(wall.values())),
             ("match_stereo", lambda total, _: total)]
    for label, of in rows:
        one, two = median(1, of), median(2, of)
        print(f"| {label} | {one:.2f} | {two:.2f} | "
              f"{one / two if two else float('nan'):.2f}x |")


def concurrent_copies(gl, gr, res, runs: int) -> None:
    """The machine's own two-thread efficiency (the module's docstring, last), on the
    matches ``res`` of the pair."""
    left = np.ascontiguousarray(res.matched_left, dtype=np.float64)
    xr = np.ascontiguousarray(res.matched_right[:, 0], dtype=np.float64)
    yr = np.ascontiguousarray(res.matched_right[:, 1], dtype=np.float64)
    flat = np.zeros(len(xr))
    img_l = np.ascontiguousarray(gl, dtype=np.float32)
    img_r = np.ascontiguousarray(gr, dtype=np.float32)

    def call():  # the first stage of hopmatch.matching.refine.refine_disparities, square
        refine_rows(img_l, img_r, left, xr, yr, flat, flat, refine.REFINE_RADIUS,
                    refine.REFINE_RADIUS, 0.0, False, refine.REFINE_STEP, refine.REFINE_LEVELS,
                    refine.REFINE_ITERATIONS, refine.REFINE_TOL, refine.REFINE_MAX_SHIFT)

    call()
    one = two = float("inf")
    for _ in range(runs):
        t0 = time.perf_counter()
        call()
        one = min(one, time.perf_counter() - t0)
        pair = [threading.Thread(target=call) for _ in range(2)]
        t0 = time.perf_counter()
        for t in pair:
            t.start()
        for t in pair:
            t.join()
        two = min(two, time.perf_counter() - t0)
    print(f"\nTwo copies of one kernel at once (refine_rows, {len(xr)} matches, best of {runs}): "
          f"one copy {one * 1e3:.1f} ms, two copies in two threads {two * 1e3:.1f} ms, "
          f"efficiency {one / two:.2f}")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pairs", type=int, default=10, help="pairs timed (default 10)")
    args = add_smoke_option(parser).parse_args(argv)
    pairs = 2 if args.smoke else args.pairs
    single_thread()
    hopmatch.warmup()
    left, right, _ = motorcycle_bgr(smoke=args.smoke)
    gl = cv2.cvtColor(left, cv2.COLOR_BGR2GRAY)
    gr = cv2.cvtColor(right, cv2.COLOR_BGR2GRAY)
    # untimed; its matches for the last check
    res = hopmatch.match_stereo(gl, gr, threads=1, **ONE_RUN)
    regions = Regions()
    replaced = patch(lambda helper: getattr(regions, helper))
    t0 = time.process_time()
    for _ in range(pairs):
        hopmatch.match_stereo(gl, gr, threads=1, **ONE_RUN)
    total = (time.process_time() - t0) / pairs
    inside, split = regions.inside / pairs, regions.split / pairs
    serial = total - inside
    print(f"## Threaded share of match_stereo on motorcycle ({gl.shape[1]}x{gl.shape[0]}), "
          f"CPU time, {pairs} pairs\n")
    print("| measure | CPU ms per pair |")
    print("|---|---:|")
    print(f"| total, threads=1 | {total * 1e3:.1f} |")
    print(f"| inside the thread helpers (map_chunks, map_ranges, run_both) | "
          f"{inside * 1e3:.1f} |")
    print(f"| serial (the rest) | {serial * 1e3:.1f} |")
    print(f"\nThreaded share {inside / total:.1%}; Amdahl's bound for 2 threads "
          f"{total / (serial + split):.2f}x (each region halved where it splits)\n")

    prof = cProfile.Profile(time.process_time)
    regions.profiler = prof
    prof.enable()
    for _ in range(pairs):
        hopmatch.match_stereo(gl, gr, threads=1, **ONE_RUN)
    prof.disable()
    regions.profiler = None
    top, _ = profile_rows(prof, pairs, 20)
    print("Serial CPU time by function (cProfile, outside the thread helpers' functions):\n")
    print("| function | own ms per pair |")
    print("|---|---:|")
    for where, own in top:
        print(f"| `{where}` | {own * 1e3:.2f} |")
    unpatch(replaced)
    print()
    two_thread_regions(gl, gr, pairs)
    concurrent_copies(gl, gr, res, pairs)


if __name__ == "__main__":
    main()
