"""Batch throughput on Dask: pairs per second against the number of local workers.

Run: ``python benchmarks/dask_batch.py [--pairs N] [--workers 1,2] [--size WxH]``
(prints a Markdown table).

The pairs are generated (a textured image and its copy shifted by 3-10 px, PNG files in a
temporary folder) so that every run does the same work; each row starts a fresh
``LocalCluster`` of N single-threaded worker processes on 127.0.0.1, runs one untimed
warm-up batch (worker start, Numba cache load), then times ``hopmatch_dask.run_batch`` on
all pairs, reading images and writing results included. Cluster start-up is reported apart.
``--smoke``: 4 pairs of 160x120 on one worker (unless ``--pairs``, ``--workers`` or
``--size`` is given); a check that the script works, figures meaningless.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_smoke_option, machine  # noqa: E402

import hopmatch_dask  # noqa: E402


def make_pairs(folder: Path, n: int, size: tuple[int, int]) -> list:
    w, h = size
    rng = np.random.default_rng(0)
    pairs = []
    for i in range(n):
        left = cv2.GaussianBlur((rng.random((h, w)) * 255).astype(np.uint8), (3, 3), 0)
        right = np.roll(left, -(3 + i % 8), axis=1)
        lp, rp = folder / f"l{i:04d}.png", folder / f"r{i:04d}.png"
        cv2.imwrite(str(lp), left)
        cv2.imwrite(str(rp), right)
        pairs.append((str(lp), str(rp), f"p{i:04d}"))
    return pairs


def bench(pairs, workers: int, tmp: Path, params: dict) -> tuple[float, float]:
    """(cluster start seconds, pairs per second) with ``workers`` local workers."""
    from distributed import Client

    t0 = time.perf_counter()
    with hopmatch_dask.local_cluster(workers) as cluster, Client(cluster) as client:
        client.wait_for_workers(workers, timeout=120)
        t_start = time.perf_counter() - t0
        warm = pairs[: 2 * workers]
        hopmatch_dask.run_batch(warm, tmp / f"warm{workers}", client=client, **params)
        out = tmp / f"out{workers}"
        t1 = time.perf_counter()
        report = hopmatch_dask.run_batch(pairs, out, client=client, **params)
        elapsed = time.perf_counter() - t1
    if not report.ok:
        raise RuntimeError(f"{report.count('failed')} pairs failed")
    return t_start, len(pairs) / elapsed


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pairs", type=int, default=None, help="number of pairs (default 48)")
    parser.add_argument("--workers", default=None,
                        help="comma-separated worker counts (default 1,2)")
    parser.add_argument("--size", default=None, help="image size WxH (default 640x480)")
    args = add_smoke_option(parser).parse_args(argv)
    for name, full, smoke in (("pairs", 48, 4), ("workers", "1,2", "1"),
                              ("size", "640x480", "160x120")):
        if getattr(args, name) is None:
            setattr(args, name, smoke if args.smoke else full)
    size = tuple(int(v) for v in args.size.lower().split("x"))
    counts = [int(v) for v in args.workers.split(",")]
    params = {"max_disparity": 16}

    with tempfile.TemporaryDirectory(prefix="hopmatch-dask-bench-") as tmp:
        tmp = Path(tmp)
        (tmp / "img").mkdir()
        pairs = make_pairs(tmp / "img", args.pairs, size)
        print(f"# hopmatch batch on a LocalCluster: {args.pairs} pairs of {size[0]}x{size[1]}, "
              f"max_disparity 16")
        print(f"# {machine()}")
        print()
        print("| workers | cluster start (s) | pairs/s | speed-up |")
        print("| ---: | ---: | ---: | ---: |")
        base = None
        for n in counts:
            t_start, rate = bench(pairs, n, tmp, params)
            base = base or rate
            print(f"| {n} | {t_start:.1f} | {rate:.1f} | {rate / base:.2f}x |", flush=True)


if __name__ == "__main__":
    main()
