"""How much of match_stereo's CPU time runs in hopmatch's thread helpers (Amdahl's bound).

Run: ``python benchmarks/threaded_share.py`` (motorcycle, one thread, 10 pairs). Every
function handed to ``hopmatch._threads``'s ``map_chunks``, ``map_ranges`` and ``run_both``
is timed in CPU time (``time.process_time``) while the pair is matched with
``threads=1``: that is the work a second thread can share. Prints the CPU ms per pair
inside and outside those functions, the threaded share, and the two-thread bound
``T1 / (serial + split)``, ``split`` being each region's time halved where it has at least
two chunks (``2 * MIN_CHUNK`` items; ``run_both``: the longer of its two calls). Then the
serial CPU time by function (cProfile with ``process_time``, disabled inside the thread
helpers' functions): the stages still on one thread, own ms per pair. ``--smoke``: on a
240 x 160 crop, 2 pairs (figures meaningless).
"""

from __future__ import annotations

import argparse
import cProfile
import sys
import time
from pathlib import Path

import cv2

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_smoke_option, motorcycle_bgr, profile_rows, single_thread  # noqa: E402

import hopmatch  # noqa: E402
from hopmatch import _threads  # noqa: E402


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


def patch(regions: Regions) -> None:
    """Replace the helpers in every hopmatch module that imported them."""
    for name, module in list(sys.modules.items()):
        if not name.startswith("hopmatch") or module is _threads:
            continue
        for helper in ("map_chunks", "map_ranges", "run_both"):
            if getattr(module, helper, None) is getattr(_threads, helper):
                setattr(module, helper, getattr(regions, helper))


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
    hopmatch.match_stereo(gl, gr, threads=1)
    regions = Regions()
    patch(regions)
    t0 = time.process_time()
    for _ in range(pairs):
        hopmatch.match_stereo(gl, gr, threads=1)
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
        hopmatch.match_stereo(gl, gr, threads=1)
    prof.disable()
    regions.profiler = None
    top, _ = profile_rows(prof, pairs, 20)
    print("Serial CPU time by function (cProfile, outside the thread helpers' functions):\n")
    print("| function | own ms per pair |")
    print("|---|---:|")
    for where, own in top:
        print(f"| `{where}` | {own * 1e3:.2f} |")


if __name__ == "__main__":
    main()
