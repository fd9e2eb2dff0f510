"""Scale benchmark: a 2964 x 2000 pair, 1k to 20k keypoints per image.

Run: ``python benchmarks/scale.py`` (single thread; each configuration runs in a fresh
process so that its peak memory, ``ru_maxrss``, is its own; times are the best of three).

The pair is scikit-image's motorcycle upsampled 4x (bicubic) to the full Middlebury 2014
size, 2964 x 2000. ``max_features`` sets the keypoint count. Prints time and peak memory
against keypoint count, the growth exponent of time (a log-log fit: 1.0 is linear), and the
ratio to SIFT ``detectAndCompute`` on the same two images (goal: <= 0.30x within 1.5 GB).
``--smoke``: the same on a 1000 x 675 pair with 1000 and 2000 keypoints, one timed run each
(a check that the script works; figures meaningless).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _common import add_smoke_option  # noqa: E402

#: (width, height, keypoint counts, timed runs) of the full run and of ``--smoke``.
FULL = (2964, 2000, (1000, 2500, 5000, 10000, 15000, 20000), 3)
SMOKE = (1000, 675, (1000, 2000), 1)

CHILD = r"""
import json, resource, sys
sys.path.insert(0, {here!r})
import cv2
from _common import best_time, motorcycle_bgr, single_thread
single_thread()
import hopmatch
left, right, _ = motorcycle_bgr()
mode, n, repeat = sys.argv[1], int(sys.argv[2]), int(sys.argv[5])
size = (int(sys.argv[3]), int(sys.argv[4]))  # width, height
left = cv2.resize(cv2.cvtColor(left, cv2.COLOR_BGR2GRAY), size, interpolation=cv2.INTER_CUBIC)
right = cv2.resize(cv2.cvtColor(right, cv2.COLOR_BGR2GRAY), size, interpolation=cv2.INTER_CUBIC)
if mode == "sift":
    sift = cv2.SIFT_create()
    sift.detectAndCompute(left[:200, :200], None)
    found = {{}}
    def both():
        found["left"], _ = sift.detectAndCompute(left, None)
        found["right"], _ = sift.detectAndCompute(right, None)
    best = best_time(both, repeat=repeat, warmup=0)  # best of `repeat`, as for hopmatch below
    out = dict(seconds=best, keypoints=(len(found["left"]) + len(found["right"])) // 2)
else:
    hopmatch.warmup()
    params = dict(max_features=n, nms_size=3, max_disparity=260)
    hopmatch.match_stereo(left[:300, :400], right[:300, :400], **params)
    last = {{}}
    def pair():
        last["res"] = hopmatch.match_stereo(left, right, **params)
    best = best_time(pair, repeat=repeat, warmup=0)
    res = last["res"]
    out = dict(seconds=best,
               keypoints=(len(res.points_left) + len(res.points_right)) // 2,
               matches=int(len(res.query_idx)), neurons=int(len(res.network.neuron_left)),
               interactions=res.network.n_interactions, timings=res.timings)
out["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps(out))
"""


def run(mode: str, n: int = 0, size: tuple[int, int] = FULL[:2], repeat: int = FULL[3]) -> dict:
    code = CHILD.format(here=str(HERE))
    proc = subprocess.run([sys.executable, "-c", code, mode, str(n), *map(str, size),
                           str(repeat)], capture_output=True, text=True)
    if proc.returncode:
        raise RuntimeError(f"the {mode} {n} run failed:\n{proc.stderr}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    args = add_smoke_option(parser).parse_args(argv)
    width, height, counts, repeat = SMOKE if args.smoke else FULL
    sift = run("sift", size=(width, height), repeat=repeat)
    print(f"## Scale: motorcycle upsampled to {width} x {height}, single thread\n")
    print(f"SIFT detectAndCompute on both images: {sift['seconds'] * 1e3:.0f} ms, "
          f"{sift['keypoints']} keypoints per image, peak {sift['peak_mb']:.0f} MB\n")
    print("| keypoints / image | matches | neurons | interactions | total ms | match ms | "
          "peak MB | hopmatch / SIFT |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    rows = []
    for n in counts:
        r = run("hopmatch", n, size=(width, height), repeat=repeat)
        rows.append(r)
        print(f"| {r['keypoints']} | {r['matches']} | {r['neurons']} | {r['interactions']} | "
              f"{r['seconds'] * 1e3:.0f} | {r['timings']['match'] * 1e3:.1f} | "
              f"{r['peak_mb']:.0f} | "
              f"{r['seconds'] / sift['seconds']:.2f} |")
    k = np.log([r["keypoints"] for r in rows])
    for label, key in (("total time", None), ("match stage", "match"), ("interactions", "n")):
        if key is None:
            y = [r["seconds"] for r in rows]
        elif key == "match":
            y = [r["timings"]["match"] for r in rows]
        else:
            y = [r["interactions"] for r in rows]
        slope = np.polyfit(k, np.log(y), 1)[0]
        print(f"Growth of {label} with keypoints (log-log slope; 1.0 = linear): {slope:.2f}")
    print("\nThe total is dominated by the per-pixel work (Deriche gradient and Moravec response\n"
          f"on {width * height / 1e6:.1f} Mpixel images), which does not depend on the keypoint "
          "count.")


if __name__ == "__main__":
    main()
