"""A full-size pair with texture everywhere, matched with no parameter (issue 18).

Run: ``python benchmarks/textured_pair.py [--size W H] [--sigma S] [--threads N] [--smoke]``

``benchmarks/unrectified.py --sections large`` matches motorcycle upsampled to 2964 x
2000: smooth at that size (cubic interpolation), it gives 95,000 keypoints an image. A
photo taken at that size has detail down to the pixel, and the keypoints, and with them
the candidate pairs of a disparity range, grow with it. This script makes such a pair:
grey levels of Gaussian noise blurred by ``--sigma`` px (1: a keypoint at about every 20th
pixel), the right view the left one resampled along its rows (``cv2.remap``, cubic) by a
disparity that is a slanted plane from 5 % of the width (top left) to 15 % (bottom right;
150 to 450 px at 2964 px), as a receding floor seen by a wide-baseline rig. It prints, for
``match_stereo(left, right)`` with no parameter (in a fresh interpreter, one thread, after
a call on a small crop that loads the kernels; ``--threads N``: hopmatch on N threads,
SIFT still on one): the keypoints, whether the network ran on
every left point or on a thinned set (``result.network.thinned``; docs/parameters.md,
"Disparity range"), the range, the matches and their precision at 1 px against the plane,
the time, the peak memory (``ru_maxrss``) and the warnings; and SIFT ``detectAndCompute``
on both images (in its own interpreter) for the ratio.

``--smoke``: a 600 x 400 pair (figures mean nothing).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import cv2
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from _common import add_smoke_option, run_fresh_interpreter  # noqa: E402

#: The disparity plane, as fractions of the width: ``D_TOP_LEFT`` at (0, 0), growing by
#: ``D_ACROSS`` to the right edge and ``D_DOWN`` to the bottom edge (150 to 450 px at 2964
#: px wide).
D_TOP_LEFT, D_ACROSS, D_DOWN = 150.0 / 2964, 150.0 / 2964, 150.0 / 2964

CHILD = r"""
import json, resource, sys, time, warnings
sys.path.insert(0, {here!r})
import cv2, numpy as np
from textured_pair import make_pair, true_right_x
from _common import single_thread
single_thread()
import hopmatch
w, h, sigma, mode = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
hopmatch.setNumThreads(int(sys.argv[5]))  # SIFT keeps one thread
left, right = make_pair(w, h, sigma)
out = {{}}
if mode == "sift":
    sift = cv2.SIFT_create()
    t0 = time.perf_counter()
    sift.detectAndCompute(left, None)
    sift.detectAndCompute(right, None)
    out["seconds"] = time.perf_counter() - t0
else:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hopmatch.match_stereo(left[:200, :300], right[:200, :300])  # load the kernels
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        t0 = time.perf_counter()
        r = hopmatch.match_stereo(left, right)
        out["seconds"] = time.perf_counter() - t0
    ml, mr = r.matched_left, r.matched_right
    xr = true_right_x(ml, w, h)
    good = (np.abs(mr[:, 0] - xr) <= 1.0) & (np.abs(mr[:, 1] - ml[:, 1]) <= 1.0)
    net = r.network
    out.update(keypoints=[len(r.points_left), int(r.n_detected_right or len(r.points_right))],
               thinned=None if net.thinned is None else len(net.thinned),
               range=[net.config.min_disparity, net.config.max_disparity],
               matches=len(ml), correct=int(good.sum()),
               precision=float(good.mean()) if len(good) else float("nan"),
               stages={{k: v for k, v in dict(r.timings, **r.match_timings).items()
                        if k in ("detect_left", "detect_right", "network", "guided",
                                 "refine")}},
               warnings=sorted({{str(x.message) for x in caught}}))
out["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps(out))
"""


def make_pair(width: int, height: int, sigma: float, seed: int = 0):
    """``(left, right)`` uint8 images of ``height x width``: blurred Gaussian noise, and
    the same resampled along its rows by the plane of :func:`disparity_at` (a right point
    at x sees the left image at ``x + d``, d the disparity there)."""
    rng = np.random.default_rng(seed)
    pad = int((D_TOP_LEFT + D_ACROSS + D_DOWN) * width) + 8
    noise = rng.normal(0.0, 1.0, (height, width + pad)).astype(np.float32)
    texture = cv2.normalize(cv2.GaussianBlur(noise, (0, 0), sigma), None, 0, 255,
                            cv2.NORM_MINMAX).astype(np.uint8)
    ys, xs = np.mgrid[0:height, 0:width].astype(np.float32)
    right = cv2.remap(texture, xs + disparity_at(xs, ys, width, height), ys, cv2.INTER_CUBIC)
    return np.ascontiguousarray(texture[:, :width]), right


def disparity_at(x, y, width: int, height: int):
    """The plane's disparity at right-image position (x, y)."""
    return width * (D_TOP_LEFT + D_ACROSS * x / width + D_DOWN * y / height)


def true_right_x(left_points, width: int, height: int):
    """The true right x of each left point (x, y): the x_r with ``x_r + d(x_r, y) = x``."""
    xl = left_points[:, 0].astype(np.float64)
    yl = left_points[:, 1].astype(np.float64)
    # d is linear in x_r: x_l = x_r (1 + D_ACROSS) + width (D_TOP_LEFT + D_DOWN y / height)
    return (xl - width * (D_TOP_LEFT + D_DOWN * yl / height)) / (1.0 + D_ACROSS)


def main(argv=None) -> int:
    ap = add_smoke_option(argparse.ArgumentParser(description=__doc__.splitlines()[0]))
    ap.add_argument("--size", type=int, nargs=2, default=(2964, 2000), metavar=("W", "H"))
    ap.add_argument("--sigma", type=float, default=1.0,
                    help="blur of the noise, px (larger: smoother, fewer keypoints)")
    ap.add_argument("--threads", type=int, default=1,
                    help="hopmatch's threads (default 1; SIFT runs on one thread)")
    args = ap.parse_args(argv)
    w, h = (600, 400) if args.smoke else args.size
    child = CHILD.format(here=str(HERE))
    runs = {mode: run_fresh_interpreter(child, [str(w), str(h), str(args.sigma), mode,
                                                str(args.threads)], None, notice=False)
            for mode in ("hopmatch", "sift")}
    hop, sift = runs["hopmatch"], runs["sift"]
    print(f"## A textured {w} x {h} pair (noise blurred by {args.sigma:g} px, disparity a "
          f"plane of {D_TOP_LEFT * w:.0f}-{(D_TOP_LEFT + D_ACROSS + D_DOWN) * w:.0f} px), "
          "match_stereo(left, right) with no parameter"
          + (f", {args.threads} threads" if args.threads != 1 else "") + "\n")
    thinned = ("every left point" if hop["thinned"] is None else
               f"{hop['thinned']} of {hop['keypoints'][0]} left points (thinned)")
    print(f"keypoints {hop['keypoints'][0]} / {hop['keypoints'][1]}; the network ran on "
          f"{thinned}; range [{hop['range'][0]:.1f}, {hop['range'][1]:.1f}] px")
    print(f"matches {hop['matches']}; correct at 1 px {hop['correct']} "
          f"(precision {hop['precision']:.4f})")
    print(f"time {hop['seconds']:.2f} s; peak memory {hop['peak_mb']:.0f} MB; SIFT "
          f"detectAndCompute on both images {sift['seconds']:.2f} s (ratio "
          f"{hop['seconds'] / sift['seconds']:.2f})")
    print("stages: " + ", ".join(f"{k} {v:.2f} s" for k, v in hop["stages"].items()))
    for message in hop["warnings"]:
        print(f"warning: {message}")
    print(json.dumps({"hopmatch": hop, "sift": sift}), file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
