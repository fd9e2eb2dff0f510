"""End-to-end speed on motorcycle: detect left, detect right, match.

Run: ``python benchmarks/end_to_end.py`` (single thread; prints a Markdown table; every
pipeline is timed in the same 15 interleaved rounds, best of 15 each, so that a drifting
machine affects them all alike; each timed call right after an untimed call of the same
pipeline, so that each is timed as it runs on its own, not in the caches and memory the
pipeline before it left (after SIFT's large buffers, the next call of another pipeline
page-faults its memory in again));
``--profile`` also prints where hopmatch's time goes (cProfile over 20 pairs: the functions
and kernels with the most time of their own, per pair). ``--smoke``: the same tables on a
240 x 160 crop, one round, 2 profiled pairs (a check that the script works; figures
meaningless).

Peers, timed in the same run on the same images: ORB (3000 features) + BFMatcher (Hamming)
knnMatch k=2 + ratio test 0.75, and SIFT + BFMatcher (L2) knnMatch k=2 + ratio test 0.75.
Goals: hopmatch <= 1.0x ORB, <= 0.10x SIFT, under 33 ms; the last line of the first table
says whether this run met each, with the ratios to three decimals.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import sys
from pathlib import Path

import cv2

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import (  # noqa: E402
    add_smoke_option,
    best_times_interleaved,
    machine,
    motorcycle_bgr,
    single_thread,
)

import hopmatch  # noqa: E402


def ratio_pipeline(feature, norm):
    matcher = cv2.BFMatcher(norm)

    def run(left, right):
        kl, dl = feature.detectAndCompute(left, None)
        kr, dr = feature.detectAndCompute(right, None)
        return [m for m, n in (p for p in matcher.knnMatch(dl, dr, k=2) if len(p) == 2)
                if m.distance < 0.75 * n.distance]

    return run


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--profile", action="store_true",
                        help="also print where hopmatch's time goes (cProfile)")
    args = add_smoke_option(parser).parse_args(argv)
    single_thread()
    hopmatch.warmup()
    left, right, _ = motorcycle_bgr(smoke=args.smoke)
    gl = cv2.cvtColor(left, cv2.COLOR_BGR2GRAY)
    gr = cv2.cvtColor(right, cv2.COLOR_BGR2GRAY)
    orb = ratio_pipeline(cv2.ORB_create(3000), cv2.NORM_HAMMING)
    sift = ratio_pipeline(cv2.SIFT_create(), cv2.NORM_L2)

    times = best_times_interleaved({
        "hop": lambda: hopmatch.match_stereo(gl, gr),
        "hop_kp": lambda: hopmatch.match_stereo(gl, gr).matches,
        "orb": lambda: orb(gl, gr),
        "sift": lambda: sift(gl, gr),
    }, repeat=1 if args.smoke else 15, settle=1)
    t_hop, t_hop_kp, t_orb, t_sift = times["hop"], times["hop_kp"], times["orb"], times["sift"]
    res = hopmatch.match_stereo(gl, gr)
    print(f"Machine: {machine()}\n")
    print(f"## End to end on motorcycle ({gl.shape[1]}x{gl.shape[0]}, grey), single thread\n")
    print(f"hopmatch: {len(res.points_left)}/{len(res.points_right)} keypoints, "
          f"{len(res.query_idx)} matches; stage times (last run): "
          + ", ".join(f"{k} {v * 1e3:.1f} ms" for k, v in res.timings.items()) + "\n")
    print("| pipeline | ms | pairs/s | hopmatch / pipeline |")
    print("|---|---:|---:|---:|")
    for name, t in [("hopmatch.match_stereo (arrays)", t_hop),
                    ("hopmatch.match_stereo + cv2.DMatch objects", t_hop_kp),
                    ("ORB(3000) + BFMatcher ratio 0.75", t_orb),
                    ("SIFT + BFMatcher ratio 0.75", t_sift)]:
        print(f"| {name} | {t * 1e3:.1f} | {1 / t:.1f} | {t_hop / t:.2f} |")
    print("\nGoals (issue 3): "
          + "; ".join(f"{goal}: {value} ({'met' if ok else 'NOT met'})" for goal, value, ok in [
              ("<= 1.0x ORB", f"{t_hop / t_orb:.3f}x", t_hop <= t_orb),
              ("<= 0.10x SIFT", f"{t_hop / t_sift:.3f}x", t_hop <= 0.10 * t_sift),
              ("under 33 ms", f"{t_hop * 1e3:.1f} ms", t_hop < 0.033)]))
    if args.profile:
        profile(gl, gr, pairs=2 if args.smoke else 20)


def profile(gl, gr, pairs: int = 20, rows: int = 15) -> None:
    """Own time per pair of the functions hopmatch spends most in (cProfile)."""
    prof = cProfile.Profile()
    prof.enable()
    for _ in range(pairs):
        hopmatch.match_stereo(gl, gr)
    prof.disable()
    stats = pstats.Stats(prof).stats
    top = sorted(stats.items(), key=lambda kv: kv[1][2], reverse=True)[:rows]
    total = sum(v[2] for v in stats.values()) / pairs
    print(f"\n## Where hopmatch's time goes ({pairs} pairs under cProfile, "
          f"{total * 1e3:.1f} ms per pair with the profiler's overhead)\n")
    print("| function | own ms per pair | share |")
    print("|---|---:|---:|")
    for (path, line, name), (_, _, own, _, _) in top:
        where = name if path == "~" else f"{Path(path).name}:{name}"
        print(f"| `{where}` | {own / pairs * 1e3:.2f} | {own / pairs / total:.0%} |")


if __name__ == "__main__":
    main()
