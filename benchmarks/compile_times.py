"""Where the cold compilation of hopmatch's kernels goes: per kernel, per signature, per
compiler pass.

Run: ``python benchmarks/compile_times.py [--first] [--top 25]``

A fresh interpreter with ``NUMBA_CACHE_DIR`` pointing at a new empty folder (and
``HOPMATCH_COMPILE_HELPER=0``: every kernel compiled in that one process) runs
``hopmatch.warmup()`` (``--first``: the first ``match_stereo`` on motorcycle instead, what a
new user waits) and listens to Numba's events: ``"numba:compile"`` (one per specialisation
compiled, never on a cache load) and ``"numba:run_pass"`` (each compiler pass). Times are
CPU seconds of the interpreter (``time.process_time``: steadier than wall time on a loaded
machine), a kernel's (or a pass's) own, without the kernels compiled inside it. Kernels
compiled for more than one signature are listed with their signatures: each costs a full
compilation. Then a second interpreter on the filled cache times the same call (the cache
load). To compare two versions on a shared machine, run both at the same time (same load)
and compare the CPU seconds.

``--smoke`` uses Numba's default cache (figures meaningless, nothing may compile): a check
that the script works.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_smoke_option, run_fresh_interpreter  # noqa: E402

CHILD = r"""
import json, sys, time
from numba.core import event

t_start = time.perf_counter()
c_start = time.process_time()
kernels, passes = {}, {}


class Own(event.Listener):  # exclusive time of nested compile (or pass) events
    def __init__(self, kind):
        self.kind = kind
        self.stack = []

    def on_start(self, ev):
        self.stack.append([ev.data, time.process_time(), 0.0])

    def on_end(self, ev):
        stack = self.stack
        data, start, inner = stack.pop()
        took = time.process_time() - start
        own = took - inner
        if stack:
            stack[-1][2] += took
        if self.kind == "compile":
            f = data["dispatcher"].py_func
            name = f"{f.__module__}.{f.__qualname__}"
            entry = kernels.setdefault(name, {"s": 0.0, "sigs": []})
            entry["s"] += own
            entry["sigs"].append(str(tuple(data["args"])))
        else:
            name = data["name"].split(" [")[0]
            passes[name] = passes.get(name, 0.0) + own


event.register("numba:compile", Own("compile"))
event.register("numba:run_pass", Own("pass"))
import hopmatch
t_import = time.perf_counter()
c_import = time.process_time()
if sys.argv[1] == "first":
    from hopmatch.datasets import load_motorcycle
    s = load_motorcycle()
    t0, c0 = time.perf_counter(), time.process_time()
    hopmatch.match_stereo(s.left, s.right)
else:
    t0, c0 = time.perf_counter(), time.process_time()
    hopmatch.warmup()
t1, c1 = time.perf_counter(), time.process_time()
print(json.dumps({"import": t_import - t_start, "call": t1 - t0,
                  "import_cpu": c_import - c_start, "call_cpu": c1 - c0, "kernels": kernels,
                  "passes": passes}))
"""


def run(cache_dir: str | None, mode: str) -> dict:
    """The figures of a fresh interpreter with ``NUMBA_CACHE_DIR=cache_dir`` (None: as set
    now) running ``hopmatch.warmup()`` (``mode`` "warmup") or the first ``match_stereo``
    ("first")."""
    return run_fresh_interpreter(CHILD, [mode], cache_dir, notice=False,
                                 extra_env={"HOPMATCH_COMPILE_HELPER": "0"})


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--first", action="store_true",
                        help="time the first match_stereo on motorcycle, not warmup()")
    parser.add_argument("--top", type=int, default=25, help="kernels listed (default 25)")
    parser.add_argument("--json", metavar="PATH", help="also write the raw figures there")
    args = add_smoke_option(parser).parse_args(argv)
    mode = "first" if args.first else "warmup"
    if args.smoke:
        cold, warm = run(None, mode), run(None, mode)
    else:
        with tempfile.TemporaryDirectory() as cache:
            cold = run(cache, mode)
            warm = run(cache, mode)
    if args.json:
        Path(args.json).write_text(json.dumps({"cold": cold, "warm": warm}, indent=1))
    call = "first match_stereo (motorcycle)" if args.first else "warmup()"
    kernels = sorted(cold["kernels"].items(), key=lambda kv: -kv[1]["s"])
    total = sum(k["s"] for _, k in kernels)
    ours = [kv for kv in kernels if kv[0].startswith("hopmatch.")]
    n_sigs = sum(len(k["sigs"]) for _, k in ours)
    print(f"## Cold {call}: {cold['call']:.1f} s wall, {cold['call_cpu']:.1f} s CPU "
          f"(import {cold['import']:.2f} s wall, {cold['import_cpu']:.2f} s CPU); warm "
          f"cache: {warm['call']:.2f} s wall, {warm['call_cpu']:.2f} s CPU (import "
          f"{warm['import']:.2f} s wall, {warm['import_cpu']:.2f} s CPU)\n")
    print(f"{len(ours)} of hopmatch's kernels compiled for {n_sigs} signatures, "
          f"{len(kernels) - len(ours)} of Numba's own (NumPy functions...), "
          f"{total:.1f} s of compilation in all (a kernel's own time)\n")
    print("| kernel | signatures | s | share |")
    print("|---|---:|---:|---:|")
    for name, k in kernels[:args.top]:
        print(f"| `{name.removeprefix('hopmatch.')}` | {len(k['sigs'])} | {k['s']:.2f} | "
              f"{k['s'] / max(total, 1e-9):.0%} |")
    rest = kernels[args.top:]
    print(f"| {len(rest)} others | {sum(len(k['sigs']) for _, k in rest)} | "
          f"{sum(k['s'] for _, k in rest):.2f} | "
          f"{sum(k['s'] for _, k in rest) / max(total, 1e-9):.0%} |")
    multi = [(n, k) for n, k in ours if len(k["sigs"]) > 1]
    if multi:
        print("\n### hopmatch kernels compiled for several signatures\n")
        for name, k in multi:
            print(f"- `{name.removeprefix('hopmatch.')}` ({k['s']:.2f} s):")
            for sig in k["sigs"]:
                print(f"  - `{sig}`")
    passes = sorted(cold["passes"].items(), key=lambda kv: -kv[1])
    ptotal = sum(t for _, t in passes)
    print(f"\n### Compiler passes ({ptotal:.1f} s in all, own time)\n")
    print("| pass | s | share |")
    print("|---|---:|---:|")
    for name, t in passes[:12]:
        print(f"| {name} | {t:.2f} | {t / max(ptotal, 1e-9):.0%} |")
    if args.smoke:
        print("\n(--smoke: Numba's default cache, figures meaningless)")


if __name__ == "__main__":
    main()
