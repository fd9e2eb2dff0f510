"""The refinement and row-search kernels on motorcycle's own inputs, and the two-thread
bound of match_stereo: one process, CPU time (``time.thread_time``), so that a machine
shared with other work (where wall-clock ratios drift) still gives fair ratios (issue 17).

Run: ``python benchmarks/kernel_ab.py [--against /work/main] [--repeat 15]``.

- Kernels: one ``match_stereo`` call on motorcycle (one thread) records the inputs of
  every ``refine_rows`` (the refinement's two stages) and ``row_search`` (the guided
  pass's rounds) call; each call is then timed alone, best of ``--repeat``. With
  ``--against CHECKOUT`` the same inputs also go, interleaved call by call, to the
  kernels of another checkout (its ``hopmatch/_kernels/refine.py`` and ``guided.py``,
  loaded beside this one's), and each row gives the ratio and how far the outputs differ
  (``identical``, or the largest difference of the float outputs). The inputs are given
  in the order ``match_stereo`` gives them (rows sorted when this checkout sorts them).
- Two threads: ``match_stereo(threads=2)`` ``--repeat`` times; per call, the process's
  CPU time over the calling thread's: the speed-up two cores could give at most (the
  calling thread's time is the serial parts plus its share of the parallel ones), median
  and range over the calls. The wall-clock speed-up is ``benchmarks/end_to_end.py``'s
  (on an idle machine).

``--smoke``: a 240 x 160 crop, 2 repeats (a check that the script works).
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_smoke_option, motorcycle_bgr, single_thread  # noqa: E402

import hopmatch  # noqa: E402
from hopmatch._kernels import guided as kg  # noqa: E402
from hopmatch._kernels import refine as kr  # noqa: E402

KERNELS = {"refine_rows": kr, "row_search": kg}


def record_calls(left, right) -> dict:
    """The arguments of every kernel call of one ``match_stereo(left, right)``."""
    calls = {name: [] for name in KERNELS}
    originals = {name: getattr(mod, name) for name, mod in KERNELS.items()}

    def recorder(name):
        def call(*args):
            calls[name].append(args)
            return originals[name](*args)
        return call

    for name, mod in KERNELS.items():
        setattr(mod, name, recorder(name))
    try:
        hopmatch.match_stereo(left, right, threads=1)
    finally:
        for name, mod in KERNELS.items():
            setattr(mod, name, originals[name])
    return calls


def load_other(checkout: Path) -> dict:
    """``refine_rows`` and ``row_search`` of another checkout's kernel files, loaded as
    modules of this package (their relative imports resolve here)."""
    out = {}
    for name, file in (("refine_rows", "refine.py"), ("row_search", "guided.py")):
        path = checkout / "hopmatch" / "_kernels" / file
        spec = importlib.util.spec_from_file_location(
            f"hopmatch._kernels._other_{path.stem}", path)
        mod = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = mod
        spec.loader.exec_module(mod)
        out[name] = getattr(mod, name)
    return out


def cpu_best(fn, args, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.thread_time()
        fn(*args)
        best = min(best, time.thread_time() - t0)
    return best


def difference(a, b) -> str:
    """``identical``, or the largest difference of the float outputs (and how many flags
    differ)."""
    worst = 0.0
    flags = 0
    for x, y in zip(a, b):
        x, y = np.asarray(x), np.asarray(y)
        if x.dtype.kind == "f":
            both = np.isfinite(x) & np.isfinite(y)
            if not np.array_equal(np.isnan(x), np.isnan(y)):
                return "NaN where the other is not"
            if both.any():
                worst = max(worst, float(np.max(np.abs(x[both] - y[both]))))
        else:
            flags += int(np.count_nonzero(x != y))
    if worst == 0.0 and flags == 0:
        return "identical"
    return f"max {worst:.2g}" + (f", {flags} flags differ" if flags else "")


def kernel_table(calls, other, repeat: int) -> None:
    head = "| kernel call | items | CPU ms |"
    if other:
        head += " other CPU ms | ratio | outputs |"
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for name, arg_lists in calls.items():
        for k, args in enumerate(arg_lists):
            items = len(args[2]) if name == "refine_rows" else len(args[4])
            fn = getattr(KERNELS[name], name)
            fn(*args)
            if other:
                ref = other[name]
                ref(*args)
                mine = theirs = float("inf")
                for _ in range(repeat):  # interleaved, so that drift hits both alike
                    mine = min(mine, cpu_best(fn, args, 1))
                    theirs = min(theirs, cpu_best(ref, args, 1))
                print(f"| {name} #{k + 1} | {items} | {mine * 1e3:.2f} | {theirs * 1e3:.2f} | "
                      f"{mine / theirs:.3f} | {difference(fn(*args), ref(*args))} |")
            else:
                print(f"| {name} #{k + 1} | {items} | {cpu_best(fn, args, repeat) * 1e3:.2f} |")


def two_thread_bound(left, right, repeat: int) -> None:
    hopmatch.match_stereo(left, right, threads=2)
    ratios, main, total = [], [], []
    for _ in range(repeat):
        t0, c0 = time.thread_time(), time.process_time()
        hopmatch.match_stereo(left, right, threads=2)
        m, c = time.thread_time() - t0, time.process_time() - c0
        ratios.append(c / m)
        main.append(m)
        total.append(c)
    print(f"\nmatch_stereo(threads=2), {repeat} calls: process CPU "
          f"{np.median(total) * 1e3:.1f} ms, calling thread {np.median(main) * 1e3:.1f} ms "
          f"(medians); bound on the 2-thread "
          f"speed-up (CPU / calling thread): {np.median(ratios):.3f} "
          f"({min(ratios):.3f}-{max(ratios):.3f}; goal >= 1.6x)")


def main() -> None:
    parser = add_smoke_option(argparse.ArgumentParser(description=__doc__.splitlines()[0]))
    parser.add_argument("--against", type=Path, default=None,
                        help="another checkout of hopmatch whose kernels to time beside these")
    parser.add_argument("--repeat", type=int, default=15)
    args = parser.parse_args()
    repeat = 2 if args.smoke else args.repeat
    single_thread()
    cv2.setNumThreads(1)
    left, right, _ = motorcycle_bgr(smoke=args.smoke)
    hopmatch.match_stereo(left, right, threads=1)  # compile / load every kernel
    calls = record_calls(left, right)
    other = load_other(args.against) if args.against else None
    against = f", interleaved with {args.against}" if other else ""
    print(f"## Kernels on {'a crop of ' if args.smoke else ''}motorcycle's inputs "
          f"(CPU time, best of {repeat}{against})\n")
    kernel_table(calls, other, repeat)
    two_thread_bound(left, right, repeat)


if __name__ == "__main__":
    main()
