"""Detector memory per pixel: the figures behind ``max_pixels`` (docs/robustness.md).

Run: ``python benchmarks/memory.py [--huge]`` (``--huge`` adds 10000 x 10000: about 1 min
and 2.6 GB; ``--smoke``: 256 x 256 and 512 x 512, the pair 512 x 512, a check that the
script works, figures meaningless).

Each size runs in a fresh process: blurred uniform noise (a worst case for the number of
keypoints), a warm-up on a 64 x 64 image, then ``detectAndCompute`` with default parameters
(``max_pixels`` raised where needed), and ``match_stereo`` on a 2000 x 2000 pair (the
noise and itself shifted by 6 px, ``max_disparity=16``). Extra peak memory = ``ru_maxrss``
after the call minus ``ru_maxrss`` before it.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_smoke_option  # noqa: E402

CHILD = r"""
import json, resource, sys, time
import cv2, numpy as np
import hopmatch
n = int(sys.argv[1])
rng = np.random.default_rng(0)
img = cv2.GaussianBlur(rng.integers(0, 256, (n, n), dtype=np.uint8), (0, 0), 2)
det = hopmatch.DericheMoravecDetector(max_pixels=max(n * n, 50_000_000))
det.detectAndCompute(img[:64, :64].copy())
if sys.argv[2] == "match":
    hopmatch.match_stereo(img[:64, :64].copy(), img[:64, 4:68].copy(), max_disparity=16)
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.perf_counter()
if sys.argv[2] == "match":  # a pair: the image and itself shifted by 6 px
    res = hopmatch.match_stereo(img, np.roll(img, -6, axis=1), max_disparity=16)
    count = len(res.points_left)
else:
    kps, desc = det.detectAndCompute(img)
    count = len(kps)
seconds = time.perf_counter() - t0
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"n": n, "extra_mb": (after - before) / 1024, "peak_mb": after / 1024,
                  "keypoints": count, "seconds": seconds}))
"""


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--huge", action="store_true", help="add 10000 x 10000 (2.6 GB)")
    args = add_smoke_option(parser).parse_args(argv)
    if args.smoke:
        sizes, pair = [256, 512], 512
    else:
        sizes, pair = [1000, 2000, 4000], 2000
    sizes += [10000] if args.huge else []
    runs = [(n, "detect") for n in sizes] + [(pair, "match")]
    print("| call | image | extra peak memory | per pixel | keypoints | time |")
    print("|---|---|---|---|---|---|")
    for n, mode in runs:
        out = subprocess.run([sys.executable, "-c", CHILD, str(n), mode], capture_output=True,
                             text=True)
        if out.returncode:
            raise RuntimeError(f"the {mode} {n} x {n} run failed:\n{out.stderr}")
        r = json.loads(out.stdout.strip().splitlines()[-1])
        call = "detectAndCompute" if mode == "detect" else "match_stereo (pair)"
        print(f"| {call} | {n} x {n} | {r['extra_mb']:.0f} MB (peak RSS {r['peak_mb']:.0f} MB) | "
              f"{r['extra_mb'] * 2**20 / n / n:.0f} B | {r['keypoints']:,} | "
              f"{r['seconds']:.1f} s |")


if __name__ == "__main__":
    main()
