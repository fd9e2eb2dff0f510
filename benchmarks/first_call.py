"""First-call (compilation) delay of hopmatch's Numba kernels, with a cold and a warm cache.

Run: ``python benchmarks/first_call.py``

Each measurement is a fresh interpreter with ``NUMBA_CACHE_DIR`` pointing at a new empty
folder (cold: every kernel is compiled) or at the folder the cold run filled (warm: machine
code is loaded from disk). It times ``import hopmatch``, ``hopmatch.warmup()`` (which compiles
or loads every kernel), and the first ``match_stereo`` on motorcycle after it.

``--smoke`` compiles nothing (compiling every kernel takes 15-30 s): both runs use Numba's
default cache, so the "cold" row loads from disk too; a check that the script works,
figures meaningless.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_smoke_option  # noqa: E402

CHILD = r"""
import json, time
t0 = time.perf_counter()
import hopmatch
t1 = time.perf_counter()
hopmatch.warmup()
t2 = time.perf_counter()
from hopmatch.datasets import load_motorcycle
s = load_motorcycle()
t3 = time.perf_counter()
hopmatch.match_stereo(s.left, s.right)
t4 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "warmup": t2 - t1, "first_match": t4 - t3}))
"""


def run(cache_dir: str | None) -> dict:
    """Times of a fresh interpreter with ``NUMBA_CACHE_DIR=cache_dir`` (None: as set now)."""
    env = dict(os.environ) if cache_dir is None else dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    out = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True,
                         text=True)
    if out.returncode:
        raise RuntimeError(f"the measuring interpreter failed:\n{out.stderr}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    args = add_smoke_option(parser).parse_args(argv)
    if args.smoke:
        cold, warm = run(None), run(None)
    else:
        with tempfile.TemporaryDirectory() as cache:
            cold = run(cache)
            warm = run(cache)
    print("## First-call delay (fresh interpreter each time)\n")
    print("| cache | import ms | warmup() ms | first match_stereo after warmup ms |")
    print("|---|---:|---:|---:|")
    for name, r in (("cold (compile)", cold), ("warm (load from disk)", warm)):
        print(f"| {name} | {r['import'] * 1e3:.0f} | {r['warmup'] * 1e3:.0f} | "
              f"{r['first_match'] * 1e3:.0f} |")
    if args.smoke:
        print("\n(--smoke: both rows loaded the kernels from the default cache; nothing was "
              "compiled)")


if __name__ == "__main__":
    main()
